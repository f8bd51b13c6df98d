//! The HTTP API: every endpoint and error path through `oneshot`, answers checked against
//! the library, and one real server on a loopback port.

use std::sync::{Arc, OnceLock};

use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use axum::Router;
use http_body_util::BodyExt;
use relight::server::{router, AppState, ServerConfig, DEFAULT_BODY_LIMIT};
use serde_json::{json, Value};
use tower::ServiceExt;

use crate::common;

fn config(scenes: std::path::PathBuf, cache: std::path::PathBuf) -> ServerConfig {
    ServerConfig {
        addr: "127.0.0.1:0".parse().unwrap(),
        scenes,
        cache,
        read_only: false,
        static_dir: std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("static"),
        cors_origins: vec![],
        body_limit: DEFAULT_BODY_LIMIT,
        ..ServerConfig::default()
    }
}

/// The bundled scenes, baked once per test run (cached under target/).
fn state() -> Arc<AppState> {
    static STATE: OnceLock<Arc<AppState>> = OnceLock::new();
    STATE
        .get_or_init(|| {
            let cache = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("http-cache");
            let s = AppState::new(config(common::scenes_dir(), cache)).unwrap();
            common::bake_all(&s);
            assert!(s.slots.iter().all(|s| s.status().0 == "ready"));
            s
        })
        .clone()
}

