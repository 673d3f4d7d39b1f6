// gltf_three.mjs - the reader's half of the glTF check (issue 10; gltf_fixture.c is the other):
// three.js's GLTFLoader (the viewer's npm three, clients/web/node_modules/three) in Debian's headless
// chromium, driven by playwright-core, loads OUT/skin.glb, plays its one animation through an
// AnimationMixer at each checked frame's key time, updates the scene's matrices and reads every
// vertex's skinned position with SkinnedMesh.getVertexPosition (then the mesh's matrixWorld).
// Node compares them with OUT/expected.bin (our reconstruction of the same frames) and fails unless
// the largest vertex error is at most 1e-4 of the rest bounding-box diagonal at every frame.
//
// The clip is played with LoopOnce and clampWhenFinished, so that a key time is that key's pose
// (three's default LoopRepeat wraps the clip's duration, the last key's time, to 0). skin.glb
// closes the loop: N + 1 keys, the last at N / fps repeating frame 0, so a looping engine goes from
// frame N - 1 to frame 0 in one frame's time; checked: its duration is N / fps and its last key's
// pose is our frame 0. once.glb (--gltf-once) ends at frame N - 1: N keys, (N - 1) / fps.
//
// Usage: node gltf_three.mjs OUTDIR     (exit 77 = skip when chromium or playwright is absent)
import { existsSync, mkdtempSync, readFileSync, rmSync, statSync } from 'node:fs';
import { createServer } from 'node:http';
import { tmpdir } from 'node:os';
import { dirname, extname, join, normalize } from 'node:path';
import { createRequire } from 'node:module';
import { fileURLToPath } from 'node:url';

const out = process.argv[2];
if (!out) {
  console.error('usage: node gltf_three.mjs OUTDIR');
  process.exit(2);
}
const here = dirname(fileURLToPath(import.meta.url));
const web = process.env.MESHSTEER_WEB_DIR ||
  join(process.env.MESHSTEER_SRC || join(here, '../../..'), 'clients/web');
const chromium = process.env.CHROMIUM || '/usr/bin/chromium';
if (!existsSync(chromium)) {
  console.error(`skip: ${chromium} not installed`);
  process.exit(77);
}
const three = join(web, 'node_modules/three');
if (!existsSync(join(three, 'examples/jsm/loaders/GLTFLoader.js'))) {
  console.error('skip: three.js not installed (npm ci in clients/web)');
  process.exit(77);
}
const require = createRequire(join(web, 'package.json'));
let pw;
try {
  pw = require('playwright-core');
} catch (e) {
  console.error('skip: playwright-core not installed (npm ci in clients/web)');
  process.exit(77);
}

// expected.bin (gltf_fixture.c): float64 nv, nsel, diag, fps, nsel x (frame, time), positions
const eb = readFileSync(join(out, 'expected.bin'));
const ex = new Float64Array(eb.buffer, eb.byteOffset, eb.byteLength / 8);
const nv = ex[0], nsel = ex[1], diag = ex[2], fps = ex[3];
const sel = [];
for (let k = 0; k < nsel; k++) sel.push({ frame: ex[4 + 2 * k], time: ex[5 + 2 * k] });
const posAt = k => ex.subarray(4 + 2 * nsel + 3 * nv * k, 4 + 2 * nsel + 3 * nv * (k + 1));
if (ex.length !== 4 + 2 * nsel + 3 * nv * nsel) {
  console.error(`expected.bin: ${ex.length} numbers, not ${4 + 2 * nsel + 3 * nv * nsel}`);
  process.exit(1);
}

