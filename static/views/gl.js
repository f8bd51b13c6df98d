// The WebGL 3D view glue: owns the Viewer (viewer.js) and the scene mesh, recolours the
// mesh from the server's per-patch radiosity (illuminance in false colour), and draws the
// false-colour lux legend. One radiosity request in flight (glFlight).

import { Viewer, parseMesh, vertexValues, cameraFromLookAt } from "../viewer.js";
import { $, luminance, fmtLux } from "../util.js";
import { state, imageCamera, lightingBody } from "../state.js";
import { postJson, problem, singleFlight } from "../api.js";
import { skyJson } from "../sky.js";

/** The 3D viewer (null until createViewer succeeds), the current scene's mesh and its
 *  preview (large scenes only). */
export let viewer = null;
export let mesh = null;
let preview = null;

/** Creates the viewer on `canvas`; throws if WebGL2 is unavailable. */
export function createViewer(canvas) {
  viewer = new Viewer(canvas);
  return viewer;
}

/** Parses the scene's binary mesh (GET /api/scenes/{id}/mesh) and its preview, if any
 *  (GET /api/scenes/{id}/mesh/preview). */
export function loadMesh(buf, previewBuf = null) {
  mesh = parseMesh(buf);
  preview = previewBuf ? parseMesh(previewBuf) : null;
}

/** Puts the loaded mesh in the viewer, with the camera from the hash's `v` if valid. */
export function showMesh(v) {
  viewer.setMesh(mesh, preview);
  viewer.cam = initialViewerCamera(v);
  viewer.redraw();
}

function initialViewerCamera(v) {
  const nums = (v || "").split(",").map(Number);
  if (nums.length === 6 && nums.every(Number.isFinite)) {
    return { pos: nums.slice(0, 3), yaw: nums[3], pitch: nums[4], dist: nums[5], fov: 60 };
  }
  const c = imageCamera();
  return cameraFromLookAt(c.position, c.target, c.fov_deg || 60);
}

export const glFlight = singleFlight(async (signal) => {
  if (!state.details || !mesh) return;
  const version = state.version;
  const t0 = performance.now();
  const body = { ...lightingBody(), quantity: state.falsecolor ? "illuminance" : "radiosity" };
  const sky = skyJson();
  if (sky) body.sky = sky;
  const r = await postJson("/radiosity", body, { signal, binary: true });
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
  viewer.setValues(values, preview ? vertexValues(preview, perPatch) : null);
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
