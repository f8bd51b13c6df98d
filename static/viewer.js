// The 3D walkthrough: the scene's shading mesh drawn with WebGL2, coloured per vertex from
// per-patch radiosity (or illuminance in false colour) fetched from the server.
//
// The mesh comes once from GET /api/scenes/{id}/mesh (layout in the OpenAPI spec). A vertex
// value is Σ weight · value[patch] over the vertex's patches, exactly as the server's
// renderer shades, so both views agree. Picking casts a ray against the triangles on the
// CPU, for this view and for the server image (same camera model).

/** Parses the RLMESH01 buffer. */
export function parseMesh(buf) {
  const magic = new TextDecoder().decode(new Uint8Array(buf, 0, 8));
  if (magic !== "RLMESH01") throw new Error("the server sent an unknown mesh format");
  const dv = new DataView(buf);
  const nv = dv.getUint32(8, true), nt = dv.getUint32(12, true), nw = dv.getUint32(16, true);
  let off = 20;
  const take = (Type, n) => {
    const a = new Type(buf, off, n);
    off += 4 * n;
    return a;
  };
  const m = {
    nv, nt, nw,
    pos: take(Float32Array, 3 * nv),
    tri: take(Uint32Array, 3 * nt),
    surface: take(Uint32Array, nt),
    start: take(Uint32Array, nv + 1),
    patch: take(Uint32Array, nw),
    weight: take(Float32Array, nw),
  };
  // Bounds, for clip planes and walking speed.
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < nv; i++) {
    for (let c = 0; c < 3; c++) {
      lo[c] = Math.min(lo[c], m.pos[3 * i + c]);
      hi[c] = Math.max(hi[c], m.pos[3 * i + c]);
    }
  }
  m.diag = Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) || 1;
  m.center = lo.map((v, c) => (v + hi[c]) / 2);
  return m;
}

/** Per-vertex RGB (Float32Array 3·nv) from per-patch RGB values (3·nt). */
export function vertexValues(m, perPatch) {
  const out = new Float32Array(3 * m.nv);
  for (let v = 0; v < m.nv; v++) {
    let r = 0, g = 0, b = 0;
    for (let k = m.start[v]; k < m.start[v + 1]; k++) {
      const p = 3 * m.patch[k], w = m.weight[k];
      r += w * perPatch[p];
      g += w * perPatch[p + 1];
      b += w * perPatch[p + 2];
    }
    out[3 * v] = r;
    out[3 * v + 1] = g;
    out[3 * v + 2] = b;
  }
  return out;
}

// ------------------------------------------------------------------- camera maths

const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => scale(a, 1 / (Math.hypot(a[0], a[1], a[2]) || 1));

/** A free camera: position, yaw/pitch (radians), vertical fov (degrees), orbit distance. */
export function cameraFromLookAt(position, target, fovDeg) {
  const d = sub(target, position);
  const dist = Math.hypot(d[0], d[1], d[2]) || 1;
  const n = scale(d, 1 / dist);
  return {
    pos: [...position],
    yaw: Math.atan2(n[0], n[2]),
    pitch: Math.asin(Math.max(-1, Math.min(1, n[1]))),
    fov: fovDeg,
    dist,
  };
}

export function forward(cam) {
  const cp = Math.cos(cam.pitch);
  return [cp * Math.sin(cam.yaw), Math.sin(cam.pitch), cp * Math.cos(cam.yaw)];
}

export function target(cam) {
  return add(cam.pos, scale(forward(cam), cam.dist));
}

/** Orthonormal basis (right, up, forward) of a camera with world up +Y. */
function basis(cam) {
  const f = forward(cam);
  let r = cross(f, [0, 1, 0]);
  if (Math.hypot(...r) < 1e-6) r = [1, 0, 0];
  r = norm(r);
  const u = cross(r, f);
  return [r, u, f];
}

/** Column-major view-projection matrix. */
function viewProj(cam, aspect, near, far) {
  const [r, u, f] = basis(cam);
  const t = 1 / Math.tan((cam.fov * Math.PI) / 360);
  const p = cam.pos;
  // View: rows r, u, -f; projection: standard GL perspective.
  const a = (far + near) / (near - far), b = (2 * far * near) / (near - far);
  const view = [
    [r[0], r[1], r[2], -dot(r, p)],
    [u[0], u[1], u[2], -dot(u, p)],
    [-f[0], -f[1], -f[2], dot(f, p)],
  ];
  const rows = [
    view[0].map((x) => x * (t / aspect)),
    view[1].map((x) => x * t),
    view[2].map((x, i) => x * a + (i === 3 ? b : 0)),
    view[2].map((x) => -x),
  ];
  const m = new Float32Array(16);
  for (let row = 0; row < 4; row++) for (let col = 0; col < 4; col++) m[col * 4 + row] = rows[row][col];
  return m;
}

