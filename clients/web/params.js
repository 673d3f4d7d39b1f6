// params.js - the "params" encoding on the GPU (docs/PROTOCOL.md 2b and 3): the params model
// message (MSPM) becomes data textures once, and each params frame only updates a small texture of
// per-piece parameters; a WebGL2 vertex shader rebuilds every vertex as
//   V_v = sum_s w_vs (R(q_i) (mean_e + sum_a lambda_ia scale_a mode_a[e]) + t_i)
// (Voegele et al. 2012 Sec. 4.4 eq. 6 and Sec. 5.3 eq. 8: rigidly placed part shapes, blended;
// for a skin, linear blend skinning). No per-vertex work on the CPU per frame: decoding a frame
// copies ninst x (7 + k) floats. The same GLSL (RECONSTRUCT_GLSL) is what the viewer's position
// pass runs and what readback() runs with transform feedback, so a test can read it back.

export const ENC_PARAMS = 2;
const TEX_W = 1024; // texels per row of every data texture

function magic(dv) {
  return String.fromCharCode(dv.getUint8(0), dv.getUint8(1), dv.getUint8(2), dv.getUint8(3));
}

export function isParamsModel(buf) {
  return buf.byteLength >= 16 && magic(new DataView(buf)) === 'MSPM';
}

// The MSPM message: per layout its counts and the texture contents (Float32Array, RGBA per texel):
// slots (entry, piece, weight, 0) per vertex slot, means (x, y, z, first mode texel) per entry,
// modes (x, y, z, 0) per entry and mode, and the parameter texture's stride per piece.
export function decodeParamsModel(buf) {
  const dv = new DataView(buf);
  if (!isParamsModel(buf)) throw new Error('not a params model message');
  const protocol = dv.getUint16(4, true), n = dv.getUint16(6, true);
  if (protocol !== 1) throw new Error(`params model: protocol ${protocol}`);
  const m = { generation: dv.getUint32(8, true), nv: dv.getUint32(12, true), layouts: [] };
  let at = 16;
  for (let l = 0; l < n; l++) {
    if (at + 36 > buf.byteLength) throw new Error('params model: truncated layout header');
    const L = {
      kind: dv.getUint8(at), slots: dv.getUint16(at + 2, true), ninst: dv.getUint32(at + 4, true),
      nparts: dv.getUint32(at + 8, true), nentries: dv.getUint32(at + 12, true),
      nmodes: dv.getUint32(at + 16, true), nvals: dv.getUint32(at + 20, true),
      nparams: dv.getUint32(at + 24, true),
    };
    const len = dv.getUint32(at + 28, true), nused = dv.getUint32(at + 32, true);
    const need = 36 + 16 * L.nparts + 4 * L.ninst + 4 * L.nmodes + 12 * L.nentries +
                 ((6 * L.nvals + 3) & ~3) + ((m.nv + 3) & ~3) + 8 * nused + ((2 * nused + 3) & ~3);
    if (len !== need || at + len > buf.byteLength) throw new Error(`params model: layout ${l} length ${len}, expected ${need}`);
    let p = at + 36;
    const part = [];
    for (let q = 0; q < L.nparts; q++, p += 16)
      part.push({ first: dv.getUint32(p, true), n: dv.getUint32(p + 4, true), k: dv.getUint32(p + 8, true),
                  mode: dv.getUint32(p + 12, true) });
    const instPart = new Uint32Array(L.ninst);
    for (let i = 0; i < L.ninst; i++, p += 4) instPart[i] = dv.getUint32(p, true);
    const scale = new Float32Array(L.nmodes);
    for (let a = 0; a < L.nmodes; a++, p += 4) scale[a] = dv.getFloat32(p, true);
    const meanAt = p, modesAt = meanAt + 12 * L.nentries, slotAt = modesAt + ((6 * L.nvals + 3) & ~3);
    // modes, entry-major: entry e of shape q has its k modes at texels modeFirst[q] + (e - first) k
    let texels = 0, vals = 0;
    L.maxk = 0;
    const modeFirst = part.map(q => { const f = texels; texels += q.n * q.k; return f; });
    L.means = new Float32Array(4 * Math.max(1, L.nentries));
    L.modes = new Float32Array(4 * Math.max(1, texels));
    part.forEach((q, qi) => {
      L.maxk = Math.max(L.maxk, q.k);
      for (let j = 0; j < q.n; j++) {
        const e = q.first + j;
        if (e >= L.nentries) throw new Error(`params model: shape ${qi} entry ${e} of ${L.nentries}`);
        for (let c = 0; c < 3; c++) L.means[4 * e + c] = dv.getFloat32(meanAt + 12 * e + 4 * c, true);
        L.means[4 * e + 3] = modeFirst[qi] + j * q.k;
      }
      for (let a = 0; a < q.k; a++)
        for (let j = 0; j < q.n; j++)
          for (let c = 0; c < 3; c++, vals++)
            L.modes[4 * (modeFirst[qi] + j * q.k + a) + c] = scale[q.mode + a] * dv.getInt16(modesAt + 2 * vals, true);
    });
    // the slots in use (a count per vertex, then entry and weight, then the pieces) spread to
    // `slots` texels per vertex, unused ones weight 0
    L.slotTex = new Float32Array(4 * m.nv * L.slots);
    const pairAt = slotAt + ((m.nv + 3) & ~3), pieceAt = pairAt + 8 * nused;
    for (let v = 0, k = 0; v < m.nv; v++) {
      const c = dv.getUint8(slotAt + v);
      if (c > L.slots || k + c > nused) throw new Error(`params model: vertex ${v}: ${c} slots`);
      for (let s = 0; s < c; s++, k++) {
        const e = dv.getUint32(pairAt + 8 * k, true), i = dv.getUint16(pieceAt + 2 * k, true);
        if (i >= L.ninst || e >= L.nentries) throw new Error(`params model: vertex ${v}: piece ${i}, entry ${e}`);
        const t = 4 * (v * L.slots + s);
        L.slotTex[t] = e; L.slotTex[t + 1] = i; L.slotTex[t + 2] = dv.getFloat32(pairAt + 8 * k + 4, true);
      }
    }
    // per piece: quaternion, (t, k), then the coefficients four to a texel
    L.stride = 2 + Math.ceil(L.maxk / 4);
    L.paramAt = new Uint32Array(L.ninst);
    L.instK = new Uint32Array(L.ninst);
    let o = 0;
    for (let i = 0; i < L.ninst; i++) {
      if (instPart[i] >= L.nparts) throw new Error(`params model: piece ${i} shape ${instPart[i]}`);
      L.paramAt[i] = o; L.instK[i] = part[instPart[i]].k; o += 7 + L.instK[i];
    }
    if (o !== L.nparams) throw new Error(`params model: ${L.nparams} floats per frame, pieces need ${o}`);
    L.paramTex = new Float32Array(4 * L.ninst * L.stride);
    m.layouts.push(L);
    at += len;
  }
  if (at !== buf.byteLength) throw new Error(`params model: ${buf.byteLength - at} bytes after the layouts`);
  return m;
}

