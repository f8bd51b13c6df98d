// The "Report" button: opens the printable design report (GET /api/scenes/{id}/report) of
// the current scene and lighting state in a new tab; the browser prints it to PDF.

import { $ } from "./util.js";
import { state, lightingJson } from "./state.js";

/** The report URL for the current scene, light groups and exposure. */
export function reportUrl() {
  const q = new URLSearchParams();
  for (const [id, s] of Object.entries(lightingJson())) {
    // light.ID=r,g,b means intensity 1 at that colour: the weight is intensity × colour.
    q.set(`light.${id}`, s.color.map((c) => +(c * s.intensity).toPrecision(6)).join(","));
  }
  if (state.exposure !== null) q.set("exposure", state.exposure.toFixed(2));
  return `/api/scenes/${encodeURIComponent(state.scene)}/report?${q}`;
}

/** Wires the button. */
export function wireReport() {
  $("#report-button").addEventListener("click", () => {
    if (!state.details) return;
    window.open(reportUrl(), "_blank", "noopener");
  });
}
