// viewer.mjs - the viewer end to end in a real browser: Debian's chromium, driven by playwright-core,
// opens the page meshsteerd serves at /, waits until frames are rendered, checks the counters the
// viewer exposes on window.meshsteer and that the canvas is not blank, saves a screenshot, then
// drives the playback controls and checks that each changes what the source does (speed 0.5 halves
// the frame rate, pause stops it, a seek jumps to the frame asked for, found by matching the markers
// against the replayed file), the ground, shadows and sparkline, the screenshot and WebM clip
// buttons, saving a screenshot of each state beside SCREENSHOT (SCREENSHOT-<state>.png); then
// restarts nothing but the daemon and checks that the viewer reconnects by itself.
//
// With MESHSTEER_KIND=harmonic (a harmonic model replaying a BVH, run_viewer.sh harmonic:...): the
// stream checks, the model kind, vertices that change between two samples 1 s apart and are all
// finite, the canvas and the screenshot; the playback checks (they match CSV rows) and the restart
// are the steering run's.
//
// Usage: node viewer.mjs URL SCREENSHOT.png     (exit 77 = skip when chromium or playwright is absent)
import { readFileSync } from 'node:fs';
import { drive, check, canvasCoverage, openViewer, checkDrawRate } from './browser.mjs';

const [url, shot] = process.argv.slice(2);
const state = name => shot.replace(/\.png$/, '') + `-${name}.png`;

// The source's frame rate over ms: frames synthesised (seq) per second of capture time, from the
// newest frames the viewer has. Software WebGL keeps the page busy, so frames wait in the browser's
// receive queue (the latency figure): a receive rate would lag the source by that much.
async function rate(page, ms) {
  const get = () => page.evaluate(() => [window.meshsteer.lastSeq, window.meshsteer.lastCaptureUs]);
  const a = await get();
  await page.waitForTimeout(ms);
  const b = await get();
  return b[1] > a[1] ? (b[0] - a[0]) * 1e6 / (b[1] - a[1]) : 0;
}
// milliseconds for a control to reach the viewer's frames: the latency, plus a margin
const settle = async page => 500 + Math.min(5000, await page.evaluate(() => window.meshsteer.latencyMs || 0));
// The server acks a control after the source applied it and the frames made before it are out, on
// the same WebSocket as the frames; the ack names the newest of those (seq), and framesSinceAck
// counts the frames made after the control.
const acked = (page, a) => page.waitForFunction(x => window.meshsteer.acks > x, a, { timeout: 5000 });

// the replayed file's row nearest to the markers now shown (all valid markers, least squares)
function nearestRow(csv, m) {
  const cols = csv.header;
  const idx = m.live.map(l => [cols.indexOf(`${l}_x`), cols.indexOf(`${l}_y`), cols.indexOf(`${l}_z`)]);
  let best = -1, bestD = Infinity;
  csv.rows.forEach((r, f) => {
    let d = 0;
    idx.forEach((c, i) => {
      if (!m.valid[i] || c[0] < 0) return;
      for (let k = 0; k < 3; k++) d += (r[c[k]] - m.xyz[3 * i + k]) ** 2;
    });
    if (d < bestD) { bestD = d; best = f; }
  });
  return { frame: best, rms: Math.sqrt(bestD / m.live.length) };
}