export const KIND_SKIN = 3;

// The colour of bone j: the golden-ratio hue sequence (successive hues j * 0.618... of the circle)
// in HSV, value 0.95, saturation 0.75: the colours `meshsteer render --skin` draws
// (server/bone_colours.c), so a bone looks the same in a contact sheet and in the viewer.
export function boneColour(j) {
  const h = ((j * 0.6180339887498949) % 1) * 6, f = h - Math.floor(h);
  const v = 0.95, p = v * 0.25, q = v * (1 - 0.75 * f), t = v * (1 - 0.75 * (1 - f));
  return [[v, t, p], [q, v, p], [p, v, t], [p, q, v], [t, p, v], [v, p, q]][Math.floor(h) % 6];
}

// A skin layout's weights as colour (Le & Deng 2012's w_ij; a skin's pieces are its bones): vertex
// i gets sum_j w_ij colour(j), as server/bone_colours.c does for `render --skin`. nv x 3 floats in
// [0, 1] (sRGB), or null when layout l is not a skin.
export function boneWeightColours(model, l) {
  const L = model.layouts[l];
  if (!L || L.kind !== KIND_SKIN) return null;
  const out = new Float32Array(3 * model.nv);
  for (let v = 0; v < model.nv; v++)
    for (let s = 0; s < L.slots; s++) {
      const t = 4 * (v * L.slots + s), w = L.slotTex[t + 2];
      if (w === 0) continue;
      const c = boneColour(L.slotTex[t + 1]);
      for (let a = 0; a < 3; a++) out[3 * v + a] += w * c[a];
    }
  return out;
}

