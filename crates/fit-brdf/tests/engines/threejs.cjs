// Renders a glTF material with three.js in headless Chromium and writes the linear
// float pixels as JSON (engines_threejs.rs compares them with brdfkit-render's image).
//
//   node threejs.cjs SCENE.json OUT.json CHROMIUM [SHOTS_DIR]
//
// SCENE.json: {"size": N, "camera": {"position": [x,y,z], "fov": deg}, "light":
// {"from": [x,y,z] (unit, towards the light), "irradiance": E}, "segments": [w, h],
// "materials": [{"name": ..., "file": "....gltf"}, ...]}. OUT.json: {"errors": [...],
// "size": N, "renders": [{"name", "info", "rgba": [N*N*4 floats, rows top-down]}]};
// with SHOTS_DIR, the canvas of each material as <name>.png (8-bit sRGB, clipped at 1,
// on black: the encoding of `fit-brdf render`'s PNG; a picture, not the measurement).
// The camera looks at the origin with +y up; the unit sphere sits at the origin.
//
// The page and three.js (npm `three`, from node_modules next to playwright-core: never a
// CDN) are served by a static server of this script on 127.0.0.1 (ES modules cannot load
// from file://). GLTFLoader reads the material (the file has no mesh: only
// materials[0]); it goes onto a SphereGeometry lit by one DirectionalLight, no
// environment, NoToneMapping, rendered into a FloatType WebGLRenderTarget whose pixels
// are read back with readRenderTargetPixels (rows bottom-up, as WebGL gives them; this
// script flips them to top-down). Alpha is 0 where the sphere does not cover the pixel.
'use strict';
const fs = require('fs');
const http = require('http');
const path = require('path');
const { launch } = require('../browser/launch.cjs');

const [scenePath, outPath, exe, shots] = process.argv.slice(2);
// The package root (its main file is build/three.cjs; package.json is not exported).
const threeDir = path.resolve(path.dirname(require.resolve('three')), '..');
const scene = JSON.parse(fs.readFileSync(scenePath, 'utf8'));

const page = `<!doctype html><html><head><meta charset="utf-8">
<script type="importmap">{"imports": {"three": "/three/build/three.module.js",
  "three/addons/": "/three/examples/jsm/"}}</script></head><body>
<script type="module">
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
window.render = async (s, url) => {
  const gltf = await new GLTFLoader().loadAsync(url);
  const material = await gltf.parser.getDependency('material', 0);
  const n = s.size;
  const renderer = new THREE.WebGLRenderer({ antialias: false });
  renderer.setSize(n, n, false);
  renderer.setPixelRatio(1);
  renderer.toneMapping = THREE.NoToneMapping;
  renderer.outputColorSpace = THREE.LinearSRGBColorSpace;
  renderer.setClearColor(0x000000, 0);
  const scene = new THREE.Scene();
  const sphere = new THREE.Mesh(new THREE.SphereGeometry(1, s.segments[0], s.segments[1]), material);
  scene.add(sphere);
  const light = new THREE.DirectionalLight(0xffffff, s.light.irradiance);
  light.position.set(...s.light.from);
  light.target.position.set(0, 0, 0);
  scene.add(light, light.target);
  const camera = new THREE.PerspectiveCamera(s.camera.fov, 1, 0.1, 100);
  camera.position.set(...s.camera.position);
  camera.up.set(0, 1, 0);
  camera.lookAt(0, 0, 0);
  const target = new THREE.WebGLRenderTarget(n, n, { type: THREE.FloatType });
  renderer.setRenderTarget(target);
  renderer.render(scene, camera);
  const px = new Float32Array(n * n * 4);
  renderer.readRenderTargetPixels(target, 0, 0, n, n, px);
  // The canvas (the screenshot, a picture for people): sRGB-encoded, clipped at 1, on
  // black, as fit-brdf render's PNG at exposure 0. The float target above stays linear.
  renderer.setRenderTarget(null);
  renderer.outputColorSpace = THREE.SRGBColorSpace;
  renderer.setClearColor(0x000000, 1);
  renderer.render(scene, camera);
  const ext = material.type + (material.sheen > 0 ? ' sheen' : '') + (material.clearcoat > 0 ? ' clearcoat' : '');
  // MeshStandardMaterial (a core-only file) has none of the extensions' fields.
  const info = { revision: THREE.REVISION, material: ext, sheen: material.sheen,
    sheenColor: material.sheenColor?.toArray(), sheenRoughness: material.sheenRoughness,
    clearcoat: material.clearcoat, clearcoatRoughness: material.clearcoatRoughness,
    ior: material.ior, specularIntensity: material.specularIntensity,
    specularColor: material.specularColor?.toArray(), color: material.color.toArray(),
    metalness: material.metalness, roughness: material.roughness,
    float: renderer.extensions.has('EXT_color_buffer_float') };
  document.body.replaceChildren(renderer.domElement);
  return { info, pixels: Array.from(px) };
};
window.ready = true;
</script></body></html>`;

