// The luminaire layout: the scene's luminaires and new ones, edited for every request
// without a bake. Markers on the 3D view's overlay show them; drag one to move it on its
// mounting plane (snapped to the grid set in the panel), "Aim" then a click on a surface
// re-aims it, ✕ removes it, and "Add" puts a luminaire from one of the scene's
// photometric files where the 3D view looks. The layout (state.layout) goes with every
// lighting request as `luminaires` (state.lightingBody), lives in the URL hash, and
// "Download scene.toml" writes it as `[[luminaires]]` tables for the next bake.
// Columns scenes answer light groups only, so there the panel says so and stays empty.

import { $ } from "./util.js";
import { state, changed, MAX_LAYOUT } from "./state.js";
import { viewer, mesh } from "./views/gl.js";
import { pick, rayThrough, target } from "./viewer.js";

/** Marker radius and the pointer's reach to grab one, CSS pixels. */
const MARKER = 6, GRAB = 10;

let aiming = null; // id of the luminaire whose aim the next click sets

/** Whether this scene takes luminaires placed per request. */
function editable() {
  return state.details && state.details.transfer !== "columns";
}

/** Every luminaire of the layout as shown: the scene's with their edits, then new ones.
 *  Each {id, position, aim, group, photometry, removed, added}. */
export function shownLuminaires() {
  if (!state.details) return [];
  const edits = new Map(state.layout.map((e) => [e.id, e]));
  const own = state.details.luminaires.map((l) => {
    const e = edits.get(l.id);
    return {
      id: l.id, group: e?.group || l.group, photometry: e?.photometry || l.photometry,
      position: e?.position || l.position, aim: e?.aim || l.aim, removed: !!e?.remove, added: false,
    };
  });
  const ids = new Set(own.map((l) => l.id));
  const added = state.layout.filter((e) => !ids.has(e.id)).map((e) => ({
    id: e.id, group: e.group, photometry: e.photometry, position: e.position,
    aim: e.aim || [0, -1, 0], removed: false, added: true,
  }));
  return [...own, ...added];
}

/** The edit of luminaire `id`, made (from what is shown) when it has none. */
function editOf(id) {
  let e = state.layout.find((x) => x.id === id);
  if (!e) {
    const l = shownLuminaires().find((x) => x.id === id);
    e = { id, position: [...l.position], aim: null, photometry: null, group: null, remove: false };
    state.layout.push(e);
  }
  return e;
}

const snapped = (v) => (state.snap > 0 ? Math.round(v / state.snap) * state.snap : v);

/** Fills the panel for the scene shown. */
export function setupLuminaires() {
  const ok = editable();
  $("#lum-section").hidden = !state.details;
  $("#lum-columns").hidden = ok;
  $("#lum-editor").hidden = !ok;
  if (!ok) return;
  $("#lum-snap").value = state.snap;
  const files = state.details.photometric_files || [];
  $("#lum-file").replaceChildren(...files.map((f) => new Option(f, f)));
  $("#lum-group").replaceChildren(new Option("(no group)", ""),
    ...state.details.lights.map((g) => new Option(g.name || g.id, g.id)));
  $("#lum-add").disabled = !files.length;
  $("#lum-add").title = files.length
    ? "Add a luminaire where the 3D view looks, at the mounting height"
    : "No .ies or .ldt file in the scene folder to add from";
  showLayout();
}

