// Renders glTF files with three.js in headless Chromium, as a stock web viewer would, for the real-client
// test stage (tests/viewer) and `furrow bench render`.
//
//   node render_three.mjs --modules DIR [--chromium PATH] JOBS.json
//
// DIR is the npm prefix holding `three` and `puppeteer-core` (.ci/install-deps installs them into
// .cache/viewer). JOBS.json is an array of views:
//   {"model": "a.glb", "out": "a.png", "width": 256, "height": 192, "eye": [x,y,z], "target": [x,y,z],
//    "up": [0,1,0], "fov": 45, "near": 0.01, "far": 100, "mode": "material", "mipmaps": "sampler"}
// mode: lit | material | coverage (page.js says what each draws); mipmaps: sampler (as the file asks) | off.
// A job with "task": "instanced" checks the instanced shell layout instead (page.js instancedJob): "model" is
// the `--layout instanced` file, "engine" the `--layout engine` file of the same fur; it writes "out" (the
// instanced layout drawn by the README's vertex shader), "engine_out" (the engine layout as loaded) and
// "straight_out" (the control: the same shader with lean = sag = 0), "report" (JSON: the largest gaps
// between the shells rebuilt in JavaScript and the engine layout's), and out + ".cutoffs.png" /
// out + ".placeholder.png" (coverage with each shell's own cutoff, and with the material's one cutoff).
// The shader is the README's own: its GLSL block's shell_position function, read here and passed to the page.
// Each view is written as an RGBA PNG with a transparent background; one line of JSON per view goes to
// stdout ({"out": ..., "ms": ...}). Exit 0 when every view was written, 1 otherwise (the reason on stderr).
//
// The page, the three.js modules and the models are served from 127.0.0.1 on a port the system picks (pages
// opened from file:// cannot import modules); only the files named in JOBS.json and three's own are served.
// Chromium draws with SwiftShader (software GL), so the result does not depend on a GPU.
import fs from 'node:fs';
import http from 'node:http';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

function fail(msg) {
  process.stderr.write(`Error: ${msg}\n`);
  process.exit(1);
}

const args = process.argv.slice(2);
let modules = '', chromium = '', jobsFile = '';
for (let i = 0; i < args.length; ++i) {
  if (args[i] === '--modules') modules = args[++i];
  else if (args[i] === '--chromium') chromium = args[++i];
  else jobsFile = args[i];
}
if (!modules || !jobsFile) fail('usage: node render_three.mjs --modules DIR [--chromium PATH] JOBS.json');
const candidates = [chromium, process.env.FURROW_CHROMIUM, '/usr/bin/chromium-headless-shell',
  '/usr/lib/chromium/headless_shell', '/usr/bin/chromium'].filter(Boolean);
chromium = candidates.find((p) => fs.existsSync(p));
if (!chromium) fail(`no headless Chromium found (tried ${candidates.join(', ')}): apt-get install chromium-headless-shell`);
const threeDir = path.join(modules, 'node_modules', 'three');
if (!fs.existsSync(path.join(threeDir, 'package.json'))) fail(`three.js is not installed under ${modules} (bash .ci/install-deps)`);

