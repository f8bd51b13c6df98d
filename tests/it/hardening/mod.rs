//! Regression tests for the hardening findings, each named after the finding it pins.
//!
//! Requests, scene files and processes that once crashed, stalled or exhausted the server;
//! this file holds the shared state and request helpers.

mod input;
mod processes;
mod resources;

use std::sync::{Arc, OnceLock};

use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use axum::Router;
use http_body_util::BodyExt;
use relight::server::{router, AppState, ServerConfig};
use serde_json::Value;
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
            assert!(s.slots().iter().all(|s| s.status().0 == "ready"));
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
