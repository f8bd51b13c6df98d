//! The HTTP API through `oneshot`, checked against the library: shared state and helpers.

mod annual;
mod batch;
mod compliance;
mod daylight;
mod export;
mod glare;
mod illuminance;
mod optimize;
mod placed;
mod radiosity;
mod render;
mod report;
mod scenes;
mod server;
mod upload;

use std::sync::{Arc, OnceLock};

use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use axum::Router;
use http_body_util::BodyExt;
use relight::server::{router, AppState, ServerConfig, DEFAULT_BODY_LIMIT};
use serde_json::Value;
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
            assert!(s.slots().iter().all(|s| s.status().0 == "ready"));
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
