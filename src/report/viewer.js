// meshgaze 3D viewer: draws what src/report/viewer.rs embedded (mesh, maps, fixations, the
// stimulus cameras) with WebGL 1. No library and no network: the page must open offline.
// Colours follow the static renders exactly: the scale ends (lo, hi) come from Rust.
(function () {
  'use strict';
  var errors = window.__mgvErrors || (window.__mgvErrors = []);
  if (!window.__mgvHooked) {
    window.__mgvHooked = true;
    window.addEventListener('error', function (e) { errors.push(String(e.message || e)); });
    var consoleError = console.error.bind(console);
    console.error = function () {
      errors.push(Array.prototype.join.call(arguments, ' '));
      consoleError.apply(null, arguments);
    };
  }

  var SUBJECT_COLORS = [[230, 25, 75], [60, 180, 75], [255, 225, 25], [0, 130, 200],
    [245, 130, 48], [145, 30, 180], [70, 240, 240], [240, 50, 230], [210, 245, 60],
    [250, 190, 212], [0, 128, 128], [220, 190, 255], [170, 110, 40], [128, 0, 0],
    [170, 255, 195], [128, 128, 0], [0, 0, 128], [128, 128, 128]];
  var RAMP = [[0, 0, 1], [0, 1, 1], [0, 1, 0], [1, 1, 0], [1, 0, 0]];
  var PLAIN = 0.8, BELOW = 0.72, BACKGROUND = [250, 250, 250];

  function decode(text, Type) {
    var bin = atob(text), bytes = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    return new Type(bytes.buffer);
  }

  // The ramp of ColorRamp::rgb in mesh/write_ply.rs, as 0..1 floats.
  function ramp(t) {
    t = isFinite(t) ? Math.min(1, Math.max(0, t)) : 0;
    var x = t * 4, i = Math.min(Math.floor(x), 3), f = x - i, out = [0, 0, 0];
    for (var k = 0; k < 3; k++) out[k] = Math.round((RAMP[i][k] * (1 - f) + RAMP[i + 1][k] * f) * 255) / 255;
    return out;
  }

  // Column-major 4x4 matrices, as WebGL and glam store them.
  function mul(a, b) {
    var o = new Float32Array(16);
    for (var c = 0; c < 4; c++) for (var r = 0; r < 4; r++) {
      var s = 0;
      for (var k = 0; k < 4; k++) s += a[k * 4 + r] * b[c * 4 + k];
      o[c * 4 + r] = s;
    }
    return o;
  }
  function sub(a, b) { return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]; }
  function add(a, b) { return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]; }
  function scale(a, s) { return [a[0] * s, a[1] * s, a[2] * s]; }
  function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
  function cross(a, b) { return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]; }
  function norm(a) { var l = Math.sqrt(dot(a, a)) || 1; return [a[0] / l, a[1] / l, a[2] / l]; }
  function rotate(v, axis, angle) { // Rodrigues
    var c = Math.cos(angle), s = Math.sin(angle), k = norm(axis);
    return add(add(scale(v, c), scale(cross(k, v), s)), scale(k, dot(k, v) * (1 - c)));
  }
  function lookAt(eye, target, up) {
    var z = norm(sub(eye, target)), x = norm(cross(up, z)), y = cross(z, x);
    return new Float32Array([x[0], y[0], z[0], 0, x[1], y[1], z[1], 0, x[2], y[2], z[2], 0,
      -dot(x, eye), -dot(y, eye), -dot(z, eye), 1]);
  }
  function perspective(fovy, aspect, near, far) {
    var f = 1 / Math.tan(fovy / 2), nf = 1 / (near - far);
    return new Float32Array([f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) * nf, -1,
      0, 0, 2 * far * near * nf, 0]);
  }

  function el(tag, attrs, parent, text) {
    var e = document.createElement(tag);
    for (var k in attrs) e.setAttribute(k, attrs[k]);
    if (text !== undefined) e.textContent = text;
    if (parent) parent.appendChild(e);
    return e;
  }

  function hashOptions() {
    var o = {};
    (location.hash || '').replace(/^#/, '').split('&').forEach(function (kv) {
      if (!kv) return;
      var i = kv.indexOf('=');
      o[decodeURIComponent(i < 0 ? kv : kv.slice(0, i))] = i < 0 ? '' : decodeURIComponent(kv.slice(i + 1));
    });
    return o;
  }

  function compile(gl, vs, fs) {
    function shader(type, src) {
      var s = gl.createShader(type);
      gl.shaderSource(s, src);
      gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error('shader: ' + gl.getShaderInfoLog(s));
      return s;
    }
    var p = gl.createProgram();
    gl.attachShader(p, shader(gl.VERTEX_SHADER, vs));
    gl.attachShader(p, shader(gl.FRAGMENT_SHADER, fs));
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error('link: ' + gl.getProgramInfoLog(p));
    return p;
  }

  var MESH_VS = 'attribute vec3 p;attribute vec3 n;attribute vec3 c;uniform mat4 V;uniform mat4 P;' +
    'varying vec3 vn;varying vec3 vc;void main(){vn=mat3(V)*n;vc=c;gl_Position=P*V*vec4(p,1.0);}';
  var MESH_FS = 'precision mediump float;varying vec3 vn;varying vec3 vc;' +
    'void main(){float d=abs(normalize(vn).z);gl_FragColor=vec4(vc*(0.3+0.7*d),1.0);}';
  var DOT_VS = 'attribute vec3 p;attribute vec3 c;uniform mat4 V;uniform mat4 P;uniform float size;' +
    'varying vec3 vc;void main(){vc=c;vec4 q=P*V*vec4(p,1.0);q.z-=0.004*q.w;gl_Position=q;gl_PointSize=size;}';
  var DOT_FS = 'precision mediump float;varying vec3 vc;void main(){vec2 d=gl_PointCoord-0.5;float r=length(d);' +
    'if(r>0.5)discard;gl_FragColor=vec4(r>0.36?vec3(0.1):vc,1.0);}';

  function Viewer(root, data) {
    var self = this;
    this.root = root;
    this.data = data;
    var opts = hashOptions();
    if (opts.ui === '0') root.classList.add('mgv-noui');
    // size=video: the drawing area exactly the video's pixels, at the page's top left (tests
    // compare it pixel for pixel with the renderer's own image of that frame).
    if (opts.size === 'video' && data.timeline) {
      root.style.width = data.timeline.width + 'px';
      root.style.height = data.timeline.height + 'px';
      root.style.border = '0';
    }
    root.innerHTML = '';
    var stage = el('div', { 'class': 'mgv-stage' }, root);
    var canvas = el('canvas', { 'class': 'mgv-gl' }, stage);
    this.tip = el('div', { 'class': 'mgv-tip' }, stage);
    this.msg = el('div', { 'class': 'mgv-msg' }, stage,
      'drag: orbit · right-drag or shift-drag: pan · wheel or pinch: zoom · double-click: reset');
    this.status = el('pre', { 'class': 'mgv-status' }, root);
    this.canvas = canvas;
    var gl = canvas.getContext('webgl', { antialias: true, preserveDrawingBuffer: true });
    if (!gl) { stage.textContent = 'This browser has no WebGL: the 3D viewer cannot draw.'; this.report(false); return; }
    this.gl = gl;

    // Geometry
    var pos = decode(data.positions, Float32Array), idx = decode(data.indices, Uint32Array);
    this.positions = pos;
    var n = data.vertices;
    if (n > 65535 && !gl.getExtension('OES_element_index_uint')) throw new Error('WebGL lacks 32-bit indices for ' + n + ' vertices');
    this.indexType = n > 65535 ? gl.UNSIGNED_INT : gl.UNSIGNED_SHORT;
    var indices = n > 65535 ? idx : new Uint16Array(idx);
    var normals = new Float32Array(n * 3);
    for (var t = 0; t < idx.length; t += 3) {
      var a = idx[t] * 3, b = idx[t + 1] * 3, c = idx[t + 2] * 3;
      var e1 = [pos[b] - pos[a], pos[b + 1] - pos[a + 1], pos[b + 2] - pos[a + 2]];
      var e2 = [pos[c] - pos[a], pos[c + 1] - pos[a + 1], pos[c + 2] - pos[a + 2]];
      var fn = cross(e1, e2); // length = twice the area: area-weighted normals
      for (var k = 0; k < 3; k++) { normals[a + k] += fn[k]; normals[b + k] += fn[k]; normals[c + k] += fn[k]; }
    }
    var lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
    for (var v = 0; v < n; v++) {
      var l = Math.hypot(normals[3 * v], normals[3 * v + 1], normals[3 * v + 2]) || 1;
      for (k = 0; k < 3; k++) {
        normals[3 * v + k] /= l;
        lo[k] = Math.min(lo[k], pos[3 * v + k]); hi[k] = Math.max(hi[k], pos[3 * v + k]);
      }
    }
    this.center = data.timeline ? data.timeline.center : scale(add(lo, hi), 0.5);
    this.radius = 0.5 * Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) || 1;
    this.count = idx.length;
    this.meshProgram = compile(gl, MESH_VS, MESH_FS);
    this.dotProgram = compile(gl, DOT_VS, DOT_FS);
    this.buffers = {
      p: this.buffer(gl.ARRAY_BUFFER, pos), n: this.buffer(gl.ARRAY_BUFFER, normals),
      c: this.buffer(gl.ARRAY_BUFFER, new Float32Array(n * 3)), i: this.buffer(gl.ELEMENT_ARRAY_BUFFER, indices),
      dp: gl.createBuffer(), dc: gl.createBuffer()
    };

    // Layers: each map and the truth, with its values sorted once for the top-k% threshold.
    this.layers = data.layers.map(function (L) {
      var values = decode(L.values, Float32Array);
      var sorted = Float32Array.from(values).sort();
      return { name: L.name, kind: L.kind, values: values, sorted: sorted, lo: L.lo, hi: L.hi };
    });

    // Fixation dots
    var D = data.dots;
    this.dots = { points: decode(D.points, Float32Array), subject: D.subject, fixation: D.fixation,
      start: D.start_ms, duration: D.duration_ms, vertex: D.vertex, fate: D.fate };
    this.subjectOn = data.subjects.map(function () { return true; });
    this.fateOn = {};
    D.fate.forEach(function (f) { self.fateOn[f] = true; });
    this.showDots = D.fate.length > 0;

    // Timeline
    var T = data.timeline;
    if (T) {
      this.matrices = decode(T.matrices, Float32Array);
      this.phases = decode(T.phases, Uint32Array);
      this.duration = T.frames / T.fps;
    }

    this.layer = this.layers.length ? 0 : -1;
    if (opts.map !== undefined) {
      var byName = -2;
      this.layers.forEach(function (L, i) { if (L.name === opts.map || L.name.split(' ')[0] === opts.map) byName = i; });
      if (opts.map === 'plain') byName = -1;
      else if (byName === -2 && /^\d+$/.test(opts.map) && +opts.map < this.layers.length) byName = +opts.map;
      if (byName === -2) errors.push('no map named ' + opts.map);
      else this.layer = byName;
    }
    this.topPercent = opts.k ? Math.min(100, Math.max(1, +opts.k)) : 100;
    this.replay = false;
    this.time = 0;
    this.buildPanel(root);
    this.resetCamera();
    if (opts.view !== undefined && T) this.holdView(+opts.view);
    if (opts.t !== undefined && T) this.setTime(+opts.t, true);
    if (opts.dots === '0') this.showDots = false;
    // press=i clicks hold-view button i as a user would (scripted checks of the page).
    if (opts.press !== undefined && this.viewButtons && this.viewButtons[+opts.press]) this.viewButtons[+opts.press].click();
    this.recolor();
    this.redots();
    this.bindInput(stage);
    var resize = function () { self.resize(); };
    window.addEventListener('resize', resize);
    this.resize();
    // Until the first frame is drawn (on the next animation frame) the status says so, so a
    // page read before it tells "not drawn yet" from "the script did not run".
    if (this.pending) this.report(false);
  }

  Viewer.prototype.buffer = function (target, array) {
    var gl = this.gl, b = gl.createBuffer();
    gl.bindBuffer(target, b);
    gl.bufferData(target, array, gl.STATIC_DRAW);
    return b;
  };

  Viewer.prototype.buildPanel = function (root) {
    var self = this, d = this.data;
    var panel = el('div', { 'class': 'mgv-panel' }, root);
    el('h3', {}, panel, d.title);
    el('div', { 'class': 'mgv-small' }, panel, d.vertices.toLocaleString() + ' vertices, ' +
      d.triangles.toLocaleString() + ' triangles');
    if (d.decimated_from) {
      el('div', { 'class': 'mgv-note' }, panel, 'Shown simplified: ' + d.vertices.toLocaleString() +
        ' of the mesh\u2019s ' + d.decimated_from.toLocaleString() + ' vertices, each with its own value; ' +
        'scores and static renders use the full mesh.');
    }
    var colour = el('fieldset', {}, panel);
    el('legend', {}, colour, 'Colour');
    var select = el('select', { 'class': 'mgv-layer', 'aria-label': 'colour the surface by' }, colour);
    el('option', { value: '-1' }, select, 'plain');
    this.layers.forEach(function (L, i) { el('option', { value: String(i) }, select, L.name); });
    select.value = String(this.layer);
    select.addEventListener('change', function () { self.setLayer(+select.value); });
    this.select = select;
    var legend = el('div', { 'class': 'mgv-legend' }, colour);
    this.legendLo = el('span', {}, legend);
    var bar = el('canvas', { width: '128', height: '1' }, legend);
    this.legendHi = el('span', {}, legend);
    var ctx = bar.getContext('2d'), img = ctx.createImageData(128, 1);
    for (var i = 0; i < 128; i++) {
      var c = ramp(i / 127);
      img.data[4 * i] = c[0] * 255; img.data[4 * i + 1] = c[1] * 255; img.data[4 * i + 2] = c[2] * 255; img.data[4 * i + 3] = 255;
    }
    ctx.putImageData(img, 0, 0);
    this.legend = legend;
    this.rule = el('div', { 'class': 'mgv-small' }, colour, d.rule);
    var kLabel = el('label', {}, colour, 'Show the top ');
    this.kValue = el('span', {}, kLabel, this.topPercent + '%');
    var k = el('input', { type: 'range', min: '1', max: '100', step: '1', value: String(this.topPercent), 'class': 'mgv-k' }, colour);
    k.addEventListener('input', function () { self.topPercent = +k.value; self.kValue.textContent = k.value + '%'; self.recolor(); });

    var fix = el('fieldset', {}, panel);
    el('legend', {}, fix, 'Fixations');
    if (!d.dots.fate.length) el('div', { 'class': 'mgv-small' }, fix, 'none given');
    else {
      var all = el('label', {}, fix);
      var allBox = el('input', { type: 'checkbox' }, all);
      allBox.checked = this.showDots;
      all.appendChild(document.createTextNode(' show ' + d.dots.fate.length + ' on the surface'));
      allBox.addEventListener('change', function () { self.showDots = allBox.checked; self.redots(); });
      d.subjects.forEach(function (s, i) {
        var lab = el('label', {}, fix), box = el('input', { type: 'checkbox' }, lab);
        box.checked = true;
        var sw = el('span', { 'class': 'mgv-swatch' }, lab), c = SUBJECT_COLORS[i % SUBJECT_COLORS.length];
        sw.style.background = 'rgb(' + c.join(',') + ')';
        var count = d.dots.subject.filter(function (x) { return x === i; }).length;
        lab.appendChild(document.createTextNode(s + ' (' + count + ')'));
        box.addEventListener('change', function () { self.subjectOn[i] = box.checked; self.redots(); });
      });
      Object.keys(this.fateOn).sort().forEach(function (f) {
        var lab = el('label', {}, fix), box = el('input', { type: 'checkbox' }, lab);
        box.checked = true;
        lab.appendChild(document.createTextNode(' ' + f));
        box.addEventListener('change', function () { self.fateOn[f] = box.checked; self.redots(); });
      });
    }
    var missed = Object.keys(d.not_on_mesh);
    if (missed.length) {
      el('div', { 'class': 'mgv-small' }, fix, 'Not on the surface (no dot): ' +
        missed.map(function (f) { return d.not_on_mesh[f] + ' ' + f; }).join(', '));
    }
    this.dotCount = el('div', { 'class': 'mgv-small' }, fix);

    var T = d.timeline;
    if (T) {
      var views = el('fieldset', {}, panel);
      el('legend', {}, views, 'What the subjects saw');
      this.viewButtons = T.holds.map(function (h, i) {
        var b = el('button', { type: 'button', 'class': 'mgv-view', title: 'hold view ' + (h.viewpoint + 1) +
          ', video frame ' + h.frame }, views, String(h.viewpoint + 1));
        b.addEventListener('click', function () { self.holdView(i); });
        return b;
      });
      var tl = el('label', {}, views, 'Time ');
      this.timeText = el('span', {}, tl, '0.0 s');
      var slider = el('input', { type: 'range', min: '0', max: String(T.frames - 1), step: '1', value: '0', 'class': 'mgv-time' }, views);
      slider.addEventListener('input', function () { self.setTime(+slider.value / T.fps, true); });
      this.slider = slider;
      var play = el('button', { type: 'button' }, views, 'play');
      play.addEventListener('click', function () { self.togglePlay(play); });
      var live = el('button', { type: 'button' }, views, 'all fixations');
      live.addEventListener('click', function () { self.replay = false; self.redots(); self.draw(); });
      el('div', { 'class': 'mgv-small' }, views, 'The views and replay use the video\u2019s own cameras ' +
        '(its timeline); during replay only the fixations made at that moment are shown.');
    }
    var reset = el('button', { type: 'button' }, panel, 'reset view');
    reset.addEventListener('click', function () { self.resetCamera(); self.draw(); });
    el('div', { 'class': 'mgv-small' }, panel, 'meshgaze ' + d.version);
  };

  Viewer.prototype.setLayer = function (i) { this.layer = i; this.select.value = String(i); this.recolor(); };

  Viewer.prototype.recolor = function () {
    var n = this.data.vertices, colors = new Float32Array(n * 3), L = this.layers[this.layer];
    if (!L) {
      colors.fill(PLAIN);
      this.legend.style.visibility = 'hidden';
      this.rule.style.visibility = 'hidden';
    } else {
      var cut = -Infinity;
      if (this.topPercent < 100) {
        var s = L.sorted, at = Math.min(s.length - 1, Math.max(0, Math.round((s.length - 1) * (1 - this.topPercent / 100))));
        cut = s[at];
      }
      var span = L.hi - L.lo;
      for (var v = 0; v < n; v++) {
        var x = L.values[v];
        var c = x < cut ? [BELOW, BELOW, BELOW] : ramp(span > 0 ? (x - L.lo) / span : 0);
        colors[3 * v] = c[0]; colors[3 * v + 1] = c[1]; colors[3 * v + 2] = c[2];
      }
      this.legend.style.visibility = '';
      this.rule.style.visibility = '';
      this.legendLo.textContent = L.lo.toPrecision(3);
      this.legendHi.textContent = L.hi.toPrecision(3);
    }
    var gl = this.gl;
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buffers.c);
    gl.bufferData(gl.ARRAY_BUFFER, colors, gl.STATIC_DRAW);
    this.draw();
  };

  Viewer.prototype.visibleDots = function () {
    var D = this.dots, out = [], t = this.time * 1000;
    if (!this.showDots) return out;
    for (var i = 0; i < D.fate.length; i++) {
      if (!this.subjectOn[D.subject[i]] || !this.fateOn[D.fate[i]]) continue;
      if (this.replay && !(D.start[i] <= t && t < D.start[i] + D.duration[i])) continue;
      out.push(i);
    }
    return out;
  };

  Viewer.prototype.redots = function () {
    var shown = this.visibleDots(), D = this.dots;
    var p = new Float32Array(shown.length * 3), c = new Float32Array(shown.length * 3);
    shown.forEach(function (i, j) {
      var col = SUBJECT_COLORS[D.subject[i] % SUBJECT_COLORS.length];
      for (var k = 0; k < 3; k++) { p[3 * j + k] = D.points[3 * i + k]; c[3 * j + k] = col[k] / 255; }
    });
    var gl = this.gl;
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buffers.dp); gl.bufferData(gl.ARRAY_BUFFER, p, gl.DYNAMIC_DRAW);
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buffers.dc); gl.bufferData(gl.ARRAY_BUFFER, c, gl.DYNAMIC_DRAW);
    this.shownDots = shown;
    if (this.dotCount) this.dotCount.textContent = shown.length + ' dots shown' + (this.replay ? ' at ' + this.time.toFixed(2) + ' s' : '');
    this.draw();
  };

  Viewer.prototype.resetCamera = function () {
    if (this.data.timeline) { this.holdView(0); return; }
    var up = [0, 1, 0];
    this.cam = { mode: 'orbit', target: this.center.slice(), eye: add(this.center, [0, 0, 3 * this.radius]), up: up, fovy: 30 * Math.PI / 180 };
    this.markViews(-1);
  };

  Viewer.prototype.frameMatrices = function (f) {
    var m = this.matrices;
    return { V: m.subarray(32 * f, 32 * f + 16), P: m.subarray(32 * f + 16, 32 * f + 32) };
  };

  Viewer.prototype.holdView = function (i) {
    var T = this.data.timeline;
    if (!T || !T.holds.length) return;
    i = Math.max(0, Math.min(T.holds.length - 1, i | 0));
    this.replay = false;
    this.cam = { mode: 'frame', frame: T.holds[i].frame };
    this.time = T.holds[i].frame / T.fps;
    if (this.slider) this.slider.value = String(T.holds[i].frame);
    this.markViews(i);
    this.redots();
  };

  Viewer.prototype.markViews = function (i) {
    (this.viewButtons || []).forEach(function (b, j) { b.classList.toggle('mgv-on', j === i); });
    this.view = i;
  };

  Viewer.prototype.setTime = function (t, replay) {
    var T = this.data.timeline;
    var f = Math.max(0, Math.min(T.frames - 1, Math.floor(t * T.fps + 1e-9)));
    this.time = f / T.fps;
    this.cam = { mode: 'frame', frame: f };
    this.replay = !!replay;
    if (this.slider) this.slider.value = String(f);
    if (this.timeText) this.timeText.textContent = this.time.toFixed(1) + ' s (' + (this.phases[f] ? 'move' : 'hold') + ')';
    this.markViews(-1);
    this.redots();
  };

  Viewer.prototype.togglePlay = function (button) {
    var self = this, T = this.data.timeline;
    if (this.playing) { this.playing = false; button.textContent = 'play'; return; }
    this.playing = true;
    button.textContent = 'pause';
    var start = performance.now() - this.time * 1000;
    function step(now) {
      if (!self.playing) return;
      var t = (now - start) / 1000;
      if (t >= self.duration) { self.playing = false; button.textContent = 'play'; return; }
      self.setTime(t, true);
      requestAnimationFrame(step);
    }
    requestAnimationFrame(step);
  };

  // A frame camera becomes an orbit camera at the same pose when the user takes over.
  Viewer.prototype.toOrbit = function () {
    if (this.cam.mode === 'orbit') return;
    var M = this.frameMatrices(this.cam.frame), V = M.V, P = M.P;
    var right = [V[0], V[4], V[8]], up = [V[1], V[5], V[9]], back = [V[2], V[6], V[10]];
    var t = [V[12], V[13], V[14]];
    var eye = scale(add(add(scale(right, t[0]), scale(up, t[1])), scale(back, t[2])), -1);
    this.cam = { mode: 'orbit', target: this.center.slice(), eye: eye, up: up, fovy: 2 * Math.atan(1 / P[5]) };
    this.replay = false;
    this.markViews(-1);
    this.redots();
  };

  Viewer.prototype.orbit = function (dx, dy) {
    this.toOrbit();
    var c = this.cam, off = sub(c.eye, c.target);
    var right = norm(cross(c.up, off));
    off = rotate(off, c.up, -dx * 0.008);
    var right2 = norm(cross(c.up, off));
    off = rotate(off, right2, -dy * 0.008);
    c.up = norm(cross(off, right2));
    if (!isFinite(c.up[0])) c.up = right;
    c.eye = add(c.target, off);
  };

  Viewer.prototype.pan = function (dx, dy) {
    this.toOrbit();
    var c = this.cam, off = sub(c.eye, c.target), dist = Math.sqrt(dot(off, off));
    var right = norm(cross(c.up, off)), h = this.canvas.clientHeight || 1;
    var s = 2 * dist * Math.tan(c.fovy / 2) / h;
    var move = add(scale(right, -dx * s), scale(c.up, dy * s));
    c.eye = add(c.eye, move); c.target = add(c.target, move);
  };

  Viewer.prototype.zoom = function (factor) {
    this.toOrbit();
    var c = this.cam, off = sub(c.eye, c.target), dist = Math.sqrt(dot(off, off));
    var next = Math.min(50 * this.radius, Math.max(0.05 * this.radius, dist * factor));
    c.eye = add(c.target, scale(off, next / dist));
  };

  Viewer.prototype.bindInput = function (stage) {
    var self = this, canvas = this.canvas, last = null, mode = null, touches = {};
    canvas.addEventListener('contextmenu', function (e) { e.preventDefault(); });
    canvas.addEventListener('pointerdown', function (e) {
      canvas.setPointerCapture(e.pointerId);
      touches[e.pointerId] = [e.clientX, e.clientY];
      last = [e.clientX, e.clientY];
      mode = (e.button === 2 || e.shiftKey) ? 'pan' : 'orbit';
      self.tip.style.display = 'none';
    });
    canvas.addEventListener('pointermove', function (e) {
      var ids = Object.keys(touches);
      if (!ids.length) { self.hover(e); return; }
      if (ids.length === 2 && touches[e.pointerId]) { // pinch: zoom and pan
        var other = touches[ids[0] == e.pointerId ? ids[1] : ids[0]], prev = touches[e.pointerId];
        var d0 = Math.hypot(prev[0] - other[0], prev[1] - other[1]);
        var d1 = Math.hypot(e.clientX - other[0], e.clientY - other[1]);
        if (d0 > 0 && d1 > 0) self.zoom(d0 / d1);
        self.pan((e.clientX - prev[0]) / 2, (e.clientY - prev[1]) / 2);
        touches[e.pointerId] = [e.clientX, e.clientY];
        self.draw();
        return;
      }
      if (!last) return;
      var dx = e.clientX - last[0], dy = e.clientY - last[1];
      last = [e.clientX, e.clientY];
      touches[e.pointerId] = last;
      if (mode === 'pan') self.pan(dx, dy); else self.orbit(dx, dy);
      self.draw();
    });
    function up(e) { delete touches[e.pointerId]; if (!Object.keys(touches).length) last = null; }
    canvas.addEventListener('pointerup', up);
    canvas.addEventListener('pointercancel', up);
    canvas.addEventListener('pointerleave', function () { self.tip.style.display = 'none'; });
    canvas.addEventListener('wheel', function (e) {
      e.preventDefault();
      self.zoom(Math.exp(e.deltaY * 0.0015));
      self.draw();
    }, { passive: false });
    canvas.addEventListener('dblclick', function () { self.resetCamera(); self.draw(); });
  };

  Viewer.prototype.hover = function (e) {
    var rect = this.canvas.getBoundingClientRect(), x = e.clientX - rect.left, y = e.clientY - rect.top;
    var best = -1, bestDepth = Infinity, M = this.current, D = this.dots;
    if (!M || !this.shownDots) return;
    var VP = mul(M.P, M.V), vp = M.viewport, dpr = window.devicePixelRatio || 1;
    for (var j = 0; j < this.shownDots.length; j++) {
      var i = this.shownDots[j], p = [D.points[3 * i], D.points[3 * i + 1], D.points[3 * i + 2]];
      var cx = VP[0] * p[0] + VP[4] * p[1] + VP[8] * p[2] + VP[12];
      var cy = VP[1] * p[0] + VP[5] * p[1] + VP[9] * p[2] + VP[13];
      var cz = VP[2] * p[0] + VP[6] * p[1] + VP[10] * p[2] + VP[14];
      var cw = VP[3] * p[0] + VP[7] * p[1] + VP[11] * p[2] + VP[15];
      if (cw <= 0) continue;
      var sx = (vp[0] + (cx / cw + 1) / 2 * vp[2]) / dpr, sy = (this.canvas.height - vp[1] - (cy / cw + 1) / 2 * vp[3]) / dpr;
      var r = Math.hypot(sx - x, sy - y);
      if (r < 9 && cz / cw < bestDepth) { best = i; bestDepth = cz / cw; }
    }
    if (best < 0) { this.tip.style.display = 'none'; return; }
    var vertex = D.vertex[best];
    this.tip.textContent = this.data.subjects[D.subject[best]] + ' · fixation ' + D.fixation[best] + ' · ' +
      Math.round(D.start[best]) + ' ms, ' + Math.round(D.duration[best]) + ' ms long · vertex ' +
      (vertex === null ? '\u2013' : vertex) + ' · ' + D.fate[best];
    this.tip.style.display = 'block';
    this.tip.style.left = Math.min(x + 12, rect.width - 10) + 'px';
    this.tip.style.top = (y + 12) + 'px';
  };

  Viewer.prototype.resize = function () {
    var dpr = window.devicePixelRatio || 1, c = this.canvas;
    var w = Math.max(1, Math.round(c.clientWidth * dpr)), h = Math.max(1, Math.round(c.clientHeight * dpr));
    if (c.width !== w || c.height !== h) { c.width = w; c.height = h; }
    this.draw();
  };

  Viewer.prototype.draw = function () {
    var self = this;
    if (this.pending || !this.gl) return;
    this.pending = true;
    requestAnimationFrame(function () { self.pending = false; self.render(); });
  };

  Viewer.prototype.render = function () {
    var gl = this.gl, c = this.canvas, V, P, viewport;
    if (this.cam.mode === 'frame') {
      // The video's own camera, in a viewport of the video's shape (letterboxed).
      var T = this.data.timeline, M = this.frameMatrices(this.cam.frame), a = T.width / T.height;
      var w = c.width, h = c.height;
      if (w / h > a) w = Math.round(h * a); else h = Math.round(w / a);
      viewport = [Math.floor((c.width - w) / 2), Math.floor((c.height - h) / 2), w, h];
      V = M.V; P = M.P;
    } else {
      var cam = this.cam, dist = Math.sqrt(dot(sub(cam.eye, cam.target), sub(cam.eye, cam.target)));
      viewport = [0, 0, c.width, c.height];
      V = lookAt(cam.eye, cam.target, cam.up);
      P = perspective(cam.fovy, c.width / c.height, Math.max(dist - 2 * this.radius, dist * 0.01), dist + 2 * this.radius);
    }
    this.current = { V: V, P: P, viewport: viewport };
    gl.viewport(0, 0, c.width, c.height);
    gl.clearColor(BACKGROUND[0] / 255, BACKGROUND[1] / 255, BACKGROUND[2] / 255, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.viewport(viewport[0], viewport[1], viewport[2], viewport[3]);
    gl.enable(gl.DEPTH_TEST);
    var p = this.meshProgram;
    gl.useProgram(p);
    this.attribute(p, 'p', this.buffers.p);
    this.attribute(p, 'n', this.buffers.n);
    this.attribute(p, 'c', this.buffers.c);
    gl.uniformMatrix4fv(gl.getUniformLocation(p, 'V'), false, V);
    gl.uniformMatrix4fv(gl.getUniformLocation(p, 'P'), false, P);
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, this.buffers.i);
    gl.drawElements(gl.TRIANGLES, this.count, this.indexType, 0);
    this.disable(p, ['p', 'n', 'c']);
    if (this.shownDots && this.shownDots.length) {
      var q = this.dotProgram;
      gl.useProgram(q);
      this.attribute(q, 'p', this.buffers.dp);
      this.attribute(q, 'c', this.buffers.dc);
      gl.uniformMatrix4fv(gl.getUniformLocation(q, 'V'), false, V);
      gl.uniformMatrix4fv(gl.getUniformLocation(q, 'P'), false, P);
      gl.uniform1f(gl.getUniformLocation(q, 'size'), 7 * (window.devicePixelRatio || 1));
      gl.drawArrays(gl.POINTS, 0, this.shownDots.length);
      this.disable(q, ['p', 'c']);
    }
    this.report(true);
  };

  Viewer.prototype.attribute = function (program, name, buffer) {
    var gl = this.gl, loc = gl.getAttribLocation(program, name);
    if (loc < 0) return;
    gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
    gl.enableVertexAttribArray(loc);
    gl.vertexAttribPointer(loc, 3, gl.FLOAT, false, 0, 0);
  };

  Viewer.prototype.disable = function (program, names) {
    var gl = this.gl;
    names.forEach(function (n) { var l = gl.getAttribLocation(program, n); if (l >= 0) gl.disableVertexAttribArray(l); });
  };

  // For tests and scripts: the state as JSON in a hidden element.
  Viewer.prototype.report = function (drawn) {
    var L = this.layers && this.layers[this.layer];
    this.status.textContent = JSON.stringify({
      ready: true, drawn: drawn, errors: errors.slice(), layer: L ? L.name : 'plain',
      mode: this.cam ? this.cam.mode : null, frame: this.cam && this.cam.mode === 'frame' ? this.cam.frame : null,
      view: this.view, dots: this.shownDots ? this.shownDots.length : 0,
      canvas: this.canvas ? [this.canvas.width, this.canvas.height] : null,
      viewport: this.current ? this.current.viewport : null, top_percent: this.topPercent
    });
  };

  function start() {
    var roots = document.querySelectorAll('.mgv:not([data-mgv-ready])');
    Array.prototype.forEach.call(roots, function (root) {
      root.setAttribute('data-mgv-ready', '1');
      var node = root.nextElementSibling;
      if (!node || !node.classList.contains('mgv-data')) return;
      try {
        new Viewer(root, JSON.parse(node.textContent));
      } catch (e) {
        errors.push(String(e && e.stack || e));
        root.textContent = 'The 3D viewer failed: ' + e;
        var status = document.createElement('pre');
        status.className = 'mgv-status';
        status.textContent = JSON.stringify({ ready: false, errors: errors.slice() });
        root.appendChild(status);
      }
    });
  }
  if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', start); else start();
})();
