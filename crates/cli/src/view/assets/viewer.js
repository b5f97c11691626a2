// thinshell view: the page's own code (WebGL2 and a 2D canvas, no library).
//
// Data come either from the server (/api/...) or from the JSON embedded by `--html`; both give
// the same binary frame layout: little-endian f32 positions (3 per vertex) followed by every
// field of the run (one value per vertex or per face). Frames are fetched on demand and a window
// around the current frame is kept (PREFETCH ahead, KEEP behind).
'use strict';
(function () {
  const PREFETCH = 24;
  const KEEP = 8;
  const MAX_INFLIGHT = 4;
  const FRONT = [235 / 255, 150 / 255, 70 / 255]; // top side, as in xtask's renderer
  const BACK = [80 / 255, 130 / 255, 220 / 255];
  const BACKGROUND = [1, 1, 1];
  const SEQUENTIAL = ['#440154', '#3b528b', '#21918c', '#5ec962', '#fde725'];
  const DIVERGING = ['#3b4cc0', '#f7f7f7', '#b40426'];
  const NONE = { key: 'none', label: 'plain (top orange, bottom blue)', unit: '', location: 'none', signed: false };

  const params = new URLSearchParams(location.search);
  const embedded = JSON.parse(document.getElementById('thinshell-data').textContent);
  const $ = (id) => document.getElementById(id);

  const state = {
    frame: 0,
    playing: false,
    field: params.get('field') || 'displacement',
    wire: params.get('wireframe') === '1',
    light: params.get('lighting') !== '0',
    fps: Math.max(1, Number(params.get('fps')) || 30),
    camera: { yaw: -0.5, pitch: 0.6, zoom: 1 },
  };
  const stats = { shown: 0, stalls: 0, playStart: 0, playShown: 0, renderMs: 0, renders: 0, ticks: 0 };
  let views = [];
  let meta = [];
  let steps = [];

  // ---- data sources ----------------------------------------------------------------------
  function b64bytes(s) {
    const bin = atob(s);
    const out = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
    return out.buffer;
  }
  async function fetchOk(url, kind) {
    const res = await fetch(url);
    if (!res.ok) {
      let msg = res.status + ' ' + res.statusText;
      try { msg = (await res.json()).error || msg; } catch (e) { /* not JSON: keep the status */ }
      throw new Error(msg);
    }
    return kind === 'json' ? res.json() : res.arrayBuffer();
  }
  const source = embedded
    ? {
      meta: async () => embedded.meta,
      mesh: async (r) => b64bytes(embedded.runs[r].mesh),
      steps: async (r) => embedded.runs[r].steps,
      frame: async (r, i) => {
        const f = embedded.runs[r].frames[i];
        if (f === undefined) throw new Error('frame ' + i + ' does not exist');
        if (typeof f !== 'string') throw new Error(f.error);
        return b64bytes(f);
      },
    }
    : {
      meta: () => fetchOk('api/runs', 'json'),
      mesh: (r) => fetchOk('api/run/' + r + '/mesh'),
      steps: (r) => fetchOk('api/run/' + r + '/steps', 'json'),
      frame: (r, i) => fetchOk('api/run/' + r + '/frame/' + i),
    };

  // ---- colour maps (also the legend) -----------------------------------------------------
  function hex(c) { return [1, 3, 5].map((k) => parseInt(c.slice(k, k + 2), 16) / 255); }
  function ramp(stops, t) {
    const s = stops.map(hex);
    const x = Math.min(Math.max(t, 0), 1) * (s.length - 1);
    const k = Math.min(Math.floor(x), s.length - 2);
    const f = x - k;
    return s[k].map((a, j) => a + f * (s[k + 1][j] - a));
  }
  function colormapBytes(stops) {
    const out = new Uint8Array(256 * 4);
    for (let i = 0; i < 256; i++) {
      const c = ramp(stops, i / 255);
      out.set([Math.round(c[0] * 255), Math.round(c[1] * 255), Math.round(c[2] * 255), 255], 4 * i);
    }
    return out;
  }

  // ---- WebGL -----------------------------------------------------------------------------
  const VS = `#version 300 es
in vec3 aPos; in float aVal; in float aValid; in vec3 aBary;
uniform mat4 uView; uniform vec4 uProj;
out vec3 vEye; out float vVal; out float vValid; out vec3 vBary;
void main() {
  vec4 e = uView * vec4(aPos, 1.0);
  vEye = e.xyz; vVal = aVal; vValid = aValid; vBary = aBary;
  gl_Position = vec4(e.x * uProj.x, e.y * uProj.y, -e.z * uProj.z, 1.0);
}`;
  const FS = `#version 300 es
precision highp float;
in vec3 vEye; in float vVal; in float vValid; in vec3 vBary;
uniform int uMode; uniform vec2 uRange; uniform bool uWire; uniform bool uLight;
uniform vec3 uFront; uniform vec3 uBack; uniform sampler2D uMap;
out vec4 outColor;
void main() {
  vec3 n = normalize(cross(dFdx(vEye), dFdy(vEye)));
  vec3 l = normalize(vec3(0.3, 0.6, 1.0));
  float shade = uLight ? 0.3 + 0.7 * abs(dot(n, l)) : 1.0;
  vec3 base;
  if (uMode == 0) {
    base = gl_FrontFacing ? uFront : uBack;
  } else if (vValid < 0.5) {
    base = vec3(0.6);
  } else {
    float w = uRange.y - uRange.x;
    float t = w > 0.0 ? (vVal - uRange.x) / w : (uMode == 2 ? 0.5 : 0.0);
    base = texture(uMap, vec2(clamp(t, 0.0, 1.0) * (255.0 / 256.0) + 0.5 / 256.0, 0.5)).rgb;
  }
  vec3 c = base * shade;
  if (uWire) {
    vec3 d = fwidth(vBary);
    vec3 a = smoothstep(vec3(0.0), 1.5 * d, vBary);
    c = mix(vec3(0.1), c, min(min(a.x, a.y), a.z));
  }
  outColor = vec4(c, 1.0);
}`;

  function compile(gl, type, src) {
    const s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error('shader: ' + gl.getShaderInfoLog(s));
    return s;
  }

  function makeView(r, m, faces, container) {
    const el = document.createElement('div');
    el.className = 'view';
    el.innerHTML = '<canvas class="gl"></canvas><div class="title"></div>' +
      '<div class="legend"><div class="lname"></div><canvas width="256" height="1"></canvas>' +
      '<div class="ticks"><span class="lo"></span><span class="hi"></span></div></div><div class="msg"></div>';
    container.appendChild(el);
    const canvas = el.querySelector('canvas.gl');
    const v = {
      r, meta: m, faces, el, canvas, cache: new Map(), inflight: new Set(), errors: new Map(),
      shown: -1, shownField: null, gl: null, range: [0, 0],
    };
    el.querySelector('.title').textContent = (r === 0 ? 'A: ' : 'B: ') + m.name + '  (' + m.n_faces + ' faces)';
    const gl = canvas.getContext('webgl2', { antialias: params.get('aa') !== '0' });
    if (!gl) {
      showMessage(v, 'This browser has no WebGL2: the shell cannot be drawn.');
      return v;
    }
    v.gl = gl;
    const prog = gl.createProgram();
    gl.attachShader(prog, compile(gl, gl.VERTEX_SHADER, VS));
    gl.attachShader(prog, compile(gl, gl.FRAGMENT_SHADER, FS));
    gl.linkProgram(prog);
    if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) throw new Error('program: ' + gl.getProgramInfoLog(prog));
    v.prog = prog;
    v.loc = {};
    for (const u of ['uView', 'uProj', 'uMode', 'uRange', 'uWire', 'uLight', 'uFront', 'uBack', 'uMap']) {
      v.loc[u] = gl.getUniformLocation(prog, u);
    }
    const nf = m.n_faces;
    v.vao = gl.createVertexArray();
    gl.bindVertexArray(v.vao);
    const attr = (name, size, data) => {
      const buf = gl.createBuffer();
      gl.bindBuffer(gl.ARRAY_BUFFER, buf);
      gl.bufferData(gl.ARRAY_BUFFER, data, gl.DYNAMIC_DRAW);
      const loc = gl.getAttribLocation(prog, name);
      gl.enableVertexAttribArray(loc);
      gl.vertexAttribPointer(loc, size, gl.FLOAT, false, 0, 0);
      return buf;
    };
    const bary = new Float32Array(9 * nf);
    for (let f = 0; f < nf; f++) bary.set([1, 0, 0, 0, 1, 0, 0, 0, 1], 9 * f);
    v.pos = new Float32Array(9 * nf);
    v.val = new Float32Array(3 * nf);
    v.valid = new Float32Array(3 * nf);
    v.bufPos = attr('aPos', 3, v.pos);
    v.bufVal = attr('aVal', 1, v.val);
    v.bufValid = attr('aValid', 1, v.valid);
    attr('aBary', 3, bary);
    v.maps = {};
    for (const [k, stops] of [['seq', SEQUENTIAL], ['div', DIVERGING]]) {
      const t = gl.createTexture();
      gl.bindTexture(gl.TEXTURE_2D, t);
      gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA, 256, 1, 0, gl.RGBA, gl.UNSIGNED_BYTE, colormapBytes(stops));
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.LINEAR);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
      v.maps[k] = t;
    }
    return v;
  }

  function showMessage(v, text) {
    const msg = v.el.querySelector('.msg');
    msg.textContent = text || '';
    msg.style.display = text ? 'block' : 'none';
  }

  function decodeFrame(v, buffer) {
    const m = v.meta;
    const data = new Float32Array(buffer);
    let need = 3 * m.n_vertices;
    for (const f of m.fields) need += f.location === 'face' ? m.n_faces : m.n_vertices;
    if (data.length !== need) throw new Error('frame has ' + data.length + ' numbers, expected ' + need);
    const out = { pos: data.subarray(0, 3 * m.n_vertices), fields: {} };
    let off = 3 * m.n_vertices;
    for (const f of m.fields) {
      const n = f.location === 'face' ? m.n_faces : m.n_vertices;
      out.fields[f.key] = data.subarray(off, off + n);
      off += n;
    }
    return out;
  }

  function request(v, i) {
    if (i < 0 || i >= v.meta.frames.length || v.cache.has(i) || v.inflight.has(i) || v.errors.has(i)) return;
    v.inflight.add(i);
    source.frame(v.r, i)
      .then((buf) => { v.cache.set(i, decodeFrame(v, buf)); })
      .catch((e) => {
        const f = v.meta.frames[i];
        v.errors.set(i, 'frame ' + i + ' (step ' + f.step + '): ' + e.message);
      })
      .finally(() => { v.inflight.delete(i); schedule(); });
  }

  // The frame of view v shown at the master (run A) frame: same index for run A, nearest time
  // for run B (runs may write frames at different rates).
  function frameOf(v, master) {
    if (v.r === 0) return master;
    const t = views[0].meta.frames[master].time;
    let best = 0;
    v.meta.frames.forEach((f, i) => { if (Math.abs(f.time - t) < Math.abs(v.meta.frames[best].time - t)) best = i; });
    return best;
  }

  function prefetch(v, i) {
    const n = v.meta.frames.length;
    for (const k of v.cache.keys()) if (k < i - KEEP || k > i + PREFETCH + KEEP) v.cache.delete(k);
    for (let d = 0; d <= PREFETCH && v.inflight.size < MAX_INFLIGHT; d++) {
      const k = state.playing ? (i + d) % n : i + d;
      request(v, k);
    }
    if (i > 0) request(v, i - 1);
  }

  function currentField() {
    const all = views.length ? views[0].meta.fields : [];
    return all.find((f) => f.key === state.field) || NONE;
  }

  // ---- camera ----------------------------------------------------------------------------
  let fit = null; // centre and radius of run A's first and last frames (the view's fixed frame of reference)
  function viewMatrix() {
    const { yaw, pitch } = state.camera;
    const a = pitch - Math.PI / 2;
    const cy = Math.cos(-yaw), sy = Math.sin(-yaw), ca = Math.cos(a), sa = Math.sin(a);
    // R = Rx(pitch − 90°) · Rz(−yaw): pitch 90° looks straight down (x right, y up).
    const R = [
      [cy, -sy, 0],
      [ca * sy, ca * cy, -sa],
      [sa * sy, sa * cy, ca],
    ];
    const c = fit.centre;
    const t = R.map((row) => -(row[0] * c[0] + row[1] * c[1] + row[2] * c[2]));
    // column-major 4×4
    return new Float32Array([
      R[0][0], R[1][0], R[2][0], 0,
      R[0][1], R[1][1], R[2][1], 0,
      R[0][2], R[1][2], R[2][2], 0,
      t[0], t[1], t[2], 1,
    ]);
  }

  function draw(v, i) {
    const gl = v.gl;
    if (!gl) return;
    const frame = v.cache.get(i);
    const field = currentField();
    const dpr = window.devicePixelRatio || 1;
    const w = Math.max(1, Math.round(v.canvas.clientWidth * dpr));
    const h = Math.max(1, Math.round(v.canvas.clientHeight * dpr));
    if (v.canvas.width !== w || v.canvas.height !== h) { v.canvas.width = w; v.canvas.height = h; }
    gl.viewport(0, 0, w, h);
    gl.clearColor(BACKGROUND[0], BACKGROUND[1], BACKGROUND[2], 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    if (!fit) return;
    // A frame still loading (or evicted) keeps the buffers of the last frame drawn.
    if (frame && (v.shown !== i || v.shownField !== field.key)) {
      const F = v.faces;
      const nf = v.meta.n_faces;
      for (let f = 0; f < nf; f++) {
        for (let k = 0; k < 3; k++) {
          const p = F[3 * f + k];
          v.pos[9 * f + 3 * k] = frame.pos[3 * p];
          v.pos[9 * f + 3 * k + 1] = frame.pos[3 * p + 1];
          v.pos[9 * f + 3 * k + 2] = frame.pos[3 * p + 2];
        }
      }
      const vals = frame.fields[field.key];
      if (vals) {
        for (let f = 0; f < nf; f++) {
          for (let k = 0; k < 3; k++) {
            const x = field.location === 'face' ? vals[f] : vals[F[3 * f + k]];
            const ok = Number.isFinite(x);
            v.val[3 * f + k] = ok ? x : 0;
            v.valid[3 * f + k] = ok ? 1 : 0;
          }
        }
      }
      gl.bindBuffer(gl.ARRAY_BUFFER, v.bufPos);
      gl.bufferSubData(gl.ARRAY_BUFFER, 0, v.pos);
      gl.bindBuffer(gl.ARRAY_BUFFER, v.bufVal);
      gl.bufferSubData(gl.ARRAY_BUFFER, 0, v.val);
      gl.bindBuffer(gl.ARRAY_BUFFER, v.bufValid);
      gl.bufferSubData(gl.ARRAY_BUFFER, 0, v.valid);
      v.shown = i;
      v.shownField = field.key;
    }
    if (v.shown < 0) return;
    const mode = field.key === 'none' ? 0 : field.signed || sharedRange.signed ? 2 : 1;
    gl.useProgram(v.prog);
    gl.bindVertexArray(v.vao);
    gl.enable(gl.DEPTH_TEST);
    gl.uniformMatrix4fv(v.loc.uView, false, viewMatrix());
    // Orthographic: s pixels per metre, the fitted bounding sphere filling 90 % of the shorter
    // side at zoom 1; depth over ±100 radii.
    const s = (0.9 * Math.min(w, h) / 2 / fit.radius) * state.camera.zoom;
    gl.uniform4f(v.loc.uProj, s / (w / 2), s / (h / 2), 1 / (100 * fit.radius), 0);
    gl.uniform1i(v.loc.uMode, mode);
    gl.uniform2f(v.loc.uRange, sharedRange.lo, sharedRange.hi);
    gl.uniform1i(v.loc.uWire, state.wire ? 1 : 0);
    gl.uniform1i(v.loc.uLight, state.light ? 1 : 0);
    gl.uniform3fv(v.loc.uFront, FRONT);
    gl.uniform3fv(v.loc.uBack, BACK);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, v.maps[mode === 2 ? 'div' : 'seq']);
    gl.uniform1i(v.loc.uMap, 0);
    gl.drawArrays(gl.TRIANGLES, 0, 3 * v.meta.n_faces);
  }

  // One colour range for all views, so the two runs are compared on one scale: [0, max] for a
  // quantity that is never negative here, symmetric [−m, m] (diverging map) otherwise.
  let sharedRange = { lo: 0, hi: 0, signed: false };
  function updateRange(field) {
    let lo = Infinity, hi = -Infinity;
    for (const v of views) {
      const fr = v.cache.get(frameOf(v, state.frame));
      const vals = fr && fr.fields[field.key];
      if (!vals) continue;
      for (const x of vals) if (Number.isFinite(x)) { if (x < lo) lo = x; if (x > hi) hi = x; }
    }
    if (!(lo <= hi)) { lo = 0; hi = 0; }
    if (field.signed || lo < 0) {
      const m = Math.max(Math.abs(lo), Math.abs(hi));
      sharedRange = { lo: -m, hi: m, signed: true };
    } else {
      sharedRange = { lo: 0, hi, signed: false };
    }
  }

  function fmt(x) {
    if (x === 0) return '0';
    const a = Math.abs(x);
    return a >= 1e-2 && a < 1e4 ? x.toPrecision(3) : x.toExponential(2);
  }

  function updateLegend(v, field) {
    const key = field.key + ' ' + sharedRange.lo + ' ' + sharedRange.hi;
    if (v.legendKey === key) return;
    v.legendKey = key;
    const leg = v.el.querySelector('.legend');
    if (field.key === 'none') { leg.style.display = 'none'; return; }
    leg.style.display = 'block';
    leg.querySelector('.lname').textContent = field.label + ' [' + field.unit + ']';
    const c = leg.querySelector('canvas');
    const img = c.getContext('2d').createImageData(256, 1);
    img.data.set(colormapBytes(sharedRange.signed ? DIVERGING : SEQUENTIAL));
    c.getContext('2d').putImageData(img, 0, 0);
    leg.querySelector('.lo').textContent = fmt(sharedRange.lo);
    leg.querySelector('.hi').textContent = fmt(sharedRange.hi) + ' ' + field.unit;
  }

  // ---- energy chart ----------------------------------------------------------------------
  const SERIES = [
    ['stretch_J', 'stretching', '#d62728'],
    ['bend_J', 'bending', '#1f77b4'],
    ['kinetic_J', 'kinetic', '#2ca02c'],
    ['total', 'total (stretch + bend + kinetic)', '#222222'],
  ];
  function seriesOf(st) {
    const col = (name) => {
      const k = st.columns.indexOf(name);
      return k < 0 ? null : st.values[k];
    };
    const t = col('time_s') || col('step');
    if (!t) return null;
    const out = { t, lines: {} };
    for (const [key] of SERIES) if (key !== 'total' && col(key)) out.lines[key] = col(key);
    out.lines.total = t.map((_, i) => ['stretch_J', 'bend_J', 'kinetic_J']
      .reduce((s, k) => s + (out.lines[k] && out.lines[k][i] != null ? out.lines[k][i] : 0), 0));
    return out;
  }
  function drawChart() {
    const c = $('chart');
    const dpr = window.devicePixelRatio || 1;
    c.width = Math.round(c.clientWidth * dpr);
    c.height = Math.round(c.clientHeight * dpr);
    const g = c.getContext('2d');
    g.setTransform(dpr, 0, 0, dpr, 0, 0);
    const W = c.clientWidth, H = c.clientHeight;
    const L = 70, R = 250, T = 10, B = 26;
    g.clearRect(0, 0, W, H);
    const all = steps.map(seriesOf);
    const msgs = steps.map((s, r) => (s.error ? (r === 0 ? 'A: ' : 'B: ') + s.error : '')).filter(Boolean);
    $('chartmsg').textContent = msgs.join('  ');
    let t0 = 0, t1 = 0, e0 = 0, e1 = 0;
    for (const s of all) {
      if (!s) continue;
      for (const x of s.t) if (x != null) { t1 = Math.max(t1, x); t0 = Math.min(t0, x); }
      for (const k in s.lines) for (const y of s.lines[k]) if (y != null) { e0 = Math.min(e0, y); e1 = Math.max(e1, y); }
    }
    if (t1 <= t0) t1 = t0 + 1;
    if (e1 <= e0) e1 = e0 + 1;
    const X = (t) => L + ((t - t0) / (t1 - t0)) * (W - L - R);
    const Y = (e) => H - B - ((e - e0) / (e1 - e0)) * (H - T - B);
    g.strokeStyle = '#999';
    g.strokeRect(L, T, W - L - R, H - T - B);
    g.fillStyle = '#222';
    g.font = '11px system-ui, sans-serif';
    g.fillText(fmt(e1) + ' J', 4, T + 10);
    g.fillText(fmt(e0) + ' J', 4, H - B);
    g.fillText(fmt(t0) + ' s', L, H - 8);
    g.fillText('t = ' + fmt(t1) + ' s', W - R - 70, H - 8);
    all.forEach((s, r) => {
      if (!s) return;
      g.setLineDash(r === 0 ? [] : [6, 4]);
      for (const [key, , colour] of SERIES) {
        const ys = s.lines[key];
        if (!ys) continue;
        g.strokeStyle = colour;
        g.lineWidth = key === 'total' ? 2 : 1.3;
        g.beginPath();
        let started = false;
        ys.forEach((y, i) => {
          if (y == null || s.t[i] == null) return;
          if (started) g.lineTo(X(s.t[i]), Y(y)); else { g.moveTo(X(s.t[i]), Y(y)); started = true; }
        });
        g.stroke();
      }
    });
    g.setLineDash([]);
    SERIES.forEach(([, label, colour], k) => {
      g.fillStyle = colour;
      g.fillRect(W - R + 12, T + 6 + 16 * k, 14, 3);
      g.fillStyle = '#222';
      g.fillText(label, W - R + 32, T + 11 + 16 * k);
    });
    if (views.length > 1) g.fillText('solid: A, dashed: B', W - R + 12, T + 11 + 16 * 4);
    chartX = { L, W: W - L - R, t0, t1, T, B, H };
  }
  let chartX = null;
  let chartSize = '';
  // The cursor is an element over the chart, so moving it does not redraw the curves.
  function drawCursor() {
    const c = $('chart');
    const size = c.clientWidth + 'x' + c.clientHeight;
    if (size !== chartSize) { chartSize = size; drawChart(); }
    if (!views.length || !chartX) return;
    const t = views[0].meta.frames[state.frame].time;
    const x = chartX.L + ((t - chartX.t0) / (chartX.t1 - chartX.t0)) * chartX.W;
    const cur = $('cursor');
    cur.style.left = x + 'px';
    cur.style.top = chartX.T + 'px';
    cur.style.height = (chartX.H - chartX.T - chartX.B) + 'px';
  }

  // ---- main loop -------------------------------------------------------------------------
  let pending = false;
  function schedule() {
    if (!pending) { pending = true; requestAnimationFrame(tick); }
  }
  let lastAdvance = 0;
  function tick(now) {
    pending = false;
    stats.ticks++;
    if (!views.length) return;
    const n = views[0].meta.frames.length;
    if (state.playing) {
      const ready = views.every((v) => v.cache.has(frameOf(v, (state.frame + 1) % n)) || v.errors.has(frameOf(v, (state.frame + 1) % n)));
      const period = 1000 / state.fps;
      if (now - lastAdvance >= period) {
        if (ready) {
          state.frame = (state.frame + 1) % n;
          // Keep the cadence (ticks jitter around the period) but never bank more than one.
          lastAdvance = Math.max(lastAdvance + period, now - period);
          stats.playShown++;
        } else {
          stats.stalls++;
        }
      }
    }
    // Draw only when something visible changed: software WebGL (no GPU) spends most of a
    // tick rasterising, and redrawing an unchanged frame would halve the playback rate.
    const key = JSON.stringify([state.frame, state.field, state.wire, state.light, state.camera,
      window.innerWidth, window.innerHeight,
      views.map((v) => { const i = frameOf(v, state.frame); return [v.cache.has(i), v.errors.has(i)]; })]);
    if (key !== lastKey) {
      lastKey = key;
      const t0 = performance.now();
      render();
      views.forEach((v) => v.gl && v.gl.finish());
      stats.renderMs += performance.now() - t0;
      stats.renders++;
    } else {
      for (const v of views) prefetch(v, frameOf(v, state.frame));
    }
    if (state.playing) schedule();
  }
  let lastKey = '';

  function render() {
    const field = currentField();
    updateRange(field);
    let allReady = true;
    for (const v of views) {
      const i = frameOf(v, state.frame);
      prefetch(v, i);
      const err = v.errors.get(i);
      if (err) {
        // Never a blank canvas: show the loaded frame nearest to the broken one, and say so.
        let near = v.shown;
        for (const k of v.cache.keys()) if (near < 0 || Math.abs(k - i) < Math.abs(near - i)) near = k;
        showMessage(v, err + (near >= 0 ? '\n(showing frame ' + near + ' instead)' : ''));
        draw(v, near);
      } else if (!v.cache.has(i)) {
        allReady = false;
        draw(v, v.shown);
      } else {
        showMessage(v, v.gl ? '' : 'This browser has no WebGL2: the shell cannot be drawn.');
        draw(v, i);
      }
      updateLegend(v, field);
    }
    const f = views[0].meta.frames[state.frame];
    $('scrub').value = String(state.frame);
    $('frameinfo').textContent = 'frame ' + state.frame + ' / ' + (views[0].meta.frames.length - 1) +
      '   step ' + f.step + '   t = ' + fmt(f.time) + ' s';
    drawCursor();
    stats.shown++;
    document.body.dataset.frame = String(state.frame);
    document.body.dataset.wire = String(state.wire);
    document.body.dataset.yaw = state.camera.yaw.toFixed(4);
    document.body.dataset.ready = allReady ? '1' : '0';
  }

  function setFrame(i) {
    const n = views[0].meta.frames.length;
    state.frame = Math.min(Math.max(0, Math.round(i)), n - 1);
    schedule();
  }
  function setPlaying(p) {
    state.playing = p;
    $('play').textContent = p ? 'pause' : 'play';
    if (p) { Object.assign(stats, { playStart: performance.now(), playShown: 0, stalls: 0, renderMs: 0, renders: 0, ticks: 0 }); }
    schedule();
  }

  function wireUi() {
    $('play').onclick = () => setPlaying(!state.playing);
    $('scrub').oninput = (e) => { setPlaying(false); setFrame(Number(e.target.value)); };
    $('field').onchange = (e) => { state.field = e.target.value; schedule(); };
    $('wire').onchange = (e) => { state.wire = e.target.checked; schedule(); };
    $('light').onchange = (e) => { state.light = e.target.checked; schedule(); };
    $('reset').onclick = () => { state.camera = { yaw: -0.5, pitch: 0.6, zoom: 1 }; schedule(); };
    document.addEventListener('keydown', (e) => {
      if (e.target.tagName === 'SELECT') return;
      if (e.key === ' ') { setPlaying(!state.playing); e.preventDefault(); }
      if (e.key === 'ArrowRight') { setPlaying(false); setFrame(state.frame + 1); }
      if (e.key === 'ArrowLeft') { setPlaying(false); setFrame(state.frame - 1); }
      if (e.key === 'End') { setPlaying(false); setFrame(Infinity); }
      if (e.key === 'Home') { setPlaying(false); setFrame(0); }
    });
    // Linked cameras: every view drives the one camera.
    for (const v of views) {
      let drag = null;
      v.canvas.addEventListener('pointerdown', (e) => { drag = [e.clientX, e.clientY]; v.canvas.setPointerCapture(e.pointerId); });
      v.canvas.addEventListener('pointerup', () => { drag = null; });
      v.canvas.addEventListener('pointermove', (e) => {
        if (!drag) return;
        state.camera.yaw += (e.clientX - drag[0]) * 0.01;
        state.camera.pitch = Math.min(Math.PI / 2, Math.max(-Math.PI / 2, state.camera.pitch + (e.clientY - drag[1]) * 0.01));
        drag = [e.clientX, e.clientY];
        schedule();
      });
      v.canvas.addEventListener('wheel', (e) => {
        state.camera.zoom *= Math.exp(-e.deltaY * 0.001);
        e.preventDefault();
        schedule();
      }, { passive: false });
    }
    $('chart').addEventListener('click', (e) => {
      if (!chartX) return;
      const x = e.clientX - $('chart').getBoundingClientRect().left;
      const t = chartX.t0 + ((x - chartX.L) / chartX.W) * (chartX.t1 - chartX.t0);
      const fr = views[0].meta.frames;
      let best = 0;
      fr.forEach((f, i) => { if (Math.abs(f.time - t) < Math.abs(fr[best].time - t)) best = i; });
      setPlaying(false);
      setFrame(best);
    });
    window.addEventListener('resize', schedule);
  }

  function fail(text) {
    const box = document.createElement('div');
    box.className = 'msg';
    box.style.cssText = 'display:block;position:static;margin:20px';
    box.textContent = text;
    $('views').appendChild(box);
    $('frameinfo').textContent = 'error';
    document.body.dataset.ready = 'error';
  }

  async function start() {
    try {
      meta = await source.meta();
      const meshes = await Promise.all(meta.map((_, r) => source.mesh(r)));
      steps = await Promise.all(meta.map((_, r) => source.steps(r).catch((e) => ({ columns: [], values: [], error: e.message }))));
      views = meta.map((m, r) => makeView(r, m, new Uint32Array(meshes[r]), $('views')));
      const sel = $('field');
      for (const f of [NONE].concat(meta[0].fields)) {
        const o = document.createElement('option');
        o.value = f.key;
        o.textContent = f.label + (f.unit ? ' [' + f.unit + ']' : '');
        sel.appendChild(o);
      }
      if (!meta[0].fields.some((f) => f.key === 'bend_density')) {
        // OBJ frames carry positions only: say how to get the energy densities instead of
        // leaving the user to wonder why they are not offered.
        const o = document.createElement('option');
        o.disabled = true;
        o.textContent = 'energy densities: run with output.formats = ["obj", "vtk"]';
        sel.appendChild(o);
      }
      if (!meta[0].fields.some((f) => f.key === state.field) && state.field !== 'none') state.field = 'displacement';
      sel.value = state.field;
      $('wire').checked = state.wire;
      $('light').checked = state.light;
      const cam = params.get('camera');
      if (cam === 'top') state.camera = { yaw: 0, pitch: Math.PI / 2, zoom: 1 };
      if (cam === 'front') state.camera = { yaw: 0, pitch: 0, zoom: 1 };
      $('scrub').max = String(meta[0].frames.length - 1);
      wireUi();
      // The camera is fitted once, to the bounding box of run A's first and last frames (the
      // last may fail to load: then the first alone).
      const first = await source.frame(0, 0).then((b) => decodeFrame(views[0], b));
      views[0].cache.set(0, first);
      const nA = meta[0].frames.length;
      const last = nA > 1 ? await source.frame(0, nA - 1).then((b) => decodeFrame(views[0], b)).catch(() => null) : null;
      const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
      for (const fr of [first, last]) {
        if (!fr) continue;
        for (let i = 0; i < fr.pos.length; i++) { lo[i % 3] = Math.min(lo[i % 3], fr.pos[i]); hi[i % 3] = Math.max(hi[i % 3], fr.pos[i]); }
      }
      const centre = lo.map((l, k) => (l + hi[k]) / 2);
      const radius = Math.max(1e-300, Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) / 2);
      fit = { centre, radius };
      setFrame(Number(params.get('frame')) || 0);
      if (params.get('play') === '1') setPlaying(true);
    } catch (e) {
      fail('thinshell view could not start: ' + e.message);
    }
  }

  // For tests and scripting: the state and playback statistics.
  window.thinshell = {
    state,
    stats: () => ({
      played: stats.playShown,
      stalls: stats.stalls,
      seconds: (performance.now() - stats.playStart) / 1000,
      fps: stats.playShown / Math.max(1e-9, (performance.now() - stats.playStart) / 1000),
      // Mean time to draw one frame (script and WebGL, gl.finish included), ms.
      renderMs: stats.renderMs / Math.max(1, stats.renders),
      // Animation-frame callbacks received while playing (the browser's own frame rate).
      ticks: stats.ticks,
    }),
    setFrame: (i) => { setPlaying(false); setFrame(i); },
    setPlaying,
    fit: () => fit,
  };
  start();
})();
