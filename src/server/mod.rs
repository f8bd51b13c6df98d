//! The HTTP server: axum over the baked scenes.
//!
//! The server listens at once. Scenes bake (or load from the cache) in the background, one
//! after another, on a plain thread (rayon does the parallel work), never on the async
//! runtime. Each scene has a slot: queued → baking (progress) → ready, or failed with its
//! error. A scene that fails, even by panicking, never takes the others down.

pub mod api;
pub mod error;
pub mod json;
pub mod limits;
pub mod metrics;
pub mod openapi;
pub mod parse;
pub mod render_api;
pub mod serve;

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
    /// Memory budget, bytes (see [`crate::budget`]).
    pub memory_budget: u64,
    /// Heavy requests running at once (renders, batches, gathers, solves); more wait.
    pub max_concurrent: usize,
    /// How long a heavy request may wait for a slot before it is shed (503).
    pub queue_wait: Duration,
    /// Longest time a request may take, from its first byte to its answer.
    pub request_timeout: Duration,
    /// Longest time a client may take to send a request's headers.
    pub header_timeout: Duration,
    /// Most open connections; more are closed at once.
    pub max_connections: usize,
    /// Bake scenes in a child process (`relight bake`), so that a bake that runs out of
    /// memory cannot take the server down. `None` bakes in this process (tests).
    pub bake_command: Option<PathBuf>,
}

/// Default longest request time.
pub const DEFAULT_REQUEST_TIMEOUT: Duration = Duration::from_secs(60);
/// Default longest time to send request headers.
pub const DEFAULT_HEADER_TIMEOUT: Duration = Duration::from_secs(10);
/// Default most open connections.
pub const DEFAULT_MAX_CONNECTIONS: usize = 1024;

impl Default for ServerConfig {
    fn default() -> Self {
        ServerConfig {
            addr: SocketAddr::from(([127, 0, 0, 1], 8080)),
            scenes: PathBuf::from("scenes"),
            cache: bake::default_cache_dir(),
            read_only: false,
            static_dir: PathBuf::from("static"),
            cors_origins: vec![],
            body_limit: DEFAULT_BODY_LIMIT,
            memory_budget: crate::budget::default_budget(),
            max_concurrent: limits::default_max_concurrent(),
            queue_wait: limits::DEFAULT_QUEUE_WAIT,
            request_timeout: DEFAULT_REQUEST_TIMEOUT,
            header_timeout: DEFAULT_HEADER_TIMEOUT,
            max_connections: DEFAULT_MAX_CONNECTIONS,
            bake_command: None,
        }
    }
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
    pub grids: Vec<crate::model::grid::GridResponse>,
    shading: std::sync::OnceLock<crate::render::Shading>,
    mesh_bytes: std::sync::OnceLock<axum::body::Bytes>,
    /// This scene's share of the memory budget, held while it is loaded.
    _pin: Option<crate::budget::Pin>,
}

/// Bytes per patch held besides the transfer: mesh, BVH, shading vertices, mesh bytes.
const SCENE_BYTES_PER_PATCH: u64 = 400;

