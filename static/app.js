// relight web page: light controls, the server's relit image, and a WebGL walkthrough.
//
// Data flow: every control change bumps `state.version` and asks both views to update.
// Each view has at most one request in flight; changes made meanwhile are coalesced into
// one follow-up request for the newest state (no queue). Changing scene aborts both.
// The URL hash always holds the state, so a what-if can be shared as a link.

import { Viewer, parseMesh, vertexValues, pick, cameraFromLookAt, target } from "./viewer.js";

const $ = (s) => document.querySelector(s);
const api = (path) => `/api/scenes/${encodeURIComponent(state.scene)}${path}`;

const state = {
  scene: null,      // scene id
  details: null,    // GET /api/scenes/{id}
  lights: {},       // id → { pct (0..200), color "#rrggbb" (sRGB), on }
  camera: null,     // preset id, or a free camera {position, target, fov_deg}
  falsecolor: false,
  exposure: null,   // stops, locked after metering; null = meter on the next image
  range: null,      // false-colour [lo, hi] lux, locked on first use
  version: 0,       // bumped on every lighting change
};
const inputTime = new Map(); // version → performance.now() of the change that made it
let mesh = null;
let viewer = null;
let surfaceCache = { version: -1, stats: null, perPatch: null };

// ------------------------------------------------------------------ utilities

async function problem(resp) {
  try {
    const p = await resp.json();
    return p.detail || p.title || `${resp.status}`;
  } catch {
    return `${resp.status} ${resp.statusText}`;
  }
}

function srgbToLinear(hex) {
  const v = [1, 3, 5].map((i) => parseInt(hex.slice(i, i + 2), 16) / 255);
  return v.map((c) => (c <= 0.04045 ? c / 12.92 : Math.pow((c + 0.055) / 1.055, 2.4)));
}

function linearToSrgbHex(rgb) {
  const m = Math.max(...rgb, 1e-9);
  // Colours brighter than 1 are shown normalised; intensity carries the level.
  return "#" + rgb.map((c) => {
    const x = Math.min(1, Math.max(0, c / Math.max(1, m)));
    const s = x <= 0.0031308 ? 12.92 * x : 1.055 * Math.pow(x, 1 / 2.4) - 0.055;
    return Math.round(s * 255).toString(16).padStart(2, "0");
  }).join("");
}

const luminance = (c) => 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];

/** Lux to 2–3 significant digits: 0.52, 5.2, 52, 520, 5.2k, 52k. */
function fmtLux(v) {
  if (v >= 1000) return `${+(v / 1000).toPrecision(v >= 10000 ? 3 : 2)}k`;
  if (v >= 100) return v.toFixed(0);
  return `${+v.toPrecision(2)}`;
}

/** At most one run in flight; calls made meanwhile coalesce into one more run. */
function singleFlight(fn) {
  let running = false, again = false, ctrl = null;
  const run = async () => {
    if (running) {
      again = true;
      return;
    }
    running = true;
    try {
      do {
        again = false;
        ctrl = new AbortController();
        try {
          await fn(ctrl.signal);
        } catch (e) {
          if (e.name !== "AbortError") showBanner(String(e.message || e), "error");
        }
      } while (again);
    } finally {
      running = false;
    }
  };
  run.abort = () => {
    again = false;
    if (ctrl) ctrl.abort();
  };
  return run;
}

function showBanner(text, kind = "info", progress = null) {
  const b = $("#banner");
  b.hidden = !text;
  b.className = kind === "error" ? "error" : "";
  $("#banner-text").textContent = text || "";
  const p = $("#banner-progress");
  p.hidden = progress === null;
  if (progress !== null) p.value = progress;
}

// ------------------------------------------------------------------ lighting state

/** The JSON lighting state: every group with its intensity and linear colour. */
function lightingJson() {
  const out = {};
  for (const g of state.details.lights) {
    const l = state.lights[g.id];
    out[g.id] = {
      intensity: l.on ? (g.intensity * l.pct) / 100 : 0,
      color: srgbToLinear(l.color),
    };
  }
  return out;
}

