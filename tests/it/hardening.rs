//! Regression tests for the hardening findings: requests that crashed, stalled or exhausted
//! the server. Each test is named after the finding it pins.

use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use axum::Router;
use http_body_util::BodyExt;
use relight::server::{router, AppState, ServerConfig};
use serde_json::{json, Value};
use tower::ServiceExt;

use crate::common;

/// The bundled scenes, baked once per test run (the cache is shared with the `http` module).
fn state() -> Arc<AppState> {
    static STATE: OnceLock<Arc<AppState>> = OnceLock::new();
    STATE
        .get_or_init(|| {
            let cache = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("http-cache");
            let s = AppState::new(ServerConfig {
                addr: "127.0.0.1:0".parse().unwrap(),
                scenes: common::scenes_dir(),
                cache,
                static_dir: std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("static"),
                ..ServerConfig::default()
            })
            .unwrap();
            common::bake_all(&s);
            assert!(s.slots.iter().all(|s| s.status().0 == "ready"));
            s
        })
        .clone()
}

fn with(f: impl FnOnce(&mut ServerConfig)) -> Arc<AppState> {
    let base = state();
    let mut cfg = base.config.clone();
    f(&mut cfg);
    base.reconfigured(cfg)
}

async fn send(app: Router, req: Request<Body>) -> (StatusCode, header::HeaderMap, Vec<u8>) {
    let resp = app.oneshot(req).await.unwrap();
    let status = resp.status();
    let headers = resp.headers().clone();
    let body = resp
        .into_body()
        .collect()
        .await
        .unwrap()
        .to_bytes()
        .to_vec();
    (status, headers, body)
}

async fn post_to(
    app: Router,
    uri: &str,
    body: impl Into<String>,
) -> (StatusCode, header::HeaderMap, Value) {
    let req = Request::post(uri)
        .header(header::CONTENT_TYPE, "application/json")
        .body(Body::from(body.into()))
        .unwrap();
    let (s, h, b) = send(app, req).await;
    (s, h, serde_json::from_slice(&b).unwrap_or(Value::Null))
}

async fn post(uri: &str, body: impl Into<String>) -> (StatusCode, header::HeaderMap, Value) {
    post_to(router(state()), uri, body).await
}

/// Asserts a problem document with `status` whose detail contains `needle`.
fn problem(s: StatusCode, h: &header::HeaderMap, v: &Value, status: StatusCode, needle: &str) {
    assert_eq!(s, status, "{v}");
    assert_eq!(h[header::CONTENT_TYPE], "application/problem+json");
    let d = v["detail"].as_str().unwrap_or_default();
    assert!(d.contains(needle), "'{d}' lacks '{needle}'");
}

