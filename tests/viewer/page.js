// The page the real-client stage loads in headless Chromium: three.js's own GLTFLoader and WebGLRenderer,
// as a stock web viewer (model-viewer, the three.js editor) uses them. render_three.mjs calls renderJob()
// once per view and saves the canvas as PNG.
//
// Nothing here re-implements what the stage tests: texture decoding, sRGB, sampler filters, mip-map
// generation, the alpha test and back-face culling all happen in three.js and the GPU (SwiftShader). The
// modes only choose what colour a surface writes:
//   lit       the materials as loaded (MeshStandardMaterial) under one directional and one ambient light:
//             what a person sees (README screenshots);
//   material  each material as MeshBasicMaterial with the same map, colour, vertex colours, alpha test, side
//             and blending: unlit, so its colours are comparable with `furrow render --ambient 1`;
//   coverage  like material, but a surface writes its material's alphaCutoff as a raw grey (0 for OPAQUE and
//             BLEND): `furrow render --mode cutoff`, the fur coverage measure (which shell shows).
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { MeshoptDecoder } from 'three/addons/libs/meshopt_decoder.module.js';

const canvas = document.getElementById('c');
const renderer = new THREE.WebGLRenderer({ canvas, alpha: true, antialias: false, preserveDrawingBuffer: true });
renderer.setPixelRatio(1);
renderer.setClearColor(0x000000, 0);

const loader = new GLTFLoader();
loader.setMeshoptDecoder(MeshoptDecoder);

function unlit(m, coverage) {
  const b = new THREE.MeshBasicMaterial({
    map: m.map || null,
    color: m.color.clone(),
    vertexColors: m.vertexColors,
    alphaTest: m.alphaTest,
    transparent: m.transparent,
    opacity: m.opacity,
    side: m.side,
    depthWrite: m.depthWrite,
  });
  b.name = m.name;
  if (coverage) {
    // The alpha test still reads map.a × colour.a; the written colour is replaced, after the colour-space
    // conversion, by the shell's height fraction (its alphaCutoff) as a raw grey, and 0 on other surfaces.
    const h = m.alphaTest > 0 ? Math.max(m.alphaTest, 1 / 255) : 0; // MASK layers; 0 on the rest
    b.onBeforeCompile = (s) => {
      s.fragmentShader = s.fragmentShader.replace('#include <dithering_fragment>',
        `#include <dithering_fragment>\n  gl_FragColor.rgb = vec3(${h.toFixed(6)});`);
    };
    b.customProgramCacheKey = () => `furrow-coverage-${h}`;
  }
  return b;
}

// Sampler filters as the file asks (three.js maps glTF minFilter/magFilter one to one), or, with
// mipmaps 'off', every texture sampled from its base level: the supersampled reference of the coverage test.
function noMipmaps(t) {
  if (!t) return;
  if (t.minFilter === THREE.NearestMipmapNearestFilter || t.minFilter === THREE.NearestMipmapLinearFilter) t.minFilter = THREE.NearestFilter;
  else if (t.minFilter !== THREE.NearestFilter) t.minFilter = THREE.LinearFilter;
  t.generateMipmaps = false;
  t.needsUpdate = true;
}

const cache = new Map();
async function load(url) {
  if (!cache.has(url)) cache.set(url, await loader.loadAsync(url));
  return cache.get(url);
}

window.renderJob = async function (job) {
  const gltf = await load(job.url);
  const root = gltf.scene.clone(true); // materials are shared with the cached original: replace, never edit
  const scene = new THREE.Scene();
  scene.add(root);
  const swapped = new Map();
  root.traverse((o) => {
    if (!o.isMesh) return;
    o.frustumCulled = false; // skinned and morphed bounds are not what is drawn
    const one = (m) => {
      if (job.mode === 'lit') {
        if (job.mipmaps === 'off') { const c = m.clone(); c.map = m.map && m.map.clone(); noMipmaps(c.map); return c; }
        return m;
      }
      if (!swapped.has(m)) {
        const b = unlit(m, job.mode === 'coverage');
        if (job.mipmaps === 'off' && b.map) { b.map = b.map.clone(); noMipmaps(b.map); }
        swapped.set(m, b);
      }
      return swapped.get(m);
    };
    o.material = Array.isArray(o.material) ? o.material.map(one) : one(o.material);
  });
  if (job.mode === 'lit') {
    scene.add(new THREE.AmbientLight(0xffffff, 0.6));
    const sun = new THREE.DirectionalLight(0xffffff, 2.0);
    sun.position.set(...job.eye);
    sun.position.add(new THREE.Vector3(-2, 4, 1).multiplyScalar(Math.hypot(...job.eye.map((v, i) => v - job.target[i]))));
    scene.add(sun);
  }
  return draw(scene, job);
};

