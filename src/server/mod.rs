//! The HTTP server: axum over the baked scenes.
//!
//! The server listens at once. Scenes bake (or load from the cache) in the background, one
//! after another, on a plain thread (rayon does the parallel work), never on the async
//! runtime. Each scene has a slot: queued → baking (progress) → ready, or failed with its
//! error. A scene that fails, even by panicking, never takes the others down.

pub mod admission;
mod config;
pub mod error;
pub mod json;
pub mod metrics;
pub mod openapi;
pub mod parse;
mod requests;
pub(crate) mod routes;
pub mod serve;
mod state;
pub mod views;

pub use config::*;
pub use state::{AppState, GroupInfo, Ready, SceneSlot, SlotState};

use std::sync::Arc;
use std::time::{Duration, Instant};

use axum::extract::{MatchedPath, Request, State};
use axum::http::{HeaderValue, Method};
use axum::middleware::{self, Next};
use axum::response::Response;
use axum::routing::{get, post};
use axum::Router;
use tower_http::cors::{AllowOrigin, CorsLayer};
use tower_http::services::ServeDir;
use tower_http::trace::{DefaultMakeSpan, DefaultOnFailure, DefaultOnResponse, TraceLayer};
use tower_http::LatencyUnit;
use tracing::Level;

use routes::{
    annual, batch, daylight, export, glare, illuminance, optimize, radiosity, render, report,
    scenes, service, upload,
};

pub use error::AppError;

async fn track(State(state): State<Arc<AppState>>, req: Request, next: Next) -> Response {
    let route = req
        .extensions()
        .get::<MatchedPath>()
        .map(|m| m.as_str().to_string())
        .unwrap_or_else(|| "unmatched".into());
    let method = metrics::method_label(req.method());
    let t0 = Instant::now();
    let resp = next.run(req).await;
    state.metrics.observe(
        method,
        &route,
        resp.status().as_u16(),
        t0.elapsed().as_secs_f64(),
    );
    resp
}

/// Answers 503 when a request takes longer than the configured limit. Dropping the
/// handler's future cancels its blocking work (see [`admission::Cancel`]).
async fn timeout(State(state): State<Arc<AppState>>, req: Request, next: Next) -> Response {
    let limit = state.config.request_timeout;
    match tokio::time::timeout(limit, next.run(req)).await {
        Ok(resp) => resp,
        Err(_) => axum::response::IntoResponse::into_response(AppError::Unavailable {
            detail: format!(
                "the request did not finish within the {} s limit (--request-timeout)",
                limit.as_secs_f64()
            ),
            progress: None,
        }),
    }
}