#[tokio::test]
async fn falsecolor_range_up_to_1e39_killed_the_process() {
    let _gate = common::shared();
    let uri = "/api/scenes/cornell-box/render";
    for range in [
        "[1, 1e39]",
        "[1, 1e300]",
        "[0, 10]",
        "[1e-9, 10]",
        "[5, 5]",
        "[1, 1e13]",
    ] {
        let body =
            format!(r#"{{"mode": "falsecolor", "range": {range}, "width": 32, "height": 32}}"#);
        let (s, h, v) = post(uri, body).await;
        assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{range}: {v}");
        assert_eq!(h[header::CONTENT_TYPE], "application/problem+json");
        assert!(v["detail"].as_str().unwrap().contains("range"), "{v}");
    }
    // The widest range allowed still draws.
    let (s, h, _) = post(
        uri,
        r#"{"mode": "falsecolor", "range": [1e-6, 1e12], "width": 64, "height": 64}"#,
    )
    .await;
    assert_eq!(
        (s, &h[header::CONTENT_TYPE]),
        (StatusCode::OK, &"image/png".parse().unwrap())
    );
}

#[tokio::test]
async fn repeated_ids_multiplied_work_and_are_refused() {
    let _gate = common::shared();
    let grids = json!({"grids": vec!["desk"; 200_000], "surfaces": []}).to_string();
    let (s, h, v) = post("/api/scenes/office/illuminance", grids).await;
    problem(
        s,
        &h,
        &v,
        StatusCode::UNPROCESSABLE_ENTITY,
        "grid 'desk' is listed twice",
    );
    let (s, h, v) = post(
        "/api/scenes/office/illuminance",
        r#"{"surfaces": ["floor", "floor"]}"#,
    )
    .await;
    problem(s, &h, &v, StatusCode::UNPROCESSABLE_ENTITY, "listed twice");
    let (s, h, v) = post(
        "/api/scenes/office/batch",
        r#"{"states": [{}], "grids": ["desk", "desk"]}"#,
    )
    .await;
    problem(s, &h, &v, StatusCode::UNPROCESSABLE_ENTITY, "listed twice");
    let (s, h, v) = post(
        "/api/scenes/office/optimize",
        r#"{"targets": [{"grid": "desk", "eavg_min": 300}, {"grid": "desk", "u0_min": 0.5}]}"#,
    )
    .await;
    problem(
        s,
        &h,
        &v,
        StatusCode::UNPROCESSABLE_ENTITY,
        "already has a target",
    );
}

#[tokio::test]
async fn optimize_with_a_group_listed_twice_reported_levels_it_did_not_apply() {
    let _gate = common::shared();
    let (s, h, v) = post(
        "/api/scenes/office/optimize",
        r#"{"targets": [{"grid": "desk", "eavg_min": 500}], "groups": ["window_row", "window_row"]}"#,
    )
    .await;
    problem(
        s,
        &h,
        &v,
        StatusCode::UNPROCESSABLE_ENTITY,
        "'window_row' is listed twice",
    );
    // Listed once, the answer applies the levels it reports.
    let (s, _, v) = post(
        "/api/scenes/office/optimize",
        r#"{"targets": [{"grid": "desk", "eavg_min": 500}], "groups": ["window_row"]}"#,
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{v}");
    assert_eq!(v["targets"][0]["met"], true, "{v}");
    let level = v["lights"]["window_row"]["intensity"].as_f64().unwrap();
    let (_, _, check) = post(
        "/api/scenes/office/illuminance",
        json!({"lights": {"window_row": level}, "grids": ["desk"], "surfaces": []}).to_string(),
    )
    .await;
    let avg = check["grids"]["desk"]["avg"].as_f64().unwrap();
    assert!(
        (avg - 500.0).abs() < 0.5,
        "reported level {level} gives {avg} lx"
    );
}

#[tokio::test]
async fn repeated_json_keys_silently_kept_the_last() {
    let _gate = common::shared();
    for body in [
        r#"{"lights": {"ceiling": 0, "ceiling": 1}}"#,
        r#"{"lights": {}, "lights": {"ceiling": 2}}"#,
    ] {
        let (s, h, v) = post("/api/scenes/cornell-box/radiosity", body).await;
        problem(s, &h, &v, StatusCode::UNPROCESSABLE_ENTITY, "appears twice");
    }
}

#[tokio::test]
async fn sparse_emission_keys_plus_1_and_1_both_meant_patch_1() {
    let _gate = common::shared();
    let uri = "/api/scenes/cornell-box/radiosity";
    for key in ["+1", "01", " 1", "1.0", "-0", "1e0"] {
        let body = format!(r#"{{"emission": {{"{key}": [1, 1, 1]}}}}"#);
        let (s, h, v) = post(uri, body).await;
        problem(
            s,
            &h,
            &v,
            StatusCode::UNPROCESSABLE_ENTITY,
            "not a patch index",
        );
    }
    let (s, h, v) = post(uri, r#"{"emission": {"1": [1, 1, 1], "1": [2, 2, 2]}}"#).await;
    problem(s, &h, &v, StatusCode::UNPROCESSABLE_ENTITY, "appears twice");
    let (s, _, v) = post(uri, r#"{"emission": {"1": [1, 1, 1], "0": [2, 2, 2]}}"#).await;
    assert_eq!(s, StatusCode::OK, "{v}");
}

#[tokio::test]
async fn a_normal_of_1e300_passed_the_zero_check_and_answered_0_lux() {
    let _gate = common::shared();
    let uri = "/api/scenes/cornell-box/illuminance";
    let at = |n: &str| {
        format!(
            r#"{{"points": [{{"position": [0.28, 0.01, 0.28], "normal": {n}}}], "surfaces": []}}"#
        )
    };
    for n in ["[1e300, 1e300, 0]", "[0, 0, 0]", "[1e39, 0, 0]"] {
        let (s, h, v) = post(uri, at(n)).await;
        assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{n}: {v}");
        assert_eq!(h[header::CONTENT_TYPE], "application/problem+json");
    }
    // Tiny and large finite normals are directions like any other.
    let (s1, _, a) = post(uri, at("[0, 1, 0]")).await;
    let (s2, _, b) = post(uri, at("[0, 1e-30, 0]")).await;
    let (s3, _, c) = post(uri, at("[0, 1e30, 0]")).await;
    assert_eq!(
        (s1, s2, s3),
        (StatusCode::OK, StatusCode::OK, StatusCode::OK)
    );
    let lux = |v: &Value| v["points"][0]["lux"].as_f64().unwrap();
    assert!(lux(&a) > 0.0);
    assert_eq!(lux(&a), lux(&b));
    assert_eq!(lux(&a), lux(&c));
    // Positions beyond the documented bound are refused.
    let far = r#"{"points": [{"position": [1e7, 0, 0], "normal": [0, 1, 0]}]}"#;
    let (s, h, v) = post(uri, far).await;
    problem(s, &h, &v, StatusCode::UNPROCESSABLE_ENTITY, "within ±");
}

#[tokio::test]
async fn any_content_type_was_parsed_as_json() {
    let _gate = common::shared();
    for ct in [
        "text/plain",
        "application/x-www-form-urlencoded",
        "multipart/form-data; boundary=x",
    ] {
        let req = Request::post("/api/scenes/cornell-box/radiosity")
            .header(header::CONTENT_TYPE, ct)
            .body(Body::from(r#"{"lights": {}}"#))
            .unwrap();
        let (s, h, b) = send(router(state()), req).await;
        assert_eq!(s, StatusCode::UNSUPPORTED_MEDIA_TYPE, "{ct}");
        assert_eq!(h[header::CONTENT_TYPE], "application/problem+json");
        assert!(String::from_utf8_lossy(&b).contains("application/json"));
    }
    // No content type with a body: 415 too; an empty body means the defaults.
    let req = Request::post("/api/scenes/cornell-box/radiosity")
        .body(Body::from("{}"))
        .unwrap();
    assert_eq!(
        send(router(state()), req).await.0,
        StatusCode::UNSUPPORTED_MEDIA_TYPE
    );
    let req = Request::post("/api/scenes/cornell-box/radiosity")
        .body(Body::empty())
        .unwrap();
    assert_eq!(send(router(state()), req).await.0, StatusCode::OK);
}

#[tokio::test]
async fn unknown_http_methods_became_new_metrics_series() {
    let _gate = common::shared();
    let app = router(with(|_| {}));
    for m in ["FOO", "BAR", "X-ATTACK"] {
        let req = Request::builder()
            .method(m)
            .uri("/healthz")
            .body(Body::empty())
            .unwrap();
        let _ = send(app.clone(), req).await;
    }
    let (_, _, b) = send(app, Request::get("/metrics").body(Body::empty()).unwrap()).await;
    let text = String::from_utf8(b).unwrap();
    assert!(
        !text.contains("FOO") && !text.contains("X-ATTACK"),
        "{text}"
    );
    assert!(text.contains("method=\"other\""), "{text}");
}

#[tokio::test]
async fn render_memory_is_estimated_and_budgeted() {
    let _gate = common::shared();
    // A 256 MB budget: one request may reserve 128 MB, so a 4096² view buffer (up to
    // 2.7 GB) is refused up front with a message naming the limit.
    let small = with(|c| c.memory_budget = 256 << 20);
    let (s, h, v) = post_to(
        router(small.clone()),
        "/api/scenes/cornell-box/render",
        r#"{"width": 4096, "height": 4096}"#,
    )
    .await;
    problem(s, &h, &v, StatusCode::UNPROCESSABLE_ENTITY, "at most");
    assert!(
        v["detail"].as_str().unwrap().contains("memory budget"),
        "{v}"
    );
    // Budget momentarily full: 503 with Retry-After.
    let hold = (
        // 256 MB less 64 MB for the view cache leaves 192 MB; keep 185 MB of it.
        small.budget.reserve(100 << 20, "a test").unwrap(),
        small.budget.reserve(85 << 20, "a test").unwrap(),
    );
    let (s, h, v) = post_to(
        router(small.clone()),
        "/api/scenes/cornell-box/render",
        r#"{"width": 256, "height": 256}"#,
    )
    .await;
    problem(s, &h, &v, StatusCode::SERVICE_UNAVAILABLE, "retry");
    assert!(h.contains_key(header::RETRY_AFTER));
    drop(hold);
    let (s, _, _) = post_to(
        router(small.clone()),
        "/api/scenes/cornell-box/render",
        r#"{"width": 256, "height": 256}"#,
    )
    .await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(small.budget.used(), 0, "reservations are returned");
}

#[tokio::test]
async fn the_same_camera_was_built_twice_at_once() {
    let _gate = common::shared();
    let st = with(|_| {});
    let body = r#"{"width": 300, "height": 200, "camera": {"position": [0.3, 0.3, -0.8], "target": [0.28, 0.27, 0.28], "fov_deg": 50}}"#;
    let tasks: Vec<_> = (0..4)
        .map(|_| {
            let app = router(st.clone());
            tokio::spawn(
                async move { post_to(app, "/api/scenes/cornell-box/render", body).await.0 },
            )
        })
        .collect();
    for t in tasks {
        assert_eq!(t.await.unwrap(), StatusCode::OK);
    }
    let views = st.views.lock().unwrap();
    assert_eq!(views.len(), 1, "one view buffer for one camera");
    // Real bytes: offsets and picking ids (8 per pixel) plus 8 per vertex weight (group
    // images are not made for one group). The estimate assumes at most 8 weights a pixel.
    let px = 300 * 200;
    let weights = (views.bytes() - 8 * px) as f64 / 8.0 / px as f64;
    println!(
        "view buffer: {} bytes, {weights:.2} vertex weights per pixel",
        views.bytes()
    );
    assert!(
        (1.0..=relight::render::EST_WEIGHTS_PER_PIXEL as f64).contains(&weights),
        "{weights}"
    );
}

#[tokio::test]
async fn distinct_cameras_were_free_to_make_and_the_lru_counted_lengths() {
    let _gate = common::shared();
    // A 128 MB budget keeps a 32 MB view cache: many distinct cameras never hold more.
    let st = with(|c| c.memory_budget = 128 << 20);
    let cap = st.budget.view_cache_max() as usize;
    for k in 0..12 {
        let body = json!({"width": 400, "height": 300, "camera": {
            "position": [0.1 + 0.03 * k as f64, 0.3, -0.8], "target": [0.28, 0.27, 0.28], "fov_deg": 50}})
        .to_string();
        let (s, _, v) = post_to(router(st.clone()), "/api/scenes/cornell-box/render", body).await;
        assert_eq!(s, StatusCode::OK, "{v}");
        let bytes = st.views.lock().unwrap().bytes();
        assert!(bytes <= cap, "view cache holds {bytes} bytes, cap {cap}");
    }
}

#[tokio::test]
async fn heavy_requests_beyond_the_concurrency_limit_are_shed_with_503() {
    let _gate = common::shared();
    let st = with(|c| {
        c.max_concurrent = 1;
        c.queue_wait = Duration::from_millis(1);
    });
    // 400 points on the office: tens of milliseconds each.
    let points: Vec<Value> = (0..400)
        .map(|k| json!({"position": [0.5 + (k % 20) as f64 * 0.25, 0.75, 0.5 + (k / 20) as f64 * 0.15], "normal": [0, 1, 0]}))
        .collect();
    let body = json!({"points": points, "surfaces": []}).to_string();
    let tasks: Vec<_> = (0..12)
        .map(|_| {
            let (app, body) = (router(st.clone()), body.clone());
            tokio::spawn(async move { post_to(app, "/api/scenes/office/illuminance", body).await })
        })
        .collect();
    let mut codes = vec![];
    for t in tasks {
        let (s, h, v) = t.await.unwrap();
        if s == StatusCode::SERVICE_UNAVAILABLE {
            assert!(h.contains_key(header::RETRY_AFTER));
            assert!(v["detail"].as_str().unwrap().contains("busy"), "{v}");
        }
        codes.push(s.as_u16());
    }
    assert!(codes.contains(&200) && codes.contains(&503), "{codes:?}");
    assert!(codes.iter().all(|c| *c == 200 || *c == 503), "{codes:?}");
}

#[tokio::test]
async fn spawned_work_kept_running_after_the_client_left() {
    // Alone: the abandoned work runs on rayon's global pool, which every test of this
    // process shares, and a long bake there would hold it past the 5 s allowed below.
    let _gate = common::alone();
    // A 30 ms request timeout on a request that needs seconds: 503 at once, and the
    // abandoned work stops soon after (its memory reservation comes back).
    let st = with(|c| c.request_timeout = Duration::from_millis(30));
    let points: Vec<Value> = (0..10_000)
        .map(|k| json!({"position": [0.5 + (k % 100) as f64 * 0.05, 0.75, 0.5 + (k / 100) as f64 * 0.03], "normal": [0, 1, 0]}))
        .collect();
    let body = json!({"points": points, "surfaces": []}).to_string();
    let t0 = Instant::now();
    let (s, h, v) = post_to(router(st.clone()), "/api/scenes/office/illuminance", body).await;
    problem(
        s,
        &h,
        &v,
        StatusCode::SERVICE_UNAVAILABLE,
        "did not finish within",
    );
    assert!(t0.elapsed() < Duration::from_secs(2), "{:?}", t0.elapsed());
    let t1 = Instant::now();
    while st.budget.used() > 0 {
        assert!(
            t1.elapsed() < Duration::from_secs(5),
            "the abandoned work did not stop"
        );
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
}

#[tokio::test]
async fn large_bodies_are_parsed_off_the_runtime_within_the_budget() {
    let _gate = common::shared();
    // A 6 MB dense emission for the Cornell box parses (on the blocking pool) and solves.
    let n = state()
        .slot("cornell-box")
        .unwrap()
        .ready()
        .unwrap()
        .baked
        .transfer
        .n;
    let emission: Vec<[f32; 3]> = (0..n)
        .map(|i| if i == 0 { [1.0; 3] } else { [1.234_567e-9; 3] })
        .collect();
    let body = json!({"emission": emission}).to_string();
    assert!(body.len() > relight::server::parse::INLINE_PARSE_BYTES);
    let (s, _, v) = post("/api/scenes/cornell-box/illuminance", body.clone()).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    // With a tiny budget the same body is refused for its parse, not half-parsed.
    let small = with(|c| c.memory_budget = 64 << 20);
    let big = json!({"emission": vec![[0.0f32; 3]; 400_000]}).to_string();
    let (s, h, v) = post_to(router(small), "/api/scenes/cornell-box/radiosity", big).await;
    assert!(
        s == StatusCode::UNPROCESSABLE_ENTITY || s == StatusCode::PAYLOAD_TOO_LARGE,
        "{s} {v}"
    );
    assert_eq!(h[header::CONTENT_TYPE], "application/problem+json");
}

#[tokio::test]
async fn repeated_query_parameters_on_render_png_are_refused() {
    let _gate = common::shared();
    let req = Request::get(
        "/api/scenes/cornell-box/render.png?w=32&h=32&light.ceiling=1&light.ceiling=0",
    )
    .body(Body::empty())
    .unwrap();
    let (s, _, b) = send(router(state()), req).await;
    assert_eq!(s, StatusCode::BAD_REQUEST);
    assert!(String::from_utf8_lossy(&b).contains("twice"));
}

#[test]
fn failed_scene_errors_carried_absolute_server_paths() {
    let _gate = common::shared();
    let root = tempfile::tempdir().unwrap();
    let scene = root.path().join("broken");
    std::fs::create_dir(&scene).unwrap();
    std::fs::write(scene.join("broken.obj"), "mtllib missing.mtl\nv 0 0 0\n").unwrap();
    let cache = tempfile::tempdir().unwrap();
    let st = AppState::new(ServerConfig {
        scenes: root.path().to_path_buf(),
        cache: cache.path().to_path_buf(),
        ..ServerConfig::default()
    })
    .unwrap();
    st.bake_all();
    let (status, _, err) = st.slot("broken").unwrap().status();
    assert_eq!(status, "failed");
    let err = err.unwrap();
    assert!(err.contains("missing.mtl"), "{err}");
    let abs = root.path().display().to_string();
    assert!(!err.contains(&abs), "'{err}' names the server path {abs}");
    let cache_abs = cache.path().display().to_string();
    assert!(!err.contains(&cache_abs), "{err}");
}

#[test]
fn a_scene_bakes_in_a_child_process_and_its_failure_is_reported() {
    let _gate = common::shared();
    let root = tempfile::tempdir().unwrap();
    let good = root.path().join("box");
    std::fs::create_dir(&good).unwrap();
    let obj = common::box_faces("room", "grey", [0.0; 3], [1.0; 3], true)
        + &common::quad(
            "lamp",
            "light",
            [
                [0.4, 0.99, 0.4],
                [0.6, 0.99, 0.4],
                [0.6, 0.99, 0.6],
                [0.4, 0.99, 0.6],
            ],
            [0.0, -1.0, 0.0],
        );
    std::fs::write(good.join("box.obj"), format!("mtllib box.mtl\n{obj}")).unwrap();
    std::fs::write(
        good.join("box.mtl"),
        format!("{}newmtl light\nKd 0 0 0\nKe 10 10 10\n", common::GREY_MTL),
    )
    .unwrap();
    std::fs::write(good.join("scene.toml"), "[mesh]\ntarget_patches = 200\n").unwrap();
    let bad = root.path().join("bad");
    std::fs::create_dir(&bad).unwrap();
    std::fs::write(bad.join("bad.obj"), "v 0 0 0\nf 1 2 3\n").unwrap();
    let cache = tempfile::tempdir().unwrap();
    let st = AppState::new(ServerConfig {
        scenes: root.path().to_path_buf(),
        cache: cache.path().to_path_buf(),
        bake_command: Some(env!("CARGO_BIN_EXE_relight").into()),
        ..ServerConfig::default()
    })
    .unwrap();
    st.bake_all();
    let (s, ready, _) = st.slot("box").unwrap().status();
    assert_eq!(s, "ready");
    // Baked by the child, loaded by the server from the entry the child wrote.
    assert!(ready.unwrap().baked.stats.from_cache);
    let (s, _, err) = st.slot("bad").unwrap().status();
    assert_eq!(s, "failed");
    let err = err.unwrap();
    assert!(err.contains("bad.obj"), "{err}");
    // The child wrote the cache entry the server loaded.
    assert!(std::fs::read_dir(cache.path()).unwrap().any(|e| e
        .unwrap()
        .file_name()
        .to_string_lossy()
        .starts_with("box-")));
}

#[test]
fn cli_on_a_closed_pipe_panicked_with_a_backtrace() {
    let _gate = common::shared();
    use std::io::Read;
    use std::process::{Command, Stdio};
    let cache = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli-pipe-cache");
    let mut child = Command::new(env!("CARGO_BIN_EXE_relight"))
        .args(["radiosity", "--json", "--cache"])
        .arg(&cache)
        .arg(common::scenes_dir().join("cornell-box"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Read one byte, then close the pipe, like `| head -c 1`.
    let mut out = child.stdout.take().unwrap();
    let mut one = [0u8; 1];
    out.read_exact(&mut one).unwrap();
    drop(out);
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    let status = child.wait().unwrap();
    assert!(
        !err.contains("panicked") && !err.contains("Broken pipe"),
        "{err}"
    );
    assert!(status.success(), "{status}: {err}");
}

#[tokio::test]
async fn slow_clients_held_connections_forever() {
    let _gate = common::shared();
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let st = with(|c| c.header_timeout = Duration::from_millis(500));
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let server = tokio::spawn(relight::server::run(listener, st, async {
        let _ = stopped.await;
    }));
    // Half a request line, then nothing: the server closes the connection.
    let mut c = tokio::net::TcpStream::connect(addr).await.unwrap();
    c.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n")
        .await
        .unwrap();
    let t0 = Instant::now();
    let mut buf = vec![0u8; 1024];
    let n = tokio::time::timeout(Duration::from_secs(5), c.read(&mut buf))
        .await
        .expect("the server kept the slow connection open")
        .unwrap_or(0);
    let waited = t0.elapsed();
    // Closed (0 bytes) or answered 408, after about the header timeout.
    let text = String::from_utf8_lossy(&buf[..n]);
    assert!(n == 0 || text.contains("408"), "{text}");
    assert!(
        waited >= Duration::from_millis(400) && waited < Duration::from_secs(3),
        "{waited:?}"
    );
    // A prompt client on the same server is served.
    let mut c = tokio::net::TcpStream::connect(addr).await.unwrap();
    c.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
        .await
        .unwrap();
    let mut resp = String::new();
    c.read_to_string(&mut resp).await.unwrap();
    assert!(resp.starts_with("HTTP/1.1 200"), "{resp}");
    let _ = stop.send(());
    server.await.unwrap();
}

#[cfg(unix)]
#[test]
fn a_bake_that_runs_out_of_memory_took_the_server_down() {
    let _gate = common::shared();
    use std::os::unix::fs::PermissionsExt;
    // The kernel's OOM killer ends a process with SIGKILL: a stand-in bake command that
    // dies that way must leave the server up and the scene failed with the reason.
    let root = tempfile::tempdir().unwrap();
    let scene = root.path().join("huge");
    std::fs::create_dir(&scene).unwrap();
    std::fs::write(scene.join("huge.obj"), "v 0 0 0\n").unwrap();
    let bin = tempfile::tempdir().unwrap();
    let exe = bin.path().join("fake-bake");
    std::fs::write(&exe, "#!/bin/sh\necho '{\"progress\": 0.1}'\nkill -9 $$\n").unwrap();
    std::fs::set_permissions(&exe, std::fs::Permissions::from_mode(0o755)).unwrap();
    let cache = tempfile::tempdir().unwrap();
    let st = AppState::new(ServerConfig {
        scenes: root.path().to_path_buf(),
        cache: cache.path().to_path_buf(),
        bake_command: Some(exe),
        ..ServerConfig::default()
    })
    .unwrap();
    st.bake_all();
    let (status, _, err) = st.slot("huge").unwrap().status();
    assert_eq!(status, "failed");
    let err = err.unwrap();
    assert!(
        err.contains("signal 9") && err.contains("out of memory"),
        "{err}"
    );
}

#[tokio::test]
async fn a_scene_id_that_is_not_utf8_got_a_plain_text_400() {
    let _gate = common::shared();
    for uri in [
        "/api/scenes/%FF/patches",
        "/api/scenes/%FF",
        "/api/scenes/%C3%28/render.png",
    ] {
        let req = Request::get(uri).body(Body::empty()).unwrap();
        let (s, h, b) = send(router(state()), req).await;
        assert_eq!(s, StatusCode::NOT_FOUND, "{uri}");
        assert_eq!(h[header::CONTENT_TYPE], "application/problem+json", "{uri}");
        assert!(
            String::from_utf8_lossy(&b).contains("no such scene"),
            "{uri}"
        );
    }
}
