// The scene side of the verification rasterizer (furrow/render.h): node hierarchy, morph targets, skins,
// materials and textures become Draws in clip space; the default camera frames the bounding box.
//
// References:
//   glTF 2.0 specification, §3.7.3 skins (joint matrix = joint world × inverse bind matrix; the skinned mesh
//     node's own transform is ignored), §3.7.2.1 morph targets, §3.9 materials (alpha modes, doubleSided),
//     §3.7.2 (a negative determinant of the world matrix flips the winding order).
//   Reversed-Z depth with an infinite far plane: Reed, "Depth Precision Visualized" (NVIDIA, 2015) — float
//     depth then keeps its precision over the whole range, so no far plane has to be guessed.
#include "render_internal.h"

#include <furrow_kernel/affine.h>
#include <furrow_kernel/vec3.h>
#include <furrow_kernel/no_throw.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <set>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace furrow {
using namespace render_detail;

namespace {

using Vec3 = kernel::Vec3; // GLM's dvec3: a + b, a - b, a * s are GLM's operators
using kernel::cross;
using kernel::dot;
double length(const Vec3& a) { return kernel::norm(a); }
Vec3 normalize(const Vec3& a) {
    double l = length(a);
    return l > 0 ? a * (1 / l) : Vec3{0, 0, 0};
}
// The public camera's std::array<double, 3> as the kernel's vector.
Vec3 v3(const std::array<double, 3>& a) { return kernel::vec3_of(a); }

Vec3 transform_point(const Mat4& m, double x, double y, double z) {
    return {m[0] * x + m[4] * y + m[8] * z + m[12], m[1] * x + m[5] * y + m[9] * z + m[13],
            m[2] * x + m[6] * y + m[10] * z + m[14]};
}
using kernel::det3;
// Inverse transpose of the upper 3×3 up to a positive factor (the cofactor matrix, sign-corrected), so that
// normals survive non-uniform and mirroring scales; row-major 3×3. Normals are renormalized per pixel.
std::array<double, 9> normal_matrix(const Mat4& m) {
    auto a = [&](int r, int c) { return m[c * 4 + r]; };
    std::array<double, 9> cof{};
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
            int r1 = (r + 1) % 3, r2 = (r + 2) % 3, c1 = (c + 1) % 3, c2 = (c + 2) % 3;
            cof[r * 3 + c] = a(r1, c1) * a(r2, c2) - a(r1, c2) * a(r2, c1);
        }
    if (det3(m) < 0)
        for (double& x : cof) x = -x;
    return cof;
}

std::string where(size_t mesh, size_t prim) {
    return "mesh " + std::to_string(mesh) + " primitive " + std::to_string(prim);
}

// A primitive under one node after the first vertex pass: world-space positions and normals.
struct Instance {
    size_t mesh = 0, prim_index = 0;
    const Primitive* prim = nullptr;
    std::vector<uint32_t> tris;   // 3 per triangle, into the vertices below
    std::vector<uint32_t> source; // source vertex of each vertex; empty = identity
    std::vector<double> position; // world xyz
    std::vector<float> normal;    // world xyz, unnormalized
    bool flip = false;
    Vec3 lo{HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL}; // of finite positions
};

Status check_sizes(const Primitive& p, size_t mesh, size_t prim) {
    size_t n = p.vertex_count();
    auto bad = [&](const char* what) {
        return Status::error(StatusCode::invalid_input, where(mesh, prim) + ": " + what + " has the wrong size");
    };
    if (p.positions.size() % 3) return bad("POSITION");
    if (!p.normals.empty() && p.normals.size() != 3 * n) return bad("NORMAL");
    if (!p.uv0.empty() && p.uv0.size() != 2 * n) return bad("TEXCOORD_0");
    if (!p.uv1.empty() && p.uv1.size() != 2 * n) return bad("TEXCOORD_1");
    if (!p.colors.empty() && p.colors.size() != 4 * n) return bad("COLOR_0");
    for (const auto& t : p.targets) {
        if (!t.position_deltas.empty() && t.position_deltas.size() != 3 * n) return bad("a morph target");
        if (!t.normal_deltas.empty() && t.normal_deltas.size() != 3 * n) return bad("a morph target");
    }
    for (const auto& c : p.custom)
        if (c.components < 1 || c.components > 4 || c.values.size() != size_t(c.components) * n)
            return bad(c.name.c_str());
    return Status::success();
}