async function playback(page) {
  const file = process.env.MESHSTEER_MARKERS;
  const lines = readFileSync(file, 'utf8').trim().split('\n');
  const csv = { header: lines[0].split(','), rows: lines.slice(1).map(l => l.split(',').map(Number)) };
  const n = csv.rows.length;
  // controls shown for the replay source; the frame count learned
  await page.waitForFunction(() => window.meshsteer.sourceFrames > 0, null, { timeout: 10000 });
  const s0 = await page.evaluate(() => ({ ...window.meshsteer }));
  check(s0.sourceFrames === n, `seek range: ${s0.sourceFrames} source frames (file: ${n})`);
  const shown = await page.evaluate(() => ['playback', 'b-pause', 'seek', 'speed']
    .map(id => !document.getElementById(id).hidden));
  check(shown.every(Boolean), `playback bar with pause, seek and speed shown ${JSON.stringify(shown)}`);
  check(s0.kind === 'steer' && s0.driver === 'tracked', `model kind '${s0.kind}', driver '${s0.driver}'`);
  check(s0.grid && s0.shadows, 'ground grid and soft shadows');
  check(s0.history.length >= 5, `sparkline of ${s0.history.length} samples`);
  const ink = await page.evaluate(() => {
    const c = document.getElementById('spark'), d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
    let k = 0;
    for (let i = 3; i < d.length; i += 4) if (d[i] > 0) k++;
    return k;
  });
  check(ink > 50, `sparkline drawn (${ink} pixels)`);
  await page.screenshot({ path: state('playing') });

  // speed 0.5 halves the frame rate
  const r1 = await rate(page, 3000);
  const acks = s0.acks;
  await page.selectOption('#speed', '0.5');
  await page.waitForFunction(a => window.meshsteer.acks > a, acks, { timeout: 5000 });
  await page.waitForTimeout(await settle(page));
  const r2 = await rate(page, 3000);
  check(r2 / r1 > 0.4 && r2 / r1 < 0.6,
        `speed 0.5: ${r2.toFixed(1)} frames/s against ${r1.toFixed(1)} at speed 1 (ratio ${(r2 / r1).toFixed(2)})`);
  await page.screenshot({ path: state('speed-half') });
  await page.selectOption('#speed', '1');

  // pause stops the source, resume starts it again
  let a = await page.evaluate(() => window.meshsteer.acks);
  await page.click('#b-pause');
  await acked(page, a);
  await page.waitForTimeout(2000);
  const pf = await page.evaluate(() => window.meshsteer.framesSinceAck);
  check(pf === 0, `paused: ${pf} frames made after the pause in the 2 s after its ack`);
  check(await page.textContent('#b-pause') === 'resume', 'the button offers resume');
  await page.screenshot({ path: state('paused') });
  a = await page.evaluate(() => window.meshsteer.acks);
  await page.click('#b-pause');
  await acked(page, a);
  await page.waitForTimeout(await settle(page));
  const rr = await rate(page, 1500);
  check(rr > r1 * 0.6, `resumed: ${rr.toFixed(1)} frames/s`);

  // a seek jumps to the frame asked for: the markers shown are that frame's (a few frames on)
  for (const target of [Math.floor(n / 6), Math.floor(n * 5 / 6)]) {
    const before = nearestRow(csv, await page.evaluate(() => window.meshsteerMarkers()));
    a = await page.evaluate(() => window.meshsteer.acks);
    await page.evaluate(f => { const e = document.getElementById('seek'); e.value = String(f);
                               e.dispatchEvent(new Event('change')); }, target);
    await acked(page, a);
    await page.waitForFunction(() => window.meshsteer.framesSinceAck >= 2, null, { timeout: 5000 });
    const m = await page.evaluate(() => ({ ...window.meshsteerMarkers(), since: window.meshsteer.framesSinceAck }));
    const after = nearestRow(csv, m);
    const ahead = (after.frame - target + n) % n;
    // the newest frame is the target plus the source frames read since the seek: the frames since
    // the ack, more where the synthesis skipped some (latest wins; allowed: 10 frames, a third of a
    // second); plus those still in the page's receive queue when it drew: latency x source rate (a
    // page that renders slowly, e.g. against a daemon under a sanitizer, lags by more frames)
    const lat = await page.evaluate(() => window.meshsteer.latencyMs);
    const queued = Number.isFinite(lat) && lat > 0 ? Math.ceil(lat / 1000 * 30) : 0;
    check(ahead <= m.since + 10 + queued && after.rms < 1e-3,
          `seek to ${target}: from frame ${before.frame} to ${after.frame}, ${m.since} frames after the ack (rms ${after.rms.toExponential(1)} m)`);
    await page.screenshot({ path: state(`seek-${target}`) });
  }

  // the screenshot button saves a PNG, the record button a WebM clip
  const [dl] = await Promise.all([page.waitForEvent('download', { timeout: 10000 }), page.click('#b-shot')]);
  const pngPath = state('button').replace(/\.png$/, '.download.png');
  await dl.saveAs(pngPath);
  const png = readFileSync(pngPath);
  check(png.length > 1000 && png.readUInt32BE(0) === 0x89504e47, `screenshot button: ${png.length} B PNG`);
  await page.click('#b-clip');
  await page.waitForTimeout(2000);
  await page.screenshot({ path: state('recording') });
  const [clip] = await Promise.all([page.waitForEvent('download', { timeout: 10000 }), page.click('#b-clip')]);
  const webmPath = shot.replace(/\.png$/, '') + '-clip.webm';
  await clip.saveAs(webmPath);
  const webm = readFileSync(webmPath);
  const c = await page.evaluate(() => ({ ...window.meshsteer }));
  check(webm.length > 1000 && webm.readUInt32BE(0) === 0x1a45dfa3,
        `record button: ${webm.length} B WebM (${c.lastClipType}) in 2 s`);
  check(c.errors === 0, `no errors after the controls ${c.lastError}`);
}
await drive(async page => {
  const s = await openViewer(page, url);
  check(s.connected, 'connected');
  check(s.hellos === 1 && s.topologies === 1, 'one hello and one topology');
  check(s.nv > 1000 && s.nf > 1000, `mesh of ${s.nv} vertices, ${s.nf} faces`);
  check(s.frames >= 100, `${s.frames} frames received`);
  check(s.rendered >= 30 && s.rendered <= s.frames, `${s.rendered} frames rendered`);
  checkDrawRate(s);
  check(s.latencyMs > 0 && s.latencyMs < 5000, `latency ${s.latencyMs.toFixed(1)} ms`);
  check(s.dropped + s.rendered >= s.frames - 2, `dropped ${s.dropped} counted`);
  check(s.errors === 0, `no errors ${s.lastError}`);
  check(s.bound === s.nm, `${s.bound} of ${s.nm} markers bound`);
  check(JSON.stringify(s.controls) === '["pause","resume","seek","speed"]',
        `the replay source's controls ${JSON.stringify(s.controls)}`);
  const tip = await page.evaluate(() => document.getElementById('o-markers').title);
  check(tip.split('\n').length === s.nm && tip.includes(' ← '), 'marker bindings in the overlay');
  // the canvas is not blank: sample the drawn pixels
  const px = await canvasCoverage(page);
  check(px.differ > 0.02 && px.colours > 20,
        `canvas not blank: ${(100 * px.differ).toFixed(1)}% of pixels are not background, ${px.colours} shades`);
  if (process.env.MESHSTEER_KIND === 'harmonic') {
    check(s.kind === 'harmonic', `model kind '${s.kind}'`);
    const v0 = await page.evaluate(() => window.meshsteerVertices());
    await page.waitForTimeout(1000);
    const v1 = await page.evaluate(() => window.meshsteerVertices());
    const bad = v1.filter(x => !Number.isFinite(x)).length + v0.filter(x => !Number.isFinite(x)).length;
    let moved = 0;
    for (let i = 0; i < v1.length; i += 3)
      if (Math.hypot(v1[i] - v0[i], v1[i + 1] - v0[i + 1], v1[i + 2] - v0[i + 2]) > 1e-3) moved++;
    check(v1.length === 3 * s.nv && bad === 0, `${v1.length / 3} vertices, ${bad} not finite`);
    check(moved > s.nv / 10, `${moved} of ${s.nv} vertices moved by more than 1 mm in 1 s`);
    // the frames' markers are where the model put the template (its alignment to the target,
    // paper Sec. 5), not in mocap units: the root marker (Hips, the rig's reference, which the
    // mesh's global position follows) lies within 10 % of the diagonal of the mesh's nearest
    // vertex in every sampled frame (how far the others are depends on how well the pose
    // follows the mocap, printed only)
    let worstRoot = 0, diag = 0, worstOther = 0;
    for (let k = 0; k < 5; k++) {
      const mk = await page.evaluate(() => ({ m: window.meshsteerMarkers(), v: window.meshsteerVertices() }));
      const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
      for (let i = 0; i < mk.v.length; i++) { lo[i % 3] = Math.min(lo[i % 3], mk.v[i]); hi[i % 3] = Math.max(hi[i % 3], mk.v[i]); }
      diag = Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
      const nearest = q => {
        let d = Infinity;
        for (let i = 0; i < mk.v.length; i += 3)
          d = Math.min(d, Math.hypot(mk.v[i] - q[0], mk.v[i + 1] - q[1], mk.v[i + 2] - q[2]));
        return d;
      };
      mk.m.valid.forEach((ok, i) => {
        if (!ok) return;
        const d = nearest(mk.m.xyz.slice(3 * i, 3 * i + 3));
        if (i === 0) worstRoot = Math.max(worstRoot, d / diag);
        else worstOther = Math.max(worstOther, d / diag);
      });
      if (!mk.m.valid[0]) worstRoot = Infinity;
      await page.waitForTimeout(300);
    }
    check(worstRoot <= 0.1,
          `root marker on the mesh: within ${worstRoot.toFixed(3)} of the diagonal (${diag.toFixed(3)}) of its nearest vertex in 5 frames; other markers within ${worstOther.toFixed(3)}`);
    await page.screenshot({ path: shot });
    console.log(`screenshot: ${shot}`);
  } else {
  // colour by part, then the screenshot
  await page.click('#c-parts');
  await page.waitForTimeout(300);
  await page.screenshot({ path: shot });
  console.log(`screenshot: ${shot}`);
  await playback(page);
  }
  if (process.env.MESHSTEER_RESTART_CMD && process.env.MESHSTEER_KIND !== 'harmonic') {
    // reconnect: the harness restarts the daemon; the viewer must come back by itself
    const { execSync } = await import('node:child_process');
    execSync(process.env.MESHSTEER_RESTART_CMD);
    await page.waitForFunction(() => window.meshsteer.reconnects >= 1 && window.meshsteer.connected
                               && window.meshsteer.hellos >= 2, null, { timeout: 30000 });
    const r = await page.evaluate(() => window.meshsteer.rendered);
    await page.waitForFunction(n => window.meshsteer.rendered > n + 10, r, { timeout: 15000 });
    check(true, 'reconnected by itself after a daemon restart and renders again');
  }
});
