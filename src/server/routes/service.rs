//! Service endpoints: `/healthz`, `/readyz`, `/metrics`, `/api/openapi.json`, and the
//! 404 of unknown API paths.

use std::sync::Arc;

use axum::extract::State;
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::Serialize;
use utoipa::ToSchema;

use super::scenes::SceneSummary;
use crate::server::openapi::{Document, HealthText, MetricsText};
use crate::server::{AppError, AppState};

#[utoipa::path(get, path = "/healthz", operation_id = "healthz", tags = ["service"],
    summary = "Liveness: 200 while the process is up.",
    responses((status = 200, description = "The text `ok`.", body = HealthText, content_type = "text/plain")))]
pub(crate) async fn healthz() -> &'static str {
    "ok"
}

pub(crate) async fn not_found() -> AppError {
    AppError::NotFound("no such endpoint; see /api/openapi.json".into())
}

#[utoipa::path(get, path = "/metrics", operation_id = "metrics", tags = ["service"],
    summary = "Prometheus metrics: requests and latency per route, bake times.",
    responses((status = 200, description = "Prometheus text exposition format 0.0.4.", body = MetricsText, content_type = "text/plain")))]
pub(crate) async fn metrics(State(state): State<Arc<AppState>>) -> Response {
    (
        [(
            header::CONTENT_TYPE,
            "text/plain; version=0.0.4; charset=utf-8",
        )],
        state.metrics.render() + &memory_metrics(&state),
    )
        .into_response()
}

/// Gauges of the memory budget and the view cache, bytes.
fn memory_metrics(state: &AppState) -> String {
    let b = &state.budget;
    let views = state.views.lock().map(|v| v.bytes()).unwrap_or(0);
    let mut out = String::new();
    for (name, help, v) in [
        (
            "relight_memory_budget_bytes",
            "The memory budget.",
            b.total(),
        ),
        (
            "relight_memory_pinned_bytes",
            "Bytes held by loaded scenes.",
            b.pinned(),
        ),
        (
            "relight_memory_reserved_bytes",
            "Bytes reserved by requests in flight.",
            b.used(),
        ),
        (
            "relight_view_cache_bytes",
            "Bytes held by cached view buffers and group images.",
            views as u64,
        ),
    ] {
        out += &format!("# HELP {name} {help}\n# TYPE {name} gauge\n{name} {v}\n");
    }
    out
}

#[utoipa::path(get, path = "/api/openapi.json", operation_id = "openapi", tags = ["service"],
    summary = "This document.",
    responses((status = 200, description = "The OpenAPI 3.1 document.", body = Document)))]
pub(crate) async fn openapi() -> Response {
    (
        [(header::CONTENT_TYPE, "application/json")],
        crate::server::openapi::spec().to_string(),
    )
        .into_response()
}

/// Whether every scene is ready or failed, with every scene's status.
#[derive(Serialize, ToSchema)]
pub(crate) struct Readiness {
    ready: bool,
    scenes: Vec<SceneSummary>,
}

#[utoipa::path(get, path = "/readyz", operation_id = "readyz", tags = ["service"],
    summary = "Readiness: 200 once every scene is ready or failed, else 503 with every scene's status and progress.",
    responses(
        (status = 200, description = "Every scene is ready or failed.", body = Readiness),
        (status = 503, description = "Some scene is still queued or baking.", body = Readiness),
    ))]
pub(crate) async fn readyz(State(state): State<Arc<AppState>>) -> Response {
    let scenes = SceneSummary::all(&state);
    let ready = state.settled();
    let status = if ready {
        StatusCode::OK
    } else {
        StatusCode::SERVICE_UNAVAILABLE
    };
    (status, Json(Readiness { ready, scenes })).into_response()
}