/** The ray through (x, y) in [-1, 1]² (y up) of a camera with this aspect: {o, d}. */
export function rayThrough(cam, aspect, x, y) {
  const [r, u, f] = basis(cam);
  const t = Math.tan((cam.fov * Math.PI) / 360);
  return { o: cam.pos, d: norm(add(f, add(scale(r, x * t * aspect), scale(u, y * t)))) };
}

/**
 * The patch hit by the ray through (x, y) in [-1, 1]² (y up) of a camera with this aspect;
 * null when the ray hits nothing. Only lit (front) sides count, like in the images.
 */
export function pick(m, cam, aspect, x, y) {
  const [r, u, f] = basis(cam);
  const t = Math.tan((cam.fov * Math.PI) / 360);
  const d = norm(add(f, add(scale(r, x * t * aspect), scale(u, y * t))));
  const o = cam.pos, P = m.pos, T = m.tri;
  let best = Infinity, hit = -1;
  for (let i = 0; i < m.nt; i++) {
    const a = 3 * T[3 * i], b = 3 * T[3 * i + 1], c = 3 * T[3 * i + 2];
    const e1x = P[b] - P[a], e1y = P[b + 1] - P[a + 1], e1z = P[b + 2] - P[a + 2];
    const e2x = P[c] - P[a], e2y = P[c + 1] - P[a + 1], e2z = P[c + 2] - P[a + 2];
    // Front faces only: the normal e1 × e2 must face the ray.
    const nx = e1y * e2z - e1z * e2y, ny = e1z * e2x - e1x * e2z, nz = e1x * e2y - e1y * e2x;
    if (nx * d[0] + ny * d[1] + nz * d[2] >= 0) continue;
    const px = d[1] * e2z - d[2] * e2y, py = d[2] * e2x - d[0] * e2z, pz = d[0] * e2y - d[1] * e2x;
    const det = e1x * px + e1y * py + e1z * pz;
    const inv = 1 / det;
    const sx = o[0] - P[a], sy = o[1] - P[a + 1], sz = o[2] - P[a + 2];
    const bu = (sx * px + sy * py + sz * pz) * inv;
    if (bu < 0 || bu > 1) continue;
    const qx = sy * e1z - sz * e1y, qy = sz * e1x - sx * e1z, qz = sx * e1y - sy * e1x;
    const bv = (d[0] * qx + d[1] * qy + d[2] * qz) * inv;
    if (bv < 0 || bu + bv > 1) continue;
    const dist = (e2x * qx + e2y * qy + e2z * qz) * inv;
    if (dist > 1e-6 && dist < best) {
      best = dist;
      hit = i;
    }
  }
  return hit < 0 ? null : { patch: hit, surface: m.surface[hit], point: add(o, scale(d, best)) };
}

// ------------------------------------------------------------------- drawing

/** Moving frames aim at this interval (ms), rendering fewer pixels when they miss it. */
const TARGET_FRAME_MS = 33;
/** Smallest fraction of the full resolution (per axis) a moving frame renders. */
const MIN_RES_SCALE = 0.3;
/** A camera that has not moved for this long (ms) is still: the view is redrawn sharp. */
const STILL_MS = 200;

const VS = `#version 300 es
in vec3 a_pos;
in vec3 a_val;
uniform mat4 u_vp;
out vec3 v_val;
void main() { v_val = a_val; gl_Position = u_vp * vec4(a_pos, 1.0); }`;