// Fan-triangulates the faces into `tris`, checking every index.
Status triangle_list(std::vector<uint32_t>& tris, const Primitive& p, size_t mesh, size_t prim) {
    size_t n = p.vertex_count();
    tris.clear();
    if (p.indices.empty()) {
        if (n % 3)
            return Status::error(StatusCode::invalid_input,
                                 where(mesh, prim) + ": unindexed triangles need a multiple of 3 vertices");
        tris.resize(n);
        for (size_t i = 0; i < n; ++i) tris[i] = uint32_t(i);
        return Status::success();
    }
    for (uint32_t i : p.indices)
        if (i >= n)
            return Status::error(StatusCode::invalid_input, where(mesh, prim) + ": index " + std::to_string(i) +
                                                                " out of range (" + std::to_string(n) + " vertices)");
    if (p.face_sizes.empty()) {
        if (p.indices.size() % 3)
            return Status::error(StatusCode::invalid_input,
                                 where(mesh, prim) + ": index count is not a multiple of 3");
        tris = p.indices;
        return Status::success();
    }
    size_t corners = 0;
    for (uint32_t size : p.face_sizes) corners += size;
    if (corners > p.indices.size())
        return Status::error(StatusCode::invalid_input, where(mesh, prim) + ": face sizes exceed the indices");
    triangulate_polygons(tris, p.indices.data(), p.indices.size(), p.face_sizes.data(), p.face_sizes.size(),
                         p.positions.data(), n);
    return Status::success();
}

