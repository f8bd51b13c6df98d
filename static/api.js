// The API client: scene URLs, a JSON POST helper, problem documents (RFC 9457) turned into
// messages, the single-flight request helper, and the scene list / scene loading calls.

import { showBanner } from "./util.js";
import { state } from "./state.js";

/** The URL of `path` under the current scene, e.g. sceneUrl("/render"). */
export const sceneUrl = (path) => `/api/scenes/${encodeURIComponent(state.scene)}${path}`;

/** POSTs `body` as JSON to `path` under the current scene; `binary` asks for octet-stream. */
export function postJson(path, body, { signal, binary = false } = {}) {
  const headers = { "content-type": "application/json" };
  if (binary) headers.accept = "application/octet-stream";
  return fetch(sceneUrl(path), { method: "POST", headers, body: JSON.stringify(body), signal });
}

/** The message of an error response: its problem document's detail or title, or the status. */
export async function problem(resp) {
  try {
    const p = await resp.json();
    return p.detail || p.title || `${resp.status}`;
  } catch {
    return `${resp.status} ${resp.statusText}`;
  }
}

/** At most one run in flight; calls made meanwhile coalesce into one more run. */
export function singleFlight(fn) {
  let running = false, again = false, ctrl = null;
  const run = async () => {
    if (running) {
      again = true;
      return;
    }
    running = true;
    try {
      do {
        again = false;
        ctrl = new AbortController();
        try {
          await fn(ctrl.signal);
        } catch (e) {
          if (e.name !== "AbortError") showBanner(String(e.message || e), "error");
        }
      } while (again);
    } finally {
      running = false;
    }
  };
  run.abort = () => {
    again = false;
    if (ctrl) ctrl.abort();
  };
  return run;
}

// ------------------------------------------------------------------ scenes

export async function loadSceneList() {
  const r = await fetch("/api/scenes");
  if (!r.ok) throw new Error(await problem(r));
  return (await r.json()).scenes;
}

let pollTimer = null;

/** Polls the scene list until scene `id` is ready (true), showing bake progress in the
 *  banner; false if it failed, does not exist, or another scene was selected meanwhile. */
async function waitUntilReady(id) {
  for (;;) {
    const scenes = await loadSceneList();
    if (state.scene !== id) return false;
    const s = scenes.find((x) => x.id === id);
    if (!s) {
      showBanner(`Scene '${id}' does not exist.`, "error");
      return false;
    }
    if (s.status === "ready") return true;
    if (s.status === "failed") {
      showBanner(`Scene '${id}' failed to load: ${s.error}`, "error");
      return false;
    }
    const pct = Math.round(100 * (s.progress || 0));
    showBanner(`Scene '${id}' is ${s.status === "queued" ? "queued for baking" : `baking: ${pct} %`}. It appears here when ready.`, "info", s.progress || 0);
    await new Promise((res) => (pollTimer = setTimeout(res, 500)));
    if (state.scene !== id) return false;
  }
}

/** Loads scene `id` (already in state.scene) once it is ready: {details, buf} with its
 *  details and binary mesh, or null (failure shown in the banner, or scene changed). */
export async function loadScene(id) {
  clearTimeout(pollTimer);
  if (!(await waitUntilReady(id))) return null;
  showBanner("");
  const [dr, mr] = await Promise.all([fetch(sceneUrl("")), fetch(sceneUrl("/mesh"))]);
  for (const r of [dr, mr]) {
    if (!r.ok) {
      showBanner(await problem(r), "error");
      return null;
    }
  }
  const details = await dr.json();
  const buf = await mr.arrayBuffer();
  // Large scenes also have a coarser preview mesh, drawn while the camera moves (the
  // server makes one above 60,000 patches).
  let previewBuf = null;
  if (details.patches > PREVIEW_ABOVE) {
    const pr = await fetch(sceneUrl("/mesh/preview"));
    if (pr.ok) previewBuf = await pr.arrayBuffer();
  }
  if (state.scene !== id) return null;
  return { details, buf, previewBuf };
}

/** Scenes with more patches than this have a preview mesh (render/preview.rs). */
const PREVIEW_ABOVE = 60000;