// Shaded: radiance B/π × 2^exposure, ACES filmic, sRGB (as the server's images).
// False colour: the server's log-lux scale of illuminance.
const FS = `#version 300 es
precision highp float;
in vec3 v_val;
uniform int u_mode;
uniform float u_k;
uniform vec2 u_log;
out vec4 o;
vec3 aces(vec3 x) { return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0); }
vec3 srgb(vec3 x) { return mix(12.92 * x, 1.055 * pow(x, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, x)); }
vec3 scale(float t) {
  vec3 s[6] = vec3[6](vec3(0.05, 0.05, 0.35), vec3(0.0, 0.35, 0.9), vec3(0.0, 0.75, 0.55),
                      vec3(0.55, 0.85, 0.1), vec3(1.0, 0.8, 0.0), vec3(0.85, 0.1, 0.05));
  float x = clamp(t, 0.0, 1.0) * 5.0;
  int i = min(int(floor(x)), 4);
  return mix(s[i], s[i + 1], x - float(i));
}
void main() {
  if (u_mode == 1) {
    float y = dot(v_val, vec3(0.2126, 0.7152, 0.0722));
    float t = y > 0.0 ? (log(y) / log(10.0) - u_log.x) / (u_log.y - u_log.x) : 0.0;
    o = vec4(scale(t), 1.0);
  } else {
    o = vec4(srgb(aces(max(v_val * u_k, 0.0))), 1.0);
  }
}`;

