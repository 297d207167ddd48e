// The one-pass OFF reader (mesh/src/off_load.cpp) gives the former reader's scene (a validation pass, then
// OpenMesh's stream reader) on the corpus's OFF file.
#include "test_support.h"

namespace furrow {
// The former OFF reader (mesh/src/openmesh_load.cpp, internal to furrow::mesh; the library is static).
Status load_openmesh_bytes(Scene& out, const std::string& bytes, const std::string& ext, const LoadOptions& options);
} // namespace furrow

using namespace furrow;
using namespace furrow::test;

TEST(off_load_corpus, BunnyGivesTheFormerReadersScene) {
    const auto file = corpus("bunny_closed/bunny.off");
    Scene now, before;
    Status st = load_scene(now, file.string());
    ASSERT_TRUE(st.ok()) << st.message;
    st = load_openmesh_bytes(before, read_text(file), ".off", LoadOptions{});
    ASSERT_TRUE(st.ok()) << st.message;
    const Primitive& p = now.meshes.at(0).primitives.at(0);
    const Primitive& q = before.meshes.at(0).primitives.at(0);
    EXPECT_EQ(p.vertex_count(), 3485u);
    EXPECT_EQ(p.triangle_count(), 6966u);
    EXPECT_EQ(p.positions, q.positions);
    EXPECT_EQ(p.indices, q.indices);
    EXPECT_EQ(p.face_sizes, q.face_sizes);
    EXPECT_EQ(now.warnings, before.warnings);
}
