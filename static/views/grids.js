// Calculation grids: the statistics table and luminaire power (one illuminance request in
// flight, gridFlight), and the grid points drawn over the 3D view, coloured on the
// false-colour scale, with lux values where labels do not overlap (drawOverlay).

import { $, fmtLux, fmtRatio } from "../util.js";
import { state, lightingBody } from "../state.js";
import { postJson, problem, singleFlight } from "../api.js";
import { viewer } from "./gl.js";
import { skyJson } from "../sky.js";
import { drawLuminaires } from "../luminaires.js";

export const gridFlight = singleFlight(async (signal) => {
  if (!state.details) return;
  const version = state.version;
  const body = { ...lightingBody(), grids: state.details.grids.map((g) => g.id), surfaces: [] };
  const sky = skyJson();
  // /daylight answers the scene's own luminaires: a layout goes to /illuminance only.
  if (sky) Object.assign(body, { sky, luminaires: undefined });
  // Under a sky, /daylight answers the grids (daylight plus the electric light).
  const r = await postJson(sky ? "/daylight" : "/illuminance", body, { signal });
  if (!r.ok) throw new Error(await problem(r));
  const v = await r.json();
  if (signal.aborted) return;
  if (sky) {
    v.grids = Object.fromEntries(Object.entries(v.grids).map(([k, g]) => [k, g.illuminance]));
  }
  state.gridStats = v.grids;
  // Maintained values (each group's light × its maintenance factor) when the answer has
  // them; a daylight answer without electric light has none.
  const shown = (v.maintained && v.maintained.grids) || v.grids;
  const compliance = v.compliance || {};
  const rows = state.details.grids.map((g) => gridRow(g, shown[g.id], v.grids[g.id], compliance[g.id]));
  $("#grid-stats tbody").replaceChildren(...rows);
  const daylight = sky ? ", daylight as is" : "";
  $("#grid-values").textContent = v.maintained
    ? `Maintained values (MF ${mfText(v.maintenance_factors)}${daylight}); the initial ones on hover.`
    : "Daylight only: no maintenance factor applies.";
  const p = v.power || {};
  $("#luminaire-power").textContent = p.luminaire_lumens
    ? `Luminaires: ${Math.round(p.luminaire_lumens).toLocaleString()} lm` +
      (p.luminaire_watts != null ? `, ${p.luminaire_watts.toFixed(1)} W` : "")
    : "";
  window.relight.stats.gridVersion = version;
  drawOverlay();
});

/** The maintenance factors as text: one number when the groups agree. */
function mfText(f) {
  const values = [...new Set(Object.values(f || {}))];
  if (values.length === 1) return values[0].toFixed(2);
  return Object.entries(f).map(([k, x]) => `${k} ${x.toFixed(2)}`).join(", ");
}

/** One row of the statistics table: grid `g` with its statistics `s` (maintained where
 *  known), the initial ones `initial`, and its compliance `c` (absent without
 *  requirements). */
function gridRow(g, s, initial, c) {
  const tr = document.createElement("tr");
  for (const t of [g.name, fmtLux(s.avg), fmtLux(s.min), fmtLux(s.max), fmtRatio(s.u0)]) {
    const td = document.createElement("td");
    td.textContent = t;
    tr.append(td);
  }
  const verdict = document.createElement("td");
  verdict.className = "verdict";
  if (c) {
    verdict.textContent = c.pass ? "✓" : "✗";
    verdict.classList.add(c.pass ? "pass" : "fail");
    verdict.title = c.checks.map(checkText).join("\n");
  }
  tr.append(verdict);
  const left = s.excluded
    ? `; ${s.excluded} inside objects left out (drawn hollow)`
    : "";
  const zone = s.kind ? `EN 12464-1 ${s.kind} area, ` : "";
  const init = initial && initial !== s ? `; initial Eavg ${fmtLux(initial.avg)} lx` : "";
  const note = s.note ? `; ${s.note}` : "";
  tr.title = `${zone}${g.count} points${left}; Emin/Emax ${fmtRatio(s.min_max)} (lux)${init}${note}`;
  return tr;
}