// Pass 1: morph, skin and transform one primitive's vertices to world space.
// The bind-pose matrices of a skinned node's joints (world × inverse bind), checked against the skin and the
// primitive's JOINTS_0.
Status joint_matrices_of(std::vector<Mat4>& joint_matrices, const Instance& inst, const Scene& scene, const std::vector<Mat4>& world,
                         int node_index) {
    const Node& node = scene.nodes[size_t(node_index)];
    const Primitive& p = *inst.prim;
    if (size_t(node.skin) >= scene.skins.size())
        return Status::error(StatusCode::invalid_input, "node " + std::to_string(node_index) + ": skin out of range");
    const Skin& skin = scene.skins[size_t(node.skin)];
    if (!skin.inverse_bind_matrices.empty() && skin.inverse_bind_matrices.size() != 16 * skin.joints.size())
        return Status::error(StatusCode::invalid_input, "skin " + std::to_string(node.skin) +
                                                            ": inverseBindMatrices has the wrong size");
    for (size_t k = 0; k < skin.joints.size(); ++k) {
        int j = skin.joints[k];
        if (j < 0 || size_t(j) >= scene.nodes.size())
            return Status::error(StatusCode::invalid_input, "skin " + std::to_string(node.skin) +
                                                                ": joint node out of range");
        Mat4 ibm{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
        if (!skin.inverse_bind_matrices.empty())
            for (int e = 0; e < 16; ++e) ibm[size_t(e)] = skin.inverse_bind_matrices[16 * k + size_t(e)];
        joint_matrices.push_back(kernel::multiply(world[size_t(j)], ibm));
    }
    for (size_t i = 0; i < p.joints.size(); ++i)
        if (p.weights[i] != 0 && p.joints[i] >= joint_matrices.size())
            return Status::error(StatusCode::invalid_input,
                                 where(inst.mesh, inst.prim_index) + ": JOINTS_0 refers to a missing joint");
    return Status::success();
}

Status world_vertices(Instance& inst, const Scene& scene, const std::vector<Mat4>& world, int node_index) {
    const Node& node = scene.nodes[size_t(node_index)];
    const Mesh& mesh = scene.meshes[size_t(node.mesh)];
    const Primitive& p = *inst.prim;
    size_t n = p.vertex_count();

    // Morph targets at the default weights: the node's override, else the mesh's.
    std::vector<double> weights(node.weights.begin(), node.weights.end());
    if (weights.empty()) weights.assign(mesh.weights.begin(), mesh.weights.end());
    std::vector<float> pos, nrm;
    const float* P = p.positions.data();
    const float* N = p.normals.empty() ? nullptr : p.normals.data();
    bool morphed = false;
    for (size_t t = 0; t < p.targets.size() && t < weights.size(); ++t) morphed |= weights[t] != 0;
    if (morphed) {
        pos = p.positions;
        nrm = p.normals;
        for (size_t t = 0; t < p.targets.size() && t < weights.size(); ++t) {
            float w = float(weights[t]);
            if (w == 0) continue;
            const MorphTarget& mt = p.targets[t];
            for (size_t i = 0; i < mt.position_deltas.size(); ++i) pos[i] += w * mt.position_deltas[i];
            if (!nrm.empty())
                for (size_t i = 0; i < mt.normal_deltas.size(); ++i) nrm[i] += w * mt.normal_deltas[i];
        }
        P = pos.data();
        N = nrm.empty() ? nullptr : nrm.data();
    }

    // Skin in bind pose: each vertex gets the weighted sum of its joints' matrices.
    const Mat4& node_world = world[size_t(node_index)];
    std::vector<Mat4> joint_matrices;
    bool skinned = node.skin >= 0 && p.joints.size() == 4 * n && p.weights.size() == 4 * n && n > 0;
    if (skinned)
        if (Status st = joint_matrices_of(joint_matrices, inst, scene, world, node_index); !st.ok()) return st;
    // A mirroring placement turns the winding around; a skinned mesh's is its bind placement (its node's
    // transform is ignored), so a mirrored bind pose culls the same faces as its unskinned twin.
    inst.flip = det3(skinned ? scene.mesh_placement(node_index, world) : node_world) < 0;
    const auto node_normals = normal_matrix(node_world);

    std::vector<double> wpos(3 * n);
    std::vector<float> wnrm(N ? 3 * n : 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i) {
            const Mat4* m = &node_world;
            const std::array<double, 9>* nm = &node_normals;
            Mat4 blended;
            std::array<double, 9> blended_normals;
            if (skinned) {
                blended.fill(0);
                double sum = 0;
                for (int k = 0; k < 4; ++k) {
                    double w = p.weights[4 * i + size_t(k)];
                    if (w == 0) continue;
                    const Mat4& j = joint_matrices[p.joints[4 * i + size_t(k)]];
                    for (int e = 0; e < 16; ++e) blended[size_t(e)] += w * j[size_t(e)];
                    sum += w;
                }
                if (sum != 0) {
                    blended_normals = normal_matrix(blended);
                    m = &blended;
                    nm = &blended_normals;
                }
            }
            Vec3 w = transform_point(*m, P[3 * i], P[3 * i + 1], P[3 * i + 2]);
            for (int c = 0; c < 3; ++c) wpos[3 * i + size_t(c)] = w[size_t(c)];
            if (N)
                for (int c = 0; c < 3; ++c)
                    wnrm[3 * i + size_t(c)] = float((*nm)[size_t(c) * 3] * N[3 * i] + (*nm)[size_t(c) * 3 + 1] * N[3 * i + 1] +
                                                    (*nm)[size_t(c) * 3 + 2] * N[3 * i + 2]);
        }
    });

    if (N) {
        inst.position = std::move(wpos);
        inst.normal = std::move(wnrm);
    } else {
        // No normals: glTF asks for flat shading, so every corner becomes its own vertex with the face normal.
        size_t corners = inst.tris.size();
        inst.source = inst.tris;
        inst.position.resize(3 * corners);
        inst.normal.resize(3 * corners);
        for (size_t t = 0; t < corners; t += 3) {
            Vec3 v[3];
            for (int k = 0; k < 3; ++k) {
                size_t s = inst.source[t + size_t(k)];
                v[k] = {wpos[3 * s], wpos[3 * s + 1], wpos[3 * s + 2]};
            }
            Vec3 fn = cross((v[1] - v[0]), (v[2] - v[0]));
            if (inst.flip) fn = (fn * -1.0);
            for (int k = 0; k < 3; ++k) {
                inst.tris[t + size_t(k)] = uint32_t(t + size_t(k));
                for (int c = 0; c < 3; ++c) {
                    inst.position[3 * (t + size_t(k)) + size_t(c)] = v[k][size_t(c)];
                    inst.normal[3 * (t + size_t(k)) + size_t(c)] = float(fn[size_t(c)]);
                }
            }
        }
    }
    for (size_t i = 0; i < inst.position.size(); i += 3) {
        Vec3 w{inst.position[i], inst.position[i + 1], inst.position[i + 2]};
        if (!kernel::finite(w)) continue;
        for (int c = 0; c < 3; ++c) {
            inst.lo[size_t(c)] = std::min(inst.lo[size_t(c)], w[size_t(c)]);
            inst.hi[size_t(c)] = std::max(inst.hi[size_t(c)], w[size_t(c)]);
        }
    }
    return Status::success();
}

// The camera, resolved against the scene's bounding box.
struct View {
    Mat4 view_proj{};
    std::array<double, 9> view_rotation{}; // rows: right, up, back (world -> view for directions)
    Vec3 eye{}, forward{};
    double near_plane = 1, far_plane = 0;
};

