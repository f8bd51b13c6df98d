// The page's controls: light groups (on/off, intensity, colour, emitted flux), the camera
// picker, false colour and exposure, reset, the calculation-grid section and the
// least-energy optimizer. wireControls() attaches the fixed controls' listeners once;
// the build* and setup* functions fill them in for each scene.

import { cameraFromLookAt, target } from "./viewer.js";
import { $, luminance, srgbToLinear, linearToSrgbHex, fmtLux, fmtRatio } from "./util.js";
import { state, changed, defaultsFor, presetCamera } from "./state.js";
import { postJson, problem } from "./api.js";
import { viewer } from "./views/gl.js";
import { drawOverlay } from "./views/grids.js";

// ------------------------------------------------------------------ light groups

export function buildLightControls() {
  const box = $("#lights");
  box.replaceChildren();
  for (const g of state.details.lights) box.append(lightControl(g, state.lights[g.id]));
  updateFluxLabels();
}

/** The control block of light group `g` with state `l`. */
function lightControl(g, l) {
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
  return el;
}

export function updateFluxLabels() {
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

function resetDefaults() {
  for (const g of state.details.lights) state.lights[g.id] = defaultsFor(g);
  state.falsecolor = false;
  state.exposure = null;
  state.range = null;
  $("#falsecolor").checked = false;
  buildLightControls();
  changed();
}

// ------------------------------------------------------------------ camera

export function buildCameraSelect() {
  const sel = $("#camera");
  sel.replaceChildren();
  for (const c of state.details.cameras) sel.append(new Option(c.id, c.id));
  sel.append(new Option("custom (from 3D view)", "__custom"));
  sel.value = typeof state.camera === "string" ? state.camera : "__custom";
}

function useViewerCamera() {
  const c = viewer.cam;
  state.camera = { position: c.pos, target: target(c), fov_deg: c.fov };
  $("#camera").value = "__custom";
  changed();
}

// ------------------------------------------------------------------ exposure

export function showExposure() {
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

// ------------------------------------------------------------------ grids and optimizer

export function setupGrids() {
  const grids = state.details.grids || [];
  $("#grids-section").hidden = grids.length === 0;
  const sel = $("#opt-grid");
  sel.replaceChildren(...grids.map((g) => new Option(g.name, g.id)));
  $("#grid-stats tbody").replaceChildren();
  $("#luminaire-power").textContent = "";
  $("#opt-out").textContent = "";
  drawOverlay();
}

async function runOptimizer() {
  const out = $("#opt-out");
  const grid = $("#opt-grid").value;
  const goal = { grid };
  const e = Number($("#opt-eavg").value), u = Number($("#opt-u0").value);
  if ($("#opt-eavg").value !== "") goal.eavg_min = e;
  if ($("#opt-u0").value !== "") goal.u0_min = u;
  out.textContent = "…";
  const r = await postJson("/optimize", { targets: [goal] });
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
    ` → ${grid}: Eavg ${fmtLux(t.achieved.avg)} lx, U₀ ${fmtRatio(t.achieved.u0)} (solved in ${v.solve_ms.toFixed(1)} ms)`;
}

// ------------------------------------------------------------------ listeners

/** Attaches the listeners of the controls that exist for every scene. */
export function wireControls() {
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
  $("#grid-overlay").addEventListener("change", drawOverlay);
  $("#opt-run").addEventListener("click", () => runOptimizer().catch((e) => ($("#opt-out").textContent = String(e))));
}