function defaultsFor(g) {
  return { pct: 100, color: linearToSrgbHex(g.color), on: true };
}

function changed() {
  state.version++;
  inputTime.set(state.version, performance.now());
  performance.mark(`relight-change-${state.version}`);
  if (inputTime.size > 200) inputTime.delete(inputTime.keys().next().value);
  updateFluxLabels();
  writeHash();
  imageFlight();
  glFlight();
  if (state.details && state.details.grids && state.details.grids.length) gridFlight();
}

// ------------------------------------------------------------------ URL state

function writeHash() {
  if (!state.details) return;
  const p = new URLSearchParams();
  p.set("scene", state.scene);
  p.set("cam", typeof state.camera === "string" ? state.camera
    : [...state.camera.position, ...state.camera.target, state.camera.fov_deg].map((v) => +v.toFixed(3)).join(","));
  p.set("l", state.details.lights.map((g) => {
    const l = state.lights[g.id];
    return `${g.id}:${l.pct}:${l.color.slice(1)}:${l.on ? 1 : 0}`;
  }).join(","));
  if (state.falsecolor) p.set("fc", "1");
  if (state.exposure !== null) p.set("ev", state.exposure.toFixed(2));
  if (viewer && viewer.cam) {
    const c = viewer.cam;
    p.set("v", [...c.pos, c.yaw, c.pitch, c.dist].map((v) => +v.toFixed(4)).join(","));
  }
  history.replaceState(null, "", "#" + p.toString());
}

function readHash() {
  const p = new URLSearchParams(location.hash.slice(1));
  return Object.fromEntries(p.entries());
}

function applyHash(h) {
  for (const item of (h.l || "").split(",")) {
    const [id, pct, color, on] = item.split(":");
    const l = state.lights[id];
    if (!l) continue;
    const k = Number(pct);
    if (Number.isFinite(k)) l.pct = Math.max(0, Math.min(200, k));
    if (/^[0-9a-f]{6}$/i.test(color || "")) l.color = "#" + color.toLowerCase();
    l.on = on !== "0";
  }
  if (h.cam) {
    const nums = h.cam.split(",").map(Number);
    if (nums.length === 7 && nums.every(Number.isFinite)) {
      state.camera = { position: nums.slice(0, 3), target: nums.slice(3, 6), fov_deg: nums[6] };
    } else if (state.details.cameras.some((c) => c.id === h.cam)) {
      state.camera = h.cam;
    }
  }
  state.falsecolor = h.fc === "1";
  const ev = Number(h.ev);
  if (h.ev !== undefined && Number.isFinite(ev)) state.exposure = ev;
}

// ------------------------------------------------------------------ scenes

async function loadSceneList() {
  const r = await fetch("/api/scenes");
  if (!r.ok) throw new Error(await problem(r));
  return (await r.json()).scenes;
}