// `reserve_right`: pixels at the right edge that the default framing leaves free (for the legend).
Status make_view(View& v, const RenderCamera& cam, const Vec3& lo, const Vec3& hi, int width, int height,
                 int reserve_right, std::vector<std::string>& warnings) {
    Vec3 centre = ((lo + hi) * 0.5);
    double radius = 0.5 * length((hi - lo));
    if (!(radius > 0)) radius = 1; // a single point: frame a unit sphere around it
    double aspect = double(width) / height;
    if (cam.eye) reserve_right = 0; // a camera the user placed is not moved
    reserve_right = std::min(reserve_right, width / 3);
    double fit_aspect = double(width - reserve_right) / height, shift = -double(reserve_right) / width; // NDC
    double half_fov = cam.fov_degrees * std::numbers::pi / 360;
    Vec3 up = normalize(v3(cam.up));
    // The default views are built on a frame of the up axis: front = +Z (or −Y when up is Z).
    Vec3 front = std::abs(up[2]) < 0.9 ? Vec3{0, 0, 1} : Vec3{0, -1, 0};
    front = normalize((front - (up * dot(front, up))));
    Vec3 right = cross(up, front);

    Vec3 target = cam.target ? v3(*cam.target) : centre;
    Vec3 eye, image_up = up;
    if (cam.eye) {
        eye = v3(*cam.eye);
    } else if (cam.orthographic) {
        eye = (target + (up * (2 * radius + length((target - centre)))));
        image_up = (front * -1.0);
    } else {
        // Back off along the 3/4 direction until every bounding-box corner is inside the frustum (with 4% to
        // spare): corner p (relative to the target) at view coordinates x, y, depth z needs distance
        // d >= |x| / tan(half angle) − z.
        Vec3 dir = normalize(((front + right) + (up * 0.8)));
        Vec3 cr = normalize(cross((dir * -1.0), up)), cu = cross(cr, (dir * -1.0));
        double tv = 0.96 * std::tan(half_fov), th = tv * fit_aspect, distance = 0;
        for (int c = 0; c < 8; ++c) {
            Vec3 p = ((Vec3{(c & 1) ? hi[0] : lo[0], (c & 2) ? hi[1] : lo[1], (c & 4) ? hi[2] : lo[2]}) - target);
            double z = -dot(p, dir);
            distance = std::max({distance, std::abs(dot(p, cr)) / th - z, std::abs(dot(p, cu)) / tv - z});
        }
        if (!(distance > 0)) distance = radius / std::sin(half_fov);
        eye = (target + (dir * distance));
    }
    Vec3 f = normalize((target - eye));
    if (length((target - eye)) == 0)
        return Status::error(StatusCode::invalid_argument, "camera position and target coincide");
    Vec3 r = cross(f, image_up);
    if (length(r) < 1e-9 * length(image_up)) {
        warnings.push_back("the up direction is parallel to the view direction; another up was chosen");
        image_up = std::abs(f[1]) < 0.9 ? Vec3{0, 1, 0} : Vec3{0, 0, -1};
        r = cross(f, image_up);
    }
    r = normalize(r);
    Vec3 u = cross(r, f);

    // Depth range of the bounding box along the view axis.
    double dmin = HUGE_VAL, dmax = -HUGE_VAL, hx = 0, hy = 0;
    for (int c = 0; c < 8; ++c) {
        Vec3 corner{(c & 1) ? hi[0] : lo[0], (c & 2) ? hi[1] : lo[1], (c & 4) ? hi[2] : lo[2]};
        Vec3 d = (corner - eye);
        dmin = std::min(dmin, dot(d, f));
        dmax = std::max(dmax, dot(d, f));
        hx = std::max(hx, std::abs(dot((corner - target), r)));
        hy = std::max(hy, std::abs(dot((corner - target), u)));
    }
    double pad = 1e-6 * std::max(radius, dmax - dmin);
    Mat4 proj{};
    if (cam.orthographic) {
        double h = cam.ortho_height > 0 ? cam.ortho_height : 1.02 * 2 * std::max(hy, hx / fit_aspect);
        if (!(h > 0)) h = 2 * radius;
        v.near_plane = cam.near_plane > 0 ? cam.near_plane : dmin - 0.01 * (dmax - dmin) - pad;
        v.far_plane = dmax + 0.01 * (dmax - dmin) + pad;
        if (v.far_plane <= v.near_plane) v.far_plane = v.near_plane + pad + 1e-6;
        // x, y to [-1,1]; z/w = 1 at the near plane, 0 at the far plane (reversed), w = 1.
        proj[0] = 2 / (h * aspect);
        proj[5] = 2 / h;
        proj[10] = 1 / (v.far_plane - v.near_plane);
        proj[14] = v.far_plane / (v.far_plane - v.near_plane);
        proj[15] = 1;
        proj[12] = shift;
    } else {
        if (cam.near_plane > 0) {
            v.near_plane = cam.near_plane;
        } else if (dmax <= 0) {
            warnings.push_back("the scene is behind the camera");
            v.near_plane = 1;
        } else {
            v.near_plane = std::max(dmin * 0.99, dmax * 1e-6);
        }
        v.far_plane = std::max(dmax, v.near_plane);
        double fy = 1 / std::tan(half_fov);
        // Reversed infinite projection: z_clip = near, w = −z_eye, so z/w = near / distance.
        proj[0] = fy / aspect;
        proj[5] = fy;
        proj[14] = v.near_plane;
        proj[11] = -1;
        proj[8] = -shift; // x_ndc += shift (w = −z_eye)
    }
    Mat4 view{r[0], u[0], -f[0], 0, r[1], u[1], -f[1], 0, r[2], u[2], -f[2], 0,
              -dot(r, eye), -dot(u, eye), dot(f, eye), 1};
    v.view_proj = kernel::multiply(proj, view);
    v.view_rotation = {r[0], r[1], r[2], u[0], u[1], u[2], -f[0], -f[1], -f[2]};
    v.eye = eye;
    v.forward = f;
    return Status::success();
}