// One frame of `scene` from the job's camera: the PNG and the time to draw it.
function draw(scene, job) {
  renderer.setSize(job.width, job.height, false);
  const cam = new THREE.PerspectiveCamera(job.fov, job.width / job.height, job.near, job.far);
  cam.up.set(...job.up);
  cam.position.set(...job.eye);
  cam.lookAt(...job.target);
  const t0 = performance.now();
  renderer.render(scene, cam);
  const gl = renderer.getContext();
  gl.finish();
  const ms = performance.now() - t0;
  return { png: canvas.toDataURL('image/png'), ms };
}

// The instanced shell layout (README "Instanced layout") in three.js, against the engine layout of the same
// fur. GLTFLoader keeps the custom attributes under lower-cased names (_FUR_DIRECTION -> _fur_direction) and
// the mesh's extras in userData; the shell base's node is outside the default scene, so it is fetched by
// index. Two checks:
//   positions  every shell rebuilt in JavaScript with the README's formula (Simpson's rule, 16 intervals),
//              in double like furrow::instanced_shell_positions, and once more with every step rounded to
//              float32 (what a GPU's highp float does), and by the GPU itself (the README's GLSL, transform
//              feedback), each compared with the engine layout's shell vertices;
//   render     the shell base drawn N times (one InstancedMesh, the layer's height fraction per instance) by
//              its own material with the README's shell_position (job.glsl) in the vertex shader, and the
//              engine layout as loaded: the caller compares the two frames' coverage.
// The controls (the checks can fail): the same two measures without comb and droop (lean = sag = 0).
window.instancedJob = async function (job) {
  const inst = await load(job.url), engine = await load(job.engineUrl);
  const meshIndex = inst.parser.json.meshes.findIndex((m) => /_fur_shells$/.test(m.name || ''));
  const nodeIndex = inst.parser.json.nodes.findIndex((n) => n.mesh === meshIndex);
  if (meshIndex < 0 || nodeIndex < 0) throw new Error('no <mesh>_fur_shells mesh on a node');
  const base = await inst.parser.getDependency('node', nodeIndex);
  const params = base.userData.FURROW_shells;
  if (!params || params.version !== 1) throw new Error('the shell base has no extras.FURROW_shells version 1');
  const level = params.levels[0];
  let shells = null;
  engine.scene.traverse((o) => { if (o.isMesh && o.geometry.attributes._fur_layer) shells = o; });
  if (!shells) throw new Error('the engine layout has no primitive with _FUR_LAYER');
  const report = { layers: level.layers, vertices: base.geometry.attributes.position.count,
    gap_double: rebuildGap(base.geometry, shells.geometry, level.heights, (s) => jsShell(base.geometry, s, false, false)),
    gap_float32: rebuildGap(base.geometry, shells.geometry, level.heights, (s) => jsShell(base.geometry, s, true, false)),
    gap_straight: rebuildGap(base.geometry, shells.geometry, level.heights, (s) => jsShell(base.geometry, s, false, true)) };
  const gpu = gpuShells(base.geometry, level.heights, job.glsl);
  report.gap_gpu = rebuildGap(base.geometry, shells.geometry, level.heights, (s) => gpu.get(s));

  const scene = new THREE.Scene();
  scene.add(inst.scene.clone(true));
  const shader = instancedShells(base, level.heights, job.glsl, false);
  scene.add(shader);
  const engineScene = new THREE.Scene();
  engineScene.add(engine.scene.clone(true));
  for (const s of [scene, engineScene]) s.traverse((o) => { o.frustumCulled = false; });
  const a = draw(scene, job), b = draw(engineScene, job);
  scene.remove(shader);
  const straight = instancedShells(base, level.heights, job.glsl, true);
  straight.frustumCulled = false;
  scene.add(straight);
  const c = draw(scene, job);

  // Coverage (the viewer layout's measure, renderJob's 'coverage' mode): the body as OPAQUE grey 0 and the
  // shells drawn by the README's fragment rule, discard below cutoffs[i-1], writing that cutoff as a raw grey;
  // the control draws every shell with the material's own (placeholder) cutoff instead.
  const coverage = (perShell) => {
    const s = new THREE.Scene();
    const body = inst.scene.clone(true);
    body.traverse((o) => { if (o.isMesh) { o.frustumCulled = false; o.material = unlit(o.material, true); } });
    s.add(body);
    const shells = instancedShells(base, level.heights, job.glsl, false, perShell ? level.cutoffs : null);
    shells.frustumCulled = false;
    s.add(shells);
    return draw(s, job).png;
  };
  return { png: a.png, enginePng: b.png, straightPng: c.png, cutoffsPng: coverage(true), placeholderPng: coverage(false),
           ms: a.ms, report };
};