impl Ready {
    fn new(
        baked: Baked,
        bake_seconds: f64,
        budget: Option<&Arc<crate::budget::MemoryBudget>>,
    ) -> Ready {
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
        let grids = crate::model::grid::GridResponse::build_all(
            &baked.scene,
            &baked.mesh,
            &baked.bvh,
            &baked.transfer,
        );
        let grid_bytes: u64 = grids
            .iter()
            .map(|g| 16 * g.len() as u64 * (1 + 3 * t.group_count() as u64))
            .sum();
        let bytes = t.bytes() + SCENE_BYTES_PER_PATCH * t.n as u64 + grid_bytes;
        let _pin = budget.map(|b| b.pin(bytes));
        Ready {
            _pin,
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
    fn bake(
        &self,
        cfg: &ServerConfig,
        metrics: &metrics::Metrics,
        budget: &Arc<crate::budget::MemoryBudget>,
    ) {
        self.set(SlotState::Baking);
        let t0 = Instant::now();
        let result = match (&cfg.bake_command, cfg.read_only) {
            (Some(exe), false) => self.bake_in_child(exe, cfg),
            _ => self.bake_here(cfg),
        };
        let secs = t0.elapsed().as_secs_f64();
        match result {
            Ok(baked) => {
                tracing::info!(
                    scene = %self.id,
                    patches = baked.stats.patches,
                    from_cache = baked.stats.from_cache,
                    seconds = secs,
                    "scene ready"
                );
                metrics.bake_done(&self.id, secs, baked.stats.from_cache);
                self.set_progress(1.0);
                self.set(SlotState::Ready(Arc::new(Ready::new(
                    baked,
                    secs,
                    Some(budget),
                ))));
            }
            Err(e) => {
                tracing::error!(scene = %self.id, "scene failed: {e}");
                self.set(SlotState::Failed(scrub_paths(&e, cfg)));
            }
        }
    }

    fn options(cfg: &ServerConfig) -> BakeOptions {
        BakeOptions {
            memory_budget: Some(cfg.memory_budget),
            ..BakeOptions::default()
        }
    }

    /// Loads (read-only) or bakes the scene in this process; a panic becomes an error.
    fn bake_here(&self, cfg: &ServerConfig) -> Result<Baked, String> {
        let policy = if cfg.read_only {
            CachePolicy::ReadOnly(&cfg.cache)
        } else {
            CachePolicy::ReadWrite(&cfg.cache)
        };
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            bake::load_or_bake(&self.dir, policy, &Self::options(cfg), &|stage, f| {
                self.set_progress(stage.overall(f))
            })
        }));
        match result {
            Ok(Ok(baked)) => Ok(baked),
            Ok(Err(e)) => Err(e.to_string()),
            Err(panic) => {
                let msg = panic
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_else(|| "unknown panic".into());
                Err(format!("internal error while baking: {msg}"))
            }
        }
    }

    /// Bakes the scene into the cache in a child `relight bake` process, then loads the
    /// entry. A bake that exhausts memory kills only the child (which also asks the
    /// kernel's OOM killer to pick it first).
    fn bake_in_child(&self, exe: &std::path::Path, cfg: &ServerConfig) -> Result<Baked, String> {
        use std::io::BufRead;
        use std::process::{Command, Stdio};
        // A valid cache entry needs no child at all.
        if let Ok(baked) = bake::load_or_bake(
            &self.dir,
            CachePolicy::ReadOnly(&cfg.cache),
            &Self::options(cfg),
            &|_, _| {},
        ) {
            return Ok(baked);
        }
        let mut child = Command::new(exe)
            .arg("bake")
            .arg(&self.dir)
            .arg("--cache")
            .arg(&cfg.cache)
            .arg("--memory-budget")
            .arg(cfg.memory_budget.to_string())
            .arg("--progress-json")
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .map_err(|e| format!("cannot start the bake process: {e}"))?;
        let mut error = None;
        if let Some(out) = child.stdout.take() {
            for line in std::io::BufReader::new(out).lines() {
                let Ok(line) = line else { break };
                let Ok(v) = serde_json::from_str::<serde_json::Value>(&line) else {
                    continue;
                };
                if let Some(p) = v.get("progress").and_then(|p| p.as_f64()) {
                    self.set_progress(p.clamp(0.0, 1.0));
                }
                if let Some(e) = v.get("error").and_then(|e| e.as_str()) {
                    error = Some(e.to_string());
                }
            }
        }
        let status = child
            .wait()
            .map_err(|e| format!("the bake process was lost: {e}"))?;
        if !status.success() {
            if let Some(e) = error {
                return Err(e);
            }
            #[cfg(unix)]
            {
                use std::os::unix::process::ExitStatusExt;
                if let Some(sig) = status.signal() {
                    return Err(format!(
                        "the bake process was killed by signal {sig}{}",
                        if sig == 9 {
                            " (most likely out of memory: lower the scene's patch count or raise the memory limit)"
                        } else {
                            ""
                        }
                    ));
                }
            }
            return Err(format!("the bake process failed ({status})"));
        }
        bake::load_or_bake(
            &self.dir,
            CachePolicy::ReadOnly(&cfg.cache),
            &Self::options(cfg),
            &|_, _| {},
        )
        .map_err(|e| format!("the bake process finished but its cache entry does not load: {e}"))
    }
}

/// Removes the server's own absolute paths (scenes and cache folders) from a message that
/// is shown to clients.
fn scrub_paths(msg: &str, cfg: &ServerConfig) -> String {
    let mut out = msg.to_string();
    for dir in [&cfg.scenes, &cfg.cache] {
        let mut forms = vec![dir.display().to_string()];
        if let Ok(c) = dir.canonicalize() {
            forms.push(c.display().to_string());
        }
        forms.sort_by_key(|f| std::cmp::Reverse(f.len()));
        for f in forms {
            if f.len() > 1 {
                out = out.replace(&format!("{f}/"), "").replace(&f, ".");
            }
        }
    }
    out
}

/// Shared state of the server.
pub struct AppState {
    pub config: ServerConfig,
    pub slots: Vec<Arc<SceneSlot>>,
    pub metrics: metrics::Metrics,
    /// View buffers per (scene, camera, size), an LRU bounded in bytes.
    pub views: std::sync::Mutex<render_api::ViewCache>,
    /// The memory budget every heavy request reserves from.
    pub budget: Arc<crate::budget::MemoryBudget>,
    heavy_permits: Arc<tokio::sync::Semaphore>,
    heavy_waiting: std::sync::atomic::AtomicUsize,
}

impl AppState {
    /// Lists the scene folders (nothing is baked yet).
    pub fn new(config: ServerConfig) -> std::io::Result<Arc<AppState>> {
        let slots = bake::scene_dirs(&config.scenes)?
            .into_iter()
            .map(|d| Arc::new(SceneSlot::new(d)))
            .collect();
        Ok(Self::with_slots(slots, config))
    }

    fn with_slots(slots: Vec<Arc<SceneSlot>>, config: ServerConfig) -> Arc<AppState> {
        let budget = crate::budget::MemoryBudget::new(config.memory_budget);
        Arc::new(AppState {
            slots,
            metrics: metrics::Metrics::default(),
            views: std::sync::Mutex::new(render_api::ViewCache::new(budget.view_cache_max())),
            budget,
            heavy_permits: Arc::new(tokio::sync::Semaphore::new(config.max_concurrent.max(1))),
            heavy_waiting: Default::default(),
            config,
        })
    }

    /// A state with another configuration over the same scene slots (tests, and replicas
    /// that share baked scenes). Caches, metrics and the budget start afresh.
    pub fn reconfigured(&self, config: ServerConfig) -> Arc<AppState> {
        Self::with_slots(self.slots.clone(), config)
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
            slot.bake(&self.config, &self.metrics, &self.budget);
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
/// handler's future cancels its blocking work (see [`limits::Cancel`]).
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
        state.slots.len(),
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