// A params frame's vertex block into the layout's parameter texture contents; returns the layout
// index. The header and markers are decoded by protocol.js (decodeFrame).
export function decodeParamsBlock(dv, model) {
  const l = dv.getUint8(56), n = dv.getUint32(60, true);
  const L = model && model.layouts[l];
  if (!L) throw new Error(`params frame: layout ${l} unknown`);
  if (n !== L.nparams) throw new Error(`params frame: ${n} floats, layout has ${L.nparams}`);
  const T = L.paramTex;
  for (let i = 0; i < L.ninst; i++) {
    const p = 64 + 4 * L.paramAt[i], b = 4 * i * L.stride, k = L.instK[i];
    for (let c = 0; c < 4; c++) T[b + c] = dv.getFloat32(p + 4 * c, true);
    for (let c = 0; c < 3; c++) T[b + 4 + c] = dv.getFloat32(p + 16 + 4 * c, true);
    T[b + 7] = k;
    for (let a = 0; a < k; a++) T[b + 8 + a] = dv.getFloat32(p + 28 + 4 * a, true);
  }
  return l;
}

// The vertex shader code (GLSL ES 3.00): msReconstruct(vertex index).
export const RECONSTRUCT_GLSL = `
uniform highp sampler2D msSlots;
uniform highp sampler2D msMeans;
uniform highp sampler2D msModes;
uniform highp sampler2D msParams;
uniform int msSlotsPer;
uniform int msStride;
highp vec4 msFetch(highp sampler2D t, int i) {
  int w = textureSize(t, 0).x;
  return texelFetch(t, ivec2(i % w, i / w), 0);
}
// q = (w, x, y, z): v + 2 u x (u x v + w v), u = (x, y, z)
highp vec3 msRotate(highp vec4 q, highp vec3 v) {
  highp vec3 u = q.yzw;
  return v + 2.0 * cross(u, cross(u, v) + q.x * v);
}
highp vec3 msReconstruct(int vid) {
  highp vec3 p = vec3(0.0);
  for (int s = 0; s < msSlotsPer; s++) {
    highp vec4 sl = msFetch(msSlots, vid * msSlotsPer + s);
    if (sl.z == 0.0) continue;
    highp vec4 me = msFetch(msMeans, int(sl.x));
    int base = int(sl.y) * msStride;
    highp vec4 q = msFetch(msParams, base);
    highp vec4 tk = msFetch(msParams, base + 1);
    highp vec3 y = me.xyz;
    int k = int(tk.w), mb = int(me.w);
    for (int a = 0; a < k; a++) {
      highp vec4 l4 = msFetch(msParams, base + 2 + a / 4);
      y += l4[a % 4] * msFetch(msModes, mb + a).xyz;
    }
    p += sl.z * (msRotate(q, y) + tk.xyz);
  }
  return p;
}
`;

function texSize(texels) {
  const n = Math.max(1, texels);
  return [Math.min(TEX_W, n), Math.ceil(n / TEX_W)];
}