let pollTimer = null;
async function selectScene(id, hash = {}) {
  imageFlight.abort();
  glFlight.abort();
  clearTimeout(pollTimer);
  state.scene = id;
  state.details = null;
  $("#scene").value = id;
  $("#lights").replaceChildren();
  $("#scene-info").textContent = "";
  // Wait until the scene is ready, showing bake progress or the failure.
  for (;;) {
    const scenes = await loadSceneList();
    if (state.scene !== id) return;
    const s = scenes.find((x) => x.id === id);
    if (!s) return showBanner(`Scene '${id}' does not exist.`, "error");
    if (s.status === "ready") break;
    if (s.status === "failed") return showBanner(`Scene '${id}' failed to load: ${s.error}`, "error");
    const pct = Math.round(100 * (s.progress || 0));
    showBanner(`Scene '${id}' is ${s.status === "queued" ? "queued for baking" : `baking: ${pct} %`}. It appears here when ready.`, "info", s.progress || 0);
    await new Promise((res) => (pollTimer = setTimeout(res, 500)));
    if (state.scene !== id) return;
  }
  showBanner("");
  const [dr, mr] = await Promise.all([fetch(api("")), fetch(api("/mesh"))]);
  if (!dr.ok) return showBanner(await problem(dr), "error");
  if (!mr.ok) return showBanner(await problem(mr), "error");
  const details = await dr.json();
  const buf = await mr.arrayBuffer();
  if (state.scene !== id) return;
  state.details = details;
  mesh = parseMesh(buf);
  surfaceCache = { version: -1, stats: null, perPatch: null };
  state.lights = Object.fromEntries(details.lights.map((g) => [g.id, defaultsFor(g)]));
  state.camera = details.cameras.length ? details.cameras[0].id : defaultCamera();
  state.exposure = null;
  state.range = null;
  applyHash(hash);
  $("#scene-info").textContent = `${details.patches.toLocaleString()} patches · ${details.transfer} transfer`;
  buildLightControls();
  buildCameraSelect();
  $("#falsecolor").checked = state.falsecolor;
  state.gridStats = null;
  setupGrids();
  showExposure();
  viewer.setMesh(mesh);
  viewer.cam = initialViewerCamera(hash.v);
  viewer.redraw();
  changed();
  window.relight.ready = true;
}

function presetCamera(id) {
  return state.details.cameras.find((c) => c.id === id);
}

function imageCamera() {
  return typeof state.camera === "string" ? presetCamera(state.camera) : state.camera;
}

/** For scenes without camera presets: the scene centre seen from outside its bounds. */
function defaultCamera() {
  const b = state.details.bounds;
  const c = b.min.map((v, i) => (v + b.max[i]) / 2);
  const d = Math.hypot(...b.max.map((v, i) => v - b.min[i]));
  return { position: [c[0], c[1], c[2] - 1.2 * d], target: c, fov_deg: 45 };
}

function initialViewerCamera(v) {
  const nums = (v || "").split(",").map(Number);
  if (nums.length === 6 && nums.every(Number.isFinite)) {
    return { pos: nums.slice(0, 3), yaw: nums[3], pitch: nums[4], dist: nums[5], fov: 60 };
  }
  const c = imageCamera();
  return cameraFromLookAt(c.position, c.target, c.fov_deg || 60);
}

// ------------------------------------------------------------------ controls

function buildLightControls() {
  const box = $("#lights");
  box.replaceChildren();
  for (const g of state.details.lights) {
    const l = state.lights[g.id];
    const el = document.createElement("div");
    el.className = "light";
    el.dataset.id = g.id;
    el.innerHTML = `
      <div class="head">
        <input type="checkbox" class="on" aria-label="${g.name} on">
        <span class="name"></span>
        <input type="color" class="color" aria-label="${g.name} colour">
      </div>
      <div class="row">
        <input type="range" class="pct" min="0" max="200" step="1" aria-label="${g.name} intensity (%)">
        <output class="pct-out"></output>
      </div>
      <div class="flux"></div>`;
    el.querySelector(".name").textContent = g.name || g.id;
    const on = el.querySelector(".on"), pct = el.querySelector(".pct"), color = el.querySelector(".color");
    on.checked = l.on;
    pct.value = l.pct;
    color.value = l.color;
    el.classList.toggle("off", !l.on);
    el.querySelector(".pct-out").textContent = `${l.pct} %`;
    on.addEventListener("change", () => {
      l.on = on.checked;
      el.classList.toggle("off", !l.on);
      changed();
    });
    pct.addEventListener("input", () => {
      l.pct = Number(pct.value);
      el.querySelector(".pct-out").textContent = `${l.pct} %`;
      changed();
    });
    color.addEventListener("input", () => {
      l.color = color.value;
      changed();
    });
    box.append(el);
  }
  updateFluxLabels();
}