// Decodes the texture once per texture index; a missing or undecodable image gives a warning and nullptr.
const DecodedTexture* get_texture(std::map<int, std::unique_ptr<DecodedTexture>>& cache, const Scene& scene, int index,
                                  bool mipmaps, std::set<int>& warned_images, std::vector<std::string>& warnings) {
    auto it = cache.find(index);
    if (it != cache.end()) return it->second.get();
    auto& slot = cache[index];
    const furrow::Texture& t = scene.textures[size_t(index)];
    if (t.image < 0 || size_t(t.image) >= scene.images.size()) {
        warnings.push_back("texture " + std::to_string(index) + " has no image; rendered with the base colour factor");
        return nullptr;
    }
    const Image& image = scene.images[size_t(t.image)];
    std::string name = "image " + std::to_string(t.image) + (image.name.empty() ? "" : " '" + image.name + "'") +
                       (image.source_uri.empty() ? "" : " (" + image.source_uri + ")");
    ImageF decoded;
    Status s = image.encoded.empty() ? Status::error(StatusCode::invalid_input, "no image data")
                                     : decode_image(decoded, image.encoded.data(), image.encoded.size());
    if (!s.ok() || decoded.width < 1 || decoded.height < 1 || decoded.channels < 1 || decoded.channels > 4) {
        if (warned_images.insert(t.image).second)
            warnings.push_back(name + ": " + (s.ok() ? "unusable image" : s.message) +
                               "; rendered with the base colour factor");
        return nullptr;
    }
    auto tex = std::make_unique<DecodedTexture>();
    MipLevel& l0 = tex->levels.emplace_back();
    l0.width = decoded.width;
    l0.height = decoded.height;
    l0.rgba.resize(size_t(decoded.width) * size_t(decoded.height) * 4);
    int ch = decoded.channels;
    for (size_t i = 0; i < size_t(decoded.width) * size_t(decoded.height); ++i) {
        const float* s = &decoded.pixels[i * size_t(ch)];
        float* d = &l0.rgba[4 * i];
        bool grey = ch < 3;
        for (int c = 0; c < 3; ++c) d[c] = srgb_to_linear(grey ? s[0] : s[c]);
        d[3] = ch == 2 ? s[1] : ch == 4 ? s[3] : 1.0f;
    }
    Sampler sm;
    if (t.sampler >= 0 && size_t(t.sampler) < scene.samplers.size()) sm = scene.samplers[size_t(t.sampler)];
    set_sampler(*tex, sm.mag_filter, sm.min_filter, sm.wrap_s, sm.wrap_t, mipmaps, warnings, "texture " + std::to_string(index));
    slot = std::move(tex);
    return slot.get();
}

const CustomAttribute* find_attribute(const Primitive& p, const std::string& name) {
    for (const auto& c : p.custom)
        if (c.name == name) return &c;
    return nullptr;
}

double ms_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

} // namespace