function padded(arr, texels) {
  const [w, h] = texSize(texels);
  if (arr.length === 4 * w * h) return arr;
  const out = new Float32Array(4 * w * h);
  out.set(arr.subarray(0, Math.min(arr.length, out.length)));
  return out;
}

// three.js side. Two passes per params frame, both on the GPU:
//   1. positions: a full-screen pass writes msReconstruct(i) of every vertex i into a float
//      render target (one texel per vertex), with the frame's layout's textures;
//   2. the mesh: the viewer's MeshStandardMaterial (and a depth material for the shadow) with its
//      position and normal replaced by texture fetches: the position of vertex gl_VertexID, and
//      its smooth normal, the area-weighted sum of the normals of the triangles around it (around
//      every copy of its rest position, as viewer.js's CPU normals), from a texture of incident
//      triangles built once per topology.
// update(l) uploads layout l's parameters (after decodeParamsBlock) and runs pass 1.
export class ParamsMesh {
  constructor(THREE, model, baseMaterial, faces, rep) {
    this.THREE = THREE;
    this.model = model;
    const nv = model.nv;
    const tex = (arr, texels) => {
      const [w, h] = texSize(texels);
      const t = new THREE.DataTexture(padded(arr, texels), w, h, THREE.RGBAFormat, THREE.FloatType);
      t.minFilter = t.magFilter = THREE.NearestFilter;
      t.needsUpdate = true;
      return t;
    };
    const [pw, ph] = texSize(nv);
    this.target = new THREE.WebGLRenderTarget(pw, ph, {
      type: THREE.FloatType, format: THREE.RGBAFormat, minFilter: THREE.NearestFilter,
      magFilter: THREE.NearestFilter, depthBuffer: false, stencilBuffer: false, generateMipmaps: false });
    this.camera = new THREE.Camera();
    this.quad = new THREE.Mesh(new THREE.PlaneGeometry(2, 2));
    this.quad.frustumCulled = false;
    this.scene = new THREE.Scene();
    this.scene.add(this.quad);
    this.layouts = model.layouts.map(L => {
      L.paramTex = padded(L.paramTex, L.ninst * L.stride);
      const uniforms = {
        msSlots: { value: tex(L.slotTex, nv * L.slots) },
        msMeans: { value: tex(L.means, L.nentries) },
        msModes: { value: tex(L.modes, L.modes.length / 4) },
        msParams: { value: tex(L.paramTex, L.ninst * L.stride) },
        msSlotsPer: { value: L.slots },
        msStride: { value: L.stride },
        msCount: { value: nv },
      };
      const pass = new THREE.RawShaderMaterial({
        glslVersion: THREE.GLSL3, uniforms, depthTest: false, depthWrite: false,
        vertexShader: `precision highp float;
in vec3 position;
void main() { gl_Position = vec4(position.xy, 0.0, 1.0); }`,
        fragmentShader: `precision highp float;
precision highp int;
${RECONSTRUCT_GLSL}
uniform int msCount;
out vec4 msColor;
void main() {
  int i = int(gl_FragCoord.y) * ${TEX_W} + int(gl_FragCoord.x);
  msColor = i < msCount ? vec4(msReconstruct(i), 1.0) : vec4(0.0);
}` });
      return { L, uniforms, pass };
    });
    // incident triangles per copy group: (the two other corners in winding order) per texel, and
    // per vertex (first texel, count) of its group
    const groups = new Map();
    for (let f = 0; f < faces.length; f += 3)
      for (let c = 0; c < 3; c++) {
        const g = rep ? rep[faces[f + c]] : faces[f + c];
        if (!groups.has(g)) groups.set(g, []);
        groups.get(g).push(faces[f + (c + 1) % 3], faces[f + (c + 2) % 3]);
      }
    const inc = new Float32Array(4 * Math.max(1, faces.length)), ring = new Float32Array(4 * nv);
    const first = new Map();
    let at = 0;
    for (const [g, list] of groups) {
      first.set(g, [at, list.length / 2]);
      for (let k = 0; k < list.length; k += 2, at++) { inc[4 * at] = list[k]; inc[4 * at + 1] = list[k + 1]; }
    }
    for (let v = 0; v < nv; v++) {
      const r = first.get(rep ? rep[v] : v) || [0, 0];
      ring[4 * v] = r[0]; ring[4 * v + 1] = r[1];
    }
    const shared = {
      msPos: { value: this.target.texture },
      msInc: { value: tex(inc, Math.max(1, faces.length)) },
      msRing: { value: tex(ring, nv) },
    };
    this.shared = shared;
    const fetchGLSL = `
uniform highp sampler2D msPos;
uniform highp sampler2D msInc;
uniform highp sampler2D msRing;
highp vec4 msGet(highp sampler2D t, int i) {
  int w = textureSize(t, 0).x;
  return texelFetch(t, ivec2(i % w, i / w), 0);
}
highp vec3 msNormal(int v) {
  highp vec3 p = msGet(msPos, v).xyz, n = vec3(0.0);
  highp vec4 r = msGet(msRing, v);
  for (int k = 0; k < int(r.y); k++) {
    highp vec4 bc = msGet(msInc, int(r.x) + k);
    n += cross(msGet(msPos, int(bc.x)).xyz - p, msGet(msPos, int(bc.y)).xyz - p);
  }
  return normalize(n);
}
`;
    const patch = mat => {
      mat.onBeforeCompile = shader => {
        Object.assign(shader.uniforms, shared);
        shader.vertexShader = fetchGLSL + shader.vertexShader
          .replace('#include <beginnormal_vertex>', 'vec3 objectNormal = msNormal(gl_VertexID);')
          .replace('#include <begin_vertex>', 'vec3 transformed = msGet(msPos, gl_VertexID).xyz;');
      };
      mat.customProgramCacheKey = () => 'meshsteer-params';
      return mat;
    };
    this.material = patch(baseMaterial.clone());
    this.depth = patch(new THREE.MeshDepthMaterial({ depthPacking: THREE.RGBADepthPacking }));
  }
  update(renderer, l) {
    const x = this.layouts[l], t = x.uniforms.msParams.value;
    t.image.data.set(x.L.paramTex);
    t.needsUpdate = true;
    this.quad.material = x.pass;
    const prev = renderer.getRenderTarget();
    renderer.setRenderTarget(this.target);
    renderer.render(this.scene, this.camera);
    renderer.setRenderTarget(prev);
  }
  // tests: the positions pass 1 wrote for the last update (what the mesh is drawn from)
  positions(renderer) {
    const { width, height } = this.target;
    const px = new Float32Array(4 * width * height), V = new Float32Array(3 * this.model.nv);
    renderer.readRenderTargetPixels(this.target, 0, 0, width, height, px);
    for (let i = 0; i < this.model.nv; i++)
      for (let c = 0; c < 3; c++) V[3 * i + c] = px[4 * i + c];
    return V;
  }
  dispose() {
    for (const x of this.layouts) {
      for (const k of ['msSlots', 'msMeans', 'msModes', 'msParams']) x.uniforms[k].value.dispose();
      x.pass.dispose();
    }
    this.shared.msInc.value.dispose();
    this.shared.msRing.value.dispose();
    this.target.dispose();
    this.quad.geometry.dispose();
    this.material.dispose();
    this.depth.dispose();
  }
}

