// The daylight panel, for scenes with a [site]: the sky (off, CIE overcast, CIE clear with
// the sun at a date and time, uniform) and its illuminance, the daylight-factor scale for
// false colour, and the annual climate-based metrics of a grid from a weather file in the
// scene's folder. skyJson() is the `sky` every request of the page carries.

import { $ } from "./util.js";
import { state, changed } from "./state.js";
import { postJson, problem } from "./api.js";

/** The sky of the page, or null (no sky: electric light only). */
export function skyJson() {
  const s = state.sky;
  if (!state.details || !state.details.site || !s || s.type === "off") return null;
  if (s.type === "cie_clear") {
    const h = Math.floor(s.hour), m = Math.round((s.hour - h) * 60);
    const hhmm = `${String(h).padStart(2, "0")}:${String(m).padStart(2, "0")}`;
    return {
      type: "cie_clear",
      horizontal_illuminance: s.eh,
      direct_normal_illuminance: s.edn,
      time: `${s.date}T${hhmm}`,
    };
  }
  return { type: s.type, horizontal_illuminance: s.eh };
}

export function defaultSky() {
  return { type: "off", eh: 10000, edn: 70000, date: "2026-06-21", hour: 12 };
}

/** Per scene: the panel shows for scenes with a site, with its weather files and grids. */
export function setupSky() {
  const site = state.details.site;
  $("#sky-section").hidden = !site;
  if (!site) return;
  state.sky = state.sky || defaultSky();
  $("#sky-site").textContent =
    `${Math.abs(site.latitude).toFixed(2)}° ${site.latitude >= 0 ? "N" : "S"}, ` +
    `${Math.abs(site.longitude).toFixed(2)}° ${site.longitude >= 0 ? "E" : "W"}, UTC${site.timezone >= 0 ? "+" : ""}${site.timezone}`;
  const wsel = $("#annual-weather");
  wsel.replaceChildren(...site.weather_files.map((f) => new Option(f, f)));
  const gsel = $("#annual-grid");
  gsel.replaceChildren(...state.details.grids.map((g) => new Option(g.name || g.id, g.id)));
  $("#annual-run").disabled = !site.weather_files.length || !state.details.grids.length;
  $("#annual-out").replaceChildren();
  showSky();
}

/** The controls from state.sky. */
function showSky() {
  const s = state.sky;
  $("#sky-type").value = s.type;
  $("#sky-eh").value = s.eh;
  $("#sky-date").value = s.date;
  $("#sky-hour").value = s.hour;
  $("#sky-hour-out").textContent = fmtHour(s.hour);
  $("#sky-clear").hidden = s.type !== "cie_clear";
  $("#sky-df").hidden = s.type !== "cie_overcast";
}

function fmtHour(h) {
  const hh = Math.floor(h), mm = Math.round((h - hh) * 60);
  return `${String(hh).padStart(2, "0")}:${String(mm).padStart(2, "0")}`;
}

/** Listeners, once. */
export function wireSky() {
  const set = (k, v) => {
    state.sky[k] = v;
    state.exposure = null;
    showSky();
    changed();
  };
  $("#sky-type").addEventListener("change", (e) => {
    const t = e.target.value;
    state.sky.eh = t === "cie_clear" ? 15000 : 10000;
    set("type", t);
  });
  $("#sky-eh").addEventListener("change", (e) => {
    const v = Number(e.target.value);
    if (Number.isFinite(v) && v >= 0 && v <= 200000) set("eh", v);
  });
  $("#sky-date").addEventListener("change", (e) => {
    if (/^\d{4}-\d{2}-\d{2}$/.test(e.target.value)) set("date", e.target.value);
  });
  $("#sky-hour").addEventListener("input", (e) => {
    state.sky.hour = Number(e.target.value);
    $("#sky-hour-out").textContent = fmtHour(state.sky.hour);
    changed();
  });
  // Daylight factor in false colour: the overcast sky at 10,000 lx puts DF = lux / 100,
  // and the scale is fixed to 0.5 … 20 % (50 … 2,000 lx).
  $("#sky-df-show").addEventListener("click", () => {
    state.sky.eh = 10000;
    state.falsecolor = true;
    state.range = [50, 2000];
    $("#falsecolor").checked = true;
    showSky();
    changed();
  });
  $("#annual-run").addEventListener("click", runAnnual);
}

async function runAnnual() {
  const out = $("#annual-out");
  const grid = $("#annual-grid").value;
  const body = {
    weather: $("#annual-weather").value,
    grids: [grid],
    occupied: [$("#annual-from").value, $("#annual-to").value],
  };
  out.textContent = "Computing a year of skies…";
  const t0 = performance.now();
  const r = await postJson("/annual", body);
  if (!r.ok) {
    out.textContent = await problem(r);
    return;
  }
  const v = await r.json();
  const g = v.grids[grid];
  const rows = [
    ["sDA300/50%", `${g.sda_300_50.toFixed(1)} % of points`],
    ["ASE1000,250h", `${g.ase_1000_250.toFixed(1)} % of points`],
    ["UDI < 100 lx", `${g.udi.below_100.toFixed(1)} % of hours`],
    ["UDI 100–3000 lx", `${g.udi.from_100_to_3000.toFixed(1)} % of hours`],
    ["UDI > 3000 lx", `${g.udi.above_3000.toFixed(1)} % of hours`],
    ["EN 17037: 300 lx over 50 %", `${g.en17037.hours_300_lx_over_50_percent.toFixed(1)} % of daylight hours`],
    ["EN 17037: 100 lx over 95 %", `${g.en17037.hours_100_lx_over_95_percent.toFixed(1)} % of daylight hours`],
    ["EN 17037 minimum level", g.en17037.minimum_level_met ? "met" : "not met"],
  ];
  const table = document.createElement("table");
  table.id = "annual-table";
  for (const [k, val] of rows) {
    const tr = table.insertRow();
    tr.insertCell().textContent = k;
    tr.insertCell().textContent = val;
  }
  const note = document.createElement("p");
  note.className = "hint";
  note.textContent = `${v.weather.city}: ${v.weather.occupied_hours} occupied hours, ` +
    `${g.count} points, ${(performance.now() - t0).toFixed(0)} ms`;
  out.replaceChildren(table, note);
}