// The options' documented ranges (invalid_argument).
Status validate(const RenderOptions& o) {
    if (o.width < 1 || o.height < 1 || o.width > 16384 || o.height > 16384)
        return Status::error(StatusCode::invalid_argument, "image size " + std::to_string(o.width) + "x" +
                                                               std::to_string(o.height) + " is outside 1..16384");
    if (o.ssaa < 1 || o.ssaa > 8)
        return Status::error(StatusCode::invalid_argument, "ssaa " + std::to_string(o.ssaa) + " is outside 1..8");
    if (o.subpixel_bits < 1 || o.subpixel_bits > 8)
        return Status::error(StatusCode::invalid_argument,
                             "subpixel_bits " + std::to_string(o.subpixel_bits) + " is outside 1..8");
    const RenderCamera& cam = o.camera;
    if (!cam.orthographic && !(cam.fov_degrees > 0 && cam.fov_degrees < 180))
        return Status::error(StatusCode::invalid_argument, "field of view must be in (0, 180) degrees");
    bool camera_finite = std::isfinite(cam.ortho_height) && std::isfinite(cam.near_plane) && kernel::finite(v3(cam.up)) &&
                         length(v3(cam.up)) > 0 && (!cam.eye || kernel::finite(v3(*cam.eye))) && (!cam.target || kernel::finite(v3(*cam.target)));
    if (!camera_finite) return Status::error(StatusCode::invalid_argument, "camera values must be finite, up non-zero");
    const Vec3 light{o.light_direction[0], o.light_direction[1], o.light_direction[2]};
    if (!kernel::finite(light) || length(light) == 0)
        return Status::error(StatusCode::invalid_argument, "light direction must be finite and non-zero");
    if (o.mode == RenderMode::attribute && o.attribute.empty())
        return Status::error(StatusCode::invalid_argument, "attribute mode needs an attribute name");
    return Status::success();
}

