// viewer.mjs - the viewer end to end in a real browser: Debian's chromium, driven by playwright-core,
// opens the page meshsteerd serves at /, waits until frames are rendered, checks the counters the
// viewer exposes on window.meshsteer and that the canvas is not blank, saves a screenshot, then
// restarts nothing but the daemon and checks that the viewer reconnects by itself.
//
// Usage: node viewer.mjs URL SCREENSHOT.png     (exit 77 = skip when chromium or playwright is absent)
import { existsSync, mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { createRequire } from 'node:module';

const [url, shot] = process.argv.slice(2);
const chromium = process.env.CHROMIUM || '/usr/bin/chromium';
if (!existsSync(chromium)) {
  console.error(`skip: ${chromium} not installed`);
  process.exit(77);
}
const require = createRequire(process.env.MESHSTEER_WEB_DIR + '/package.json');
let pw;
try {
  pw = require('playwright-core');
} catch (e) {
  console.error('skip: playwright-core not installed (npm ci in clients/web)');
  process.exit(77);
}

const profile = mkdtempSync(join(tmpdir(), 'meshsteer-chromium-'));
// a fresh profile directory (playwright passes it to chromium as --user-data-dir)
const browser = await pw.chromium.launchPersistentContext(profile, {
  executablePath: chromium,
  headless: true,
  viewport: { width: 800, height: 600 },
  bypassCSP: true, // playwright's waitForFunction evaluates strings; the page itself runs under the CSP
  args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-background-networking',
         '--disable-component-update', '--disable-sync', '--no-first-run', '--disable-quic',
         // WebGL without a GPU: SwiftShader, which recent Chromium enables only on request
         '--use-angle=swiftshader', '--enable-unsafe-swiftshader'],
});
let failed = false;
const logs = [];
function check(cond, what) {
  console.log(`${cond ? 'ok  ' : 'FAIL'} ${what}`);
  if (!cond) failed = true;
}
try {
  const page = browser.pages()[0] || await browser.newPage();
  page.on('console', m => logs.push(`${m.type()}: ${m.text()}`));
  page.on('pageerror', e => logs.push(`pageerror: ${e}`));
  await page.goto(url, { waitUntil: 'load' });
  await page.waitForFunction(() => window.meshsteer && window.meshsteer.rendered >= 30, null,
                             { timeout: 30000 });
  // a few more seconds for fps and latency to settle
  await page.waitForTimeout(3000);
  const s = await page.evaluate(() => ({ ...window.meshsteer }));
  console.log(JSON.stringify(s));
  check(s.connected, 'connected');
  check(s.hellos === 1 && s.topologies === 1, 'one hello and one topology');
  check(s.nv > 1000 && s.nf > 1000, `mesh of ${s.nv} vertices, ${s.nf} faces`);
  check(s.frames >= 100, `${s.frames} frames received`);
  // headless chromium renders WebGL in software (SwiftShader) on a shared 2-core machine: it draws
  // 10-15 fps here, so the bounds check that the pipeline works, not a GPU's speed
  check(s.rendered >= 30 && s.rendered <= s.frames, `${s.rendered} frames rendered`);
  check(s.fps > 5, `fps ${s.fps.toFixed(1)} (source 30)`);
  check(s.latencyMs > 0 && s.latencyMs < 5000, `latency ${s.latencyMs.toFixed(1)} ms`);
  check(s.dropped + s.rendered >= s.frames - 2, `dropped ${s.dropped} counted`);
  check(s.errors === 0, `no errors ${s.lastError}`);
  check(s.bound === s.nm, `${s.bound} of ${s.nm} markers bound`);
  check(JSON.stringify(s.controls) === '["pause","resume","seek","speed"]',
        `the replay source's controls ${JSON.stringify(s.controls)}`);
  const tip = await page.evaluate(() => document.getElementById('o-markers').title);
  check(tip.split('\n').length === s.nm && tip.includes(' ← '), 'marker bindings in the overlay');
  // the canvas is not blank: sample the drawn pixels
  const px = await page.evaluate(() => {
    const src = document.querySelector('#view canvas');
    const c = document.createElement('canvas');
    c.width = 200; c.height = 150;
    const g = c.getContext('2d');
    g.drawImage(src, 0, 0, 200, 150);
    const d = g.getImageData(0, 0, 200, 150).data;
    const bg = [d[0], d[1], d[2]];
    let differ = 0;
    const colours = new Set();
    for (let i = 0; i < d.length; i += 4) {
      if (Math.abs(d[i] - bg[0]) + Math.abs(d[i + 1] - bg[1]) + Math.abs(d[i + 2] - bg[2]) > 30) differ++;
      colours.add((d[i] >> 3) << 10 | (d[i + 1] >> 3) << 5 | (d[i + 2] >> 3));
    }
    return { differ: differ / (d.length / 4), colours: colours.size };
  });
  check(px.differ > 0.02 && px.colours > 20,
        `canvas not blank: ${(100 * px.differ).toFixed(1)}% of pixels are not background, ${px.colours} shades`);
  // colour by part, then the screenshot
  await page.click('#c-parts');
  await page.waitForTimeout(300);
  await page.screenshot({ path: shot });
  console.log(`screenshot: ${shot}`);
  if (process.env.MESHSTEER_RESTART_CMD) {
    // reconnect: the harness restarts the daemon; the viewer must come back by itself
    const { execSync } = await import('node:child_process');
    execSync(process.env.MESHSTEER_RESTART_CMD);
    await page.waitForFunction(() => window.meshsteer.reconnects >= 1 && window.meshsteer.connected
                               && window.meshsteer.hellos >= 2, null, { timeout: 30000 });
    const r = await page.evaluate(() => window.meshsteer.rendered);
    await page.waitForFunction(n => window.meshsteer.rendered > n + 10, r, { timeout: 15000 });
    check(true, 'reconnected by itself after a daemon restart and renders again');
  }
  if (failed) console.log(logs.join('\n'));
} catch (e) {
  console.error(`FAIL ${e}`);
  console.error(logs.join('\n'));
  try {
    console.error(JSON.stringify(await browser.pages()[0].evaluate(() => window.meshsteer)));
  } catch (e2) { /* the page is gone */ }
  failed = true;
} finally {
  await browser.close();
  rmSync(profile, { recursive: true, force: true });
}
process.exit(failed ? 1 : 0);