export class Viewer {
  constructor(canvas) {
    this.canvas = canvas;
    const gl = canvas.getContext("webgl2", { antialias: true, preserveDrawingBuffer: true });
    if (!gl) throw new Error("this browser has no WebGL2");
    this.gl = gl;
    const sh = (type, src) => {
      const s = gl.createShader(type);
      gl.shaderSource(s, src);
      gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
      return s;
    };
    const prog = gl.createProgram();
    gl.attachShader(prog, sh(gl.VERTEX_SHADER, VS));
    gl.attachShader(prog, sh(gl.FRAGMENT_SHADER, FS));
    gl.linkProgram(prog);
    if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(prog));
    this.prog = prog;
    this.u = Object.fromEntries(["u_vp", "u_mode", "u_k", "u_log"].map((n) => [n, gl.getUniformLocation(prog, n)]));
    this.mesh = null;
    this.cam = null;
    this.mode = 0;
    this.exposure = 0;
    this.logRange = [0, 1];
    this.pending = false;
    this.onchange = null; // called after the camera moves
    // Adaptive resolution while the camera moves: large meshes in software WebGL draw
    // slowly, so moving frames render fewer pixels (down to MIN_RES_SCALE of the full
    // resolution) to keep about TARGET_FRAME_MS; the view is redrawn sharp once it
    // stays still for STILL_MS.
    this.motion = false;
    this.resScale = 1;
    this.lastDraw = null;
    this.stillTimer = null;
  }

  /** Marks the camera as moving; a sharp frame follows once it stops. */
  moving() {
    this.motion = true;
    clearTimeout(this.stillTimer);
    this.stillTimer = setTimeout(() => {
      this.motion = false;
      this.lastDraw = null;
      this.redraw();
    }, STILL_MS);
  }

  /** Adapts the moving-frame resolution to the interval since the last moving frame. */
  adaptResolution(now) {
    if (this.lastDraw !== null) {
      const dt = now - this.lastDraw;
      if (dt > 1.25 * TARGET_FRAME_MS) this.resScale = Math.max(MIN_RES_SCALE, this.resScale * 0.85);
      else if (dt < 0.6 * TARGET_FRAME_MS) this.resScale = Math.min(1, this.resScale * 1.1);
    }
    this.lastDraw = now;
  }

  /** The mesh to draw, and optionally its coarser preview (drawn while the camera moves;
   *  see GET /api/scenes/{id}/mesh/preview). */
  setMesh(m, preview = null) {
    const gl = this.gl;
    for (const d of [this.full, this.previewDraw]) {
      if (!d) continue;
      gl.deleteVertexArray(d.vao);
      for (const b of d.buffers) gl.deleteBuffer(b);
    }
    this.full = this.upload(m);
    this.previewDraw = preview ? this.upload(preview) : null;
    this.mesh = m;
    this.preview = preview;
  }

  /** A vertex array for mesh `m`: positions, per-vertex values (updated later), indices. */
  upload(m) {
    const gl = this.gl;
    const vao = gl.createVertexArray();
    gl.bindVertexArray(vao);
    const pos = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, pos);
    gl.bufferData(gl.ARRAY_BUFFER, m.pos, gl.STATIC_DRAW);
    const lp = gl.getAttribLocation(this.prog, "a_pos");
    gl.enableVertexAttribArray(lp);
    gl.vertexAttribPointer(lp, 3, gl.FLOAT, false, 0, 0);
    const val = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, val);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array(3 * m.nv), gl.DYNAMIC_DRAW);
    const lv = gl.getAttribLocation(this.prog, "a_val");
    gl.enableVertexAttribArray(lv);
    gl.vertexAttribPointer(lv, 3, gl.FLOAT, false, 0, 0);
    const idx = gl.createBuffer();
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, idx);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, m.tri, gl.STATIC_DRAW);
    gl.bindVertexArray(null);
    return { vao, val, buffers: [pos, val, idx], count: 3 * m.nt };
  }

  /** New per-vertex values (radiosity lm/m², or illuminance lx in false colour) of the
   *  mesh, and of the preview when there is one. */
  setValues(values, previewValues = null) {
    const gl = this.gl;
    gl.bindBuffer(gl.ARRAY_BUFFER, this.full.val);
    gl.bufferSubData(gl.ARRAY_BUFFER, 0, values);
    if (this.previewDraw && previewValues) {
      gl.bindBuffer(gl.ARRAY_BUFFER, this.previewDraw.val);
      gl.bufferSubData(gl.ARRAY_BUFFER, 0, previewValues);
    }
    this.redraw();
  }

  redraw() {
    if (this.pending) return;
    this.pending = true;
    requestAnimationFrame(() => {
      this.pending = false;
      this.draw();
    });
  }

  draw() {
    const gl = this.gl, c = this.canvas;
    let dpr = window.devicePixelRatio || 1;
    if (this.motion) {
      this.adaptResolution(performance.now());
      dpr *= this.resScale;
    }
    const w = Math.max(1, Math.round(c.clientWidth * dpr)), h = Math.max(1, Math.round(c.clientHeight * dpr));
    if (c.width !== w || c.height !== h) {
      c.width = w;
      c.height = h;
    }
    gl.viewport(0, 0, w, h);
    gl.clearColor(0.08, 0.08, 0.09, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    if (!this.mesh || !this.cam) return;
    gl.enable(gl.DEPTH_TEST);
    gl.enable(gl.CULL_FACE);
    gl.cullFace(gl.BACK);
    gl.frontFace(gl.CCW);
    gl.useProgram(this.prog);
    const d = this.mesh.diag;
    this.vp = viewProj(this.cam, w / h, d * 1e-3, d * 20);
    gl.uniformMatrix4fv(this.u.u_vp, false, this.vp);
    gl.uniform1i(this.u.u_mode, this.mode);
    gl.uniform1f(this.u.u_k, Math.pow(2, this.exposure) / Math.PI);
    gl.uniform2f(this.u.u_log, this.logRange[0], this.logRange[1]);
    const lod = this.motion && this.previewDraw ? this.previewDraw : this.full;
    gl.bindVertexArray(lod.vao);
    gl.drawElements(gl.TRIANGLES, lod.count, gl.UNSIGNED_INT, 0);
    gl.bindVertexArray(null);
    if (this.afterDraw) this.afterDraw();
  }

  /** CSS-pixel position of a world point in the last frame, or null behind the camera. */
  project(p) {
    const m = this.vp;
    if (!m) return null;
    const x = m[0] * p[0] + m[4] * p[1] + m[8] * p[2] + m[12];
    const y = m[1] * p[0] + m[5] * p[1] + m[9] * p[2] + m[13];
    const w = m[3] * p[0] + m[7] * p[1] + m[11] * p[2] + m[15];
    if (w <= 1e-9) return null;
    const c = this.canvas;
    // Screen x and y in CSS pixels, and the clip w (the distance along the view axis).
    return [((x / w + 1) / 2) * c.clientWidth, ((1 - y / w) / 2) * c.clientHeight, w];
  }

  get aspect() {
    return this.canvas.clientWidth / Math.max(1, this.canvas.clientHeight);
  }

  // ------------------------------------------------------------- navigation

  /** Mouse and keyboard: drag orbits about the target, shift/right drag looks around,
   *  wheel dollies, WASD/arrows walk, Q/E move down/up. */
  attachControls() {
    const c = this.canvas;
    let last = null, mode = null;
    c.addEventListener("contextmenu", (e) => e.preventDefault());
    c.addEventListener("pointerdown", (e) => {
      last = [e.clientX, e.clientY];
      mode = e.button === 2 || e.shiftKey ? "look" : "orbit";
      c.setPointerCapture(e.pointerId);
      c.focus();
    });
    c.addEventListener("pointerup", () => (last = null));
    c.addEventListener("pointermove", (e) => {
      if (!last || !this.cam) return;
      const dx = (e.clientX - last[0]) * 0.005, dy = (e.clientY - last[1]) * 0.005;
      last = [e.clientX, e.clientY];
      if (mode === "orbit") this.orbit(-dx, dy);
      else this.look(-dx, -dy);
    });
    c.addEventListener("wheel", (e) => {
      if (!this.cam) return;
      e.preventDefault();
      this.dolly(Math.exp(e.deltaY * 0.001));
    }, { passive: false });
    const keys = new Set();
    c.addEventListener("keydown", (e) => {
      keys.add(e.key.toLowerCase());
      if (!this.walking) this.walk(keys);
    });
    c.addEventListener("keyup", (e) => keys.delete(e.key.toLowerCase()));
    c.addEventListener("blur", () => keys.clear());
  }

  orbit(dyaw, dpitch) {
    this.turnAboutTarget(dyaw, dpitch);
    this.moved();
  }

  turnAboutTarget(dyaw, dpitch) {
    this.moving();
    const t = target(this.cam);
    this.cam.yaw += dyaw;
    this.cam.pitch = Math.max(-1.5, Math.min(1.5, this.cam.pitch + dpitch));
    this.cam.pos = sub(t, scale(forward(this.cam), this.cam.dist));
  }

  look(dyaw, dpitch) {
    this.moving();
    this.cam.yaw += dyaw;
    this.cam.pitch = Math.max(-1.5, Math.min(1.5, this.cam.pitch + dpitch));
    this.moved();
  }

  dolly(f) {
    this.moving();
    const t = target(this.cam);
    this.cam.dist = Math.max(this.mesh.diag * 1e-3, this.cam.dist * f);
    this.cam.pos = sub(t, scale(forward(this.cam), this.cam.dist));
    this.moved();
  }

  walk(keys) {
    this.walking = true;
    let prev = performance.now();
    const step = (now) => {
      const dt = Math.min(0.1, (now - prev) / 1000);
      prev = now;
      const [r, , f] = basis(this.cam);
      const flat = norm([f[0], 0, f[2]]);
      const speed = this.mesh.diag * 0.25 * dt;
      let mv = [0, 0, 0];
      if (keys.has("w") || keys.has("arrowup")) mv = add(mv, flat);
      if (keys.has("s") || keys.has("arrowdown")) mv = sub(mv, flat);
      if (keys.has("d") || keys.has("arrowright")) mv = add(mv, r);
      if (keys.has("a") || keys.has("arrowleft")) mv = sub(mv, r);
      if (keys.has("e")) mv = add(mv, [0, 1, 0]);
      if (keys.has("q")) mv = sub(mv, [0, 1, 0]);
      if (mv[0] || mv[1] || mv[2]) {
        this.moving();
        this.cam.pos = add(this.cam.pos, scale(mv, speed));
        this.moved();
        requestAnimationFrame(step);
      } else {
        this.walking = false;
      }
    };
    requestAnimationFrame(step);
  }

  moved() {
    this.redraw();
    if (this.onchange) this.onchange();
  }

  /**
   * Orbits for `frames` animation frames and reports the frame rate the page achieved
   * (capped by the display's refresh) and the resolution scale the moving frames settled
   * at, then times single full-resolution draws up to a pixel read-back.
   */
  async measureFps(frames = 120) {
    const gl = this.gl;
    const saved = { ...this.cam, pos: [...this.cam.pos] };
    const times = [];
    await new Promise((done) => {
      let prev = null, n = 0;
      const frame = (now) => {
        if (prev !== null) times.push(now - prev);
        prev = now;
        this.turnAboutTarget((2 * Math.PI) / frames, 0);
        this.draw();
        if (++n <= frames) requestAnimationFrame(frame);
        else done();
      };
      requestAnimationFrame(frame);
    });
    const movingScale = this.resScale;
    // Reading a pixel back waits until the frame is really drawn.
    const costs = [], px = new Uint8Array(4);
    for (let i = 0; i < 30; i++) {
      this.turnAboutTarget(0.01, 0);
      this.motion = false;
      const t0 = performance.now();
      this.draw();
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
      costs.push(performance.now() - t0);
    }
    this.cam = saved;
    this.draw();
    const q = (a, p) => [...a].sort((x, y) => x - y)[Math.floor(p * (a.length - 1))];
    const mean = times.reduce((s, x) => s + x, 0) / times.length;
    return {
      frames: times.length,
      fps: 1000 / mean,
      frameMsP50: q(times, 0.5),
      frameMsP95: q(times, 0.95),
      movingResolutionScale: movingScale,
      fullDrawMsP50: q(costs, 0.5),
      triangles: this.mesh.nt,
      previewTriangles: this.preview ? this.preview.nt : null,
    };
  }
}