function updateFluxLabels() {
  if (!state.details) return;
  let total = 0;
  for (const g of state.details.lights) {
    const l = state.lights[g.id];
    const k = l.on ? (g.intensity * l.pct) / 100 : 0;
    const lm = g.lumens * k * luminance(srgbToLinear(l.color));
    total += lm;
    const el = document.querySelector(`.light[data-id="${CSS.escape(g.id)}"] .flux`);
    if (el) el.textContent = `${lm.toLocaleString(undefined, { maximumFractionDigits: lm < 10 ? 3 : 0 })} lm emitted`;
  }
  $("#scene-info").textContent = `${state.details.patches.toLocaleString()} patches · ${state.details.transfer} transfer · ${total.toLocaleString(undefined, { maximumFractionDigits: total < 10 ? 3 : 0 })} lm total`;
}

function buildCameraSelect() {
  const sel = $("#camera");
  sel.replaceChildren();
  for (const c of state.details.cameras) sel.append(new Option(c.id, c.id));
  sel.append(new Option("custom (from 3D view)", "__custom"));
  sel.value = typeof state.camera === "string" ? state.camera : "__custom";
}

function resetDefaults() {
  for (const g of state.details.lights) state.lights[g.id] = defaultsFor(g);
  state.falsecolor = false;
  state.exposure = null;
  state.range = null;
  $("#falsecolor").checked = false;
  buildLightControls();
  changed();
}

function showExposure() {
  const out = $("#exposure-out"), s = $("#exposure");
  if (state.exposure === null) {
    out.textContent = "auto";
  } else {
    out.textContent = `${state.exposure.toFixed(1)} EV`;
    // Centre the slider range on the metered value.
    if (state.exposure < Number(s.min) || state.exposure > Number(s.max)) {
      s.min = Math.floor(state.exposure - 6);
      s.max = Math.ceil(state.exposure + 6);
    }
    s.value = state.exposure;
  }
}

// ------------------------------------------------------------------ the server image

const imageFlight = singleFlight(async (signal) => {
  if (!state.details) return;
  const canvas = $("#image");
  const dpr = window.devicePixelRatio || 1;
  const w = Math.min(1600, Math.max(64, Math.round(canvas.clientWidth * dpr)));
  const h = Math.min(1200, Math.max(48, Math.round((w * 3) / 4)));
  const version = state.version;
  const body = {
    lights: lightingJson(),
    camera: typeof state.camera === "string" ? state.camera : imageCamera(),
    width: w,
    height: h,
    format: "jpeg",
    exposure: state.exposure === null ? "auto" : state.exposure,
    mode: state.falsecolor ? "falsecolor" : "shaded",
  };
  if (state.falsecolor && state.range) body.range = state.range;
  const t0 = performance.now();
  const r = await fetch(api("/render"), {
    method: "POST",
    headers: { "content-type": "application/json" },
    body: JSON.stringify(body),
    signal,
  });
  if (!r.ok) throw new Error(await problem(r));
  const blob = await r.blob();
  const rtt = performance.now() - t0;
  const bitmap = await createImageBitmap(blob);
  if (signal.aborted) return;
  if (state.exposure === null && !state.falsecolor) {
    const ev = Number(r.headers.get("x-relight-exposure"));
    if (Number.isFinite(ev)) {
      state.exposure = ev;
      showExposure();
      writeHash();
      glFlight();
    }
  }
  if (state.falsecolor && !state.range) {
    const fc = (r.headers.get("x-relight-falsecolor-lux") || "").split(",").map(Number);
    if (fc.length === 2 && fc.every(Number.isFinite)) {
      state.range = fc;
      glFlight();
    }
  }
  canvas.width = bitmap.width;
  canvas.height = bitmap.height;
  canvas.getContext("2d").drawImage(bitmap, 0, 0);
  bitmap.close();
  // On screen at the next frame.
  await new Promise((res) => requestAnimationFrame(() => res()));
  const shown = performance.now();
  const since = inputTime.get(version);
  const st = window.relight.stats;
  st.imageVersion = version;
  st.imagesShown++;
  st.rttMs = rtt;
  st.serverMs = Number(r.headers.get("x-relight-render-ms"));
  if (since !== undefined) {
    st.changeToScreenMs = shown - since;
    performance.measure(`relight-change-to-image-${version}`, { start: since, end: shown });
  }
  $("#t-rtt").textContent = `${rtt.toFixed(1)} ms`;
  $("#t-server").textContent = `${st.serverMs.toFixed(1)} ms`;
  $("#t-screen").textContent = since === undefined ? "–" : `${st.changeToScreenMs.toFixed(1)} ms`;
});

