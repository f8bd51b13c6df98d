//! The HTTP server: axum over the baked scenes.
//!
//! The server listens at once. Scenes bake (or load from the cache) in the background, one
//! after another, on a plain thread (rayon does the parallel work), never on the async
//! runtime. Each scene has a slot: queued → baking (progress) → ready, or failed with its
//! error. A scene that fails, even by panicking, never takes the others down.

pub mod api;
pub mod error;
pub mod metrics;
pub mod openapi;
pub mod render_api;

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, RwLock};
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

use crate::bake::{self, BakeOptions, Baked, CachePolicy};
use crate::color::luminance64;

pub use error::AppError;

/// Largest accepted request body (bytes) unless configured.
pub const DEFAULT_BODY_LIMIT: usize = 16 << 20;

/// Everything `relight serve` can be told.
#[derive(Debug, Clone)]
pub struct ServerConfig {
    pub addr: SocketAddr,
    pub scenes: PathBuf,
    pub cache: PathBuf,
    /// Never bake or write: serve only what the cache holds.
    pub read_only: bool,
    /// Folder served at `/` (the web page).
    pub static_dir: PathBuf,
    /// Origins allowed by CORS; empty = same origin only. `*` allows any.
    pub cors_origins: Vec<String>,
    pub body_limit: usize,
}

/// Light-group facts shown by the API.
#[derive(Debug, Clone, serde::Serialize)]
pub struct GroupInfo {
    pub id: String,
    pub name: String,
    /// Default intensity and colour.
    pub intensity: f32,
    pub color: [f32; 3],
    /// Area of the emitting patches, m².
    pub emitting_area: f64,
    /// Luminous flux at intensity 1, colour white, lm (emissive surfaces and luminaires).
    pub lumens: f64,
    /// Point luminaires in the group.
    pub luminaires: usize,
    /// Electrical power of the luminaires at intensity 1, W, when every one gives it.
    pub watts: Option<f64>,
}

/// A scene ready to answer.
pub struct Ready {
    pub baked: Baked,
    pub groups: Vec<GroupInfo>,
    pub bake_seconds: f64,
    /// Calculation grids with per-group responses, built when the scene becomes ready.
    pub grids: Vec<crate::grid::GridResponse>,
    shading: std::sync::OnceLock<crate::render::Shading>,
    mesh_bytes: std::sync::OnceLock<axum::body::Bytes>,
}

impl Ready {
    fn new(baked: Baked, bake_seconds: f64) -> Ready {
        let t = &baked.transfer;
        let groups = baked
            .scene
            .lights
            .iter()
            .zip(&t.groups)
            .map(|(l, g)| {
                let mut area = 0.0;
                let mut flux = [0f64; 3];
                for i in 0..t.n {
                    let e = &g.e[3 * i..3 * i + 3];
                    if e.iter().any(|&v| v > 0.0) {
                        area += t.area[i] as f64;
                        for c in 0..3 {
                            flux[c] += t.area[i] as f64 * e[c] as f64;
                        }
                    }
                }
                let watts: Option<f64> = l.luminaires.iter().map(|m| m.watts).sum();
                GroupInfo {
                    id: l.id.clone(),
                    name: l.name.clone(),
                    intensity: l.intensity,
                    color: l.color,
                    emitting_area: area,
                    lumens: luminance64(flux) + luminance64(g.flux),
                    luminaires: l.luminaires.len(),
                    watts: if l.luminaires.is_empty() { None } else { watts },
                }
            })
            .collect();
        let grids = crate::grid::GridResponse::build_all(
            &baked.scene,
            &baked.mesh,
            &baked.bvh,
            &baked.transfer,
        );
        Ready {
            baked,
            groups,
            bake_seconds,
            grids,
            shading: std::sync::OnceLock::new(),
            mesh_bytes: std::sync::OnceLock::new(),
        }
    }

    /// Gouraud shading vertices, built on first use.
    pub fn shading(&self) -> &crate::render::Shading {
        self.shading
            .get_or_init(|| crate::render::Shading::new(&self.baked.mesh))
    }