namespace {

// Pass 1: world-space vertices of every triangle primitive the scene draws (nodes depth first), with the
// triangle count in out.
Status collect_instances(std::vector<Instance>& instances, RenderResult& out, const Scene& scene, const std::vector<Mat4>& world) {
    const std::vector<int> order = scene.drawn_nodes();
    for (int n : order) {
        const Node& node = scene.nodes[size_t(n)];
        if (node.mesh < 0) continue;
        if (size_t(node.mesh) >= scene.meshes.size())
            return Status::error(StatusCode::invalid_input, "node " + std::to_string(n) + ": mesh out of range");
        const Mesh& mesh = scene.meshes[size_t(node.mesh)];
        for (size_t pi = 0; pi < mesh.primitives.size(); ++pi) {
            const Primitive& p = mesh.primitives[pi];
            if (p.mode != PrimitiveMode::triangles) continue;
            Instance inst;
            inst.mesh = size_t(node.mesh);
            inst.prim_index = pi;
            inst.prim = &p;
            if (Status s = check_sizes(p, inst.mesh, pi); !s.ok()) return s;
            if (Status s = triangle_list(inst.tris, p, inst.mesh, pi); !s.ok()) return s;
            if (p.material >= 0 && size_t(p.material) >= scene.materials.size())
                return Status::error(StatusCode::invalid_input, where(inst.mesh, pi) + ": material out of range");
            if (inst.tris.empty()) continue;
            if (Status s = world_vertices(inst, scene, world, n); !s.ok()) return s;
            out.triangles += inst.tris.size() / 3;
            instances.push_back(std::move(inst));
        }
    }
    if (instances.empty())
        return Status::error(StatusCode::invalid_input, "nothing to render: the scene has no triangles");
    if (instances.empty())
        return Status::error(StatusCode::invalid_input, "nothing to render: the scene has no triangles");
    return Status::success();
}

// The attribute's range over everything drawn (attribute mode): into out.attribute_min/max.
Status attribute_range(RenderResult& out, const std::vector<Instance>& instances, const RenderOptions& o) {
    float amin = HUGE_VALF, amax = -HUGE_VALF;
    if (o.mode == RenderMode::attribute) {
        bool any = false;
        std::set<std::string> available;
        for (const Instance& inst : instances) {
            for (const auto& c : inst.prim->custom) available.insert(c.name);
            const CustomAttribute* a = find_attribute(*inst.prim, o.attribute);
            if (!a) continue;
            any = true;
            for (size_t i = 0; i < a->values.size(); i += size_t(a->components))
                if (std::isfinite(a->values[i])) {
                    amin = std::min(amin, a->values[i]);
                    amax = std::max(amax, a->values[i]);
                }
        }
        if (!any) {
            std::string list;
            for (const auto& name : available) list += (list.empty() ? "" : ", ") + name;
            return Status::error(StatusCode::invalid_argument, "no primitive has the attribute '" + o.attribute +
                                                                   "' (available: " + (list.empty() ? "none" : list) + ")");
        }
        if (!(amin <= amax)) amin = amax = 0;
        out.attribute_min = amin;
        out.attribute_max = amax;
    }
    return Status::success();
}

// Shared by every draw of a frame: textures decoded once, warnings said once.
struct DrawContext {
    const Scene& scene;
    const RenderOptions& o;
    const View& view;
    float amin, amax;
    std::map<int, std::unique_ptr<DecodedTexture>> textures;
    std::set<int> warned_images;
    bool missing_attribute_warned = false;
};

// Pass 2 for one instance: clip space plus the attributes the pixel stage needs, and its depth for sorting.
Status make_draw(Draw& draw, double& sort_depth, Instance& inst, DrawContext& ctx, RenderResult& out) {
    const Scene& scene = ctx.scene;
    const RenderOptions& o = ctx.o;
    const View& view = ctx.view;
    const float amin = ctx.amin, amax = ctx.amax;
    auto& textures = ctx.textures;
    auto& warned_images = ctx.warned_images;
    bool& missing_attribute_warned = ctx.missing_attribute_warned;
    const Mat4& vp = view.view_proj;
    const Primitive& p = *inst.prim;
    Material m = p.material >= 0 ? scene.materials[size_t(p.material)] : Material{};
    draw.base_color = m.base_color;
    draw.emissive = m.emissive;
    draw.alpha_mode = m.alpha_mode;
    draw.alpha_cutoff = m.alpha_cutoff;
    draw.double_sided = m.double_sided;
    draw.flip_winding = inst.flip;
    const std::vector<float>* uv = o.mode == RenderMode::uv ? &p.uv0 : nullptr;
    if (m.base_color_texture.texture >= 0 && o.mode != RenderMode::uv) {
        if (size_t(m.base_color_texture.texture) >= scene.textures.size())
            return Status::error(StatusCode::invalid_input,
                                 "material " + std::to_string(p.material) + ": texture out of range");
        uv = m.base_color_texture.texcoord == 0 ? &p.uv0 : m.base_color_texture.texcoord == 1 ? &p.uv1 : nullptr;
        if (uv && !uv->empty())
            draw.texture = get_texture(textures, scene, m.base_color_texture.texture, o.mipmaps, warned_images, out.warnings);
        else
            out.warnings.push_back(where(inst.mesh, inst.prim_index) + ": the base colour texture's TEXCOORD_" +
                                   std::to_string(m.base_color_texture.texcoord) + " is missing; texture ignored");
    }
    const CustomAttribute* attr = o.mode == RenderMode::attribute ? find_attribute(p, o.attribute) : nullptr;
    if (o.mode == RenderMode::attribute && !attr && !missing_attribute_warned) {
        out.warnings.push_back("some primitives lack '" + o.attribute + "'; they are drawn grey");
        missing_attribute_warned = true;
    }
    Vec3 centre = ((inst.lo + inst.hi) * 0.5);
    sort_depth = kernel::finite(centre) ? dot((centre - view.eye), view.forward) : 0;

    const auto& R = view.view_rotation;
    bool view_normals = o.mode != RenderMode::normals;
    size_t count = inst.position.size() / 3;
    draw.verts.resize(count);
    draw.tris = std::move(inst.tris);
    float arange = amax > amin ? amax - amin : 1.0f;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 4096), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i) {
            size_t s = inst.source.empty() ? i : inst.source[i];
            const double* w = &inst.position[3 * i];
            Vert& v = draw.verts[i];
            v.x = float(vp[0] * w[0] + vp[4] * w[1] + vp[8] * w[2] + vp[12]);
            v.y = float(vp[1] * w[0] + vp[5] * w[1] + vp[9] * w[2] + vp[13]);
            v.z = float(vp[2] * w[0] + vp[6] * w[1] + vp[10] * w[2] + vp[14]);
            v.w = float(vp[3] * w[0] + vp[7] * w[1] + vp[11] * w[2] + vp[15]);
            const float* n = &inst.normal[3 * i];
            for (int c = 0; c < 3; ++c)
                v.n[c] = view_normals ? float(R[size_t(c) * 3] * n[0] + R[size_t(c) * 3 + 1] * n[1] +
                                              R[size_t(c) * 3 + 2] * n[2])
                                      : n[c];
            bool has_uv = uv && !uv->empty();
            v.uv[0] = has_uv ? (*uv)[2 * s] : 0.0f;
            v.uv[1] = has_uv ? (*uv)[2 * s + 1] : 0.0f;
            for (int c = 0; c < 4; ++c) v.c[c] = p.colors.empty() ? 1.0f : p.colors[4 * s + size_t(c)];
            v.s = -1;
            if (attr) {
                float a = attr->values[s * size_t(attr->components)];
                v.s = std::isfinite(a) ? std::clamp((a - amin) / arange, 0.0f, 1.0f) : -1.0f;
                if (amax == amin && std::isfinite(a)) v.s = 0.5f;
            }
        }
    });
    return Status::success();
}