/** The table of luminaires, and the overlay. */
export function showLayout() {
  if (!editable()) return;
  const rows = shownLuminaires().map((l) => {
    const tr = document.createElement("tr");
    tr.dataset.id = l.id;
    tr.className = l.removed ? "removed" : l.added ? "added" : "";
    const p = l.position.map((v) => v.toFixed(2)).join(", ");
    tr.innerHTML = `<td class="id"></td><td class="group"></td><td class="pos num">${p}</td>
      <td><button type="button" class="aim" title="Aim: click a surface in the 3D view">Aim</button>
      <button type="button" class="del"></button></td>`;
    tr.querySelector(".id").textContent = l.id;
    tr.querySelector(".id").title = l.photometry || "";
    tr.querySelector(".group").textContent = l.group || "–";
    const del = tr.querySelector(".del");
    del.textContent = l.removed ? "↺" : "✕";
    del.title = l.removed ? "Put it back" : "Remove it";
    del.setAttribute("aria-label", `${l.removed ? "Restore" : "Remove"} ${l.id}`);
    del.addEventListener("click", () => remove(l));
    tr.querySelector(".aim").disabled = l.removed;
    tr.querySelector(".aim").addEventListener("click", () => {
      aiming = l.id;
      $("#lum-status").textContent = `Click a surface in the 3D view to aim ${l.id} at it.`;
    });
    return tr;
  });
  $("#lum-table tbody").replaceChildren(...rows);
  const edits = state.layout.length;
  $("#lum-status").textContent = edits
    ? `${edits} change${edits > 1 ? "s" : ""} for every answer; nothing is baked.`
    : "The scene's luminaires as baked.";
  if (viewer) viewer.redraw();
}

/** Removes a luminaire (a new one is dropped; the scene's is marked removed, or put back). */
function remove(l) {
  if (l.added) {
    state.layout = state.layout.filter((e) => e.id !== l.id);
  } else if (l.removed) {
    state.layout = state.layout.filter((e) => e.id !== l.id);
  } else {
    editOf(l.id).remove = true;
  }
  showLayout();
  changed();
}

/** Adds a luminaire of the chosen file and group where the 3D view looks, on the mounting
 *  height of the scene's luminaires (else just below the ceiling). */
function add() {
  if (state.layout.length >= MAX_LAYOUT || !viewer?.cam) return;
  const own = state.details.luminaires;
  const b = state.details.bounds;
  const y = +(own.length ? own[0].position[1] : b.max[1] - 0.05).toFixed(3);
  // Where the view's centre ray meets that plane, else above the point it looks at.
  const hit = planeHit(viewer.cam, viewer.aspect, 0, 0, y) || target(viewer.cam);
  const inside = (v, k) => Math.min(b.max[k] - 0.05, Math.max(b.min[k] + 0.05, v));
  const x = inside(snapped(hit[0]), 0);
  const z = inside(snapped(hit[2]), 2);
  let n = state.layout.length + 1;
  const taken = new Set(shownLuminaires().map((l) => l.id));
  while (taken.has(`new${n}`)) n++;
  state.layout.push({
    id: `new${n}`, position: [x, y, z], aim: [0, -1, 0],
    photometry: $("#lum-file").value, group: $("#lum-group").value || null, remove: false,
  });
  showLayout();
  changed();
}

/** Where the ray through (x, y) ∈ [-1, 1]² meets the plane at height y0, or null. */
function planeHit(cam, aspect, x, y, y0) {
  const { o, d } = rayThrough(cam, aspect, x, y);
  if (Math.abs(d[1]) < 1e-6) return null;
  const t = (y0 - o[1]) / d[1];
  return t > 0 ? [o[0] + t * d[0], y0, o[2] + t * d[2]] : null;
}

/** Draws the markers on the overlay (called after the grids' labels). */
export function drawLuminaires(g2) {
  if (!editable() || !viewer) return;
  for (const l of shownLuminaires()) {
    const q = viewer.project(l.position);
    if (!q) continue;
    g2.beginPath();
    g2.arc(q[0], q[1], MARKER, 0, 2 * Math.PI);
    g2.fillStyle = l.removed ? "rgba(120,120,120,0.5)" : l.added ? "#ffb000" : "#fff6c0";
    g2.fill();
    g2.lineWidth = 1.5;
    g2.strokeStyle = "#222";
    g2.stroke();
    const tip = viewer.project(l.position.map((v, k) => v + 0.4 * l.aim[k]));
    if (tip && !l.removed) {
      g2.beginPath();
      g2.moveTo(q[0], q[1]);
      g2.lineTo(tip[0], tip[1]);
      g2.stroke();
    }
  }
}

/** Pointer handling on the 3D view: a press near a marker drags that luminaire on its
 *  mounting plane (the view does not orbit); in aim mode a click aims it at the surface. */
