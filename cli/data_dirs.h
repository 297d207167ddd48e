// Where the command finds its data at run time. Nothing is compiled in: the installed binary works from any
// folder and names no path of the machine it was built on.
#pragma once

#include <filesystem>

namespace furrow::cli {

// The bundled sample assets (scene.json, creature.glb, ground.glb, ...): $FURROW_MODELS if set, else
// <folder of the furrow binary>/../share/furrow/models — the installed layout (`cmake --install`), which the
// build tree repeats (cli/CMakeLists.txt copies models/ to <build>/share/furrow/models).
std::filesystem::path bundled_models_dir();

// The third-party corpus the benchmarks also read when it is there: $FURROW_CORPUS if set, else
// ../shared/corpus from the working folder, else from the repository the binary sits in (<repo>/build*/cli/furrow
// → <repo>/../shared/corpus). May not exist; callers check.
std::filesystem::path corpus_dir();

} // namespace furrow::cli