// ------------------------------------------------------------------ the 3D view

const glFlight = singleFlight(async (signal) => {
  if (!state.details || !mesh) return;
  const version = state.version;
  const t0 = performance.now();
  const r = await fetch(api("/radiosity"), {
    method: "POST",
    headers: { "content-type": "application/json", accept: "application/octet-stream" },
    body: JSON.stringify({ lights: lightingJson(), quantity: state.falsecolor ? "illuminance" : "radiosity" }),
    signal,
  });
  if (!r.ok) throw new Error(await problem(r));
  const perPatch = new Float32Array(await r.arrayBuffer());
  if (signal.aborted) return;
  if (perPatch.length !== 3 * mesh.nt) throw new Error("radiosity length does not match the mesh");
  const values = vertexValues(mesh, perPatch);
  viewer.mode = state.falsecolor ? 1 : 0;
  if (state.falsecolor) {
    if (!state.range) {
      let max = 0;
      for (let i = 0; i < mesh.nv; i++) max = Math.max(max, luminance(values.subarray(3 * i, 3 * i + 3)));
      state.range = [Math.max(max, 1e-6) / 100, Math.max(max, 1e-6)];
    }
    viewer.logRange = state.range.map(Math.log10);
    drawLegend();
  }
  $("#legend").hidden = !state.falsecolor;
  viewer.exposure = state.exposure ?? autoExposure(values);
  viewer.setValues(values);
  await new Promise((res) => requestAnimationFrame(() => res()));
  const st = window.relight.stats;
  st.glVersion = version;
  st.glFrames++;
  st.glMs = performance.now() - t0;
  $("#t-3d").textContent = `${st.glMs.toFixed(1)} ms`;
});

/** Stops that bring the log-average vertex radiance to middle grey (as the server meters). */
function autoExposure(values) {
  let s = 0, n = 0;
  for (let i = 0; i < values.length; i += 3) {
    const y = luminance(values.subarray(i, i + 3)) / Math.PI;
    if (y > 0) {
      s += Math.log(y);
      n++;
    }
  }
  return n ? Math.log2(0.18 / Math.exp(s / n)) : 0;
}

function drawLegend() {
  const [lo, hi] = state.range;
  const stops = ["#0d0d59", "#0059e6", "#00bf8c", "#8cd91a", "#ffcc00", "#d91a0d"];
  $("#legend .bar").style.background = `linear-gradient(to top, ${stops.join(",")})`;
  const labels = $("#legend .labels");
  labels.replaceChildren();
  const l0 = Math.log10(lo), l1 = Math.log10(hi);
  for (let e = Math.floor(l0); e <= Math.ceil(l1); e++) {
    for (const m of [1, 2, 5]) {
      const v = m * 10 ** e, t = (Math.log10(v) - l0) / (l1 - l0);
      if (t < -1e-6 || t > 1 + 1e-6) continue;
      const s = document.createElement("span");
      s.style.top = `${(1 - t) * 100}%`;
      s.textContent = `${fmtLux(v)} lx`;
      labels.append(s);
    }
  }
}

// ------------------------------------------------------------------ calculation grids