    /// The shading mesh as served by `GET /api/scenes/{id}/mesh`, built on first use.
    pub fn mesh_bytes(&self) -> axum::body::Bytes {
        self.mesh_bytes
            .get_or_init(|| self.shading().mesh_bytes(&self.baked.mesh).into())
            .clone()
    }
}

/// Where a scene is in its life.
pub enum SlotState {
    Queued,
    Baking,
    Ready(Arc<Ready>),
    Failed(String),
}

/// One scene folder and its state.
pub struct SceneSlot {
    pub id: String,
    pub dir: PathBuf,
    progress: AtomicU64,
    state: RwLock<SlotState>,
}

impl SceneSlot {
    fn new(dir: PathBuf) -> SceneSlot {
        SceneSlot {
            id: dir
                .file_name()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
            dir,
            progress: AtomicU64::new(0f64.to_bits()),
            state: RwLock::new(SlotState::Queued),
        }
    }

    /// Bake progress, 0..1.
    pub fn progress(&self) -> f64 {
        f64::from_bits(self.progress.load(Ordering::Relaxed))
    }

    fn set_progress(&self, p: f64) {
        self.progress.store(p.to_bits(), Ordering::Relaxed);
    }

    fn set(&self, s: SlotState) {
        *self.state.write().unwrap_or_else(|p| p.into_inner()) = s;
    }

    /// Status word and, when ready, the scene.
    pub fn status(&self) -> (&'static str, Option<Arc<Ready>>, Option<String>) {
        match &*self.state.read().unwrap_or_else(|p| p.into_inner()) {
            SlotState::Queued => ("queued", None, None),
            SlotState::Baking => ("baking", None, None),
            SlotState::Ready(r) => ("ready", Some(r.clone()), None),
            SlotState::Failed(e) => ("failed", None, Some(e.clone())),
        }
    }

    /// The ready scene, or the 503 that explains why not.
    pub fn ready(&self) -> Result<Arc<Ready>, AppError> {
        match self.status() {
            (_, Some(r), _) => Ok(r),
            ("failed", _, Some(e)) => Err(AppError::Unavailable {
                detail: format!("scene '{}' failed to load: {e}", self.id),
                progress: None,
            }),
            (word, _, _) => Err(AppError::Unavailable {
                detail: format!(
                    "scene '{}' is {word} ({:.0} % done); retry shortly",
                    self.id,
                    self.progress() * 100.0
                ),
                progress: Some(self.progress()),
            }),
        }
    }

    /// Bakes or loads the scene; never panics.
    fn bake(&self, cfg: &ServerConfig, metrics: &metrics::Metrics) {
        self.set(SlotState::Baking);
        let t0 = Instant::now();
        let policy = if cfg.read_only {
            CachePolicy::ReadOnly(&cfg.cache)
        } else {
            CachePolicy::ReadWrite(&cfg.cache)
        };
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            bake::load_or_bake(&self.dir, policy, &BakeOptions::default(), &|stage, f| {
                self.set_progress(stage.overall(f))
            })
        }));
        let secs = t0.elapsed().as_secs_f64();
        match result {
            Ok(Ok(baked)) => {
                tracing::info!(
                    scene = %self.id,
                    patches = baked.stats.patches,
                    from_cache = baked.stats.from_cache,
                    seconds = secs,
                    "scene ready"
                );
                metrics.bake_done(&self.id, secs, baked.stats.from_cache);
                self.set_progress(1.0);
                self.set(SlotState::Ready(Arc::new(Ready::new(baked, secs))));
            }
            Ok(Err(e)) => {
                tracing::error!(scene = %self.id, "scene failed: {e}");
                self.set(SlotState::Failed(e.to_string()));
            }
            Err(panic) => {
                let msg = panic
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_else(|| "unknown panic".into());
                tracing::error!(scene = %self.id, "scene bake panicked: {msg}");
                self.set(SlotState::Failed(format!(
                    "internal error while baking: {msg}"
                )));
            }
        }
    }
}

/// Shared state of the server.
pub struct AppState {
    pub config: ServerConfig,
    pub slots: Vec<Arc<SceneSlot>>,
    pub metrics: metrics::Metrics,
    /// View buffers per (scene, camera, size), bounded LRU.
    pub views: std::sync::Mutex<render_api::ViewCache>,
}

