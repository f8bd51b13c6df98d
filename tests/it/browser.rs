//! The web page in real headless Chromium, driven over WebDriver (chromedriver).
//!
//! Needs Debian's `chromium` and `chromium-driver` (`.ci/run` installs them). Without them
//! the test says so and passes, unless `RELIGHT_REQUIRE_BROWSER=1` (set by CI), where a
//! missing browser fails it. Timings are reported (stderr and
//! `target/tmp/browser-report.json`), never asserted; the test holds `common::alone()` so
//! that no other test competes for the cores meanwhile.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use relight::server::{router, AppState, ServerConfig, DEFAULT_BODY_LIMIT};
use serde_json::{json, Value};

use crate::common;

/// A chromedriver child process, killed on drop.
pub(crate) struct Driver(Child);

impl Drop for Driver {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// The admin token of the browser test's server (the page uploads a model with it).
const BROWSER_TOKEN: &str = "browser-test-token-0123456789";

/// A WebDriver session.
pub(crate) struct Session {
    http: reqwest::Client,
    base: String,
}

impl Session {
    pub(crate) async fn cmd(&self, method: reqwest::Method, path: &str, body: Value) -> Value {
        let url = format!("{}{path}", self.base);
        let req = self.http.request(method, &url);
        let req = if body.is_null() { req } else { req.json(&body) };
        let resp = req.send().await.unwrap_or_else(|e| panic!("{url}: {e}"));
        let v: Value = resp.json().await.unwrap();
        if let Some(err) = v["value"].get("error") {
            panic!("WebDriver {path}: {err} {}", v["value"]["message"]);
        }
        v["value"].clone()
    }

    pub(crate) async fn post(&self, path: &str, body: Value) -> Value {
        self.cmd(reqwest::Method::POST, path, body).await
    }

    /// Runs `script` (a function body) in the page and returns its value.
    pub(crate) async fn js(&self, script: &str) -> Value {
        self.post("/execute/sync", json!({"script": script, "args": []}))
            .await
    }

    /// Runs an async script: the body gets a callback as its last argument.
    async fn js_async(&self, script: &str) -> Value {
        self.post("/execute/async", json!({"script": script, "args": []}))
            .await
    }

