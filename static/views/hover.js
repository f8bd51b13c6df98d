// Hover over either view: picks the surface under the pointer and shows its illuminance
// (here, average, min, max, U₀) in a tooltip and the Surface panel. Surface statistics are
// fetched once per state version (surfaceCache).

import { pick, cameraFromLookAt } from "../viewer.js";
import { $, luminance, fmtLux, showBanner } from "../util.js";
import { state, imageCamera, lightingBody } from "../state.js";
import { postJson, problem } from "../api.js";
import { viewer, mesh } from "./gl.js";

let surfaceCache = { version: -1, stats: null, perPatch: null };
let hoverSeq = 0;

/** Forgets the cached statistics (a new scene was loaded). */
export function resetSurfaceCache() {
  surfaceCache = { version: -1, stats: null, perPatch: null };
}

/** Hover on the server image and the 3D view; the tooltip hides when the pointer leaves. */
export function attachHover() {
  $("#image").addEventListener("mousemove", (e) => hover(e, imageCam(), 4 / 3));
  $("#gl").addEventListener("mousemove", (e) => hover(e, viewer.cam, viewer.aspect));
  for (const el of [$("#image"), $("#gl")]) el.addEventListener("mouseleave", () => ($("#tooltip").hidden = true));
}

function imageCam() {
  const c = imageCamera();
  return cameraFromLookAt(c.position, c.target, c.fov_deg || 60);
}

/** Per-surface statistics and per-patch illuminance for the current state. */
async function surfaceStats() {
  if (surfaceCache.version === state.version) return surfaceCache;
  const version = state.version;
  const names = state.details.surfaces.map((s) => s.id);
  const lit = lightingBody();
  const [sr, pr] = await Promise.all([
    postJson("/illuminance", { ...lit, surfaces: names }),
    postJson("/radiosity", { ...lit, quantity: "illuminance" }, { binary: true }),
  ]);
  if (!sr.ok) throw new Error(await problem(sr));
  if (!pr.ok) throw new Error(await problem(pr));
  const stats = (await sr.json()).surfaces;
  const perPatch = new Float32Array(await pr.arrayBuffer());
  surfaceCache = { version, stats, perPatch };
  return surfaceCache;
}

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
