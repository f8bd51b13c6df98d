// Page state: the state object and its version (bumped on every change), lighting and
// camera defaults, and the URL hash that mirrors the state so a what-if can be shared.
// Imports only util.js; every other module may import this one.

import { srgbToLinear, linearToSrgbHex } from "./util.js";

export const state = {
  scene: null,      // scene id
  details: null,    // GET /api/scenes/{id}
  lights: {},       // id → { pct (0..200), color "#rrggbb" (sRGB), on }
  camera: null,     // preset id, or a free camera {position, target, fov_deg}
  falsecolor: false,
  exposure: null,   // stops, locked after metering; null = meter on the next image
  range: null,      // false-colour [lo, hi] lux, locked on first use
  sky: null,        // daylight panel: {type, eh, edn, date, hour}, or null (sky.js)
  layout: [],       // luminaires placed for every request (luminaires.js): {id, position,
                    // aim, photometry, group, remove}, the scene's by id, new ones besides
  snap: 0.25,       // the grid (m) a dragged luminaire snaps to; 0 = none
  version: 0,       // bumped on every lighting change
  // gridStats (per-grid illuminance, or null) is added when a scene is shown.
};
export const inputTime = new Map(); // version → performance.now() of the change that made it

// ------------------------------------------------------------------ versioning

let onChange = () => {};

/** Sets what happens after every change (app.js: update labels, URL hash and views). */
export function setOnChange(f) {
  onChange = f;
}

/** Records a change: bumps the version, timestamps it, then runs the change handler. */
export function changed() {
  state.version++;
  inputTime.set(state.version, performance.now());
  performance.mark(`relight-change-${state.version}`);
  if (inputTime.size > 200) inputTime.delete(inputTime.keys().next().value);
  onChange();
}

// ------------------------------------------------------------------ lighting and defaults

/** The JSON lighting state: every group with its intensity and linear colour. */
export function lightingJson() {
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

/** Most luminaire edits a layout holds (the server takes at most 1,000 per request). */
export const MAX_LAYOUT = 1000;

/** The request body's lighting: the groups, and the layout's luminaires when any. */
export function lightingBody() {
  const b = { lights: lightingJson() };
  if (state.layout.length) b.luminaires = state.layout.map(luminaireEntry);
  return b;
}

/** One layout edit as the API's `luminaires` entry. */
function luminaireEntry(e) {
  if (e.remove) return { id: e.id, remove: true };
  const out = { id: e.id, position: e.position };
  if (e.aim) out.aim = e.aim;
  if (e.photometry) out.photometry = e.photometry;
  if (e.group) out.group = e.group;
  return out;
}

export function defaultsFor(g) {
  return { pct: 100, color: linearToSrgbHex(g.color), on: true };
}

/** Default state for the scene in state.details, then whatever the URL hash `h` overrides. */
export function resetForScene(h) {
  const details = state.details;
  state.lights = Object.fromEntries(details.lights.map((g) => [g.id, defaultsFor(g)]));
  state.camera = details.cameras.length ? details.cameras[0].id : defaultCamera();
  state.exposure = null;
  state.range = null;
  state.sky = null;
  state.layout = [];
  applyHash(h);
}

// ------------------------------------------------------------------ cameras

export function presetCamera(id) {
  return state.details.cameras.find((c) => c.id === id);
}

/** The server image's camera as {position, target, fov_deg}. */
export function imageCamera() {
  return typeof state.camera === "string" ? presetCamera(state.camera) : state.camera;
}

/** For scenes without camera presets: the scene centre seen from outside its bounds. */
function defaultCamera() {
  const b = state.details.bounds;
  const c = b.min.map((v, i) => (v + b.max[i]) / 2);
  const d = Math.hypot(...b.max.map((v, i) => v - b.min[i]));
  return { position: [c[0], c[1], c[2] - 1.2 * d], target: c, fov_deg: 45 };
}

// ------------------------------------------------------------------ URL hash

/** Writes the state to the URL hash; `viewerCam` is the 3D view's camera, if any. */
export function writeHash(viewerCam) {
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
  if (state.sky && state.sky.type !== "off") {
    const s = state.sky;
    p.set("sky", [s.type, s.eh, s.date, s.hour].join(":"));
  }
  if (state.exposure !== null) p.set("ev", state.exposure.toFixed(2));
  if (state.layout.length) p.set("lum", state.layout.map(layoutItem).join(";"));
  if (state.snap !== 0.25) p.set("snap", String(state.snap));
  if (viewerCam) {
    const c = viewerCam;
    p.set("v", [...c.pos, c.yaw, c.pitch, c.dist].map((v) => +v.toFixed(4)).join(","));
  }
  history.replaceState(null, "", "#" + p.toString());
}

/** The URL hash as a plain object (scene, cam, l, fc, ev, v). */
export function readHash() {
  const p = new URLSearchParams(location.hash.slice(1));
  return Object.fromEntries(p.entries());
}

const fixed = (v) => v.map((x) => +x.toFixed(4)).join(",");

/** One layout edit in the hash: `id|x,y,z|ax,ay,az|photometry|group|r` (r: removed). */
function layoutItem(e) {
  return [e.id, e.position ? fixed(e.position) : "", e.aim ? fixed(e.aim) : "",
    e.photometry || "", e.group || "", e.remove ? "r" : ""].join("|");
}

/** The layout edits of the hash's `lum`, those that read whole (at most MAX_LAYOUT). */
function readLayout(text) {
  const triple = (t) => {
    const v = (t || "").split(",").map(Number);
    return v.length === 3 && v.every(Number.isFinite) ? v : null;
  };
  const out = [];
  for (const item of (text || "").split(";").slice(0, MAX_LAYOUT)) {
    const [id, pos, aim, photometry, group, r] = item.split("|");
    if (!id || id.length > 64 || out.some((e) => e.id === id)) continue;
    const e = { id, position: triple(pos), aim: triple(aim), photometry: photometry || null,
      group: group || null, remove: r === "r" };
    if (e.remove || e.position) out.push(e);
  }
  return out;
}

function applyHash(h) {
  state.layout = readLayout(h.lum);
  const snap = Number(h.snap);
  state.snap = Number.isFinite(snap) && snap >= 0 && snap <= 10 ? snap : 0.25;
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
  const [type, eh, date, hour] = (h.sky || "").split(":");
  if (["cie_overcast", "cie_clear", "uniform"].includes(type) && state.details.site) {
    const e = Number(eh), hr = Number(hour);
    state.sky = {
      type,
      eh: Number.isFinite(e) && e >= 0 && e <= 200000 ? e : 10000,
      edn: 70000,
      date: /^\d{4}-\d{2}-\d{2}$/.test(date || "") ? date : "2026-06-21",
      hour: Number.isFinite(hr) && hr >= 0 && hr <= 24 ? hr : 12,
    };
  }
  const ev = Number(h.ev);
  if (h.ev !== undefined && Number.isFinite(ev)) state.exposure = ev;
}