// The README's formula in JavaScript; f32 rounds every step to float32 (Math.fround) as GLSL highp would.
function shellPosition(out, root, D, H, lean, sag, s, f32) {
  const r = f32 ? Math.fround : (x) => x;
  const theta = r(Math.hypot(sag[0], sag[1], sag[2]));
  let A = s, B = 0;
  if (theta > 0) {
    const h = r(s / 16);
    let sa = 0, sb = 0;
    for (let k = 0; k <= 16; ++k) {
      const u = r(h * k), th = r(r(theta * u) * u), w = k === 0 || k === 16 ? 1 : (k & 1 ? 4 : 2);
      sa = r(sa + r(w * r(Math.cos(th))));
      sb = r(sb + r(w * r(Math.sin(th))));
    }
    A = r(r(sa * h) / 3);
    B = r(r(sb * h) / 3);
  }
  const g = theta > 0 ? r(B / theta) : 0;
  for (let k = 0; k < 3; ++k) out[k] = Math.fround(root[k] + r(H * r(r(r(A * D[k]) + r(g * sag[k])) + r(s * lean[k]))));
}

// Shell s rebuilt in JavaScript from the base's attributes, as xyz per vertex in the base's order;
// straight: lean and sag taken as zero (the control).
function jsShell(baseGeo, s, f32, straight) {
  const A = (n) => baseGeo.attributes[n];
  const zero = { getX: () => 0, getY: () => 0, getZ: () => 0 };
  const bp = A('position'), dir = A('_fur_direction'), len = A('_fur_length');
  const lean = (!straight && A('_fur_lean')) || zero, sag = (!straight && A('_fur_sag')) || zero;
  const out = new Float64Array(3 * bp.count), p = [0, 0, 0];
  for (let b = 0; b < bp.count; ++b) {
    shellPosition(p, [bp.getX(b), bp.getY(b), bp.getZ(b)], [dir.getX(b), dir.getY(b), dir.getZ(b)], len.getX(b),
      [lean.getX(b), lean.getY(b), lean.getZ(b)], [sag.getX(b), sag.getY(b), sag.getZ(b)], s, f32);
    out.set(p, 3 * b);
  }
  return out;
}