// Transform feedback: the positions RECONSTRUCT_GLSL gives for layout l with the parameter
// texture contents `paramTex` (default: the layout's current ones), read back (nv x 3
// Float32Array), on a WebGL2 context of its own (tests; the viewer's renderer is left alone). The
// context, program and the layout's fixed textures are made at the first call and kept.
const feedback = new WeakMap(); // layout -> { gl, prog, params texture, output buffer, tf }
function feedbackFor(L, nv) {
  let f = feedback.get(L);
  if (f) return f;
  const gl = document.createElement('canvas').getContext('webgl2');
  if (!gl) throw new Error('no WebGL2');
  const sh = (type, src) => {
    const x = gl.createShader(type);
    gl.shaderSource(x, src);
    gl.compileShader(x);
    if (!gl.getShaderParameter(x, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(x));
    return x;
  };
  const prog = gl.createProgram();
  gl.attachShader(prog, sh(gl.VERTEX_SHADER, `#version 300 es
precision highp float;
precision highp int;
${RECONSTRUCT_GLSL}
out vec3 msOut;
void main() { msOut = msReconstruct(gl_VertexID); gl_Position = vec4(0.0); gl_PointSize = 1.0; }`));
  gl.attachShader(prog, sh(gl.FRAGMENT_SHADER, `#version 300 es
precision highp float;
out vec4 c;
void main() { c = vec4(0.0); }`));
  gl.transformFeedbackVaryings(prog, ['msOut'], gl.INTERLEAVED_ATTRIBS);
  gl.linkProgram(prog);
  if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(prog));
  gl.useProgram(prog);
  const bind = (name, arr, texels, unit) => {
    const [w, h] = texSize(texels);
    const t = gl.createTexture();
    gl.activeTexture(gl.TEXTURE0 + unit);
    gl.bindTexture(gl.TEXTURE_2D, t);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, w, h, 0, gl.RGBA, gl.FLOAT, padded(arr, texels));
    gl.uniform1i(gl.getUniformLocation(prog, name), unit);
    return t;
  };
  bind('msSlots', L.slotTex, nv * L.slots, 0);
  bind('msMeans', L.means, L.nentries, 1);
  bind('msModes', L.modes, L.modes.length / 4, 2);
  const params = bind('msParams', L.paramTex, L.ninst * L.stride, 3);
  gl.uniform1i(gl.getUniformLocation(prog, 'msSlotsPer'), L.slots);
  gl.uniform1i(gl.getUniformLocation(prog, 'msStride'), L.stride);
  const out = gl.createBuffer();
  gl.bindBuffer(gl.TRANSFORM_FEEDBACK_BUFFER, out);
  gl.bufferData(gl.TRANSFORM_FEEDBACK_BUFFER, 12 * nv, gl.STREAM_READ);
  const tf = gl.createTransformFeedback();
  f = { gl, params, out, tf };
  feedback.set(L, f);
  return f;
}