const page = `<!doctype html><html><head><meta charset="utf-8">
<script type="importmap">{"imports": {"three": "/three/build/three.module.js",
  "three/addons/": "/three/examples/jsm/"}}</script></head><body>
<script type="module">
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
window.skinned = async (file, frames, anim = 0, nanims = 1) => {
  const gltf = await new GLTFLoader().loadAsync('/out/' + file);
  const scene = gltf.scene;
  let mesh = null;
  scene.traverse(o => { if (o.isSkinnedMesh) mesh = o; });
  if (!mesh) throw new Error('no SkinnedMesh in skin.glb');
  if (gltf.animations.length !== nanims) throw new Error(gltf.animations.length + ' animations, not ' + nanims);
  const clip = gltf.animations[anim];
  const info = {
    vertices: mesh.geometry.attributes.position.count,
    joints: mesh.skeleton.bones.map(b => b.name),
    clip: clip.name, tracks: clip.tracks.length, duration: clip.duration,
    keys: clip.tracks[0].times.length, frames: [],
  };
  const v = new THREE.Vector3();
  for (const f of frames) {
    const t = clip.tracks[0].times[f]; // the key time as the file holds it (float32 f / fps)
    const mixer = new THREE.AnimationMixer(scene);
    const action = mixer.clipAction(clip);
    action.setLoop(THREE.LoopOnce, 1);
    action.clampWhenFinished = true;
    action.play();
    mixer.setTime(t);
    scene.updateMatrixWorld(true);
    const pos = new Array(3 * info.vertices);
    for (let i = 0; i < info.vertices; i++) {
      mesh.getVertexPosition(i, v).applyMatrix4(mesh.matrixWorld);
      pos[3 * i] = v.x; pos[3 * i + 1] = v.y; pos[3 * i + 2] = v.z;
    }
    info.frames.push({ frame: f, time: t, pos });
    mixer.stopAllAction();
    mixer.uncacheRoot(scene);
  }
  return info;
};
window.ready = true;
</script></body></html>`;

const types = { '.js': 'text/javascript', '.mjs': 'text/javascript', '.glb': 'model/gltf-binary',
                '.json': 'application/json' };
const server = createServer((req, res) => {
  const url = new URL(req.url, 'http://x').pathname;
  let file = null;
  if (url === '/') {
    res.writeHead(200, { 'content-type': 'text/html' });
    return res.end(page);
  }
  if (url === '/favicon.ico') {
    res.writeHead(204);
    return res.end();
  }
  for (const [prefix, root] of [['/three/', three], ['/out/', out]]) {
    if (url.startsWith(prefix)) {
      const p = normalize(join(root, decodeURIComponent(url.slice(prefix.length))));
      if (p.startsWith(normalize(root))) file = p;
    }
  }
  if (!file || !existsSync(file) || !statSync(file).isFile()) {
    res.writeHead(404);
    return res.end();
  }
  res.writeHead(200, { 'content-type': types[extname(file)] || 'application/octet-stream' });
  res.end(readFileSync(file));
});
await new Promise(r => server.listen(0, '127.0.0.1', r));
const base = `http://127.0.0.1:${server.address().port}/`;