    /// Polls `cond` (a JS expression) until it is true.
    pub(crate) async fn wait_for(&self, cond: &str, what: &str) {
        let t = Instant::now();
        while t.elapsed() < Duration::from_secs(60) {
            if self.js(&format!("return !!({cond});")).await == json!(true) {
                return;
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        let banner = self
            .js("return document.querySelector('#banner-text').textContent;")
            .await;
        let errors = self.console_errors().await;
        panic!("timed out waiting for {what} ({cond}); banner: {banner}; console: {errors:?}");
    }

    async fn element(&self, css: &str) -> String {
        let v = self
            .post("/element", json!({"using": "css selector", "value": css}))
            .await;
        v.as_object()
            .and_then(|o| o.values().next())
            .and_then(|v| v.as_str())
            .unwrap_or_else(|| panic!("no element {css}"))
            .to_string()
    }

    async fn click(&self, css: &str) {
        let id = self.element(css).await;
        self.post(&format!("/element/{id}/click"), json!({})).await;
    }

    /// Severe browser-console entries (errors, uncaught exceptions, failed loads).
    async fn console_errors(&self) -> Vec<String> {
        let v = self.post("/se/log", json!({"type": "browser"})).await;
        v.as_array()
            .into_iter()
            .flatten()
            .filter(|e| e["level"] == "SEVERE")
            .map(|e| e["message"].as_str().unwrap_or("").to_string())
            .collect()
    }
}

/// Mean sRGB brightness (0..255) and a checksum of a canvas, read in the page.
const CANVAS_STATS: &str = r#"
    const c = document.querySelector(arguments[0]);
    const t = document.createElement('canvas');
    t.width = c.width; t.height = c.height;
    const g = t.getContext('2d');
    g.drawImage(c, 0, 0);
    const d = g.getImageData(0, 0, t.width, t.height).data;
    let sum = 0, hash = 0, lit = 0;
    for (let i = 0; i < d.length; i += 4) {
        const y = (d[i] + d[i + 1] + d[i + 2]) / 3;
        sum += y;
        if (y > 40) lit++;
        hash = (hash * 31 + d[i] + 7 * d[i + 1] + 13 * d[i + 2]) % 1000000007;
    }
    return {mean: sum / (d.length / 4), lit: lit / (d.length / 4), hash, w: t.width, h: t.height};
"#;

async fn canvas(s: &Session, css: &str) -> Value {
    s.post(
        "/execute/sync",
        json!({"script": CANVAS_STATS, "args": [css]}),
    )
    .await
}

/// Sets a range input and fires `input` and `change` as a user's drag would; returns
/// the page's new state version.
async fn set_slider(s: &Session, css: &str, value: u32) -> u64 {
    let css = serde_json::to_string(css).unwrap();
    s.js(&format!(
        "const e = document.querySelector({css}); e.value = {value};
         e.dispatchEvent(new Event('input', {{bubbles: true}}));
         e.dispatchEvent(new Event('change', {{bubbles: true}}));
         return window.relight.state.version;"
    ))
    .await
    .as_u64()
    .unwrap()
}

async fn image_for(s: &Session, version: u64) {
    s.wait_for(
        &format!("window.relight.stats.imageVersion >= {version}"),
        "the relit image",
    )
    .await;
}

/// Picks `scene` in the page's scene picker and waits until it is loaded, the 3D view
/// shows the current state, and `also` (a JS expression) holds.
async fn switch_scene(s: &Session, scene: &str, also: &str) {
    s.js(&format!(
        "const e = document.querySelector('#scene'); e.value = '{scene}';
         e.dispatchEvent(new Event('change'));"
    ))
    .await;
    s.wait_for(
        &format!(
            "window.relight.state.details && window.relight.state.details.id === '{scene}' \
             && window.relight.stats.glVersion === window.relight.state.version && ({also})"
        ),
        scene,
    )
    .await;
}

/// [`find_driver`], or None after saying the test is skipped (a panic instead when
/// `RELIGHT_REQUIRE_BROWSER=1`, as in CI).
fn driver_or_skip() -> Option<(PathBuf, PathBuf)> {
    let found = find_driver();
    if found.is_none() {
        let msg = "chromium/chromedriver not found (apt-get install chromium chromium-driver)";
        if std::env::var("RELIGHT_REQUIRE_BROWSER").as_deref() == Ok("1") {
            panic!("{msg}");
        }
        eprintln!("SKIPPED the browser test: {msg}");
    }
    found
}

pub(crate) fn find_driver() -> Option<(PathBuf, PathBuf)> {
    let driver = std::env::var_os("RELIGHT_CHROMEDRIVER")
        .map(PathBuf::from)
        .unwrap_or_else(|| "/usr/bin/chromedriver".into());
    let browser = std::env::var_os("RELIGHT_CHROMIUM")
        .map(PathBuf::from)
        .unwrap_or_else(|| "/usr/bin/chromium".into());
    (driver.exists() && browser.exists()).then_some((driver, browser))
}

/// Bundled Cornell box and desk room plus an 8-group room of ~10k patches for the frame
/// rate, baked once (cache under target/tmp).
fn scenes() -> (PathBuf, PathBuf) {
    let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("browser");
    let scenes = root.join("scenes");
    for id in ["cornell-box", "desk-room", "office"] {
        let dst = scenes.join(id);
        std::fs::create_dir_all(&dst).unwrap();
        for f in std::fs::read_dir(common::scenes_dir().join(id)).unwrap() {
            let f = f.unwrap();
            if f.file_type().unwrap().is_file() {
                std::fs::copy(f.path(), dst.join(f.file_name())).unwrap();
            }
        }
    }
    // The test uploads this one through the page.
    let _ = std::fs::remove_dir_all(scenes.join("little-box"));
    let room = scenes.join("room-10k");
    std::fs::create_dir_all(&room).unwrap();
    relight::bench::write_group_room(&room, 8, 8200).unwrap();
    (scenes, root.join("cache"))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_page_relights_live_in_headless_chromium() {
    let Some((driver_bin, browser_bin)) = driver_or_skip() else {
        return;
    };
    let _gate = common::alone();
    // The server, on a loopback port, with every scene baked first.
    let (scene_dir, cache) = scenes();
    let (site, server) = serve(scene_dir, cache).await;
    let (s, _driver, _profile) = open_session(&driver_bin, &browser_bin).await;

    // ---- Load the page on the Cornell box; wait for both views.
    s.post("/url", json!({"url": format!("{site}/#scene=cornell-box")}))
        .await;
    s.wait_for(
        "window.relight && window.relight.ready && window.relight.stats.imagesShown > 0 \
         && window.relight.stats.glFrames > 0 && window.relight.state.exposure !== null",
        "the Cornell box",
    )
    .await;
    // The exposure is metered once; wait for the image made with the locked exposure.
    let v0 = s
        .js("return window.relight.state.version;")
        .await
        .as_u64()
        .unwrap();
    image_for(&s, v0).await;
    let slider = ".light[data-id='ceiling'] .pct";
    let base = canvas(&s, "#image").await;
    assert!(base["mean"].as_f64().unwrap() > 5.0, "dark image: {base}");

    // ---- Move the slider: the image changes, and brightness rises with intensity.
    let v = set_slider(&s, slider, 200).await;
    image_for(&s, v).await;
    let bright = canvas(&s, "#image").await;
    assert_ne!(bright["hash"], base["hash"], "the image did not change");
    let v = set_slider(&s, slider, 40).await;
    image_for(&s, v).await;
    let dim = canvas(&s, "#image").await;
    let (m_dim, m_base, m_bright) = (
        dim["mean"].as_f64().unwrap(),
        base["mean"].as_f64().unwrap(),
        bright["mean"].as_f64().unwrap(),
    );
    assert!(
        m_dim < m_base && m_base < m_bright,
        "brightness at 40/100/200 %: {m_dim} {m_base} {m_bright}"
    );

    // ---- Change → image on screen, from performance marks, over 30 slider releases.
    let mut lat = vec![];
    for k in 0..30 {
        let v = set_slider(&s, slider, 50 + (k * 37) % 150).await;
        image_for(&s, v).await;
        let st = s.js("return window.relight.stats;").await;
        lat.push(st["changeToScreenMs"].as_f64().unwrap());
    }
    lat.sort_by(f64::total_cmp);
    let (p50, p90) = (lat[lat.len() / 2], lat[lat.len() * 9 / 10]);
    let rtt = s.js("return window.relight.stats.rttMs;").await;

    // ---- The URL holds the state: a reload restores the slider and the light.
    let v = set_slider(&s, slider, 150).await;
    image_for(&s, v).await;
    let hash = s.js("return location.hash;").await;
    assert!(
        hash.as_str()
            .unwrap()
            .contains("l=ceiling%3A150%3Affffff%3A1"),
        "{hash}"
    );
    let url = s.js("return location.href;").await;
    s.post("/url", json!({"url": "about:blank"})).await;
    s.post("/url", json!({"url": url})).await;
    s.wait_for(
        "window.relight && window.relight.ready && window.relight.stats.imagesShown > 0",
        "the reloaded page",
    )
    .await;
    let q = serde_json::to_string(slider).unwrap();
    assert_eq!(
        s.js(&format!("return document.querySelector({q}).value;"))
            .await,
        "150"
    );

    // ---- Desk room: toggle the lamp off; the 3D view still draws the ceiling panel's light.
    switch_scene(
        &s,
        "desk-room",
        "window.relight.stats.imageVersion === window.relight.state.version \
         && window.relight.state.exposure !== null",
    )
    .await;
    let v = s
        .js("return window.relight.state.version;")
        .await
        .as_u64()
        .unwrap();
    image_for(&s, v).await;
    let lamp_on = canvas(&s, "#image").await;
    s.click(".light[data-id='lamp'] .on").await;
    s.wait_for(
        "window.relight.state.lights.lamp.on === false \
         && window.relight.stats.glVersion === window.relight.state.version \
         && window.relight.stats.imageVersion === window.relight.state.version",
        "both views after the lamp toggle",
    )
    .await;
    let lamp_off = canvas(&s, "#image").await;
    assert!(
        lamp_off["mean"].as_f64().unwrap() < lamp_on["mean"].as_f64().unwrap(),
        "lamp off is not darker: {lamp_on} vs {lamp_off}"
    );
    let gl = canvas(&s, "#gl").await;
    assert!(
        gl["lit"].as_f64().unwrap() > 0.2,
        "the WebGL view is blank: {gl}"
    );

    // ---- Hover: the surface under the image centre, with its illuminance.
    let id = s.element("#image").await;
    s.post(
        "/actions",
        json!({"actions": [{"type": "pointer", "id": "mouse", "parameters": {"pointerType": "mouse"},
            "actions": [{"type": "pointerMove", "origin": {"element-6066-11e4-a52e-4f735466cecf": id}, "x": 0, "y": 60, "duration": 0}]}]}),
    )
    .await;
    s.wait_for("window.relight.stats.lastPick", "a pick").await;
    let pick = s.js("return window.relight.stats.lastPick;").await;
    assert!(
        pick["surface"].is_string() && pick["avgLux"].as_f64().unwrap() > 0.0,
        "{pick}"
    );
    let info = s
        .js("return document.querySelector('#surface-info').textContent;")
        .await;
    assert!(info
        .as_str()
        .unwrap()
        .contains(pick["surface"].as_str().unwrap()));

    // ---- False colour: the image and the 3D view switch to the lux scale with a legend.
    s.click("#falsecolor").await;
    s.wait_for(
        "window.relight.stats.imageVersion === window.relight.state.version \
         && window.relight.stats.glVersion === window.relight.state.version",
        "false colour",
    )
    .await;
    let labels = s
        .js("return document.querySelectorAll('#legend .labels span').length;")
        .await;
    assert!(labels.as_u64().unwrap() >= 2, "legend labels: {labels}");

    // ---- Screenshot of the page, for the record: in the target folder, and as the README's
    // image (`docs/screenshot.png`), so the committed picture is the page as it is now.
    let png = s
        .cmd(reqwest::Method::GET, "/screenshot", Value::Null)
        .await;
    let png = base64_decode(png.as_str().unwrap());
    let shot = Path::new(env!("CARGO_TARGET_TMPDIR")).join("browser-page.png");
    std::fs::write(&shot, &png).unwrap();
    let docs = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/screenshot.png");
    std::fs::write(&docs, &png).unwrap();

    // ---- Office: grid statistics, the grid overlay, and the optimizer applied to sliders.
    switch_scene(
        &s,
        "office",
        "window.relight.stats.gridVersion === window.relight.state.version",
    )
    .await;
    let rows = s
        .js("return document.querySelectorAll('#grid-stats tbody tr').length;")
        .await;
    assert_eq!(rows, 2, "grid rows");
    // The desk carries EN 12464-1 requirements: its row says pass or fail, and the values
    // shown are maintained (the office's MF is 0.8).
    let verdicts = s
        .js("return [...document.querySelectorAll('#grid-stats td.verdict')].map(e => e.textContent);")
        .await;
    let verdicts: Vec<&str> = verdicts
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert!(
        verdicts.iter().filter(|v| ["✓", "✗"].contains(v)).count() == 1 && verdicts.contains(&""),
        "{verdicts:?}"
    );
    let note = s
        .js("return document.querySelector('#grid-values').textContent;")
        .await;
    assert!(note.as_str().unwrap().contains("MF 0.80"), "{note}");
    let shown = s.js("return window.relight.stats.overlayPoints;").await;
    assert!(shown.as_u64().unwrap() > 100, "overlay points: {shown}");
    // The lux labels never overlap (dozens piled up in this view), from the first view and
    // after the camera moves.
    let overlaps = "const b = window.relight.stats.labelBoxes || []; let o = 0; \
         for (let i = 0; i < b.length; i++) for (let j = 0; j < i; j++) { \
           const p = b[i], q = b[j]; \
           if (p.x < q.x + q.w && q.x < p.x + p.w && p.y < q.y + q.h && q.y < p.y + p.h) o++; } \
         return [b.length, o];";
    for step in 0..3 {
        let r = s.js(overlaps).await;
        let (labels, overlapping) = (r[0].as_u64().unwrap(), r[1].as_u64().unwrap());
        assert!(labels >= 5, "view {step}: {labels} labels");
        assert_eq!(
            overlapping, 0,
            "view {step}: {overlapping} of {labels} labels overlap"
        );
        s.js(
            "window.relight.oldBoxes = window.relight.stats.labelBoxes; \
              document.querySelector('#gl').dispatchEvent( \
                new WheelEvent('wheel', {deltaY: 240, bubbles: true, cancelable: true}));",
        )
        .await;
        s.wait_for(
            "window.relight.stats.labelBoxes !== window.relight.oldBoxes",
            "the overlay redrawn after the camera moved",
        )
        .await;
    }
    s.click("#optimizer summary").await;
    s.click("#opt-run").await;
    s.wait_for(
        "document.querySelector('#opt-out').textContent.includes('lm')",
        "the optimizer's answer",
    )
    .await;
    let out = s
        .js("return document.querySelector('#opt-out').textContent;")
        .await;
    assert!(out.as_str().unwrap().contains("Eavg 500"), "{out}");
    let pcts = s
        .js("return [...document.querySelectorAll('.light .pct')].map(e => Number(e.value));")
        .await;
    let pcts: Vec<f64> = pcts
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert!(pcts.iter().any(|&p| p < 100.0), "levels applied: {pcts:?}");

    // ---- Every light off: the unlit grids show no uniformity ("–"), not 0.00, and their
    // rows say why.
    let all_on = |on: bool| {
        format!(
            "window.relight.state.lights.window_row.on === {on} \
             && window.relight.state.lights.corridor_row.on === {on} \
             && window.relight.stats.gridVersion === window.relight.state.version"
        )
    };
    for id in ["window_row", "corridor_row"] {
        s.click(&format!(".light[data-id='{id}'] .on")).await;
    }
    s.wait_for(&all_on(false), "the grids with every light off")
        .await;
    let rows = s
        .js(
            "return [...document.querySelectorAll('#grid-stats tbody tr')]
                 .map(r => [r.children[4].textContent, r.title]);",
        )
        .await;
    for row in rows.as_array().unwrap() {
        assert_eq!(row[0], "–", "{rows}");
        assert!(row[1].as_str().unwrap().contains("0 lx"), "{rows}");
    }
    for id in ["window_row", "corridor_row"] {
        s.click(&format!(".light[data-id='{id}'] .on")).await;
    }
    s.wait_for(&all_on(true), "the grids with the lights on again")
        .await;

    // ---- Daylight on the office: a clear sky with the sun, the time slider, the URL, and
    // the annual metrics of the desk from the Mannheim weather file in its folder.
    assert_eq!(
        s.js("return document.querySelector('#sky-section').hidden;")
            .await,
        false
    );
    let before = canvas(&s, "#image").await["hash"].clone();
    let v = s
        .js(
            "const e = document.querySelector('#sky-type'); e.value = 'cie_clear';
             e.dispatchEvent(new Event('change')); return window.relight.state.version;",
        )
        .await
        .as_u64()
        .unwrap();
    image_for(&s, v).await;
    s.wait_for(
        &format!(
            "window.relight.stats.glVersion >= {v} && window.relight.stats.gridVersion >= {v}"
        ),
        "the 3D view and grids under the sky",
    )
    .await;
    assert!(s
        .js("return location.hash.includes('sky=cie_clear');")
        .await
        .as_bool()
        .unwrap());
    let v = set_slider(&s, "#sky-hour", 10).await;
    image_for(&s, v).await;
    let after = canvas(&s, "#image").await["hash"].clone();
    assert_ne!(after, before, "the sky changes the image");
    s.click("#annual summary").await;
    s.js("document.querySelector('#annual-grid').value = 'desk';")
        .await;
    s.click("#annual-run").await;
    s.wait_for(
        "document.querySelectorAll('#annual-table tr').length === 8",
        "the annual metrics",
    )
    .await;
    let text = s
        .js("return document.querySelector('#annual-out').textContent;")
        .await;
    assert!(text.as_str().unwrap().contains("sDA300/50%"), "{text}");
    s.js(
        "const e = document.querySelector('#sky-type'); e.value = 'off';
          e.dispatchEvent(new Event('change'));",
    )
    .await;

    // ---- Frame rate while orbiting the ~10k-patch room.
    switch_scene(&s, "room-10k", "true").await;
    let fps = s
        .js_async("const done = arguments[arguments.length - 1]; window.relight.measureFps(180).then(done);")
        .await;
    assert!(fps["triangles"].as_u64().unwrap() > 10_000, "{fps}");

    // ---- The export link carries the page's lighting.
    s.js("document.querySelector('#export-glb').dispatchEvent(new Event('focus'));")
        .await;
    let href = s
        .js("return document.querySelector('#export-glb').href;")
        .await;
    assert!(
        href.as_str()
            .unwrap()
            .contains("/api/scenes/room-10k/export.glb?light."),
        "{href}"
    );

    // ---- Open model: a .glb dropped into the dialog is uploaded, baked and shown.
    s.click("#open-model-button").await;
    assert_eq!(
        s.js("return document.querySelector('#open-model').open;")
            .await,
        true
    );
    let glb = crate::gltf_import::box_glb();
    let bytes = serde_json::to_string(&glb).unwrap();
    s.js(&format!(
        "const dt = new DataTransfer(); \
         dt.items.add(new File([new Uint8Array({bytes})], 'Little Box.glb')); \
         const f = document.querySelector('#model-file'); f.files = dt.files; \
         f.dispatchEvent(new Event('change')); \
         document.querySelector('#model-token').value = '{BROWSER_TOKEN}';"
    ))
    .await;
    assert_eq!(
        s.js("return document.querySelector('#model-id').value;")
            .await,
        "little-box"
    );
    s.click("#model-upload").await;
    s.wait_for(
        "window.relight.state.details && window.relight.state.details.id === 'little-box' \
         && window.relight.stats.glVersion === window.relight.state.version",
        "the uploaded model",
    )
    .await;
    assert_eq!(
        s.js("return document.querySelector('#scene').value;").await,
        "little-box"
    );

    // ---- The glTF example: the export in three.js, relit by its sliders.
    s.post(
        "/url",
        json!({"url": format!("{site}/gltf-example.html?scene=cornell-box")}),
    )
    .await;
    s.wait_for(
        "window.relightExample && window.relightExample.ready",
        "the glTF example",
    )
    .await;
    let sum = "return Array.from(window.relightExample.model.geometry.getAttribute('color').array).reduce((a, b) => a + b, 0);";
    let lit = s.js(sum).await.as_f64().unwrap();
    assert!(lit > 100.0, "the export is lit: {lit}");
    s.js("const i = document.querySelector('#g-ceiling'); i.value = 0; i.dispatchEvent(new Event('input'));")
        .await;
    let dark = s.js(sum).await.as_f64().unwrap();
    assert_eq!(dark, 0.0, "the only group at 0 leaves the model black");
    s.js("const i = document.querySelector('#g-ceiling'); i.value = 2; i.dispatchEvent(new Event('input'));")
        .await;
    let brighter = s.js(sum).await.as_f64().unwrap();
    assert!(
        brighter > lit,
        "twice the light is brighter: {brighter} vs {lit}"
    );
    let recolour = s
        .js("return document.querySelector('#recolour-ms').textContent;")
        .await;

    // ---- No console errors anywhere along the way.
    let errors = s.console_errors().await;
    assert!(errors.is_empty(), "console errors: {errors:#?}");

    let report = json!({
        "change_to_image_ms": {"p50": p50, "p90": p90, "runs": lat.len()},
        "last_rtt_ms": rtt,
        "fps_10k_orbit": fps,
        "gltf_example_recolour": recolour,
        "screenshot": shot,
    });
    eprintln!("browser report: {report:#}");
    std::fs::write(
        Path::new(env!("CARGO_TARGET_TMPDIR")).join("browser-report.json"),
        serde_json::to_string_pretty(&report).unwrap(),
    )
    .unwrap();
    s.cmd(reqwest::Method::DELETE, "", Value::Null).await;
    server.abort();
}

/// Serves `scenes` (baked first, every one ready) on a loopback port; returns the site's
/// address and the server task.
pub(crate) async fn serve(
    scenes: PathBuf,
    cache: PathBuf,
) -> (String, tokio::task::JoinHandle<std::io::Result<()>>) {
    let state = AppState::new(ServerConfig {
        addr: "127.0.0.1:0".parse().unwrap(),
        scenes,
        cache,
        read_only: false,
        static_dir: Path::new(env!("CARGO_MANIFEST_DIR")).join("static"),
        cors_origins: vec![],
        body_limit: DEFAULT_BODY_LIMIT,
        admin_token: Some(BROWSER_TOKEN.into()),
        ..ServerConfig::default()
    })
    .unwrap();
    let st = state.clone();
    tokio::task::spawn_blocking(move || st.bake_all())
        .await
        .unwrap();
    assert!(state.slots().iter().all(|s| s.status().0 == "ready"));
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let site = format!("http://{}", listener.local_addr().unwrap());
    let server = tokio::spawn(async move { axum::serve(listener, router(state)).await });
    (site, server)
}

/// chromedriver and a headless Chromium session (software WebGL), with its profile folder.
pub(crate) async fn open_session(
    driver_bin: &Path,
    browser_bin: &Path,
) -> (Session, Driver, tempfile::TempDir) {
    let port = common::free_port();
    let driver = Driver(
        Command::new(driver_bin)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("start chromedriver"),
    );
    let http = reqwest::Client::new();
    let wd = format!("http://127.0.0.1:{port}");
    let t = Instant::now();
    while http.get(format!("{wd}/status")).send().await.is_err() {
        assert!(
            t.elapsed() < Duration::from_secs(20),
            "chromedriver did not start"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let profile = tempfile::tempdir().unwrap();
    let caps = json!({"capabilities": {"alwaysMatch": {
        "browserName": "chrome",
        "goog:loggingPrefs": {"browser": "ALL"},
        "goog:chromeOptions": {
            "binary": browser_bin,
            "args": ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                     "--no-first-run", "--disable-background-networking",
                     "--disable-component-update", "--disable-sync",
                     "--window-size=1400,900", "--use-angle=swiftshader",
                     "--enable-unsafe-swiftshader",
                     format!("--user-data-dir={}", profile.path().display())]
        }
    }}});
    let v: Value = http
        .post(format!("{wd}/session"))
        .json(&caps)
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    let sid = v["value"]["sessionId"]
        .as_str()
        .unwrap_or_else(|| panic!("no session: {v}"))
        .to_string();
    let s = Session {
        http: http.clone(),
        base: format!("{wd}/session/{sid}"),
    };
    s.post(
        "/timeouts",
        json!({"script": 120000, "pageLoad": 60000, "implicit": 0}),
    )
    .await;
    (s, driver, profile)
}

/// The page on `scenes/office-floor` (177k patches): the 3D view's frame rate and the
/// time from a slider move to the redrawn view. A measurement, not a check, so ignored
/// in `cargo test`: run it with
/// `cargo test --release --test it browser::office_floor_page -- --ignored --nocapture`.
/// The first run bakes the scene (minutes) into `target/tmp/office-floor-cache`.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
#[ignore = "a measurement on the large bundled scene; minutes on a cold cache"]
async fn office_floor_page_frame_rate() {
    let Some((driver_bin, browser_bin)) = find_driver() else {
        panic!("chromium/chromedriver not found (apt-get install chromium chromium-driver)");
    };
    let _gate = common::alone();
    let root = Path::new(env!("CARGO_TARGET_TMPDIR"));
    let scenes = root.join("office-floor-scenes");
    std::fs::create_dir_all(&scenes).unwrap();
    let link = scenes.join("office-floor");
    if !link.exists() {
        std::os::unix::fs::symlink(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office-floor"),
            &link,
        )
        .unwrap();
    }
    let (site, server) = serve(scenes, root.join("office-floor-cache")).await;
    let mesh = reqwest::get(format!("{site}/api/scenes/office-floor/mesh"))
        .await
        .unwrap()
        .bytes()
        .await
        .unwrap();
    let t = Instant::now();
    let preview = reqwest::get(format!("{site}/api/scenes/office-floor/mesh/preview"))
        .await
        .unwrap()
        .bytes()
        .await
        .unwrap();
    let preview_s = t.elapsed().as_secs_f64();
    let (s, _driver, _profile) = open_session(&driver_bin, &browser_bin).await;
    let t = Instant::now();
    s.post(
        "/url",
        json!({"url": format!("{site}/#scene=office-floor")}),
    )
    .await;
    s.wait_for(
        "window.relight && window.relight.ready && window.relight.stats.glFrames > 0 \
         && window.relight.stats.glVersion === window.relight.state.version",
        "the office floor",
    )
    .await;
    let load_s = t.elapsed().as_secs_f64();
    let fps = s
        .js_async("const done = arguments[arguments.length - 1]; window.relight.measureFps(180).then(done);")
        .await;
    // Slider to redrawn 3D view: fetch of the binary radiosity plus the vertex colours.
    let mut lat = Vec::new();
    for (k, pct) in [40u32, 100, 60, 80, 20, 100].into_iter().enumerate() {
        let t = Instant::now();
        let v = set_slider(&s, ".light[data-id='s1'] .pct", pct).await;
        s.wait_for(
            &format!("window.relight.stats.glVersion >= {v}"),
            &format!("the redrawn view {k}"),
        )
        .await;
        lat.push(t.elapsed().as_secs_f64() * 1e3);
    }
    let errors = s.console_errors().await;
    assert!(errors.is_empty(), "console errors: {errors:#?}");
    let report = json!({
        "mesh_bytes": mesh.len(),
        "preview_mesh_bytes": preview.len(),
        "preview_first_request_s": preview_s,
        "page_load_to_first_frame_s": load_s,
        "fps_orbit": fps,
        "slider_to_view_ms": lat,
    });
    eprintln!("office-floor page: {report:#}");
    s.cmd(reqwest::Method::DELETE, "", Value::Null).await;
    server.abort();
}

/// Standard base64 (the screenshot), without a dependency.
pub(crate) fn base64_decode(s: &str) -> Vec<u8> {
    let val = |c: u8| -> u32 {
        match c {
            b'A'..=b'Z' => (c - b'A') as u32,
            b'a'..=b'z' => (c - b'a' + 26) as u32,
            b'0'..=b'9' => (c - b'0' + 52) as u32,
            b'+' => 62,
            _ => 63,
        }
    };
    let bytes: Vec<u8> = s.bytes().filter(|&c| c != b'=' && c != b'\n').collect();
    let mut out = Vec::with_capacity(bytes.len() * 3 / 4);
    for chunk in bytes.chunks(4) {
        let mut acc = 0u32;
        for (i, &c) in chunk.iter().enumerate() {
            acc |= val(c) << (18 - 6 * i);
        }
        let n = chunk.len() * 6 / 8;
        for i in 0..n {
            out.push((acc >> (16 - 8 * i)) as u8);
        }
    }
    out
}

/// The luminaire layout on the page, on the desk room (factored) with a photometric file:
/// "Add" places a luminaire and every view follows with it in the request; dragging its
/// marker moves it on its mounting plane, snapped to the grid; the URL hash carries the
/// layout (a link opens it again); the scene.toml tables hold it; ✕ takes it out.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_page_places_drags_and_removes_luminaires() {
    let Some((driver_bin, browser_bin)) = driver_or_skip() else {
        return;
    };
    let _gate = common::alone();
    let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("browser-luminaires");
    let room = root.join("scenes/desk-room");
    std::fs::create_dir_all(&room).unwrap();
    for f in std::fs::read_dir(common::scenes_dir().join("desk-room")).unwrap() {
        let f = f.unwrap();
        if f.file_type().unwrap().is_file() {
            std::fs::copy(f.path(), room.join(f.file_name())).unwrap();
        }
    }
    std::fs::copy(
        common::bundled_scenes().join("office-floor/downlight.ies"),
        room.join("downlight.ies"),
    )
    .unwrap();
    let (site, server) = serve(root.join("scenes"), root.join("cache")).await;
    let (s, _driver, _profile) = open_session(&driver_bin, &browser_bin).await;
    // The 3D view from the door looking up at (2, 2.75, 1.5), under the ceiling.
    let view = "v=3.7,1.6,0.3,-0.9566,0.5047,2.3775";
    s.post(
        "/url",
        json!({"url": format!("{site}/#scene=desk-room&{view}")}),
    )
    .await;
    s.wait_for(
        "window.relight && window.relight.ready && window.relight.stats.imagesShown > 0 \
         && window.relight.stats.glFrames > 0 && window.relight.state.exposure !== null",
        "the desk room",
    )
    .await;
    let v0 = s
        .js("return window.relight.state.version;")
        .await
        .as_u64()
        .unwrap();
    image_for(&s, v0).await;
    let before = canvas(&s, "#image").await;
    let files = s
        .js("return [...document.querySelectorAll('#lum-file option')].map(o => o.value);")
        .await;
    assert_eq!(files, json!(["downlight.ies"]));

    // ---- Add: a luminaire at the mounting height, in every request; the image brightens.
    s.js("document.querySelector('#lum-add').click();").await;
    let v = s
        .js("return window.relight.state.version;")
        .await
        .as_u64()
        .unwrap();
    image_for(&s, v).await;
    s.wait_for(
        &format!("window.relight.stats.glVersion >= {v}"),
        "the 3D view with the new luminaire",
    )
    .await;
    let layout = s.js("return window.relight.state.layout;").await;
    assert_eq!(layout[0]["id"], "new1", "{layout}");
    assert_eq!(layout[0]["photometry"], "downlight.ies");
    let y = layout[0]["position"][1].as_f64().unwrap();
    assert!(
        (y - 2.75).abs() < 1e-9,
        "mounted just below the ceiling: {y}"
    );
    let after = canvas(&s, "#image").await;
    assert!(
        after["mean"].as_f64().unwrap() > before["mean"].as_f64().unwrap() + 1.0,
        "a 2,500 lm downlight brightens the room: {before} → {after}"
    );
    let hash = s.js("return location.hash;").await;
    assert!(hash.as_str().unwrap().contains("lum=new1"), "{hash}");
    // Its marker is drawn on the 3D view's overlay where it projects (when in view).
    let marker = s
        .js(r#"
        const q = window.relight.project(window.relight.state.layout[0].position);
        const c = document.querySelector('#overlay');
        if (!q || q[0] < 0 || q[1] < 0 || q[0] > c.clientWidth || q[1] > c.clientHeight) return null;
        const k = c.width / c.clientWidth;
        return c.getContext('2d').getImageData(Math.round(q[0] * k), Math.round(q[1] * k), 1, 1).data[3];
        "#)
        .await;
    assert!(
        marker.as_u64().is_some_and(|a| a > 0),
        "no marker: {marker}"
    );

    // ---- Drag its marker 60 px right: it moves on its plane, snapped to 0.25 m.
    let moved = s
        .js(r#"
        const l = window.relight.state.layout[0];
        const q = window.relight.project(l.position);
        const c = document.querySelector('#gl');
        const r = c.getBoundingClientRect();
        const at = (dx) => ({clientX: r.left + q[0] + dx, clientY: r.top + q[1],
                             pointerId: 7, bubbles: true, button: 0});
        c.dispatchEvent(new PointerEvent('pointerdown', at(0)));
        for (let k = 1; k <= 6; k++) c.dispatchEvent(new PointerEvent('pointermove', at(10 * k)));
        c.dispatchEvent(new PointerEvent('pointerup', at(60)));
        return {from: q, to: window.relight.state.layout[0].position};
        "#)
        .await;
    let to = &moved["to"];
    assert!((to[1].as_f64().unwrap() - 2.75).abs() < 1e-9, "{moved}");
    for k in [0, 2] {
        let v = to[k].as_f64().unwrap();
        assert!(
            ((v / 0.25).round() * 0.25 - v).abs() < 1e-9,
            "snapped: {moved}"
        );
    }
    assert_ne!(layout[0]["position"], *to, "the drag moved it: {moved}");
    let v = s
        .js("return window.relight.state.version;")
        .await
        .as_u64()
        .unwrap();
    image_for(&s, v).await;

    // ---- "Export glTF" with a layout: the page POSTs it and saves the file it gets.
    s.js(r#"
        window.__saved = [];
        const make = URL.createObjectURL;
        URL.createObjectURL = (b) => { window.__saved.push([b.size, b.type]); return make(b); };
        HTMLAnchorElement.prototype.click = function () { window.__clicked = this.download; };
        document.querySelector('#export-glb').dispatchEvent(
            new MouseEvent('click', {bubbles: true, cancelable: true}));
        "#)
        .await;
    s.wait_for("window.__clicked === 'desk-room.glb'", "the exported file")
        .await;
    let saved = s.js("return window.__saved;").await;
    assert_eq!(saved[0][1], "model/gltf-binary", "{saved}");
    assert!(saved[0][0].as_u64().unwrap() > 10_000, "{saved}");

    // ---- "Report" with a layout: POSTed, shown from the answer; its schedule lists it.
    s.js(r#"
        window.open = () => ({ set location(u) { window.__report = u; }, close() {} });
        document.querySelector('#report-button').click();
        "#)
        .await;
    s.wait_for("typeof window.__report === 'string'", "the report")
        .await;
    let html = s
        .js_async(
            "const done = arguments[arguments.length - 1];
             fetch(window.__report).then((r) => r.text()).then(done);",
        )
        .await;
    let html = html.as_str().unwrap();
    assert!(
        html.contains("Luminaire schedule") && html.contains("downlight.ies"),
        "{}",
        &html[..html.len().min(300)]
    );

    // ---- The scene.toml tables, and the link: the layout comes back from the hash.
    let toml = s.js("return window.relight.layoutToml();").await;
    let toml = toml.as_str().unwrap();
    assert!(
        toml.contains("[[luminaires]]\nid = \"new1\"\nphotometry = \"downlight.ies\""),
        "{toml}"
    );
    relight::scene::parse_scene_toml("scene.toml", toml).expect("the tables read as scene.toml");
    let link = s.js("return location.href;").await;
    s.post("/url", json!({"url": "about:blank"})).await;
    s.post("/url", json!({"url": link})).await;
    s.wait_for(
        "window.relight && window.relight.ready && window.relight.state.layout.length === 1",
        "the layout from the link",
    )
    .await;
    let back = s
        .js("return window.relight.state.layout[0].position;")
        .await;
    assert_eq!(back, *to, "the link keeps the position");

    // ---- ✕ removes it: no `luminaires` any more, nor `lum` in the hash.
    s.wait_for(
        "document.querySelector('#lum-table tr[data-id=\"new1\"] .del')",
        "the row",
    )
    .await;
    s.js("document.querySelector('#lum-table tr[data-id=\"new1\"] .del').click();")
        .await;
    let left = s.js("return window.relight.state.layout.length;").await;
    assert_eq!(left, 0);
    s.wait_for(
        "!location.hash.includes('lum=')",
        "the hash without the layout",
    )
    .await;
    assert!(
        s.console_errors().await.is_empty(),
        "{:?}",
        s.console_errors().await
    );
    s.cmd(reqwest::Method::DELETE, "", Value::Null).await;
    server.abort();
}
