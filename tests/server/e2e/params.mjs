// params.mjs - the params encoding's GPU reconstruction in headless Chromium (playwright-core):
// the viewer, opened with ?encoding=params, draws params frames with its vertex shader
// (clients/web/params.js); meanwhile the page also subscribes to float32 frames on a second
// WebSocket. For params frames of both kinds (the steering model while the replay plays, its skin
// once the replay has ended and the idle animation runs), the shader's positions read back by
// transform feedback (window.meshsteerParams.snapshot) must equal the float32 frame of the same
// sequence number within the int16 bound of docs/PROTOCOL.md on every axis of every vertex; so
// must the position texture the viewer draws the mesh from (its first pass, read back).
// Usage: node params.mjs URL SCREENSHOT.png     (exit 77 = skip when chromium or playwright is absent)
import { existsSync, mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { createRequire } from 'node:module';

const [url, shot] = process.argv.slice(2);
const chromium = process.env.CHROMIUM || '/usr/bin/chromium';
if (!existsSync(chromium)) { console.error(`skip: ${chromium} not installed`); process.exit(77); }
const require = createRequire(process.env.MESHSTEER_WEB_DIR + '/package.json');
let pw;
try { pw = require('playwright-core'); } catch (e) { console.error('skip: playwright-core not installed'); process.exit(77); }
const profile = mkdtempSync(join(tmpdir(), 'meshsteer-chromium-'));
const browser = await pw.chromium.launchPersistentContext(profile, {
  executablePath: chromium, headless: true, viewport: { width: 640, height: 480 }, bypassCSP: true,
  args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-background-networking',
         '--disable-component-update', '--disable-sync', '--no-first-run', '--disable-quic',
         '--use-angle=swiftshader', '--enable-unsafe-swiftshader'],
});
let failed = false;
const fail = msg => { console.error('FAIL: ' + msg); failed = true; };
try {
  const page = browser.pages()[0] || await browser.newPage();
  page.on('pageerror', e => fail(`page error: ${e}`));
  await page.goto(url);
  await page.waitForFunction(() => window.meshsteer.paramsFrames > 3 && window.meshsteerParams.material(),
                             null, { timeout: 30000 });
  // the float32 stream of the same daemon, kept by sequence number (the newest 600)
  await page.evaluate(async () => {
    const P = await import('/protocol.js');
    const ws = new WebSocket(`ws://${location.host}/stream`, 'meshsteer.v1');
    ws.binaryType = 'arraybuffer';
    let topo = null;
    window.f32 = new Map();
    ws.onmessage = ev => {
      if (typeof ev.data === 'string') return;
      const k = P.kind(ev.data);
      if (k === 'topology') topo = P.decodeTopology(ev.data);
      else if (k === 'frame' && topo) {
        const out = { V: new Float32Array(topo.nv * 3), markers: new Float32Array(topo.nm * 3),
                      valid: new Uint8Array(topo.nm) };
        const h = P.decodeFrame(ev.data, topo, out);
        window.f32.set(h.seq, { V: out.V, flags: h.flags });
        if (window.f32.size > 600) window.f32.delete(window.f32.keys().next().value);
      }
    };
    window.f32topo = () => topo;
  });
  // Each check takes a frame both WebSockets got: the shader by transform feedback for one of the
  // viewer's last 120 params frames of the wanted kind (steer: layout kind 1, skin: 3), or the
  // position texture the mesh was last drawn from ('drawn'), against the float32 frame.
  const checked = { 1: 0, 3: 0, drawn: 0 };
  let worst = 0;
  const t0 = Date.now();
  const order = [1, 'drawn', 1, 'drawn', 1, 'drawn', 3, 3, 3];
  for (let n = 0; n < order.length && Date.now() - t0 < 90000;) {
    const want = order[n];
    const r = await page.evaluate(want => {
      const m = window.meshsteerParams, t = window.f32topo();
      if (!t) return null;
      let snap = null;
      if (want === 'drawn') {
        if (window.f32.has(m.drawnSeq)) snap = { seq: m.drawnSeq, layout: -1, kind: 'drawn', V: m.positions() };
      } else {
        const q = m.seqs(want).filter(q => window.f32.has(q)).pop(); // the newest in both
        if (q !== undefined) snap = m.snapshot(q);
      }
      if (!snap) return null;
      const f = window.f32.get(snap.seq);
      let worst = 0, at = -1, bad = 0;
      for (let i = 0; i < snap.V.length; i++) {
        const a = i % 3, bound = (t.qmax[a] - t.qmin[a]) / 131070 * 1.0001 + 1e-6;
        const d = Math.abs(snap.V[i] - f.V[i]) / bound;
        if (!(d <= 1)) bad++;
        if (!(d <= worst)) { worst = d; at = i; }
      }
      return { seq: snap.seq, layout: snap.layout, kind: snap.kind, worst, at, bad, n: snap.V.length / 3,
               idle: (f.flags & 8) !== 0 };
    }, want);
    if (!r) { await page.waitForTimeout(250); continue; } // no common frame of that kind yet
    const what = r.kind === 'drawn' ? 'drawn (position texture)' : r.kind === 1 ? 'steer' : 'skin';
    console.log(`seq ${r.seq} layout ${r.layout} (${what}${r.idle ? ', idle' : ''}): ` +
                `${r.n} vertices, worst ${r.worst.toFixed(3)} of the int16 bound (coordinate ${r.at}), ${r.bad} outside`);
    if (r.bad) fail(`seq ${r.seq}: ${r.bad} coordinates outside the int16 bound (worst ${r.worst})`);
    if (r.kind !== 'drawn' && (r.kind === 3) !== r.idle) fail(`seq ${r.seq}: layout kind ${r.kind} but idle flag ${r.idle}`);
    worst = Math.max(worst, r.worst);
    checked[r.kind]++;
    n++;
    await page.waitForTimeout(300); // the next check on other frames
  }
  // "colour by part" on a skin's frames shows its weights as colour: every vertex the blend of its
  // bones' colours (the golden-ratio HSV hues of `render --skin`, server/bone_colours.c, computed
  // here again), so a vertex between two bones gets a colour of neither
  await page.click('#c-parts');
  await page.waitForFunction(() => window.meshsteer.colouring === 'bone weights', null, { timeout: 20000 });
  const drv = await page.evaluate(() => window.meshsteer.driver);
  if (drv !== 'idle') fail(`the skin's idle frames show driver '${drv}', want 'idle'`);
  const bc = await page.evaluate(() => ({ c: window.meshsteerParams.colours(), w: window.meshsteerParams.skinWeights() }));
  const hsv = j => {
    const h = ((j * 0.6180339887498949) % 1) * 6, f = h - Math.floor(h), v = 0.95, p = v * 0.25;
    return [[v, v * (1 - 0.75 * (1 - f)), p], [v * (1 - 0.75 * f), v, p], [p, v, v * (1 - 0.75 * (1 - f))],
            [p, v * (1 - 0.75 * f), v], [v * (1 - 0.75 * (1 - f)), p, v], [v, p, v * (1 - 0.75 * f)]][Math.floor(h) % 6];
  };
  let cworst = 0, blended = 0, wsum = 0;
  const bones = new Set(), shades = new Set();
  bc.w.forEach((row, v) => {
    const want = [0, 0, 0];
    let s = 0;
    for (const [j, w] of row) { bones.add(j); s += w; const c = hsv(j); for (let a = 0; a < 3; a++) want[a] += w * c[a]; }
    wsum = Math.max(wsum, Math.abs(s - 1));
    if (row.length > 1 && row.every(([, w]) => w < 0.9)) blended++;
    for (let a = 0; a < 3; a++) cworst = Math.max(cworst, Math.abs(bc.c[3 * v + a] - want[a]));
    shades.add(bc.c.slice(3 * v, 3 * v + 3).map(x => Math.round(x * 255)).join(','));
  });
  console.log(`bone colours: ${bc.w.length} vertices, ${bones.size} bones, ${blended} vertices blended ` +
              `(no weight over 0.9), ${shades.size} shades; worst colour error ${cworst.toExponential(1)}, ` +
              `weight sums within ${wsum.toExponential(1)} of 1`);
  if (!(cworst < 1e-5)) fail(`bone colours: a vertex is ${cworst} off the blend of its bones' colours`);
  if (!(bones.size > 1 && blended > 0 && shades.size > bones.size))
    fail(`bone colours: ${bones.size} bones, ${blended} blended vertices, ${shades.size} shades`);
  await page.waitForTimeout(500);
  await page.screenshot({ path: shot.replace(/\.png$/, '-bones.png') });
  await page.click('#c-parts');
  if (checked[1] < 3 || checked[3] < 3 || checked.drawn < 3)
    fail(`compared ${checked[1]} steer, ${checked[3]} skin and ${checked.drawn} drawn frames, want 3 each`);
  const st = await page.evaluate(() => window.meshsteer);
  console.log(`params: ${st.paramsModels} params model(s), ${st.paramsFrames} params frames, ${st.rendered} drawn, ` +
              `${st.errors} errors${st.lastError ? ' (' + st.lastError + ')' : ''}; worst ${worst.toFixed(3)} of the bound`);
  if (st.errors) fail(`viewer errors: ${st.lastError}`);
  if (st.paramsModels < 1 || st.rendered < 10) fail('the viewer drew too few params frames');
  // the canvas is not blank: the shader's mesh is on screen
  await page.screenshot({ path: shot }); // (the file stays in the build tree for a look)
  const lit = await page.evaluate(() => {
    const c = document.querySelector('#view canvas'), g = document.createElement('canvas');
    g.width = c.width; g.height = c.height;
    const x = g.getContext('2d');
    x.drawImage(c, 0, 0);
    const d = x.getImageData(0, 0, g.width, g.height).data;
    let n = 0;
    for (let i = 0; i < d.length; i += 4) if (d[i] > 120 && d[i + 1] > 100) n++; // the mesh's tan
    return n / (d.length / 4);
  });
  console.log(`mesh pixels: ${(100 * lit).toFixed(1)} % of the canvas`);
  if (!(lit > 0.005)) fail('the params mesh is not on screen');
} catch (e) {
  fail(String(e && e.stack || e));
} finally {
  await browser.close();
  rmSync(profile, { recursive: true, force: true });
}
process.exit(failed ? 1 : 0);