const profile = mkdtempSync(join(tmpdir(), 'meshsteer-chromium-'));
// a fresh profile directory (playwright passes it to chromium as --user-data-dir); the same flags
// as the viewer's end-to-end test (tests/server/e2e/viewer.mjs); no WebGL is needed here
const browser = await pw.chromium.launchPersistentContext(profile, {
  executablePath: chromium,
  headless: true,
  args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-background-networking',
         '--disable-component-update', '--disable-sync', '--no-first-run', '--disable-quic'],
});
let failed = false;
try {
  const pg = browser.pages()[0] || await browser.newPage();
  pg.on('console', m => { if (m.type() === 'warning' || m.type() === 'error') console.log(`page ${m.type()}: ${m.text()}`); });
  pg.on('pageerror', e => { console.log(`page error: ${e.message}`); failed = true; });
  await pg.goto(base);
  await pg.waitForFunction(() => window.ready === true, null, { timeout: 30000 });
  const n = sel[nsel - 1].frame + 1; // the fitted frames: sel is 0, N/2, N - 1
  // skin.glb: the checked frames, then the closing key N (expected: frame 0's pose at N / fps)
  const info = await pg.evaluate(a => window.skinned(a.file, a.frames),
                                 { file: 'skin.glb', frames: [...sel.map(s => s.frame), n] });
  const once = await pg.evaluate(a => window.skinned(a.file, a.frames),
                                 { file: 'once.glb', frames: [n - 1] });
  console.log(`three.js GLTFLoader: ${info.vertices} vertices, ${info.joints.length} joints ` +
              `(${info.joints.join(' ')}), animation "${info.clip}": ${info.tracks} tracks, ` +
              `${info.keys} keys, ${info.duration.toFixed(6)} s; once.glb ${once.keys} keys, ` +
              `${once.duration.toFixed(6)} s`);
  const check = (ok, what) => { if (!ok) { console.log(`FAIL: ${what}`); failed = true; } };
  check(info.vertices === nv, `${info.vertices} vertices, not ${nv}`);
  check(info.joints.every((n, j) => n === `bone_${String(j).padStart(3, '0')}`), 'joint names');
  check(info.tracks === 2 * info.joints.length, 'a translation and a rotation track per joint');
  check(info.keys === n + 1, `skin.glb: ${info.keys} keys, not N + 1 = ${n + 1}`);
  check(Math.abs(info.duration - n / fps) < 1e-6, 'skin.glb: clip duration N / fps');
  check(once.keys === n, `once.glb: ${once.keys} keys, not N = ${n}`);
  check(Math.abs(once.duration - (n - 1) / fps) < 1e-6, 'once.glb: clip duration (N - 1) / fps');
  // expected per checked pose: sel[0..nsel) for skin.glb, then frame 0 (the closing key), then
  // frame N - 1 of once.glb
  const want = [...sel.map((s, k) => ({ k, time: s.time })), { k: 0, time: n / fps },
                { k: nsel - 1, time: sel[nsel - 1].time }];
  [...info.frames, ...once.frames].forEach((fr, q) => {
    const e = posAt(want[q].k), name = q < nsel ? '' : q === nsel ? ' (closing key)' : ' (once.glb)';
    let max = 0, sum = 0, worst = -1;
    for (let i = 0; i < nv; i++) {
      const d = Math.hypot(fr.pos[3 * i] - e[3 * i], fr.pos[3 * i + 1] - e[3 * i + 1],
                           fr.pos[3 * i + 2] - e[3 * i + 2]);
      sum += d * d;
      if (d > max) { max = d; worst = i; }
    }
    const ok = max <= 1e-4 * diag;
    console.log(`frame ${fr.frame}${name} (t = ${fr.time.toFixed(6)} s, expected ${want[q].time.toFixed(6)}): ` +
                `max error ${max.toExponential(3)} m (${(max / diag).toExponential(3)} of the ` +
                `diagonal ${diag.toFixed(4)} m, vertex ${worst}), rms ${Math.sqrt(sum / nv).toExponential(3)} m` +
                (ok ? '' : '  > 1e-4 of the diagonal'));
    check(Math.abs(fr.time - want[q].time) < 1e-6, `frame ${fr.frame}${name}: key time`);
    check(ok, `frame ${fr.frame}: skinned positions differ`);
  });
  // variations.glb: two walks as two animations on one skinned mesh; frames 0, 30, 59 of each
  // against the walks' own skinning (variations.bin, gltf_fixture.c)
  const vb = readFileSync(join(out, 'variations.bin'));
  const vx = new Float64Array(vb.buffer, vb.byteOffset, vb.byteLength / 8);
  const vnv = vx[0], vsel = vx[1], vdiag = vx[2];
  for (let a = 0; a < 2; a++) {
    const fr = [0, 1, 2].map(k => vx[4 + 2 * (3 * a + k)] - 1000 * a);
    const got = await pg.evaluate(x => window.skinned(x.file, x.frames, x.anim, 2),
                                  { file: 'variations.glb', frames: fr, anim: a });
    check(got.clip === `variation_${String(a).padStart(3, '0')}`, `animation ${a} is named ${got.clip}`);
    check(got.keys === 60, `variation ${a}: ${got.keys} keys, not 60`);
    got.frames.forEach((g, k) => {
      const q = 3 * a + k, e = vx.subarray(4 + 2 * vsel + 3 * vnv * q, 4 + 2 * vsel + 3 * vnv * (q + 1));
      let max = 0;
      for (let i = 0; i < vnv; i++)
        max = Math.max(max, Math.hypot(g.pos[3 * i] - e[3 * i], g.pos[3 * i + 1] - e[3 * i + 1],
                                       g.pos[3 * i + 2] - e[3 * i + 2]));
      console.log(`variations.glb animation ${a} ("${got.clip}") frame ${g.frame}: max error ` +
                  `${max.toExponential(3)} (${(max / vdiag).toExponential(3)} of the diagonal)`);
      check(max <= 1e-4 * vdiag, `variation ${a} frame ${g.frame}: skinned positions differ`);
    });
  }
} catch (e) {
  console.log(`FAIL: ${e.stack || e}`);
  failed = true;
} finally {
  await browser.close();
  server.close();
  rmSync(profile, { recursive: true, force: true });
}
console.log(failed ? 'gltf_three: FAILED' : 'gltf_three: ok');
process.exit(failed ? 1 : 0);