const types = { '.js': 'text/javascript', '.html': 'text/html', '.gltf': 'model/gltf+json' };
function serve(req, res) {
  const url = decodeURIComponent(req.url.split('?')[0]);
  let file = null;
  if (url === '/' || url === '/index.html') {
    res.writeHead(200, { 'content-type': types['.html'] });
    return res.end(page);
  }
  if (url === '/favicon.ico') {
    res.writeHead(204);
    return res.end();
  }
  const m = /^\/material\/(\d+)\.gltf$/.exec(url);
  if (m && scene.materials[Number(m[1])]) file = scene.materials[Number(m[1])].file;
  else if (url.startsWith('/three/')) {
    file = path.join(threeDir, path.normalize(url.slice('/three/'.length)));
    if (!file.startsWith(threeDir + path.sep)) file = null;
  }
  if (file === null || !fs.existsSync(file)) {
    res.writeHead(404);
    return res.end();
  }
  res.writeHead(200, { 'content-type': types[path.extname(file)] || 'application/octet-stream' });
  fs.createReadStream(file).pipe(res);
}

async function main() {
  const server = http.createServer(serve);
  await new Promise((ok) => server.listen(0, '127.0.0.1', ok));
  const port = server.address().port;
  const browser = await launch(exe);
  const errors = [];
  try {
    const tab = await browser.newPage({ viewport: { width: scene.size, height: scene.size } });
    tab.on('console', (m) => { if (m.type() === 'error') errors.push('console: ' + m.text()); });
    tab.on('pageerror', (e) => errors.push('exception: ' + e.message));
    tab.on('requestfailed', (r) => errors.push('request failed: ' + r.url()));
    await tab.goto(`http://127.0.0.1:${port}/`);
    await tab.waitForFunction(() => window.ready === true, null, { timeout: 60000 });
    const n = scene.size;
    const renders = [];
    for (const [i, m] of scene.materials.entries()) {
      const r = await tab.evaluate(([s, url]) => window.render(s, url), [scene, `/material/${i}.gltf`]);
      if (shots) {
        await tab.locator('canvas').last().screenshot({ path: path.join(shots, m.name + '.png') });
      }
      const rows = [];
      for (let y = n - 1; y >= 0; y--) rows.push(r.pixels.slice(y * n * 4, (y + 1) * n * 4));
      renders.push({ name: m.name, info: r.info, rgba: [].concat(...rows) });
    }
    fs.writeFileSync(outPath, JSON.stringify({ errors, size: n, renders }));
  } finally {
    await browser.close();
    server.close();
  }
  if (errors.length) {
    console.error(errors.join('\n'));
    process.exit(1);
  }
}

main().catch((e) => { console.error(String(e && e.stack || e)); process.exit(1); });