function setupGrids() {
  const grids = state.details.grids || [];
  $("#grids-section").hidden = grids.length === 0;
  const sel = $("#opt-grid");
  sel.replaceChildren(...grids.map((g) => new Option(g.name, g.id)));
  $("#grid-stats tbody").replaceChildren();
  $("#luminaire-power").textContent = "";
  $("#opt-out").textContent = "";
  drawOverlay();
}

const gridFlight = singleFlight(async (signal) => {
  if (!state.details) return;
  const version = state.version;
  const r = await fetch(api("/illuminance"), {
    method: "POST",
    headers: { "content-type": "application/json" },
    body: JSON.stringify({ lights: lightingJson(), grids: state.details.grids.map((g) => g.id), surfaces: [] }),
    signal,
  });
  if (!r.ok) throw new Error(await problem(r));
  const v = await r.json();
  if (signal.aborted) return;
  state.gridStats = v.grids;
  const rows = state.details.grids.map((g) => {
    const s = v.grids[g.id];
    const tr = document.createElement("tr");
    for (const t of [g.name, fmtLux(s.avg), fmtLux(s.min), fmtLux(s.max), s.u0.toFixed(2)]) {
      const td = document.createElement("td");
      td.textContent = t;
      tr.append(td);
    }
    tr.title = `${g.count} points; Emin/Emax ${s.min_max.toFixed(2)} (lux)`;
    return tr;
  });
  $("#grid-stats tbody").replaceChildren(...rows);
  const p = v.power || {};
  $("#luminaire-power").textContent = p.luminaire_lumens
    ? `Luminaires: ${Math.round(p.luminaire_lumens).toLocaleString()} lm` +
      (p.luminaire_watts != null ? `, ${p.luminaire_watts.toFixed(1)} W` : "")
    : "";
  window.relight.stats.gridVersion = version;
  drawOverlay();
});

/** Grid points in the 3D view: coloured by lux (the false-colour scale), with values
 *  where labels do not overlap. */
function drawOverlay() {
  const c = $("#overlay");
  const dpr = window.devicePixelRatio || 1;
  const w = c.clientWidth, h = c.clientHeight;
  if (c.width !== Math.round(w * dpr) || c.height !== Math.round(h * dpr)) {
    c.width = Math.round(w * dpr);
    c.height = Math.round(h * dpr);
  }
  const g2 = c.getContext("2d");
  g2.setTransform(dpr, 0, 0, dpr, 0, 0);
  g2.clearRect(0, 0, w, h);
  if (!state.details || !state.gridStats || !$("#grid-overlay").checked || !viewer) return;
  const stops = [[13, 13, 89], [0, 89, 230], [0, 191, 140], [140, 217, 26], [255, 204, 0], [217, 26, 13]];
  const all = Object.values(state.gridStats).flatMap((s) => s.values);
  const hi = Math.max(...all, 1e-6), lo = hi / 100;
  const color = (v) => {
    const t = Math.max(0, Math.min(1, (Math.log10(Math.max(v, 1e-9)) - Math.log10(lo)) / 2)) * 5;
    const i = Math.min(4, Math.floor(t)), f = t - i;
    return `rgb(${stops[i].map((a, k) => Math.round(a + (stops[i + 1][k] - a) * f)).join(",")})`;
  };
  const taken = new Set();
  g2.font = "11px system-ui, sans-serif";
  g2.textAlign = "center";
  let drawn = 0;
  for (const g of state.details.grids) {
    const s = state.gridStats[g.id];
    if (!s) continue;
    g.points.forEach((p, i) => {
      const q = viewer.project(p);
      if (!q || q[0] < 0 || q[1] < 0 || q[0] > w || q[1] > h) return;
      g2.fillStyle = color(s.values[i]);
      g2.beginPath();
      g2.arc(q[0], q[1], 2.5, 0, 2 * Math.PI);
      g2.fill();
      drawn++;
      const key = `${Math.floor(q[0] / 40)},${Math.floor(q[1] / 18)}`;
      if (taken.has(key)) return;
      taken.add(key);
      const text = fmtLux(s.values[i]);
      g2.fillStyle = "rgba(0,0,0,0.65)";
      g2.fillRect(q[0] - 15, q[1] - 16, 30, 13);
      g2.fillStyle = "#fff";
      g2.fillText(text, q[0], q[1] - 6);
    });
  }
  window.relight.stats.overlayPoints = drawn;
}

