// The server's relit image: one render request in flight (imageFlight), the exposure and
// false-colour range locked from the first image's headers, and the timing readouts.

import { $ } from "../util.js";
import { state, inputTime, imageCamera, lightingBody, writeHash } from "../state.js";
import { postJson, problem, singleFlight } from "../api.js";
import { showExposure } from "../controls.js";
import { viewer, glFlight } from "./gl.js";
import { skyJson } from "../sky.js";

/** The POST /render body for the current state, sized to the canvas. */
function renderBody(canvas) {
  const dpr = window.devicePixelRatio || 1;
  const w = Math.min(1600, Math.max(64, Math.round(canvas.clientWidth * dpr)));
  const h = Math.min(1200, Math.max(48, Math.round((w * 3) / 4)));
  const body = {
    ...lightingBody(),
    camera: typeof state.camera === "string" ? state.camera : imageCamera(),
    width: w,
    height: h,
    format: "jpeg",
    exposure: state.exposure === null ? "auto" : state.exposure,
    mode: state.falsecolor ? "falsecolor" : "shaded",
  };
  if (state.falsecolor && state.range) body.range = state.range;
  const sky = skyJson();
  if (sky) body.sky = sky;
  return body;
}

/** Locks the metered exposure and the false-colour range from the response headers. */
function lockFromHeaders(r) {
  if (state.exposure === null && !state.falsecolor) {
    const ev = Number(r.headers.get("x-relight-exposure"));
    if (Number.isFinite(ev)) {
      state.exposure = ev;
      showExposure();
      writeHash(viewer?.cam);
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
}

/** Records the image's timings in window.relight.stats and the Timing panel. */
function recordTiming(version, r, rtt, shown) {
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
}

/** The camera and size a body renders: the server builds `final` images per view. */
const viewKey = (body) => JSON.stringify([state.scene, body.camera, body.width, body.height]);

/** The view whose `final` images the server has built (then sliders relight it). */
let finalView = null;
let finalTimer = 0;
/** How long the camera must rest before the final image is asked for, ms. */
const FINAL_REST_MS = 400;

/** Whether the current image should be made at final quality. */
const wantFinal = () => $("#final")?.checked && !state.falsecolor;

function finalStatus(text) {
  const el = $("#final-status");
  if (el) el.textContent = text;
}

/** Builds the final image of the current view, then shows it; progress in #final-status. */
const finalFlight = singleFlight(async (signal) => {
  if (!state.details || !wantFinal()) return;
  const canvas = $("#image");
  const body = { ...renderBody(canvas), quality: "final" };
  const key = viewKey(body);
  if (finalView === key) return;
  finalStatus("tracing the final image…");
  const t0 = performance.now();
  const r = await postJson("/render", body, { signal });
  if (!r.ok) {
    finalStatus("");
    throw new Error(await problem(r));
  }
  const bitmap = await createImageBitmap(await r.blob());
  if (signal.aborted) return;
  finalView = key;
  window.relight.stats.finalMs = performance.now() - t0;
  finalStatus(`final (${((performance.now() - t0) / 1000).toFixed(1)} s)`);
  if (viewKey(renderBody(canvas)) !== key) return;
  canvas.width = bitmap.width;
  canvas.height = bitmap.height;
  canvas.getContext("2d").drawImage(bitmap, 0, 0);
  bitmap.close();
});

$("#final")?.addEventListener("change", () => imageFlight());

export const imageFlight = singleFlight(async (signal) => {
  if (!state.details) return;
  const canvas = $("#image");
  const body = renderBody(canvas);
  const key = viewKey(body);
  // Sliders relight whichever quality is built for this view.
  if (wantFinal() && finalView === key) body.quality = "final";
  if (finalView !== key) {
    finalFlight.abort();
    finalStatus(wantFinal() ? "fast" : "");
  }
  const version = state.version;
  const t0 = performance.now();
  const r = await postJson("/render", body, { signal });
  if (!r.ok) throw new Error(await problem(r));
  clearTimeout(finalTimer);
  if (wantFinal() && body.quality !== "final") {
    finalTimer = setTimeout(() => finalFlight(), FINAL_REST_MS);
  }
  const blob = await r.blob();
  const rtt = performance.now() - t0;
  const bitmap = await createImageBitmap(blob);
  if (signal.aborted) return;
  lockFromHeaders(r);
  canvas.width = bitmap.width;
  canvas.height = bitmap.height;
  canvas.getContext("2d").drawImage(bitmap, 0, 0);
  bitmap.close();
  // On screen at the next frame.
  await new Promise((res) => requestAnimationFrame(() => res()));
  recordTiming(version, r, rtt, performance.now());
});