// The same shells computed by the GPU: the README's shell_position in a WebGL2 vertex shader whose output is
// captured by transform feedback (three.js has no such path, so raw WebGL2 on a canvas of its own).
function gpuShells(baseGeo, heights, glsl) {
  const gl = document.createElement('canvas').getContext('webgl2');
  const compile = (type, src) => {
    const sh = gl.createShader(type);
    gl.shaderSource(sh, src);
    gl.compileShader(sh);
    if (!gl.getShaderParameter(sh, gl.COMPILE_STATUS)) throw new Error(`GLSL: ${gl.getShaderInfoLog(sh)}`);
    return sh;
  };
  const prog = gl.createProgram();
  gl.attachShader(prog, compile(gl.VERTEX_SHADER, `#version 300 es
in vec3 position, _FUR_DIRECTION, _FUR_LEAN, _FUR_SAG;
in float _FUR_LENGTH;
uniform float u_s;
out vec3 shell;
${glsl}
void main() { shell = shell_position(position, _FUR_DIRECTION, _FUR_LENGTH, _FUR_LEAN, _FUR_SAG, u_s); gl_Position = vec4(0.0); }`));
  gl.attachShader(prog, compile(gl.FRAGMENT_SHADER, '#version 300 es\nprecision highp float;\nout vec4 c;\nvoid main() { c = vec4(0.0); }'));
  gl.transformFeedbackVaryings(prog, ['shell'], gl.INTERLEAVED_ATTRIBS);
  gl.linkProgram(prog);
  if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) throw new Error(`link: ${gl.getProgramInfoLog(prog)}`);
  gl.useProgram(prog);
  const n = baseGeo.attributes.position.count;
  for (const [name, attr] of [['position', 'position'], ['_FUR_DIRECTION', '_fur_direction'], ['_FUR_LENGTH', '_fur_length'],
    ['_FUR_LEAN', '_fur_lean'], ['_FUR_SAG', '_fur_sag']]) {
    const loc = gl.getAttribLocation(prog, name), a = baseGeo.attributes[attr];
    if (loc < 0) continue;
    if (!a) { gl.vertexAttrib4f(loc, 0, 0, 0, 0); continue; } // absent: zero, as the README says
    const values = new Float32Array(n * a.itemSize);
    for (let i = 0; i < n; ++i) for (let k = 0; k < a.itemSize; ++k) values[i * a.itemSize + k] = a.getComponent(i, k);
    gl.bindBuffer(gl.ARRAY_BUFFER, gl.createBuffer());
    gl.bufferData(gl.ARRAY_BUFFER, values, gl.STATIC_DRAW);
    gl.enableVertexAttribArray(loc);
    gl.vertexAttribPointer(loc, a.itemSize, gl.FLOAT, false, 0, 0);
  }
  const captured = gl.createBuffer();
  gl.bindBuffer(gl.TRANSFORM_FEEDBACK_BUFFER, captured);
  gl.bufferData(gl.TRANSFORM_FEEDBACK_BUFFER, 12 * n, gl.STATIC_READ);
  gl.enable(gl.RASTERIZER_DISCARD);
  const out = new Map();
  for (const s of heights) {
    gl.uniform1f(gl.getUniformLocation(prog, 'u_s'), s);
    gl.bindBufferBase(gl.TRANSFORM_FEEDBACK_BUFFER, 0, captured);
    gl.beginTransformFeedback(gl.POINTS);
    gl.drawArrays(gl.POINTS, 0, n);
    gl.endTransformFeedback();
    gl.bindBufferBase(gl.TRANSFORM_FEEDBACK_BUFFER, 0, null);
    const values = new Float32Array(3 * n);
    gl.bindBuffer(gl.TRANSFORM_FEEDBACK_BUFFER, captured);
    gl.getBufferSubData(gl.TRANSFORM_FEEDBACK_BUFFER, 0, values);
    out.set(s, values);
  }
  gl.getExtension('WEBGL_lose_context')?.loseContext();
  return out;
}

