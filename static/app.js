// relight web page: light controls, the server's relit image, and a WebGL walkthrough.
// This entry module only wires the others together:
//   util.js      DOM lookup, banner, colour conversion, lux formatting
//   state.js     the page state, its version, defaults and the URL hash
//   api.js       the API client (fetch helpers, problem documents, single flight, scenes)
//   controls.js  light groups, camera picker, false colour/exposure, grids and optimizer
//   views/       image.js (server image), gl.js (WebGL view, legend), grids.js (grid
//                statistics, overlay), hover.js (surface under the pointer)
//   viewer.js    the WebGL viewer itself
//   models.js    the "Open model" upload dialog and the glTF export link
//   sky.js       the daylight panel (sky, sun time, daylight factor, annual metrics)
//   report.js    the "Report" button (the printable design report in a new tab)
//   luminaires.js the luminaire layout: markers, drag, aim, add, remove, scene.toml
//
// Data flow: every control change bumps `state.version` (changed() in state.js) and asks
// both views to update (onChange below). Each view has at most one request in flight;
// changes made meanwhile are coalesced into one follow-up request for the newest state
// (no queue). Changing scene aborts both. The URL hash always holds the state, so a
// what-if can be shared as a link.

import { $, showBanner } from "./util.js";
import { state, changed, setOnChange, resetForScene, writeHash, readHash } from "./state.js";
import { loadSceneList, loadScene } from "./api.js";
import { wireControls, buildLightControls, buildCameraSelect, setupGrids, showExposure, updateFluxLabels } from "./controls.js";
import { viewer, createViewer, loadMesh, showMesh, glFlight } from "./views/gl.js";
import { imageFlight } from "./views/image.js";
import { gridFlight, drawOverlay } from "./views/grids.js";
import { attachHover, resetSurfaceCache } from "./views/hover.js";
import { wireModels } from "./models.js";
import { wireSky, setupSky } from "./sky.js";
import { wireReport } from "./report.js";
import { wireLuminaires, setupLuminaires, layoutToml } from "./luminaires.js";

/** After every change: labels, URL hash, and a request for each view. */
function onChange() {
  updateFluxLabels();
  writeHash(viewer?.cam);
  imageFlight();
  glFlight();
  if (state.details && state.details.grids && state.details.grids.length) gridFlight();
}

async function selectScene(id, hash = {}) {
  imageFlight.abort();
  glFlight.abort();
  state.scene = id;
  state.details = null;
  $("#scene").value = id;
  $("#lights").replaceChildren();
  $("#scene-info").textContent = "";
  const loaded = await loadScene(id);
  if (loaded) showScene(loaded.details, loaded.buf, loaded.previewBuf, hash);
}

/** Shows a loaded scene: fresh state (with the URL hash applied), controls and views. */
function showScene(details, buf, previewBuf, hash) {
  state.details = details;
  loadMesh(buf, previewBuf);
  resetSurfaceCache();
  resetForScene(hash);
  $("#scene-info").textContent = `${details.patches.toLocaleString()} patches · ${details.transfer} transfer`;
  buildLightControls();
  buildCameraSelect();
  setupLuminaires();
  $("#falsecolor").checked = state.falsecolor;
  state.gridStats = null;
  setupGrids();
  setupSky();
  showExposure();
  showMesh(hash.v);
  changed();
  window.relight.ready = true;
}

async function main() {
  setOnChange(onChange);
  window.relight = {
    ready: false,
    stats: { imagesShown: 0, imageVersion: -1, glFrames: 0, glVersion: -1 },
    get state() { return state; },
    measureFps: (frames) => viewer.measureFps(frames),
    // For tests: where a world point is drawn in the 3D view, and the layout's scene.toml.
    project: (p) => viewer.project(p),
    layoutToml,
  };
  try {
    createViewer($("#gl"));
  } catch (e) {
    showBanner(`3D view unavailable: ${e.message}`, "error");
    return;
  }
  viewer.attachControls();
  viewer.afterDraw = drawOverlay;
  let hashTimer = null;
  viewer.onchange = () => {
    clearTimeout(hashTimer);
    hashTimer = setTimeout(() => writeHash(viewer.cam), 200);
  };
  new ResizeObserver(() => viewer.redraw()).observe($("#gl"));
  $("#scene").addEventListener("change", (e) => {
    history.replaceState(null, "", "#scene=" + encodeURIComponent(e.target.value));
    selectScene(e.target.value);
  });
  wireControls();
  attachHover();
  wireModels(openUploaded);
  wireSky();
  wireReport();
  wireLuminaires();
  window.addEventListener("resize", () => imageFlight());
  await openFirstScene();
}

/** After an upload has baked: the scene picker lists it, and it is shown. */
async function openUploaded(id) {
  const scenes = await loadSceneList();
  const sel = $("#scene");
  sel.replaceChildren(...scenes.map((s) => new Option(s.name || s.id, s.id)));
  history.replaceState(null, "", "#scene=" + encodeURIComponent(id));
  await selectScene(id);
}

/** Fills the scene picker and opens the scene named in the URL hash (or the first ready). */
async function openFirstScene() {
  let scenes;
  try {
    scenes = await loadSceneList();
  } catch (e) {
    return showBanner(`Cannot reach the server: ${e.message}`, "error");
  }
  if (!scenes.length) return showBanner("No scenes: start the server with --scenes DIR.", "error");
  const sel = $("#scene");
  for (const s of scenes) sel.append(new Option(s.name || s.id, s.id));
  const h = readHash();
  const first = scenes.find((s) => s.id === h.scene) || scenes.find((s) => s.status === "ready") || scenes[0];
  await selectScene(first.id, h.scene === first.id ? h : {});
}

main();
