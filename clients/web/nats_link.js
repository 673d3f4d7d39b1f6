// nats_link.js - the viewer's second way in: the daemon's stream as published to NATS
// (docs/PROTOCOL.md, "NATS"), read straight from a NATS server's WebSocket listener, so that an
// audience is served by a NATS cluster rather than by the daemon. Used when the page is opened with
// ?nats=ws://HOST:PORT[,ws://...][&subject=PREFIX].
//
// It offers the viewer what its /stream WebSocket does: the hello (text) and topology (binary) –
// fetched by request-reply as a late joiner (PREFIX.get.hello, PREFIX.get.topology), and again
// whenever the daemon announces a new model on PREFIX.hello / PREFIX.topology – then the frames of
// the chosen encoding (PREFIX.frames.ENCODING; switching encoding switches subscription). For the
// params encoding the params model (MSPM) comes the same way: PREFIX.get.params when joining or
// switching to params, PREFIX.params when the daemon announces a new model. A ping is
// a request on PREFIX.get.ping, answered with the daemon's clock as on /stream. Source controls
// (pause, seek, speed) do not travel over NATS: the hello is passed on without them.
// The client library is @nats-io/nats-core (npm), bundled for the browser into
// node_modules/.meshsteer/nats-core.js by the package's postinstall (Debian's esbuild).

const BUNDLE = './node_modules/.meshsteer/nats-core.js';

// A fresh ArrayBuffer holding exactly the message's bytes (the library's Uint8Array may be a
// view into a larger read buffer).
function bytes(msg) {
  const d = msg.data;
  return d.byteOffset === 0 && d.byteLength === d.buffer.byteLength
    ? d.buffer : d.buffer.slice(d.byteOffset, d.byteOffset + d.byteLength);
}

// Connects and keeps connected (the library reconnects, across the servers given and those the
// cluster advertises). handlers: onOpen(), onClose(why), onText(obj), onBinary(arraybuffer),
// onSkipped(n), onError(err).
// Latest wins here too: the library hands over every message it parsed from one WebSocket read
// at once, so frames are kept as they come and only the newest is passed on, in a task of its own
// after them, or earlier by poll() (the page calls it at the start of each animation frame: Chrome
// may run the next animation frame before that task, and the frame would miss it); those it
// replaced are reported to onSkipped (a page slower than the stream skips frames instead of
// falling behind, as a /stream client does). waiting() says whether a frame is held that poll()
// would pass on. Returns { send(obj), poll(), waiting() }.
export function natsLink(servers, prefix, encoding, handlers) {
  let nc = null, frames = null, enc = encoding, newest = null, replaced = 0;
  const subject = s => `${prefix}.${s}`;
  const fail = e => handlers.onError(e);

  function deliver() {
    const m = newest;
    newest = null;
    if (replaced) handlers.onSkipped(replaced);
    replaced = 0;
    if (m) handlers.onBinary(bytes(m));
  }
  function subscribeFrames() {
    if (frames) frames.unsubscribe();
    frames = nc.subscribe(subject(`frames.${enc}`), {
      callback: (err, m) => {
        if (err) { fail(err); return; }
        if (newest) replaced++;
        else setTimeout(deliver, 0);
        newest = m;
      },
    });
  }
  function withoutControls(hello) {
    if (hello.source) hello.source = { ...hello.source, controls: [] };
    return hello;
  }
  async function getParams() {
    const pm = await nc.request(subject('get.params'), '', { timeout: 5000 });
    handlers.onBinary(bytes(pm));
  }
  async function join() {
    const hello = await nc.request(subject('get.hello'), '', { timeout: 5000 });
    handlers.onText(withoutControls(JSON.parse(hello.string())));
    const topo = await nc.request(subject('get.topology'), '', { timeout: 5000 });
    handlers.onBinary(bytes(topo));
    if (enc === 'params') await getParams();
  }
  async function watchStatus() {
    for await (const s of nc.status()) {
      if (s.type === 'disconnect') handlers.onClose('NATS server lost; reconnecting');
      else if (s.type === 'reconnect') { handlers.onOpen(); join().catch(fail); }
    }
  }
  async function run() {
    const { wsconnect } = (await import(BUNDLE)).default;
    for (let backoff = 500; ; backoff = Math.min(backoff * 2, 5000)) {
      try {
        nc = await wsconnect({ servers, maxReconnectAttempts: -1, reconnectTimeWait: 500,
                               name: 'meshsteer viewer' });
      } catch (e) {
        handlers.onClose(`no NATS server answers (${e.message}); retrying in ${backoff / 1000} s`);
        await new Promise(r => setTimeout(r, backoff));
        continue;
      }
      handlers.onOpen();
      // a new model: its hello, then its topology, announced before its first frame
      nc.subscribe(subject('hello'), { callback: (err, m) => (err ? fail(err)
        : handlers.onText(withoutControls(JSON.parse(m.string())))) });
      nc.subscribe(subject('topology'), { callback: (err, m) => (err ? fail(err)
        : handlers.onBinary(bytes(m))) });
      nc.subscribe(subject('params'), { callback: (err, m) => (err ? fail(err)
        : enc === 'params' && handlers.onBinary(bytes(m))) });
      subscribeFrames();
      watchStatus().catch(fail);
      await join().catch(fail);
      const err = await nc.closed();
      handlers.onClose(`NATS connection closed${err ? ': ' + err.message : ''}`);
    }
  }
  run().catch(fail);

  return {
    poll: deliver,
    waiting: () => newest !== null,
    send(obj) {
      if (!nc || nc.isClosed()) return;
      if (obj.type === 'ping') { // an unanswered ping is only a lost clock sample, as on /stream
        nc.request(subject('get.ping'), '', { timeout: 5000 })
          .then(m => handlers.onText(JSON.parse(m.string()))).catch(() => {});
      } else if (obj.type === 'encoding') {
        enc = obj.encoding;
        if (enc === 'params') getParams().then(subscribeFrames).catch(fail);
        else subscribeFrames();
      }
      // pause/resume/seek/speed: not over NATS (the hello offered no controls)
    },
  };
}
