//! The OpenAPI document, metrics, CORS, and one real server on a loopback port.

use std::sync::Arc;

use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use relight::color::Rgb;
use relight::server::{router, AppState, ServerConfig};

use super::{app, get, ready, send, state};
use crate::common;

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
    let want = ready_cornell()
        .model
        .baked
        .transfer
        .relight(&[Rgb::splat(0.7)])
        .b;
    assert_eq!(got, want);
    server.abort();
}

fn ready_cornell() -> Arc<relight::server::Ready> {
    ready("cornell-box")
}