const jobs = JSON.parse(fs.readFileSync(jobsFile, 'utf8'));
const here = path.dirname(fileURLToPath(import.meta.url));
const models = [...new Set(jobs.flatMap((j) => [j.model, j.engine].filter(Boolean).map((m) => path.resolve(m))))];
// The README's reference vertex shader, verbatim: its GLSL block's functions, from the comment above the first
// one to the end of shell_position (the block's attribute and uniform declarations are the caller's).
function readmeShellPosition() {
  const readme = fs.readFileSync(path.join(here, '..', '..', 'README.md'), 'utf8');
  const block = readme.split('```glsl\n').slice(1).map((b) => b.split('```')[0]).find((b) => b.includes('vec3 shell_position('));
  if (!block) fail('README.md has no GLSL block with shell_position');
  const first = block.search(/^(void|float|vec[234]) \w+\(/m);
  const from = block.lastIndexOf('\n', block.lastIndexOf('uniform', first)) + 1;
  const end = block.indexOf('\n}', block.indexOf('vec3 shell_position('));
  return block.slice(block.indexOf('\n', from) + 1, end + 2);
}
for (const m of models) if (!fs.existsSync(m)) fail(`${m}: no such file`);

const types = { '.js': 'text/javascript', '.mjs': 'text/javascript', '.html': 'text/html', '.glb': 'model/gltf-binary',
  '.gltf': 'model/gltf+json', '.bin': 'application/octet-stream', '.png': 'image/png', '.jpg': 'image/jpeg' };
const page = `<!doctype html><html><head><meta charset="utf-8">
<script type="importmap">{"imports": {"three": "/three/build/three.module.js", "three/addons/": "/three/examples/jsm/"}}</script>
</head><body style="margin:0"><canvas id="c"></canvas><script type="module" src="/page.js"></script></body></html>`;

// /model/<k>/<name>: model k's folder, so a .gltf finds its .bin and images beside it.
function resolve(url) {
  const p = decodeURIComponent(url.split('?')[0]);
  if (p === '/page.js') return path.join(here, 'page.js');
  if (p.startsWith('/three/')) return path.join(threeDir, path.normalize(p.slice(7)).replace(/^(\.\.[/\\])+/, ''));
  const m = p.match(/^\/model\/(\d+)\/(.+)$/);
  if (m && Number(m[1]) < models.length) {
    const dir = path.dirname(models[Number(m[1])]);
    const file = path.resolve(dir, path.normalize(m[2]));
    if (file.startsWith(dir + path.sep)) return file;
  }
  return null;
}
const server = http.createServer((req, res) => {
  if (req.url === '/') { res.writeHead(200, { 'content-type': 'text/html' }); res.end(page); return; }
  const file = resolve(req.url);
  if (!file || !fs.existsSync(file)) { res.writeHead(404); res.end(); return; }
  res.writeHead(200, { 'content-type': types[path.extname(file)] || 'application/octet-stream' });
  fs.createReadStream(file).pipe(res);
});
await new Promise((ok) => server.listen(0, '127.0.0.1', ok));
const base = `http://127.0.0.1:${server.address().port}`;

const { default: puppeteer } = await import(path.join(modules, 'node_modules', 'puppeteer-core', 'lib', 'esm', 'puppeteer', 'puppeteer-core.js'));
let browser;
let status = 0;
try {
  browser = await puppeteer.launch({
    executablePath: chromium,
    headless: 'shell',
    args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--disable-gpu-driver-bug-workarounds',
      '--disable-background-networking', '--disable-component-update', '--disable-sync', '--no-first-run', '--disable-quic'],
  });
  const tab = await browser.newPage();
  const errors = [];
  tab.on('pageerror', (e) => errors.push(String(e)));
  tab.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  await tab.goto(`${base}/`);
  await tab.waitForFunction('window.pageReady === true', { timeout: 60000 }).catch(() => fail(`the page did not start: ${errors.join('; ')}`));
  for (const job of jobs) {
    const k = models.indexOf(path.resolve(job.model));
    const view = { mode: 'material', mipmaps: 'sampler', up: [0, 1, 0], ...job, url: `${base}/model/${k}/${encodeURIComponent(path.basename(job.model))}` };
    let r;
    if (job.task === 'instanced') {
      view.engineUrl = `${base}/model/${models.indexOf(path.resolve(job.engine))}/${encodeURIComponent(path.basename(job.engine))}`;
      view.glsl = readmeShellPosition();
    }
    try {
      r = await tab.evaluate((v) => (v.task === 'instanced' ? window.instancedJob(v) : window.renderJob(v)), view);
    } catch (e) {
      process.stderr.write(`Error: ${job.model}: ${String(e).split('\n')[0]} ${errors.join('; ')}\n`);
      status = 1;
      continue;
    }
    fs.writeFileSync(job.out, Buffer.from(r.png.split(',')[1], 'base64'));
    if (job.task === 'instanced') {
      fs.writeFileSync(job.engine_out, Buffer.from(r.enginePng.split(',')[1], 'base64'));
      fs.writeFileSync(job.straight_out, Buffer.from(r.straightPng.split(',')[1], 'base64'));
      fs.writeFileSync(`${job.out}.cutoffs.png`, Buffer.from(r.cutoffsPng.split(',')[1], 'base64'));
      fs.writeFileSync(`${job.out}.placeholder.png`, Buffer.from(r.placeholderPng.split(',')[1], 'base64'));
      fs.writeFileSync(job.report, JSON.stringify(r.report));
    }
    process.stdout.write(JSON.stringify({ out: job.out, ms: r.ms }) + '\n');
  }
} catch (e) {
  process.stderr.write(`Error: ${String(e).split('\n')[0]}\n`);
  status = 1;
} finally {
  if (browser) await browser.close();
  server.close();
}
process.exit(status);
