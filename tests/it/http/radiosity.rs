//! `radiosity`: light levels or per-patch emission in, radiosity out, and every refusal.

use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use relight::color::Rgb;
use relight::server::{router, AppState, ServerConfig};
use serde_json::json;

use super::{app, config, floats, post, ready, send, state};
use crate::common;

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
    let sol = r
        .model
        .baked
        .transfer
        .relight(&[Rgb::splat(0.4), Rgb::new(2.0, 1.0, 0.5)]);
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
        r.model.baked.transfer.relight(&[Rgb::ONE, Rgb::ZERO]).b
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
        r.model.baked.mesh.len().to_string().as_str()
    );
    let got: &[f32] = bytemuck::cast_slice(&b);
    assert_eq!(
        got,
        r.model
            .baked
            .transfer
            .relight(&[Rgb::new(1.0, 0.6, 0.3)])
            .b
            .as_slice()
    );
}

#[tokio::test]
async fn per_patch_emission_dense_and_sparse() {
    let _gate = common::shared();
    let r = ready("cornell-box");
    let n = r.model.baked.mesh.len();
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
    let want = r
        .model
        .baked
        .transfer
        .solve(bytemuck::cast_slice(&e))
        .unwrap();
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
        router(s.clone()),
        "/api/scenes/room/radiosity",
        r#"{"emission": {"0": [1, 1, 1]}}"#,
    )
    .await;
    assert_eq!(st, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(v["detail"].as_str().unwrap().contains("factored"), "{v}");
    // A batch with an emission state among group states, too, before any work.
    let (st, _, v) = post(
        router(s),
        "/api/scenes/room/batch",
        r#"{"states": [{"lights": {}}, {"emission": {"0": [1, 1, 1]}}]}"#,
    )
    .await;
    assert_eq!(st, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(v["detail"].as_str().unwrap().contains("factored"), "{v}");
}