/** One requirement as text: "Ēm 552 lx ≥ 500 ✓". */
function checkText(k) {
  const name = { em: "Ēm", u0: "U₀", ugr_l: "UGR", ra: "Ra" }[k.requirement] || k.requirement;
  const op = k.requirement === "ugr_l" ? "≤" : "≥";
  const got = k.achieved == null ? "?" : k.unit === "lx" ? `${fmtLux(k.achieved)} lx` : k.achieved.toFixed(2);
  const note = k.note ? ` (${k.note})` : "";
  return `${name} ${got} ${op} ${k.required} ${k.pass ? "✓" : "✗"}${note}`;
}

/** Grid points in the 3D view: coloured by lux (the false-colour scale), with values
 *  where labels do not overlap. */
export function drawOverlay() {
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
  drawLuminaires(g2);
  if (!state.details || !state.gridStats || !$("#grid-overlay").checked || !viewer) return;
  const all = Object.values(state.gridStats).flatMap((s) => s.values.filter((v) => v != null));
  const color = luxColour(Math.max(...all, 1e-6));
  window.relight.stats.overlayPoints = drawPoints(g2, w, h, color);
}

/** Lux → CSS colour on the false-colour scale spanning [hi / 100, hi]. */
function luxColour(hi) {
  const stops = [[13, 13, 89], [0, 89, 230], [0, 191, 140], [140, 217, 26], [255, 204, 0], [217, 26, 13]];
  const lo = hi / 100;
  return (v) => {
    const t = Math.max(0, Math.min(1, (Math.log10(Math.max(v, 1e-9)) - Math.log10(lo)) / 2)) * 5;
    const i = Math.min(4, Math.floor(t)), f = t - i;
    return `rgb(${stops[i].map((a, k) => Math.round(a + (stops[i + 1][k] - a) * f)).join(",")})`;
  };
}

/** Label box of a point at screen (x, y), CSS pixels: 30 × 13 above the point. */
const LABEL = { w: 30, h: 13, above: 16 };
/** Least free space between two labels, CSS pixels. */
const LABEL_GAP = 3;

/** Draws every grid point visible in the w × h view; returns how many were drawn. Lux
 *  labels go to the nearest points first, each only where its box keeps LABEL_GAP from
 *  every label already placed, so labels never overlap from any viewpoint and the nearest
 *  keep theirs as the camera moves (window.relight.stats.labelBoxes lists the boxes). */
function drawPoints(g2, w, h, color) {
  g2.font = "11px system-ui, sans-serif";
  g2.textAlign = "center";
  const seen = [];
  for (const g of state.details.grids) {
    const s = state.gridStats[g.id];
    if (!s) continue;
    g.points.forEach((p, i) => {
      const q = viewer.project(p);
      if (!q || q[0] < 0 || q[1] < 0 || q[0] > w || q[1] > h) return;
      seen.push({ x: q[0], y: q[1], depth: q[2], v: s.values[i] });
    });
  }
  for (const p of seen) {
    g2.beginPath();
    g2.arc(p.x, p.y, 2.5, 0, 2 * Math.PI);
    if (p.v == null) {
      // Left out of the statistics (inside an object): hollow, no label.
      g2.strokeStyle = "rgba(255,255,255,0.8)";
      g2.lineWidth = 1;
      g2.stroke();
    } else {
      g2.fillStyle = color(p.v);
      g2.fill();
    }
  }
  const boxes = [];
  const free = (b) =>
    boxes.every(
      (o) =>
        b.x + b.w + LABEL_GAP <= o.x || o.x + o.w + LABEL_GAP <= b.x ||
        b.y + b.h + LABEL_GAP <= o.y || o.y + o.h + LABEL_GAP <= b.y,
    );
  const labelled = seen.filter((p) => p.v != null).sort((a, b) => a.depth - b.depth);
  for (const p of labelled) {
    const b = { x: p.x - LABEL.w / 2, y: p.y - LABEL.above, w: LABEL.w, h: LABEL.h };
    if (!free(b)) continue;
    boxes.push(b);
    g2.fillStyle = "rgba(0,0,0,0.65)";
    g2.fillRect(b.x, b.y, b.w, b.h);
    g2.fillStyle = "#fff";
    g2.fillText(fmtLux(p.v), p.x, p.y - 6);
  }
  window.relight.stats.labelBoxes = boxes;
  return seen.length;
}
