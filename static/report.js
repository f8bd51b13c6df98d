// The "Report" button: opens the printable design report (GET /api/scenes/{id}/report) of
// the current scene and lighting state in a new tab; the browser prints it to PDF. With a
// luminaire layout the report is asked by POST (the layout rides in the body) and shown
// from the answer.

import { $, showBanner } from "./util.js";
import { state, lightingJson, lightingBody } from "./state.js";
import { postJson, problem } from "./api.js";

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
  $("#report-button").addEventListener("click", async () => {
    if (!state.details) return;
    if (!state.layout.length) {
      window.open(reportUrl(), "_blank", "noopener");
      return;
    }
    // Opened now, while the click still counts as the user's, and filled when it comes.
    const tab = window.open("", "_blank");
    const body = lightingBody();
    if (state.exposure !== null) body.exposure = state.exposure;
    const r = await postJson("/report", body);
    if (!r.ok) {
      if (tab) tab.close();
      showBanner(`Report: ${await problem(r)}`, "error");
      return;
    }
    const url = URL.createObjectURL(new Blob([await r.text()], { type: "text/html" }));
    if (tab) tab.location = url;
    setTimeout(() => URL.revokeObjectURL(url), 60000);
  });
}