export function readback(model, l, paramTex) {
  const L = model.layouts[l], nv = model.nv;
  const { gl, params, out, tf } = feedbackFor(L, nv);
  const [w, h] = texSize(L.ninst * L.stride);
  gl.activeTexture(gl.TEXTURE3);
  gl.bindTexture(gl.TEXTURE_2D, params);
  gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, w, h, gl.RGBA, gl.FLOAT,
                   padded(paramTex || L.paramTex, L.ninst * L.stride));
  gl.bindTransformFeedback(gl.TRANSFORM_FEEDBACK, tf);
  gl.bindBufferBase(gl.TRANSFORM_FEEDBACK_BUFFER, 0, out);
  gl.enable(gl.RASTERIZER_DISCARD);
  gl.beginTransformFeedback(gl.POINTS);
  gl.drawArrays(gl.POINTS, 0, nv);
  gl.endTransformFeedback();
  gl.disable(gl.RASTERIZER_DISCARD);
  gl.bindTransformFeedback(gl.TRANSFORM_FEEDBACK, null);
  const V = new Float32Array(3 * nv);
  gl.bindBuffer(gl.TRANSFORM_FEEDBACK_BUFFER, out);
  gl.getBufferSubData(gl.TRANSFORM_FEEDBACK_BUFFER, 0, V);
  return V;
}
