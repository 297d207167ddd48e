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
};
window.pageReady = true;