// The largest distance (per coordinate) between the engine layout's shells and rebuilt(s) (shell s from the
// instanced base, xyz in the base's vertex order), over the diagonal of the engine shells' bounds. Each file
// has its own vertex order, so the vertices of a shell are paired by what both files store unchanged:
// TEXCOORD_0, _FUR_DIRECTION and _FUR_LENGTH (then the root, or the engine's point, break ties).
function rebuildGap(baseGeo, engineGeo, heights, rebuilt) {
  const A = (g, n) => g.attributes[n];
  const bp = A(baseGeo, 'position'), ep = A(engineGeo, 'position'), layer = A(engineGeo, '_fur_layer');
  const key = (g, i) => [A(g, 'uv').getX(i), A(g, 'uv').getY(i), ...[0, 1, 2].map((k) => A(g, '_fur_direction').getComponent(i, k)), A(g, '_fur_length').getX(i)];
  const order = (g, idx, pos) => idx.map((i) => ({ k: [...key(g, i), ...pos(i)], i })).sort((x, y) => {
    for (let c = 0; c < x.k.length; ++c) if (x.k[c] !== y.k[c]) return x.k[c] - y.k[c];
    return 0;
  });
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < ep.count; ++i) for (let k = 0; k < 3; ++k) {
    lo[k] = Math.min(lo[k], ep.getComponent(i, k)); hi[k] = Math.max(hi[k], ep.getComponent(i, k));
  }
  const diagonal = Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
  const baseOrder = order(baseGeo, [...Array(bp.count).keys()], (i) => [bp.getX(i), bp.getY(i), bp.getZ(i)]);
  let worst = 0, compared = 0;
  for (const s of heights) {
    const mine = [...Array(ep.count).keys()].filter((i) => layer.getX(i) === Math.fround(s));
    if (mine.length !== bp.count) throw new Error(`shell ${s}: ${mine.length} engine vertices, ${bp.count} in the base`);
    const engineOrder = order(engineGeo, mine, (i) => [ep.getX(i), ep.getY(i), ep.getZ(i)]);
    const p = rebuilt(s);
    for (let j = 0; j < bp.count; ++j) {
      const b = baseOrder[j].i, e = engineOrder[j].i;
      for (let k = 0; k < 3; ++k) worst = Math.max(worst, Math.abs(p[3 * b + k] - ep.getComponent(e, k)));
      ++compared;
    }
  }
  return { max: worst, relative: worst / diagonal, diagonal, compared };
}

// The shell base as one InstancedMesh of `heights.length` instances, its material as loaded (the MASK shell
// material) extruding each vertex by the README's shell_position at the instance's height fraction;
// straight: with zero lean and sag (the control). With `cutoffs` (coverage): unlit, each instance discards
// alpha below its own cutoff and writes that cutoff as a raw grey (cutoffs null: the material's own).
function instancedShells(base, heights, glsl, straight, cutoffs) {
  const geo = base.geometry.clone();
  geo.setAttribute('fur_s', new THREE.InstancedBufferAttribute(new Float32Array(heights), 1));
  const coverage = cutoffs !== undefined;
  const own = base.material.alphaTest;
  if (coverage) geo.setAttribute('fur_cutoff', new THREE.InstancedBufferAttribute(new Float32Array(cutoffs || heights.map(() => own)), 1));
  const mat = coverage ? unlit(base.material, false) : base.material.clone();
  mat.onBeforeCompile = (sh) => {
    sh.vertexShader = 'attribute vec3 _fur_direction, _fur_lean, _fur_sag;\nattribute float _fur_length, fur_s;\n' +
      (coverage ? 'attribute float fur_cutoff;\nvarying float v_fur_cutoff;\n' : '') + glsl + '\n' +
      sh.vertexShader.replace('#include <begin_vertex>',
        `vec3 transformed = shell_position(position, _fur_direction, _fur_length, ${straight ? 'vec3(0.0), vec3(0.0)' : '_fur_lean, _fur_sag'}, fur_s);` +
        (coverage ? '\n  v_fur_cutoff = fur_cutoff;' : ''));
    if (!coverage) return;
    sh.fragmentShader = 'varying float v_fur_cutoff;\n' +
      sh.fragmentShader.replace('#include <alphatest_fragment>', 'if (diffuseColor.a < v_fur_cutoff) discard;')
        .replace('#include <dithering_fragment>', '#include <dithering_fragment>\n  gl_FragColor.rgb = vec3(max(v_fur_cutoff, 1.0 / 255.0));');
  };
  mat.customProgramCacheKey = () => `furrow-instanced-shells-${straight}-${coverage}`;
  const mesh = new THREE.InstancedMesh(geo, mat, heights.length);
  for (let i = 0; i < heights.length; ++i) mesh.setMatrixAt(i, new THREE.Matrix4());
  mesh.matrix.copy(base.matrix);
  mesh.matrix.decompose(mesh.position, mesh.quaternion, mesh.scale);
  return mesh;
}
window.pageReady = true;