async function runOptimizer() {
  const out = $("#opt-out");
  const grid = $("#opt-grid").value;
  const target = { grid };
  const e = Number($("#opt-eavg").value), u = Number($("#opt-u0").value);
  if ($("#opt-eavg").value !== "") target.eavg_min = e;
  if ($("#opt-u0").value !== "") target.u0_min = u;
  out.textContent = "…";
  const r = await fetch(api("/optimize"), {
    method: "POST",
    headers: { "content-type": "application/json" },
    body: JSON.stringify({ targets: [target] }),
  });
  if (!r.ok) {
    out.textContent = await problem(r);
    return;
  }
  const v = await r.json();
  for (const g of state.details.lights) {
    const l = state.lights[g.id];
    const level = v.lights[g.id].intensity;
    l.pct = Math.max(0, Math.min(200, Math.round((100 * level) / (g.intensity || 1))));
    l.on = true;
    l.color = linearToSrgbHex(g.color);
  }
  buildLightControls();
  changed();
  const t = v.targets[0];
  out.textContent = `${Math.round(v.lumens).toLocaleString()} lm` +
    (v.power.luminaire_watts != null ? `, ${v.power.luminaire_watts.toFixed(1)} W` : "") +
    ` → ${grid}: Eavg ${fmtLux(t.achieved.avg)} lx, U₀ ${t.achieved.u0.toFixed(2)} (solved in ${v.solve_ms.toFixed(1)} ms)`;
}

// ------------------------------------------------------------------ hover: surface and lux

async function surfaceStats() {
  if (surfaceCache.version === state.version) return surfaceCache;
  const version = state.version;
  const names = state.details.surfaces.map((s) => s.id);
  const lights = lightingJson();
  const [sr, pr] = await Promise.all([
    fetch(api("/illuminance"), {
      method: "POST",
      headers: { "content-type": "application/json" },
      body: JSON.stringify({ lights, surfaces: names }),
    }),
    fetch(api("/radiosity"), {
      method: "POST",
      headers: { "content-type": "application/json", accept: "application/octet-stream" },
      body: JSON.stringify({ lights, quantity: "illuminance" }),
    }),
  ]);
  if (!sr.ok) throw new Error(await problem(sr));
  if (!pr.ok) throw new Error(await problem(pr));
  const stats = (await sr.json()).surfaces;
  const perPatch = new Float32Array(await pr.arrayBuffer());
  surfaceCache = { version, stats, perPatch };
  return surfaceCache;
}

let hoverSeq = 0;
async function hover(ev, cam, aspect) {
  if (!mesh || !state.details) return;
  const rect = ev.currentTarget.getBoundingClientRect();
  const x = ((ev.clientX - rect.left) / rect.width) * 2 - 1;
  const y = 1 - ((ev.clientY - rect.top) / rect.height) * 2;
  const hit = pick(mesh, cam, aspect, x, y);
  const tip = $("#tooltip");
  if (!hit) {
    tip.hidden = true;
    return;
  }
  const seq = ++hoverSeq;
  const surface = state.details.surfaces[hit.surface];
  let c;
  try {
    c = await surfaceStats();
  } catch (e) {
    return showBanner(String(e.message || e), "error");
  }
  if (seq !== hoverSeq) return;
  const s = c.stats[surface.id];
  const here = luminance(c.perPatch.subarray(3 * hit.patch, 3 * hit.patch + 3));
  const text = `<b>${surface.id}</b> · ${surface.area.toFixed(2)} m²<br>` +
    `here ${fmtLux(here)} lx · average ${fmtLux(s.avg.lux)} lx<br>` +
    `min ${fmtLux(s.min.lux)} · max ${fmtLux(s.max.lux)} lx · U₀ ${s.uniformity.toFixed(2)}`;
  tip.innerHTML = text;
  tip.hidden = false;
  tip.style.left = `${ev.clientX + 14}px`;
  tip.style.top = `${ev.clientY + 14}px`;
  $("#surface-info").innerHTML = text;
  window.relight.stats.lastPick = { surface: surface.id, hereLux: here, avgLux: s.avg.lux };
}

