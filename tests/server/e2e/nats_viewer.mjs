// nats_viewer.mjs - the viewer reading the stream from a NATS cluster instead of the daemon: the
// page the daemon serves, opened with ?nats=ws://NODE2 (a node the daemon does not publish to; its
// WebSocket listener), must get the hello and topology as a late joiner, render frames, measure its
// latency through PREFIX.get.ping, switch encoding by switching subscription, and offer no source
// controls (they do not travel over NATS). Then the node it reads from is killed and restarted
// (MESHSTEER_NATS_RESTART_CMD): the viewer must reconnect by itself and render again.
// Usage: node nats_viewer.mjs URL SCREENSHOT.png       (exit 77 = skip)
import { drive, check, canvasCoverage, openViewer, checkDrawRate } from './browser.mjs';

const [url, shot] = process.argv.slice(2);
await drive(async page => {
  // the daemon's own /stream must not be used: count WebSockets by their URL
  const sockets = [];
  page.on('websocket', ws => sockets.push(ws.url()));
  const s = await openViewer(page, url);
  check(s.transport === 'nats' && s.connected, `connected over ${s.transport}`);
  check(sockets.length >= 1 && sockets.every(u => !u.includes('/stream')),
        `WebSockets opened: ${sockets.join(', ')} (none to the daemon's /stream)`);
  check(s.hellos >= 1 && s.topologies >= 1, `hello ${s.hellos}, topology ${s.topologies}`);
  check(s.nv > 1000 && s.nf > 1000, `mesh of ${s.nv} vertices, ${s.nf} faces`);
  // frames that arrived: decoded, or replaced by a newer one first (latest wins in the page too)
  check(s.frames + s.coalesced >= 100, `${s.frames + s.coalesced} frames received (${s.frames} decoded)`);
  check(s.rendered >= 30 && s.rendered <= s.frames, `${s.rendered} frames rendered`);
  checkDrawRate(s);
  check(s.latencyMs > 0 && s.latencyMs < 5000, `latency ${s.latencyMs.toFixed(1)} ms (clock by PREFIX.get.ping)`);
  check(s.errors === 0, `no errors ${s.lastError}`);
  check(JSON.stringify(s.controls) === '[]', `no source controls over NATS: ${JSON.stringify(s.controls)}`);
  const px = await canvasCoverage(page);
  check(px.differ > 0.02 && px.colours > 20,
        `canvas not blank: ${(100 * px.differ).toFixed(1)}% of pixels are not background, ${px.colours} shades`);
  await page.screenshot({ path: shot });
  console.log(`screenshot: ${shot}`);

  // the other encoding: another subscription (the page opened with &encoding=int16, as a viewer
  // across a real network would, at half float32's bytes); its frames decode without error
  check(s.encoding === 'int16', `opened in ${s.encoding}`);
  await page.click('#c-int16');
  const f0 = await page.evaluate(() => window.meshsteer.frames);
  await page.waitForFunction(n => window.meshsteer.frames > n + 10, f0, { timeout: 15000 });
  const e = await page.evaluate(() => ({ enc: window.meshsteer.encoding, errors: window.meshsteer.errors }));
  check(e.enc === 'float32' && e.errors === 0, `float32 frames over NATS after the switch (${e.errors} errors)`);

  if (process.env.MESHSTEER_NATS_RESTART_CMD) {
    const { execSync } = await import('node:child_process');
    const before = await page.evaluate(() => window.meshsteer.connects);
    execSync(process.env.MESHSTEER_NATS_RESTART_CMD);
    await page.waitForFunction(n => window.meshsteer.connects > n && window.meshsteer.connected,
                               before, { timeout: 30000 });
    const r = await page.evaluate(() => window.meshsteer.rendered);
    await page.waitForFunction(n => window.meshsteer.rendered > n + 10, r, { timeout: 15000 });
    check(true, 'reconnected by itself after its NATS node restarted, and renders again');
  }
});