/// The full application: API, metrics, health, the web page.
pub fn router(state: Arc<AppState>) -> Router {
    let cors = cors_layer(&state.config.cors_origins);
    let static_dir = state.config.static_dir.clone();
    let not_found = axum::handler::HandlerWithoutStateExt::into_service(service::not_found);
    let app = Router::new()
        .route("/healthz", get(service::healthz))
        .route("/readyz", get(service::readyz))
        .route("/metrics", get(service::metrics))
        .route("/api/openapi.json", get(service::openapi))
        .route("/api/scenes", get(scenes::list_scenes))
        .route(
            "/api/scenes/{id}",
            get(scenes::scene_details)
                .put(upload::put_scene)
                .delete(upload::delete_scene),
        )
        .route("/api/scenes/{id}/patches", get(scenes::patches))
        .route("/api/scenes/{id}/mesh", get(scenes::mesh))
        .route("/api/scenes/{id}/mesh/preview", get(scenes::mesh_preview))
        .route("/api/scenes/{id}/radiosity", post(radiosity::radiosity))
        .route(
            "/api/scenes/{id}/illuminance",
            post(illuminance::illuminance),
        )
        .route("/api/scenes/{id}/daylight", post(daylight::daylight))
        .route("/api/scenes/{id}/annual", post(annual::annual))
        .route("/api/scenes/{id}/glare", post(glare::glare))
        .route("/api/scenes/{id}/batch", post(batch::batch))
        .route("/api/scenes/{id}/optimize", post(optimize::optimize))
        .route("/api/scenes/{id}/render", post(render::render_post))
        .route("/api/scenes/{id}/render.png", get(render::render_get))
        .route(
            "/api/scenes/{id}/export.glb",
            get(export::export_glb).post(export::export_glb_post),
        )
        .route(
            "/api/scenes/{id}/report",
            get(report::report).post(report::report_post),
        )
        .route("/api/{*rest}", axum::routing::any(service::not_found))
        .fallback_service(ServeDir::new(static_dir).not_found_service(not_found))
        .layer(axum::extract::DefaultBodyLimit::max(
            state.config.body_limit,
        ))
        .layer(middleware::from_fn_with_state(state.clone(), timeout))
        .layer(middleware::from_fn_with_state(state.clone(), track))
        .with_state(state);
    let app = match cors {
        Some(c) => app.layer(c),
        None => app,
    };
    app.layer(
        TraceLayer::new_for_http()
            .make_span_with(DefaultMakeSpan::new().level(Level::INFO))
            .on_response(
                DefaultOnResponse::new()
                    .level(Level::INFO)
                    .latency_unit(LatencyUnit::Micros),
            )
            .on_failure(DefaultOnFailure::new().level(Level::DEBUG)),
    )
}

fn cors_layer(origins: &[String]) -> Option<CorsLayer> {
    if origins.is_empty() {
        return None;
    }
    let allow = if origins.iter().any(|o| o == "*") {
        AllowOrigin::any()
    } else {
        AllowOrigin::list(
            origins
                .iter()
                .filter_map(|o| HeaderValue::from_str(o).ok())
                .collect::<Vec<_>>(),
        )
    };
    Some(
        CorsLayer::new()
            .allow_origin(allow)
            .allow_methods([Method::GET, Method::POST, Method::OPTIONS])
            .allow_headers([axum::http::header::CONTENT_TYPE, axum::http::header::ACCEPT])
            .max_age(Duration::from_secs(3600)),
    )
}

/// Runs the server until SIGINT/SIGTERM; in-flight requests finish.
pub async fn serve(config: ServerConfig) -> anyhow::Result<()> {
    let state = AppState::new(config.clone()).map_err(|e| {
        anyhow::anyhow!(
            "cannot read the scenes folder {}: {e}",
            config.scenes.display()
        )
    })?;
    let listener = tokio::net::TcpListener::bind(config.addr)
        .await
        .map_err(|e| anyhow::anyhow!("cannot listen on {}: {e}", config.addr))?;
    let addr = listener.local_addr()?;
    tracing::info!(
        "listening on http://{addr} with {} scene(s) from {} (cache {}{})",
        state.slots().len(),
        config.scenes.display(),
        config.cache.display(),
        if config.read_only { ", read-only" } else { "" }
    );
    if !config.read_only {
        let removed = crate::bake::cache::remove_stale_temps(&config.cache);
        if removed > 0 {
            tracing::info!("removed {removed} stale temporary file(s) from the cache");
        }
    }
    state.spawn_bakes();
    run(listener, state, shutdown_signal()).await;
    tracing::info!("shut down");
    Ok(())
}

/// Serves `state` on `listener`, with its configured header timeout and connection cap,
/// until `shutdown` completes; in-flight requests then finish.
pub async fn run(
    listener: tokio::net::TcpListener,
    state: Arc<AppState>,
    shutdown: impl std::future::Future<Output = ()> + Send,
) {
    let (header_timeout, max_connections) =
        (state.config.header_timeout, state.config.max_connections);
    serve::serve_with_limits(
        listener,
        router(state),
        header_timeout,
        max_connections,
        shutdown,
    )
    .await;
}

async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {},
        _ = term => {},
    }
    tracing::info!("shutdown signal: finishing in-flight requests");
}