fn app() -> Router {
    router(state())
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

async fn get(app: Router, uri: &str) -> (StatusCode, Value) {
    let (s, _, b) = send(app, Request::get(uri).body(Body::empty()).unwrap()).await;
    (s, serde_json::from_slice(&b).unwrap_or(Value::Null))
}

async fn post(
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

fn ready(id: &str) -> Arc<relight::server::Ready> {
    state().slot(id).unwrap().ready().unwrap()
}

fn floats(v: &Value) -> Vec<f32> {
    v.as_array()
        .unwrap()
        .iter()
        .flat_map(|t| {
            t.as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap() as f32)
        })
        .collect()
}

#[tokio::test]
async fn health_ready_and_scene_list() {
    let _gate = common::shared();
    let (s, _, b) = send(app(), Request::get("/healthz").body(Body::empty()).unwrap()).await;
    assert_eq!((s, b.as_slice()), (StatusCode::OK, &b"ok"[..]));
    let (s, v) = get(app(), "/readyz").await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(v["ready"], true);
    let (s, v) = get(app(), "/api/scenes").await;
    assert_eq!(s, StatusCode::OK);
    let scenes = v["scenes"].as_array().unwrap();
    let ids: Vec<&str> = scenes.iter().map(|s| s["id"].as_str().unwrap()).collect();
    assert_eq!(ids, ["cornell-box", "desk-room", "office"]);
    assert!(scenes
        .iter()
        .all(|s| s["status"] == "ready" && s["patches"].as_u64().unwrap() > 1000));
    assert_eq!(scenes[1]["lights"].as_array().unwrap().len(), 2);
}

#[tokio::test]
async fn scene_details_with_flux_surfaces_and_cameras() {
    let _gate = common::shared();
    let (s, v) = get(app(), "/api/scenes/cornell-box").await;
    assert_eq!(s, StatusCode::OK);
    let light = &v["lights"][0];
    assert_eq!(light["id"], "ceiling");
    // 50 lm/m² over the 0.13 m × 0.105 m light.
    assert!(
        (light["lumens"].as_f64().unwrap() - 0.6825).abs() < 1e-4,
        "{light}"
    );
    assert!((light["emitting_area"].as_f64().unwrap() - 0.01365).abs() < 1e-6);
    assert_eq!(v["surfaces"].as_array().unwrap().len(), 10);
    assert_eq!(v["cameras"][0]["id"], "front");
    assert_eq!(v["transfer"], "factored");
    let total: u64 = v["surfaces"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["patches"]["count"].as_u64().unwrap())
        .sum();
    assert_eq!(total, v["patches"].as_u64().unwrap());
    let (_, v) = get(app(), "/api/scenes/desk-room").await;
    let lamp = v["lights"]
        .as_array()
        .unwrap()
        .iter()
        .find(|l| l["id"] == "lamp")
        .unwrap();
    assert!((lamp["lumens"].as_f64().unwrap() - 400.0).abs() < 0.01);
}

#[tokio::test]
async fn unknown_scene_is_a_404_problem() {
    let _gate = common::shared();
    let (s, h, b) = send(
        app(),
        Request::get("/api/scenes/atlantis")
            .body(Body::empty())
            .unwrap(),
    )
    .await;
    assert_eq!(s, StatusCode::NOT_FOUND);
    assert_eq!(h[header::CONTENT_TYPE], "application/problem+json");
    let v: Value = serde_json::from_slice(&b).unwrap();
    assert_eq!(v["status"], 404);
    assert!(v["detail"].as_str().unwrap().contains("atlantis"));
    let (s, _, _) = post(app(), "/api/scenes/atlantis/radiosity", "{}").await;
    assert_eq!(s, StatusCode::NOT_FOUND);
    let (s, _) = get(app(), "/api/nothing-here").await;
    assert_eq!(s, StatusCode::NOT_FOUND);
}

#[tokio::test]
async fn patches_as_json_and_binary() {
    let _gate = common::shared();
    let r = ready("cornell-box");
    let n = r.baked.mesh.len();
    let (s, v) = get(app(), "/api/scenes/cornell-box/patches").await;
    assert_eq!(s, StatusCode::OK);
    let list = v["patches"].as_array().unwrap();
    assert_eq!(list.len(), n);
    assert_eq!(list[0]["surface"], "floor");
    let req = Request::get("/api/scenes/cornell-box/patches")
        .header(header::ACCEPT, "application/octet-stream")
        .body(Body::empty())
        .unwrap();
    let (s, h, b) = send(app(), req).await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(h[header::CONTENT_TYPE], "application/octet-stream");
    assert_eq!(b.len(), 32 * n);
    let words: &[u32] = bytemuck::cast_slice(&b);
    let last = n - 1;
    assert_eq!(words[8 * last], r.baked.mesh.patches[last].surface);
    let area: f64 = (0..n)
        .map(|i| f32::from_bits(words[8 * i + 1]) as f64)
        .sum();
    // The areas of shared/reference/cornell-box/scene.json sum to 1.92070 m².
    assert!((area - 1.92070).abs() < 1e-4, "total area {area}");
}

#[tokio::test]
async fn radiosity_json_equals_the_library() {
    let _gate = common::shared();
    let (s, _, v) = post(
        app(),
        "/api/scenes/desk-room/radiosity",
        r#"{"lights": {"ceiling": 0.4, "lamp": {"intensity": 2, "color": [1, 0.5, 0.25]}}, "surfaces": true}"#,
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let r = ready("desk-room");
    let sol = r.baked.transfer.relight(&[[0.4; 3], [2.0, 1.0, 0.5]]);
    assert_eq!(floats(&v["radiosity"]), sol.b);
    assert_eq!(v["unit"], "lm/m2");
    let desk = &v["surfaces"]["desk_top"];
    assert!(desk["illuminance"][0].as_f64().unwrap() > 0.0);
    // Groups left out keep their defaults.
    let (_, _, v) = post(
        app(),
        "/api/scenes/desk-room/radiosity",
        r#"{"lights": {"lamp": 0}}"#,
    )
    .await;
    assert_eq!(
        floats(&v["radiosity"]),
        r.baked.transfer.relight(&[[1.0; 3], [0.0; 3]]).b
    );
}

#[tokio::test]
async fn radiosity_binary_equals_the_library() {
    let _gate = common::shared();
    let req = Request::post("/api/scenes/cornell-box/radiosity")
        .header(header::CONTENT_TYPE, "application/json")
        .header(header::ACCEPT, "application/octet-stream")
        .body(Body::from(
            r#"{"lights": {"ceiling": {"color": [1, 0.6, 0.3]}}}"#,
        ))
        .unwrap();
    let (s, h, b) = send(app(), req).await;
    assert_eq!(s, StatusCode::OK);
    let r = ready("cornell-box");
    assert_eq!(
        h["x-relight-patches"],
        r.baked.mesh.len().to_string().as_str()
    );
    let got: &[f32] = bytemuck::cast_slice(&b);
    assert_eq!(
        got,
        r.baked.transfer.relight(&[[1.0, 0.6, 0.3]]).b.as_slice()
    );
}

#[tokio::test]
async fn per_patch_emission_dense_and_sparse() {
    let _gate = common::shared();
    let r = ready("cornell-box");
    let n = r.baked.mesh.len();
    let mut e = vec![[0f32; 3]; n];
    e[17] = [100.0, 50.0, 25.0];
    e[n - 1] = [3.0, 3.0, 3.0];
    let (s, _, v) = post(
        app(),
        "/api/scenes/cornell-box/radiosity",
        json!({ "emission": e }).to_string(),
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let want = r.baked.transfer.solve(bytemuck::cast_slice(&e)).unwrap();
    assert_eq!(floats(&v["radiosity"]), want.b);
    let sparse = json!({"emission": {"17": [100, 50, 25], (n - 1).to_string(): [3, 3, 3]}});
    let (s, _, v2) = post(
        app(),
        "/api/scenes/cornell-box/radiosity",
        sparse.to_string(),
    )
    .await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(v2["radiosity"], v["radiosity"]);
}

#[tokio::test]
async fn bad_requests_get_precise_problems() {
    let _gate = common::shared();
    let cases: &[(&str, StatusCode, &str)] = &[
        ("{not json", StatusCode::BAD_REQUEST, "malformed JSON"),
        (
            r#"{"lights": {"sun": 1}}"#,
            StatusCode::UNPROCESSABLE_ENTITY,
            "unknown light group 'sun'",
        ),
        (
            r#"{"lights": {"ceiling": -0.5}}"#,
            StatusCode::UNPROCESSABLE_ENTITY,
            "≥ 0",
        ),
        (
            r#"{"lights": {"ceiling": 1e300}}"#,
            StatusCode::UNPROCESSABLE_ENTITY,
            "finite",
        ),
        (
            r#"{"lights": {"ceiling": 5e6}}"#,
            StatusCode::UNPROCESSABLE_ENTITY,
            "exceeds the limit",
        ),
        (
            r#"{"lights": {"ceiling": "bright"}}"#,
            StatusCode::UNPROCESSABLE_ENTITY,
            "must be a number",
        ),
        (
            r#"{"lights": {"ceiling": {"color": [1, 1]}}}"#,
            StatusCode::UNPROCESSABLE_ENTITY,
            "three numbers",
        ),
        (
            r#"{"lights": {"ceiling": {"color": [1, -1, 1]}}}"#,
            StatusCode::UNPROCESSABLE_ENTITY,
            "color",
        ),
        (
            r#"{"lights": {"ceiling": {"hue": 3}}}"#,
            StatusCode::UNPROCESSABLE_ENTITY,
            "unknown field 'hue'",
        ),
        (
            r#"{"emission": [[1, 1, 1]]}"#,
            StatusCode::UNPROCESSABLE_ENTITY,
            "the scene has",
        ),
        (
            r#"{"emission": {"x": [1, 1, 1]}}"#,
            StatusCode::UNPROCESSABLE_ENTITY,
            "not a patch index",
        ),
        (
            r#"{"emission": {"0": [1, -1, 1]}}"#,
            StatusCode::UNPROCESSABLE_ENTITY,
            "emission[0]",
        ),
        (
            r#"{"emission": {"0": [1, 1, 1]}, "lights": {}}"#,
            StatusCode::UNPROCESSABLE_ENTITY,
            "not both",
        ),
        (
            r#"{"light": {}}"#,
            StatusCode::UNPROCESSABLE_ENTITY,
            "unknown field 'light'",
        ),
        (
            r#"[1, 2, 3]"#,
            StatusCode::UNPROCESSABLE_ENTITY,
            "JSON object",
        ),
        (
            r#"{"surfaces": "yes"}"#,
            StatusCode::UNPROCESSABLE_ENTITY,
            "true or false",
        ),
    ];
    for (body, status, needle) in cases {
        let (s, h, v) = post(app(), "/api/scenes/cornell-box/radiosity", *body).await;
        assert_eq!(s, *status, "{body}: {v}");
        assert_eq!(h[header::CONTENT_TYPE], "application/problem+json");
        let detail = v["detail"].as_str().unwrap();
        assert!(
            detail.contains(needle),
            "{body}: '{detail}' lacks '{needle}'"
        );
    }
}

#[tokio::test]
async fn oversized_bodies_get_413() {
    let _gate = common::shared();
    let base = state();
    let small = base.reconfigured(ServerConfig {
        body_limit: 1000,
        ..base.config.clone()
    });
    let body = format!(r#"{{"lights": {{}}, "pad": "{}"}}"#, "x".repeat(5000));
    let (s, h, v) = post(router(small), "/api/scenes/cornell-box/radiosity", body).await;
    assert_eq!(s, StatusCode::PAYLOAD_TOO_LARGE, "{v}");
    assert_eq!(h[header::CONTENT_TYPE], "application/problem+json");
    assert!(v["detail"].as_str().unwrap().contains("limit"));
}

#[tokio::test]
async fn columns_mode_refuses_per_patch_emission() {
    let _gate = common::shared();
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("room");
    relight::bench::write_group_room(&scene, 2, 300).unwrap();
    let s = AppState::new(config(dir.path().into(), dir.path().join("cache"))).unwrap();
    s.bake_all();
    let (st, _, v) = post(
        router(s),
        "/api/scenes/room/radiosity",
        r#"{"emission": {"0": [1, 1, 1]}}"#,
    )
    .await;
    assert_eq!(st, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(v["detail"].as_str().unwrap().contains("factored"), "{v}");
}

#[tokio::test]
async fn illuminance_per_surface_and_at_points_matches_the_reference() {
    let _gate = common::shared();
    let reference: Value = serde_json::from_str(
        &std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("tests/data/cornell_reference.json"),
        )
        .unwrap(),
    )
    .unwrap();
    let grid = reference["states"]["white"]["floor_grid_5x5_y1mm"]["points"]
        .as_array()
        .unwrap();
    let points: Vec<Value> = grid
        .iter()
        .map(|p| json!({"position": p["p"], "normal": p["n"]}))
        .collect();
    let body = json!({"surfaces": ["floor", "back_wall"], "points": points});
    let (s, _, v) = post(
        app(),
        "/api/scenes/cornell-box/illuminance",
        body.to_string(),
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let got = v["points"].as_array().unwrap();
    assert_eq!(got.len(), 25);
    let mut worst = 0f64;
    for (g, r) in got.iter().zip(grid) {
        for c in 0..3 {
            let (a, b) = (g["rgb"][c].as_f64().unwrap(), r["E"][c].as_f64().unwrap());
            if b == 0.0 {
                assert!(a < 1e-3, "inside a block: {a}");
            } else {
                worst = worst.max(((a - b) / b).abs());
            }
        }
    }
    eprintln!("floor points: worst relative error {worst:.4}");
    // Measured: 2.75 % at worst (a point in the short block's penumbra), most under 1 %.
    assert!(worst < 0.035, "worst point error {worst}");
    // Per surface: avg equals the library's area-weighted mean; min ≤ avg ≤ max.
    let floor = &v["surfaces"]["floor"];
    let r = ready("cornell-box");
    let sol = r.baked.transfer.relight(&[[1.0; 3]]);
    let avg =
        &relight::model::report::surface_averages(&r.baked.scene, &r.baked.mesh, &sol)["floor"];
    assert!((floor["avg"]["rgb"][1].as_f64().unwrap() - avg.illuminance[1]).abs() < 1e-9);
    let (mn, av, mx) = (
        floor["min"]["lux"].as_f64().unwrap(),
        floor["avg"]["lux"].as_f64().unwrap(),
        floor["max"]["lux"].as_f64().unwrap(),
    );
    assert!(mn <= av && av <= mx);
    assert!((floor["uniformity"].as_f64().unwrap() - mn / av).abs() < 1e-12);
    // Errors.
    let (s, _, v) = post(
        app(),
        "/api/scenes/cornell-box/illuminance",
        r#"{"surfaces": ["roof"]}"#,
    )
    .await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(v["detail"]
        .as_str()
        .unwrap()
        .contains("unknown surface 'roof'"));
    let (s, _, v) = post(
        app(),
        "/api/scenes/cornell-box/illuminance",
        r#"{"points": [{"position": [0, 0], "normal": [0, 1, 0]}]}"#,
    )
    .await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(v["detail"].as_str().unwrap().contains("points[0].position"));
}

#[tokio::test]
async fn batch_answers_each_state_like_a_single_request() {
    let _gate = common::shared();
    let states: Vec<Value> = (0..5)
        .map(|k| json!({"lights": {"ceiling": k as f64 * 0.25, "lamp": 1.0 - k as f64 * 0.2}}))
        .collect();
    let body = json!({"states": states, "surfaces": ["desk_top"]});
    let (s, _, v) = post(app(), "/api/scenes/desk-room/batch", body.to_string()).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let results = v["results"].as_array().unwrap();
    assert_eq!(results.len(), 5);
    for (k, res) in results.iter().enumerate() {
        let single = json!({"lights": {"ceiling": k as f64 * 0.25, "lamp": 1.0 - k as f64 * 0.2}, "surfaces": ["desk_top"]});
        let (_, _, one) = post(
            app(),
            "/api/scenes/desk-room/illuminance",
            single.to_string(),
        )
        .await;
        assert_eq!(res["surfaces"]["desk_top"], one["surfaces"]["desk_top"]);
        assert!(res["power"]["emitted_lm"].as_f64().unwrap() >= 0.0);
    }
    let too_many: Vec<Value> = (0..1001).map(|_| json!({})).collect();
    let (s, _, v) = post(
        app(),
        "/api/scenes/desk-room/batch",
        json!({ "states": too_many }).to_string(),
    )
    .await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(v["detail"].as_str().unwrap().contains("1000"));
    let (s, _, v) = post(
        app(),
        "/api/scenes/desk-room/batch",
        r#"{"states": [{"lights": {"x": 1}}]}"#,
    )
    .await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(v["detail"].as_str().unwrap().starts_with("states[0]"));
}

#[tokio::test]
async fn baking_scenes_answer_503_with_progress() {
    let _gate = common::shared();
    let s = AppState::new(config(
        common::scenes_dir(),
        std::env::temp_dir().join("never"),
    ))
    .unwrap();
    let (st, v) = get(router(s.clone()), "/readyz").await;
    assert_eq!(st, StatusCode::SERVICE_UNAVAILABLE);
    assert_eq!(v["ready"], false);
    let (st, h, v) = post(router(s.clone()), "/api/scenes/cornell-box/radiosity", "{}").await;
    assert_eq!(st, StatusCode::SERVICE_UNAVAILABLE);
    assert_eq!(h[header::CONTENT_TYPE], "application/problem+json");
    assert!(v["progress"].is_number() && v["detail"].as_str().unwrap().contains("retry"));
    let (st, v) = get(router(s), "/api/scenes").await;
    assert_eq!(st, StatusCode::OK);
    assert_eq!(v["scenes"][0]["status"], "queued");
}

#[tokio::test]
async fn a_broken_scene_is_listed_as_failed_and_the_others_serve() {
    let _gate = common::shared();
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("broken");
    std::fs::create_dir(&bad).unwrap();
    std::fs::write(
        bad.join("b.obj"),
        "mtllib b.mtl\no t\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n",
    )
    .unwrap();
    std::fs::write(bad.join("b.mtl"), "newmtl m\nKd 1.5 0.5 0.5\n").unwrap();
    relight::bench::write_group_room(&dir.path().join("good"), 1, 300).unwrap();
    let s = AppState::new(config(dir.path().into(), dir.path().join("cache"))).unwrap();
    s.bake_all();
    let (st, v) = get(router(s.clone()), "/readyz").await;
    assert_eq!(st, StatusCode::OK, "failed scenes count as settled");
    let (_, v2) = get(router(s.clone()), "/api/scenes").await;
    let broken = &v2["scenes"][0];
    assert_eq!(broken["status"], "failed", "{v}");
    assert!(broken["error"].as_str().unwrap().contains("b.mtl:2"));
    let (st, _, v) = post(router(s.clone()), "/api/scenes/broken/radiosity", "{}").await;
    assert_eq!(st, StatusCode::SERVICE_UNAVAILABLE);
    assert!(v["detail"].as_str().unwrap().contains("failed to load"));
    let (st, _, _) = post(router(s), "/api/scenes/good/radiosity", "{}").await;
    assert_eq!(st, StatusCode::OK);
}

#[tokio::test]
async fn openapi_metrics_and_cors() {
    let _gate = common::shared();
    let (s, v) = get(app(), "/api/openapi.json").await;
    assert_eq!(s, StatusCode::OK);
    for p in [
        "/api/scenes",
        "/api/scenes/{id}/radiosity",
        "/api/scenes/{id}/illuminance",
        "/api/scenes/{id}/batch",
        "/api/scenes/{id}/patches",
    ] {
        assert!(v["paths"][p].is_object(), "spec lacks {p}");
    }
    let _ = get(app(), "/api/scenes").await;
    let (s, _, b) = send(app(), Request::get("/metrics").body(Body::empty()).unwrap()).await;
    assert_eq!(s, StatusCode::OK);
    let text = String::from_utf8(b).unwrap();
    assert!(
        text.contains(
            "relight_http_requests_total{method=\"GET\",route=\"/api/scenes\",status=\"200\"}"
        ),
        "{text}"
    );
    assert!(text.contains("relight_http_request_duration_seconds_bucket"));
    assert!(text.contains("relight_bake_seconds{scene=\"cornell-box\""));
    // Same origin only by default: no CORS header.
    let req = Request::get("/api/scenes")
        .header(header::ORIGIN, "http://elsewhere.example")
        .body(Body::empty())
        .unwrap();
    let (_, h, _) = send(app(), req).await;
    assert!(h.get(header::ACCESS_CONTROL_ALLOW_ORIGIN).is_none());
    let base = state();
    let open = base.reconfigured(ServerConfig {
        cors_origins: vec!["http://studio.example".into()],
        ..base.config.clone()
    });
    let req = Request::get("/api/scenes")
        .header(header::ORIGIN, "http://studio.example")
        .body(Body::empty())
        .unwrap();
    let (_, h, _) = send(router(open), req).await;
    assert_eq!(
        h[header::ACCESS_CONTROL_ALLOW_ORIGIN],
        "http://studio.example"
    );
}

#[tokio::test]
async fn real_server_on_a_loopback_port_relights_the_cornell_box() {
    let _gate = common::shared();
    // A fresh state with the shared cache: the server listens first, bakes in the background.
    let cfg = state().config.clone();
    let s = AppState::new(cfg).unwrap();
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    s.spawn_bakes();
    let server = tokio::spawn(async move { axum::serve(listener, router(s)).await });
    let client = reqwest::Client::new();
    let base = format!("http://{addr}");
    let mut ready = false;
    for _ in 0..600 {
        let r = client.get(format!("{base}/readyz")).send().await.unwrap();
        if r.status() == 200 {
            ready = true;
            break;
        }
        tokio::time::sleep(std::time::Duration::from_millis(100)).await;
    }
    assert!(ready, "server did not become ready");
    let resp = client
        .post(format!("{base}/api/scenes/cornell-box/radiosity"))
        .header("accept", "application/octet-stream")
        .header("content-type", "application/json")
        .body(r#"{"lights": {"ceiling": 0.7}}"#)
        .send()
        .await
        .unwrap();
    assert_eq!(resp.status(), 200);
    let bytes = resp.bytes().await.unwrap();
    let got: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    let want = ready_cornell().baked.transfer.relight(&[[0.7; 3]]).b;
    assert_eq!(got, want);
    server.abort();
}

fn ready_cornell() -> Arc<relight::server::Ready> {
    ready("cornell-box")
}

#[tokio::test]
async fn render_endpoints_return_images_and_precise_errors() {
    let _gate = common::shared();
    let req = |uri: &str| Request::get(uri).body(Body::empty()).unwrap();
    // Quick GET: PNG; a brighter light gives a brighter image (fixed exposure).
    let (s, h, dim) = send(app(), req("/api/scenes/cornell-box/render.png?camera=front&w=64&h=64&exposure=0&light.ceiling=0.5")).await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(h[header::CONTENT_TYPE], "image/png");
    assert_eq!(&dim[1..4], b"PNG");
    let (_, _, bright) = send(app(), req("/api/scenes/cornell-box/render.png?camera=front&w=64&h=64&exposure=0&light.ceiling=1.5")).await;
    let mean = |png: &[u8]| {
        let img = image::load_from_memory(png).unwrap().to_rgb8();
        img.pixels()
            .map(|p| p.0.iter().map(|&v| v as f64).sum::<f64>())
            .sum::<f64>()
    };
    assert!(mean(&bright) > mean(&dim) * 1.2);
    // POST: JPEG, EXR, false colour with its range header.
    for (fmt, ct) in [("jpeg", "image/jpeg"), ("exr", "image/x-exr")] {
        let body = json!({"camera": "front", "width": 32, "height": 32, "format": fmt}).to_string();
        let r = Request::post("/api/scenes/cornell-box/render")
            .header(header::CONTENT_TYPE, "application/json")
            .body(Body::from(body))
            .unwrap();
        let (s, h, b) = send(app(), r).await;
        assert_eq!(
            (s, h[header::CONTENT_TYPE].to_str().unwrap()),
            (StatusCode::OK, ct)
        );
        assert!(b.len() > 100);
    }
    let body = json!({"camera": {"position": [0.278, 0.273, -0.8], "target": [0.278, 0.273, 0], "fov_deg": 39.3},
                      "width": 48, "height": 32, "mode": "falsecolor"});
    let (s, h, _) = send(
        app(),
        Request::post("/api/scenes/cornell-box/render")
            .header(header::CONTENT_TYPE, "application/json")
            .body(Body::from(body.to_string()))
            .unwrap(),
    )
    .await;
    assert_eq!(s, StatusCode::OK);
    assert!(h.contains_key("x-relight-falsecolor-lux"));
    // Errors.
    for (body, needle) in [
        (json!({"width": 5000}), "4096"),
        (json!({"camera": "top"}), "unknown camera 'top'"),
        (json!({"format": "gif"}), "format 'gif'"),
        (
            json!({"camera": {"position": [0, 0, 0], "target": [0, 0, 0], "fov_deg": 40}}),
            "target must differ",
        ),
        (json!({"mode": "falsecolor", "format": "exr"}), "8-bit"),
    ] {
        let (s, _, v) = post(app(), "/api/scenes/cornell-box/render", body.to_string()).await;
        assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{body}");
        assert!(
            v["detail"].as_str().unwrap().contains(needle),
            "{body}: {v}"
        );
    }
    let (s, _, _) = send(app(), req("/api/scenes/cornell-box/render.png?w=big")).await;
    assert_eq!(s, StatusCode::BAD_REQUEST);
}

#[tokio::test]
async fn mesh_and_per_patch_illuminance_let_a_client_shade_like_the_server() {
    let _gate = common::shared();
    let (s, h, b) = send(
        app(),
        Request::get("/api/scenes/desk-room/mesh")
            .body(Body::empty())
            .unwrap(),
    )
    .await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(h[header::CONTENT_TYPE], "application/octet-stream");
    assert_eq!(&b[..8], b"RLMESH01");
    let u = |i: usize| u32::from_le_bytes(b[i..i + 4].try_into().unwrap());
    let (nv, nt, nw) = (u(8) as usize, u(12) as usize, u(16) as usize);
    let r = ready("desk-room");
    let mesh = &r.baked.mesh;
    assert_eq!(nt, mesh.len());
    assert_eq!(b.len(), 20 + 4 * (3 * nv + 3 * nt + nt + nv + 1 + 2 * nw));
    let f = |i: usize| f32::from_bits(u(i));
    let (pos, tri) = (20, 20 + 12 * nv);
    let (surf, start) = (tri + 12 * nt, tri + 16 * nt);
    let (patch, weight) = (start + 4 * (nv + 1), start + 4 * (nv + 1) + 4 * nw);
    for (t, p) in mesh.patches.iter().enumerate() {
        assert_eq!(u(surf + 4 * t), p.surface);
        // Each triangle corner sits on the patch's mesh vertex, counter-clockwise.
        for k in 0..3 {
            let v = u(tri + 12 * t + 4 * k) as usize;
            let want = mesh.vertices[p.v[k] as usize].as_vec3();
            let got = glam::Vec3::new(f(pos + 12 * v), f(pos + 12 * v + 4), f(pos + 12 * v + 8));
            assert!((got - want).length() < 1e-6);
        }
    }
    // Vertex colours from the CSR weights and the binary radiosity match the renderer's.
    let req = Request::post("/api/scenes/desk-room/radiosity")
        .header(header::CONTENT_TYPE, "application/json")
        .header(header::ACCEPT, "application/octet-stream")
        .body(Body::from(r#"{"lights": {"lamp": 0.4}}"#))
        .unwrap();
    let (_, _, rb) = send(app(), req).await;
    let rad: &[f32] = bytemuck::cast_slice(&rb);
    let want = r.shading().vertex_values(rad);
    for (v, w) in want.iter().enumerate() {
        let mut acc = [0f32; 3];
        let mut wsum = 0.0;
        for k in u(start + 4 * v)..u(start + 4 * v + 4) {
            let (p, wt) = (
                u(patch + 4 * k as usize) as usize,
                f(weight + 4 * k as usize),
            );
            wsum += wt;
            for c in 0..3 {
                acc[c] += wt * rad[3 * p + c];
            }
        }
        assert!((wsum - 1.0).abs() < 1e-5);
        for c in 0..3 {
            assert!((acc[c] - w[c]).abs() <= 1e-4 * w[c].max(1.0));
        }
    }
    // quantity = illuminance gives H (lux), binary and JSON alike.
    let weights: Vec<[f32; 3]> = r
        .groups
        .iter()
        .map(|g| {
            let k = if g.id == "lamp" { 0.4 } else { g.intensity };
            g.color.map(|c| c * k)
        })
        .collect();
    let h_want = r.baked.transfer.relight(&weights).h;
    let req = Request::post("/api/scenes/desk-room/radiosity")
        .header(header::CONTENT_TYPE, "application/json")
        .header(header::ACCEPT, "application/octet-stream")
        .body(Body::from(
            r#"{"lights": {"lamp": 0.4}, "quantity": "illuminance"}"#,
        ))
        .unwrap();
    let (s, h, hb) = send(app(), req).await;
    assert_eq!(s, StatusCode::OK);
    assert!(h["x-relight-layout"].to_str().unwrap().contains("lx"));
    assert_eq!(bytemuck::cast_slice::<u8, f32>(&hb), h_want.as_slice());
    let (s, _, v) = post(
        app(),
        "/api/scenes/desk-room/radiosity",
        r#"{"lights": {"lamp": 0.4}, "quantity": "illuminance"}"#,
    )
    .await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(v["unit"], "lx");
    assert_eq!(floats(&v["illuminance"]).len(), 3 * mesh.len());
    let (s, _, v) = post(
        app(),
        "/api/scenes/desk-room/radiosity",
        r#"{"quantity": "luminance"}"#,
    )
    .await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(v["detail"].as_str().unwrap().contains("'quantity'"), "{v}");
}

#[tokio::test]
async fn grids_answer_with_statistics_and_luminaire_power() {
    let _gate = common::shared();
    let (s, _, v) = post(
        app(),
        "/api/scenes/office/illuminance",
        r#"{"lights": {"window_row": 0.5}, "grids": ["desk", "workplane"], "surfaces": []}"#,
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let r = ready("office");
    for id in ["desk", "workplane"] {
        let g = &v["grids"][id];
        let values: Vec<f64> = g["values"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        let gr = r.grids.iter().find(|x| x.grid.id == id).unwrap();
        assert_eq!(values.len(), gr.len());
        let avg = values.iter().sum::<f64>() / values.len() as f64;
        let min = values.iter().copied().fold(f64::INFINITY, f64::min);
        let max = values.iter().copied().fold(0.0, f64::max);
        assert!((g["avg"].as_f64().unwrap() - avg).abs() < 1e-6 * avg);
        assert!((g["u0"].as_f64().unwrap() - min / avg).abs() < 1e-6);
        assert!((g["min_max"].as_f64().unwrap() - min / max).abs() < 1e-6);
        // Linear in the weights: the half-dimmed window row equals the weighted sum.
        let full = gr.values(&[[0.5; 3], [1.0; 3]]);
        for (a, b) in values.iter().zip(&full) {
            assert!((a - *b as f64).abs() <= 1e-4 * a.max(1.0));
        }
    }
    // 3 × 2500 lm at half plus 3 × 2500 lm at full (the table integrates to 2495 lm each).
    let lm = v["power"]["luminaire_lumens"].as_f64().unwrap();
    assert!((lm / 11250.0 - 1.0).abs() < 0.005, "{lm}");
    let w = v["power"]["luminaire_watts"].as_f64().unwrap();
    assert!((w / (lm / 113.6) - 1.0).abs() < 1e-6, "{w}");
    // Unknown grids are precise 422s.
    let (s, _, v) = post(
        app(),
        "/api/scenes/office/illuminance",
        r#"{"grids": ["kitchen"]}"#,
    )
    .await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(
        v["detail"].as_str().unwrap().contains("desk, workplane"),
        "{v}"
    );
}

#[tokio::test]
async fn optimize_finds_the_least_flux_levels_that_meet_the_targets() {
    let _gate = common::shared();
    let body = r#"{"targets": [{"grid": "desk", "eavg_min": 500, "u0_min": 0.6}]}"#;
    let (s, _, v) = post(app(), "/api/scenes/office/optimize", body).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    assert_eq!(v["targets"][0]["met"], true, "{v}");
    let lv = |id: &str| v["lights"][id]["intensity"].as_f64().unwrap();
    let (a, b) = (lv("window_row"), lv("corridor_row"));
    let r = ready("office");
    let desk = r.grids.iter().find(|g| g.grid.id == "desk").unwrap();
    let meets = |x: f64, y: f64| {
        let s = desk.stats(&[[x as f32; 3], [y as f32; 3]]);
        s.avg >= 500.0 * (1.0 - 1e-4) && s.u0 >= 0.6 - 1e-4
    };
    assert!(meets(a, b), "levels {a} {b}");
    // Brute force over a 1 % grid of levels: nothing feasible uses less flux (both rows
    // have the same lumens, so flux ∝ a + b).
    let best = (0..=100)
        .flat_map(|i| (0..=100).map(move |j| (i as f64 / 100.0, j as f64 / 100.0)))
        .filter(|&(x, y)| meets(x, y))
        .map(|(x, y)| x + y)
        .fold(f64::INFINITY, f64::min);
    assert!(a + b <= best + 1e-6, "LP {a} + {b} vs brute force {best}");
    // Out of reach: a clear reason with the best achievable value.
    let (s, _, v) = post(
        app(),
        "/api/scenes/office/optimize",
        r#"{"targets": [{"grid": "desk", "eavg_min": 5000}]}"#,
    )
    .await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);
    let d = v["detail"].as_str().unwrap();
    assert!(d.contains("out of reach") && d.contains("100 %"), "{d}");
    // Bad targets are precise 422s.
    for (body, needle) in [
        (r#"{"targets": []}"#, "non-empty"),
        (r#"{"targets": [{"grid": "desk"}]}"#, "sets no bound"),
        (r#"{"targets": [{"grid": "desk", "u0_min": 2}]}"#, "u0_min"),
        (
            r#"{"targets": [{"grid": "desk", "eavg": 5}]}"#,
            "unknown field",
        ),
        (
            r#"{"targets": [{"grid": "desk", "u0_min": 0.9}]}"#,
            "u0_min needs",
        ),
        (
            r#"{"targets": [{"grid": "nope", "eavg_min": 5}]}"#,
            "unknown grid",
        ),
        (
            r#"{"targets": [{"grid": "desk", "eavg_min": 5}], "groups": ["x"]}"#,
            "unknown light group",
        ),
    ] {
        let (s, _, v) = post(app(), "/api/scenes/office/optimize", body).await;
        assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{body}");
        assert!(
            v["detail"].as_str().unwrap().contains(needle),
            "{body}: {v}"
        );
    }
}