function imageCam() {
  const c = imageCamera();
  return cameraFromLookAt(c.position, c.target, c.fov_deg || 60);
}

// ------------------------------------------------------------------ start

async function main() {
  window.relight = {
    ready: false,
    stats: { imagesShown: 0, imageVersion: -1, glFrames: 0, glVersion: -1 },
    get state() { return state; },
    measureFps: (frames) => viewer.measureFps(frames),
  };
  try {
    viewer = new Viewer($("#gl"));
  } catch (e) {
    showBanner(`3D view unavailable: ${e.message}`, "error");
    return;
  }
  viewer.attachControls();
  viewer.afterDraw = drawOverlay;
  $("#grid-overlay").addEventListener("change", drawOverlay);
  $("#opt-run").addEventListener("click", () => runOptimizer().catch((e) => ($("#opt-out").textContent = String(e))));
  let hashTimer = null;
  viewer.onchange = () => {
    clearTimeout(hashTimer);
    hashTimer = setTimeout(writeHash, 200);
  };
  new ResizeObserver(() => viewer.redraw()).observe($("#gl"));

  $("#scene").addEventListener("change", (e) => {
    history.replaceState(null, "", "#scene=" + encodeURIComponent(e.target.value));
    selectScene(e.target.value);
  });
  $("#falsecolor").addEventListener("change", (e) => {
    state.falsecolor = e.target.checked;
    changed();
  });
  $("#reset").addEventListener("click", resetDefaults);
  $("#exposure").addEventListener("input", (e) => {
    state.exposure = Number(e.target.value);
    showExposure();
    changed();
  });
  $("#meter").addEventListener("click", () => {
    state.exposure = null;
    showExposure();
    changed();
  });
  $("#camera").addEventListener("change", (e) => {
    if (e.target.value === "__custom") return useViewerCamera();
    state.camera = e.target.value;
    const c = presetCamera(state.camera);
    viewer.cam = cameraFromLookAt(c.position, c.target, c.fov_deg);
    viewer.redraw();
    changed();
  });
  $("#use-3d").addEventListener("click", useViewerCamera);
  $("#image").addEventListener("mousemove", (e) => hover(e, imageCam(), 4 / 3));
  $("#gl").addEventListener("mousemove", (e) => hover(e, viewer.cam, viewer.aspect));
  for (const el of [$("#image"), $("#gl")]) el.addEventListener("mouseleave", () => ($("#tooltip").hidden = true));
  window.addEventListener("resize", () => imageFlight());

  let scenes;
  try {
    scenes = await loadSceneList();
  } catch (e) {
    return showBanner(`Cannot reach the server: ${e.message}`, "error");
  }
  if (!scenes.length) return showBanner("No scenes: start the server with --scenes DIR.", "error");
  const sel = $("#scene");
  for (const s of scenes) sel.append(new Option(s.name || s.id, s.id));
  const h = readHash();
  const first = scenes.find((s) => s.id === h.scene) || scenes.find((s) => s.status === "ready") || scenes[0];
  await selectScene(first.id, h.scene === first.id ? h : {});
}

function useViewerCamera() {
  const c = viewer.cam;
  state.camera = { position: c.pos, target: target(c), fov_deg: c.fov };
  $("#camera").value = "__custom";
  changed();
}

main();