// Opaque and MASK first in scene order, then BLEND back to front (glTF's "sorted" transparency).
std::vector<Draw> draw_order(std::vector<Draw>& draws, const std::vector<double>& sort_depth) {
    std::vector<size_t> draw_order(draws.size());
    for (size_t i = 0; i < draws.size(); ++i) draw_order[i] = i;
    std::stable_sort(draw_order.begin(), draw_order.end(), [&](size_t a, size_t b) {
        bool ba = draws[a].alpha_mode == AlphaMode::blend, bb = draws[b].alpha_mode == AlphaMode::blend;
        if (ba != bb) return !ba;
        return ba && sort_depth[a] > sort_depth[b];
    });
    std::vector<Draw> sorted;
    sorted.reserve(draws.size());
    for (size_t i : draw_order) sorted.push_back(std::move(draws[i]));
    return sorted;
}

} // namespace

Status render_scene(RenderResult& out, const Scene& scene, const RenderOptions& o) {
    return kernel::no_throw("rendering", [&]() -> Status {
        auto t0 = std::chrono::steady_clock::now();
        out = RenderResult{};
        if (Status s = validate(o); !s.ok()) return s;
        const RenderCamera& cam = o.camera;
        const std::vector<Mat4> world = scene.world_matrices();
        if (world.size() != scene.nodes.size())
            return Status::error(StatusCode::invalid_input, "world matrices do not match the node count");
        std::vector<Instance> instances;
        if (Status s = collect_instances(instances, out, scene, world); !s.ok()) return s;
        Vec3 lo{HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
        for (const Instance& inst : instances)
            for (int c = 0; c < 3; ++c) {
                lo[size_t(c)] = std::min(lo[size_t(c)], inst.lo[size_t(c)]);
                hi[size_t(c)] = std::max(hi[size_t(c)], inst.hi[size_t(c)]);
            }
        if (!(lo[0] <= hi[0]))
            return Status::error(StatusCode::invalid_input, "nothing to render: no vertex position is finite");

        if (Status s = attribute_range(out, instances, o); !s.ok()) return s;
        const float amin = out.attribute_min, amax = out.attribute_max;

        bool legend = o.mode == RenderMode::attribute && o.legend && o.width >= 64 && o.height >= 48;
        View view;
        int reserve = legend ? legend_width(o.height, amin, amax) : 0;
        if (Status s = make_view(view, cam, lo, hi, o.width, o.height, reserve, out.warnings); !s.ok()) return s;

        // Pass 2: one Draw per instance.
        DrawContext ctx{scene, o, view, amin, amax, {}, {}, false};
        std::vector<Draw> draws(instances.size());
        std::vector<double> sort_depth(instances.size());
        for (size_t d = 0; d < instances.size(); ++d)
            if (Status s = make_draw(draws[d], sort_depth[d], instances[d], ctx, out); !s.ok()) return s;
        out.timing.vertices = ms_since(t0);
        std::vector<Draw> sorted = draw_order(draws, sort_depth);

        Frame frame;
        frame.width = o.width;
        frame.height = o.height;
        frame.ssaa = o.ssaa;
        frame.subpixel_bits = o.subpixel_bits;
        frame.mode = o.mode;
        frame.orthographic = cam.orthographic;
        frame.near_plane = view.near_plane;
        frame.far_plane = view.far_plane;
        const Vec3 l = normalize(Vec3{o.light_direction[0], o.light_direction[1], o.light_direction[2]});
        frame.light = {float(l[0]), float(l[1]), float(l[2])};
        frame.ambient = o.ambient;
        frame.background = o.background;
        RasterStats stats = rasterize(out, sorted, frame);
        out.nan_triangles = stats.nan_triangles;
        out.culled = stats.culled;
        out.timing.setup = stats.setup_ms;
        out.timing.raster = stats.raster_ms;
        if (out.nan_triangles)
            out.warnings.push_back(std::to_string(out.nan_triangles) + " triangles with NaN or infinite positions skipped");

        if (legend)
            draw_legend(out.color, amin, amax);
        else if (o.mode == RenderMode::attribute && o.legend)
            out.warnings.push_back("image too small for the legend");
        size_t pixels = size_t(o.width) * size_t(o.height);
        out.rgba8.resize(4 * pixels);
        for (size_t i = 0; i < 4 * pixels; ++i) {
            float v = out.color.pixels[i];
            out.rgba8[i] = uint8_t((v >= 0 ? (v <= 1 ? v : 1.0f) : 0.0f) * 255.0f + 0.5f); // NaN -> 0
        }
        out.timing.total = ms_since(t0);
        return Status::success();
    });
}
} // namespace furrow
