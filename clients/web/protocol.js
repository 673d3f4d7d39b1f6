// protocol.js - decoding of meshsteerd's /stream messages, protocol 1 (docs/PROTOCOL.md).
// All multi-byte fields are little-endian.

export const PROTOCOL = 1;
export const ENC_FLOAT32 = 0;
export const ENC_INT16 = 1;
export const ENC_PARAMS = 2; // the vertex block is per-piece parameters (params.js)
export const FLAG_REFERENCE_LOST = 1;
export const FLAG_CLAMPED = 2;
export const FLAG_HELD = 4;

function magic(dv) {
  return String.fromCharCode(dv.getUint8(0), dv.getUint8(1), dv.getUint8(2), dv.getUint8(3));
}

// The binary message's kind: "topology", "frame" or null.
export function kind(buf) {
  if (buf.byteLength < 56) return null;
  const m = magic(new DataView(buf));
  return m === 'MSTO' ? 'topology' : m === 'MSFR' ? 'frame' : null;
}

export function decodeTopology(buf) {
  const dv = new DataView(buf);
  const t = {
    protocol: dv.getUint16(4, true),
    generation: dv.getUint32(8, true),
    nv: dv.getUint32(12, true),
    nf: dv.getUint32(16, true),
    nm: dv.getUint32(20, true),
    nparts: dv.getUint32(24, true),
    qmin: [dv.getFloat32(32, true), dv.getFloat32(36, true), dv.getFloat32(40, true)],
    qmax: [dv.getFloat32(44, true), dv.getFloat32(48, true), dv.getFloat32(52, true)],
  };
  const need = 56 + t.nv * 12 + t.nf * 12 + t.nv * 4;
  if (buf.byteLength !== need) throw new Error(`topology: ${buf.byteLength} bytes, expected ${need}`);
  // little-endian hosts (all browsers in practice) can view the arrays directly; copy to be safe
  t.rest = new Float32Array(buf.slice(56, 56 + t.nv * 12));
  t.faces = new Uint32Array(buf.slice(56 + t.nv * 12, 56 + t.nv * 12 + t.nf * 12));
  t.parts = new Uint32Array(buf.slice(56 + t.nv * 12 + t.nf * 12, need));
  return t;
}

// Decodes a frame into out.V (nv*3 Float32Array; not for params frames) and out.markers /
// out.valid; returns the header.
export function decodeFrame(buf, topo, out) {
  const dv = new DataView(buf);
  const h = {
    encoding: dv.getUint8(4),
    flags: dv.getUint8(5),
    missing: dv.getUint16(6, true),
    generation: dv.getUint32(8, true),
    nv: dv.getUint32(12, true),
    nm: dv.getUint32(16, true),
    skipped: dv.getUint32(20, true),
    seq: Number(dv.getBigUint64(24, true)),
    tCapture: Number(dv.getBigUint64(32, true)),
    tSynth: Number(dv.getBigUint64(40, true)),
    tSend: Number(dv.getBigUint64(48, true)),
  };
  if (h.nv !== topo.nv || h.nm !== topo.nm) throw new Error('frame does not match the topology');
  const n3 = h.nv * 3;
  let off = 56;
  if (h.encoding === ENC_FLOAT32) {
    for (let i = 0; i < n3; i++, off += 4) out.V[i] = dv.getFloat32(off, true);
  } else if (h.encoding === ENC_INT16) {
    const s = [0, 1, 2].map(a => (topo.qmax[a] - topo.qmin[a]) / 65535);
    for (let i = 0; i < n3; i++, off += 2) {
      const a = i % 3;
      out.V[i] = topo.qmin[a] + (dv.getInt16(off, true) + 32768) * s[a];
    }
    off = 56 + ((n3 * 2 + 3) & ~3);
  } else if (h.encoding === ENC_PARAMS) { // out.V is left alone: params.js rebuilds it on the GPU
    off = 56 + 8 + 4 * dv.getUint32(60, true);
  } else {
    throw new Error(`unknown encoding ${h.encoding}`);
  }
  for (let i = 0; i < h.nm * 3; i++, off += 4) out.markers[i] = dv.getFloat32(off, true);
  for (let i = 0; i < h.nm; i++) out.valid[i] = dv.getUint8(off + i);
  return h;
}