export function wireLuminaires() {
  $("#lum-add").addEventListener("click", add);
  $("#lum-snap").addEventListener("change", () => {
    const v = Number($("#lum-snap").value);
    state.snap = Number.isFinite(v) && v >= 0 && v <= 10 ? v : 0.25;
    changed();
  });
  $("#lum-download").addEventListener("click", download);
  const c = $("#gl");
  let drag = null;
  const ndc = (ev) => {
    const r = c.getBoundingClientRect();
    return [((ev.clientX - r.left) / r.width) * 2 - 1, 1 - ((ev.clientY - r.top) / r.height) * 2];
  };
  c.addEventListener("pointerdown", (ev) => {
    if (!editable() || !viewer?.cam) return;
    const r = c.getBoundingClientRect();
    const [x, y] = [ev.clientX - r.left, ev.clientY - r.top];
    if (aiming) {
      const [nx, ny] = ndc(ev);
      const hit = mesh && pick(mesh, viewer.cam, viewer.aspect, nx, ny);
      const e = editOf(aiming);
      aiming = null;
      if (hit) {
        const d = hit.point.map((v, k) => v - e.position[k]);
        const len = Math.hypot(...d);
        if (len > 1e-6) e.aim = d.map((v) => +(v / len).toFixed(4));
        changed();
      }
      showLayout();
      ev.stopImmediatePropagation();
      return;
    }
    const near = shownLuminaires()
      .filter((l) => !l.removed)
      .map((l) => ({ l, q: viewer.project(l.position) }))
      .filter(({ q }) => q && Math.hypot(q[0] - x, q[1] - y) <= GRAB)
      .sort((a, b) => a.q[2] - b.q[2])[0];
    if (!near) return;
    drag = { id: near.l.id, y: near.l.position[1] };
    try {
      c.setPointerCapture(ev.pointerId);
    } catch {
      // A synthetic event has no active pointer to capture.
    }
    ev.stopImmediatePropagation();
  }, { capture: true });
  c.addEventListener("pointermove", (ev) => {
    if (!drag) return;
    ev.stopImmediatePropagation();
    const [nx, ny] = ndc(ev);
    const p = planeHit(viewer.cam, viewer.aspect, nx, ny, drag.y);
    if (!p) return;
    const b = state.details.bounds;
    const inside = (v, k) => Math.min(b.max[k] - 0.01, Math.max(b.min[k] + 0.01, v));
    const e = editOf(drag.id);
    e.position = [inside(snapped(p[0]), 0), drag.y, inside(snapped(p[2]), 2)];
    showLayout();
    changed();
  }, { capture: true });
  const end = (ev) => {
    if (!drag) return;
    drag = null;
    ev.stopImmediatePropagation();
  };
  c.addEventListener("pointerup", end, { capture: true });
  c.addEventListener("pointercancel", end, { capture: true });
}

/** The layout as scene.toml `[[luminaires]]` tables: every luminaire that stays, at its
 *  place, so the next bake keeps the layout. */
export function layoutToml() {
  const num = (v) => +v.toFixed(4);
  const arr = (v) => `[${v.map(num).join(", ")}]`;
  const q = (s) => JSON.stringify(s);
  const lines = [
    `# The luminaire layout of ${q(state.details.id)} from relight's page: replace the`,
    "# scene's [[luminaires]] tables with these, then bake again.",
  ];
  const own = new Map(state.details.luminaires.map((l) => [l.id, l]));
  for (const l of shownLuminaires()) {
    if (l.removed) continue;
    lines.push("", "[[luminaires]]", `id = ${q(l.id)}`);
    if (l.group) lines.push(`group = ${q(l.group)}`);
    if (l.photometry) lines.push(`photometry = ${q(l.photometry)}`);
    lines.push(`position = ${arr(l.position)}`, `aim = ${arr(l.aim)}`);
    const o = own.get(l.id);
    if (o && !l.added) {
      lines.push(`lumens = ${num(o.lumens)}`);
      if (o.watts != null) lines.push(`watts = ${num(o.watts)}`);
    }
  }
  return lines.join("\n") + "\n";
}

function download() {
  const blob = new Blob([layoutToml()], { type: "application/toml" });
  const a = document.createElement("a");
  a.href = URL.createObjectURL(blob);
  a.download = `${state.details.id}-luminaires.toml`;
  a.click();
  setTimeout(() => URL.revokeObjectURL(a.href), 1000);
}