impl AppState {
    /// Lists the scene folders (nothing is baked yet).
    pub fn new(config: ServerConfig) -> std::io::Result<Arc<AppState>> {
        let slots = bake::scene_dirs(&config.scenes)?
            .into_iter()
            .map(|d| Arc::new(SceneSlot::new(d)))
            .collect();
        Ok(Arc::new(AppState {
            config,
            slots,
            metrics: metrics::Metrics::default(),
            views: Default::default(),
        }))
    }

    /// Bakes every scene on a background thread, one after another.
    pub fn spawn_bakes(self: &Arc<Self>) {
        let state = self.clone();
        std::thread::Builder::new()
            .name("relight-bake".into())
            .spawn(move || state.bake_all())
            .expect("spawn bake thread");
    }

    /// Bakes every scene on this thread (tests, and `relight serve` replicas that want to
    /// be ready before listening).
    pub fn bake_all(&self) {
        for slot in &self.slots {
            slot.bake(&self.config, &self.metrics);
        }
    }

    pub fn slot(&self, id: &str) -> Result<&Arc<SceneSlot>, AppError> {
        self.slots.iter().find(|s| s.id == id).ok_or_else(|| {
            let known: Vec<&str> = self.slots.iter().map(|s| s.id.as_str()).collect();
            AppError::NotFound(format!(
                "unknown scene '{id}' (known: {})",
                if known.is_empty() {
                    "none".into()
                } else {
                    known.join(", ")
                }
            ))
        })
    }

    /// True when every scene is ready or failed.
    pub fn settled(&self) -> bool {
        self.slots
            .iter()
            .all(|s| matches!(s.status().0, "ready" | "failed"))
    }
}

async fn track(State(state): State<Arc<AppState>>, req: Request, next: Next) -> Response {
    let route = req
        .extensions()
        .get::<MatchedPath>()
        .map(|m| m.as_str().to_string())
        .unwrap_or_else(|| "unmatched".into());
    let method = req.method().to_string();
    let t0 = Instant::now();
    let resp = next.run(req).await;
    state.metrics.observe(
        &method,
        &route,
        resp.status().as_u16(),
        t0.elapsed().as_secs_f64(),
    );
    resp
}

/// The full application: API, metrics, health, the web page.
pub fn router(state: Arc<AppState>) -> Router {
    let cors = cors_layer(&state.config.cors_origins);
    let static_dir = state.config.static_dir.clone();
    let not_found = axum::handler::HandlerWithoutStateExt::into_service(api::not_found);
    let app = Router::new()
        .route("/healthz", get(api::healthz))
        .route("/readyz", get(api::readyz))
        .route("/metrics", get(api::metrics))
        .route("/api/openapi.json", get(api::openapi))
        .route("/api/scenes", get(api::list_scenes))
        .route("/api/scenes/{id}", get(api::scene_details))
        .route("/api/scenes/{id}/patches", get(api::patches))
        .route("/api/scenes/{id}/mesh", get(api::mesh))
        .route("/api/scenes/{id}/radiosity", post(api::radiosity))
        .route("/api/scenes/{id}/illuminance", post(api::illuminance))
        .route("/api/scenes/{id}/batch", post(api::batch))
        .route("/api/scenes/{id}/optimize", post(api::optimize))
        .route("/api/scenes/{id}/render", post(render_api::render_post))
        .route("/api/scenes/{id}/render.png", get(render_api::render_get))
        .route("/api/{*rest}", axum::routing::any(api::not_found))
        .fallback_service(ServeDir::new(static_dir).not_found_service(not_found))
        .layer(axum::extract::DefaultBodyLimit::max(
            state.config.body_limit,
        ))
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
        state.slots.len(),
        config.scenes.display(),
        config.cache.display(),
        if config.read_only { ", read-only" } else { "" }
    );
    state.spawn_bakes();
    axum::serve(listener, router(state))
        .with_graceful_shutdown(shutdown_signal())
        .await?;
    tracing::info!("shut down");
    Ok(())
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
