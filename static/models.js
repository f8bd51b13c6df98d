// Models in and out: the "Open model" dialog (PUT /api/scenes/{id} with a .glb or a zipped
// scene folder, the admin token, then the bake's progress) and the "Export glTF" link
// (GET /api/scenes/{id}/export.glb with the page's lighting and exposure; a POST with the
// luminaire layout when there is one).

import { $, showBanner } from "./util.js";
import { state, lightingJson, lightingBody } from "./state.js";
import { postJson, problem } from "./api.js";

const TOKEN_KEY = "relight.adminToken";

/** A scene id from a file name: lower case, runs of other characters than a-z0-9 as '-'. */
export function idFromName(name) {
  return name
    .replace(/\.(glb|zip)$/i, "")
    .toLowerCase()
    .replace(/[^a-z0-9]+/g, "-")
    .replace(/^-+|-+$/g, "")
    .slice(0, 64);
}

/** The export URL for the current scene and lighting state. */
export function exportUrl() {
  const q = new URLSearchParams();
  for (const [id, s] of Object.entries(lightingJson())) {
    // light.ID=r,g,b means intensity 1 at that colour: the weight is intensity × colour.
    q.set(`light.${id}`, s.color.map((c) => +(c * s.intensity).toPrecision(6)).join(","));
  }
  if (state.exposure !== null) q.set("exposure", state.exposure.toFixed(2));
  return `/api/scenes/${encodeURIComponent(state.scene)}/export.glb?${q}`;
}

/** Wires the dialog. `onReady(id)` is called when an uploaded scene has baked. */
export function wireModels(onReady) {
  const dlg = $("#open-model");
  const file = $("#model-file"), id = $("#model-id"), token = $("#model-token");
  const out = $("#model-status"), send = $("#model-upload"), drop = $("#model-drop");
  const progress = $("#model-progress");
  let chosen = null, poll = null;

  const say = (text, error = false) => {
    out.textContent = text;
    out.className = error ? "hint error-text" : "hint";
  };
  const choose = (f) => {
    if (!f) return;
    if (!/\.(glb|zip)$/i.test(f.name)) return say(`${f.name}: choose a .glb file or a .zip of a scene folder`, true);
    chosen = f;
    drop.querySelector("span").textContent = `${f.name} (${(f.size / 1048576).toFixed(1)} MB)`;
    if (!id.value || id.dataset.auto === "1") {
      id.value = idFromName(f.name);
      id.dataset.auto = "1";
    }
    say("");
    send.disabled = false;
  };

  $("#open-model-button").addEventListener("click", () => {
    token.value = sessionStorage.getItem(TOKEN_KEY) || "";
    say("");
    progress.hidden = true;
    dlg.showModal();
  });
  dlg.addEventListener("close", () => clearTimeout(poll));
  $("#model-cancel").addEventListener("click", () => dlg.close());
  id.addEventListener("input", () => (id.dataset.auto = "0"));
  file.addEventListener("change", () => choose(file.files[0]));
  drop.addEventListener("click", () => file.click());
  drop.addEventListener("keydown", (e) => {
    if (e.key === "Enter" || e.key === " ") { e.preventDefault(); file.click(); }
  });
  drop.addEventListener("dragover", (e) => { e.preventDefault(); drop.classList.add("over"); });
  drop.addEventListener("dragleave", () => drop.classList.remove("over"));
  drop.addEventListener("drop", (e) => {
    e.preventDefault();
    drop.classList.remove("over");
    choose(e.dataTransfer.files[0]);
  });

  send.addEventListener("click", () => {
    if (!chosen) return say("Choose a .glb or .zip first.", true);
    if (!/^[a-z0-9-]{1,64}$/.test(id.value)) return say("Scene id: 1 to 64 characters a-z, 0-9 and '-'.", true);
    sessionStorage.setItem(TOKEN_KEY, token.value);
    const xhr = new XMLHttpRequest();
    xhr.open("PUT", `/api/scenes/${encodeURIComponent(id.value)}`);
    xhr.setRequestHeader("Content-Type", /\.glb$/i.test(chosen.name) ? "model/gltf-binary" : "application/zip");
    if (token.value) xhr.setRequestHeader("Authorization", `Bearer ${token.value}`);
    progress.hidden = false;
    progress.removeAttribute("value");
    xhr.upload.onprogress = (e) => {
      if (e.lengthComputable) progress.value = e.loaded / e.total;
    };
    xhr.onerror = () => { send.disabled = false; say("The upload failed: the server could not be reached.", true); };
    xhr.onload = async () => {
      send.disabled = false;
      if (xhr.status !== 202) {
        progress.hidden = true;
        const detail = await problem(new Response(xhr.responseText, { status: xhr.status }));
        return say(`${xhr.status}: ${detail}`, true);
      }
      const body = JSON.parse(xhr.responseText);
      const warn = body.warnings && body.warnings.length ? ` ${body.warnings.length} warning(s): ${body.warnings.join("; ")}` : "";
      say(`Stored ${body.files} files; baking…${warn}`);
      watch(body.id);
    };
    send.disabled = true;
    say("Uploading…");
    xhr.send(chosen);
  });

  /** Polls the scene until it is ready (then opens it) or failed. */
  function watch(sceneId) {
    clearTimeout(poll);
    const step = async () => {
      if (!dlg.open) return;
      const r = await fetch("/api/scenes");
      const s = r.ok ? (await r.json()).scenes.find((x) => x.id === sceneId) : null;
      if (s && s.status === "ready") {
        say(`${sceneId} is ready.`);
        dlg.close();
        return onReady(sceneId);
      }
      if (s && s.status === "failed") return say(`The bake failed: ${s.error}`, true);
      if (s) progress.value = s.progress || 0;
      poll = setTimeout(step, 500);
    };
    step();
  }

  // The export link follows the page's state when it is used.
  const link = $("#export-glb");
  const refresh = () => { if (state.details) link.href = exportUrl(); };
  link.addEventListener("pointerenter", refresh);
  link.addEventListener("focus", refresh);
  link.addEventListener("click", async (ev) => {
    refresh();
    if (!state.details || !state.layout.length) return;
    // A luminaire layout rides in a POST body: fetch the file, then save it.
    ev.preventDefault();
    const body = lightingBody();
    if (state.exposure !== null) body.exposure = state.exposure;
    const r = await postJson("/export.glb", body, { binary: true });
    if (!r.ok) return showBanner(`Export: ${await problem(r)}`, "error");
    const a = document.createElement("a");
    a.href = URL.createObjectURL(await r.blob());
    a.download = `${state.scene}.glb`;
    a.click();
    setTimeout(() => URL.revokeObjectURL(a.href), 10000);
  });
}
