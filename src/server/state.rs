//! The server's shared state: the scene slots (queued → baking → ready | failed), the
//! bakes (in a child `relight bake --progress-json` process, or in this process for
//! tests), and [`Ready`], a scene that answers.

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, RwLock};
use std::time::Instant;

use super::{metrics, views, AppError, ServerConfig};
use crate::bake::{self, BakeOptions, Baked, CachePolicy};
use crate::model::Model;

pub use crate::model::GroupInfo;

/// A scene ready to answer: its [`Model`] plus what only the server keeps (lazily built
/// shading data, its pin on the memory budget).
pub struct Ready {
    pub model: Model,
    pub bake_seconds: f64,
    shading: std::sync::OnceLock<crate::render::Shading>,
    /// The patches by scene triangle, for `final` renders, built on first use.
    patch_locator: std::sync::OnceLock<crate::geometry::patch_locator::PatchLocator>,
    mesh_bytes: std::sync::OnceLock<axum::body::Bytes>,
    preview_bytes: std::sync::OnceLock<axum::body::Bytes>,
    /// This scene's share of the memory budget, held while it is loaded.
    _pin: Option<crate::budget::Reservation>,
}

impl Ready {
    fn new(
        baked: Baked,
        bake_seconds: f64,
        budget: Option<&Arc<crate::budget::MemoryBudget>>,
    ) -> Ready {
        let model = Model::new(baked);
        let _pin = budget.map(|b| b.pin(model.bytes()));
        Ready {
            _pin,
            model,
            bake_seconds,
            shading: std::sync::OnceLock::new(),
            patch_locator: std::sync::OnceLock::new(),
            mesh_bytes: std::sync::OnceLock::new(),
            preview_bytes: std::sync::OnceLock::new(),
        }
    }

    /// Gouraud shading vertices, built on first use.
    pub fn shading(&self) -> &crate::render::Shading {
        self.shading
            .get_or_init(|| crate::render::Shading::new(&self.model.baked.mesh))
    }

    /// The index of the patches by scene triangle that `final` renders trace with, built
    /// on first use.
    pub fn patch_locator(&self) -> &crate::geometry::patch_locator::PatchLocator {
        self.patch_locator.get_or_init(|| {
            let b = &self.model.baked;
            crate::render::final_gather::patch_locator(&b.mesh, &b.scene.triangles)
        })
    }

    /// The points per group at which a `final` build's gather holds the radiosity
    /// ([`crate::render::final_gather::gather_points`]).
    pub fn gather_points(&self) -> u64 {
        let b = &self.model.baked;
        crate::render::final_gather::gather_points(
            self.patch_locator.get(),
            &b.mesh,
            b.scene.triangles.len(),
            self.shading.get().map_or(3 * b.mesh.len(), |s| s.len()),
        )
    }

    /// Bytes [`Ready::patch_locator`] will allocate, 0 once built.
    pub fn patch_locator_pending_bytes(&self) -> u64 {
        match self.patch_locator.get() {
            Some(_) => 0,
            None => crate::render::final_gather::patch_locator_bytes(
                &self.model.baked.mesh,
                self.model.baked.scene.triangles.len(),
            ),
        }
    }

    /// The shading mesh as served by `GET /api/scenes/{id}/mesh`, built on first use.
    pub(crate) fn mesh_bytes(&self) -> axum::body::Bytes {
        self.mesh_bytes
            .get_or_init(|| self.shading().mesh_bytes(&self.model.baked.mesh).into())
            .clone()
    }

    /// The preview mesh as served by `GET /api/scenes/{id}/mesh/preview` (the full mesh
    /// for scenes small enough to draw whole), built on first use.
    pub(crate) fn preview_bytes(&self) -> axum::body::Bytes {
        self.preview_bytes
            .get_or_init(|| {
                let fine = &self.model.baked.mesh;
                match crate::render::preview::preview_mesh(&self.model.baked.scene, fine) {
                    Some((coarse, cs)) => self.shading().preview_bytes(fine, &coarse, &cs).into(),
                    None => self.mesh_bytes(),
                }
            })
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
    /// Uploaded over HTTP (its folder holds [`UPLOAD_MARKER`]): it may be replaced and
    /// deleted. The server's own scenes may not.
    pub uploaded: bool,
    progress: AtomicU64,
    state: RwLock<SlotState>,
}

/// The file that marks a scene folder as uploaded.
pub const UPLOAD_MARKER: &str = ".relight-upload.json";

impl SceneSlot {
    pub(crate) fn new(dir: PathBuf) -> SceneSlot {
        SceneSlot {
            id: dir
                .file_name()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
            uploaded: dir.join(UPLOAD_MARKER).is_file(),
            dir,
            progress: AtomicU64::new(0f64.to_bits()),
            state: RwLock::new(SlotState::Queued),
        }
    }

    /// True while the scene waits for its bake or bakes.
    pub fn busy(&self) -> bool {
        matches!(self.status().0, "queued" | "baking")
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
    /// The scenes, sorted by id; uploads add and replace slots, deletes remove them.
    slots: RwLock<Vec<Arc<SceneSlot>>>,
    /// One bake at a time (each may use the whole memory budget).
    bake_lock: std::sync::Mutex<()>,
    /// One scene write (upload or delete) at a time.
    pub(crate) write_lock: tokio::sync::Mutex<()>,
    pub(crate) metrics: metrics::Metrics,
    /// View buffers per (scene, camera, size), an LRU bounded in bytes.
    pub views: std::sync::Mutex<views::ViewCache>,
    /// The memory budget every heavy request reserves from.
    pub budget: Arc<crate::budget::MemoryBudget>,
    pub(super) heavy_permits: Arc<tokio::sync::Semaphore>,
    pub(super) heavy_waiting: std::sync::atomic::AtomicUsize,
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
            slots: RwLock::new(slots),
            bake_lock: std::sync::Mutex::new(()),
            write_lock: tokio::sync::Mutex::new(()),
            metrics: metrics::Metrics::default(),
            views: std::sync::Mutex::new(views::ViewCache::new(budget.view_cache_max())),
            budget,
            heavy_permits: Arc::new(tokio::sync::Semaphore::new(config.max_concurrent.max(1))),
            heavy_waiting: Default::default(),
            config,
        })
    }

    /// A state with another configuration over the same scene slots (tests, and replicas
    /// that share baked scenes). Caches, metrics and the budget start afresh.
    pub fn reconfigured(&self, config: ServerConfig) -> Arc<AppState> {
        Self::with_slots(self.slots(), config)
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
    /// be ready before listening), smallest first ([`AppState::bake_order`]).
    pub fn bake_all(&self) {
        for slot in self.bake_order() {
            self.bake_slot(&slot);
        }
    }

    /// The scenes in the order a start bakes them: by the estimated patch count
    /// ([`bake::estimated_patches`]), smallest first, then by id, so small scenes are
    /// ready while a large one still bakes.
    pub fn bake_order(&self) -> Vec<Arc<SceneSlot>> {
        let mut keyed: Vec<(u64, Arc<SceneSlot>)> = self
            .slots()
            .into_iter()
            .map(|s| (bake::estimated_patches(&s.dir), s))
            .collect();
        keyed.sort_by(|a, b| a.0.cmp(&b.0).then_with(|| a.1.id.cmp(&b.1.id)));
        keyed.into_iter().map(|(_, s)| s).collect()
    }

    /// Bakes one scene (after any bake in progress), unless it left the list meanwhile.
    fn bake_slot(&self, slot: &Arc<SceneSlot>) {
        let _one = self.bake_lock.lock().unwrap_or_else(|p| p.into_inner());
        let current = self.slots().iter().any(|s| Arc::ptr_eq(s, slot));
        if current && slot.status().0 == "queued" {
            slot.bake(&self.config, &self.metrics, &self.budget);
        }
    }

    /// Bakes one scene on a background thread.
    pub(crate) fn spawn_bake(self: &Arc<Self>, slot: Arc<SceneSlot>) {
        let state = self.clone();
        let spawned = std::thread::Builder::new()
            .name("relight-bake".into())
            .spawn(move || state.bake_slot(&slot));
        if let Err(e) = spawned {
            tracing::error!("cannot start a bake thread: {e}");
        }
    }

    /// The scenes, sorted by id (a snapshot).
    pub fn slots(&self) -> Vec<Arc<SceneSlot>> {
        self.slots.read().unwrap_or_else(|p| p.into_inner()).clone()
    }

    /// Adds a scene, or replaces the one with its id.
    pub(crate) fn put_slot(&self, slot: Arc<SceneSlot>) {
        let mut list = self.slots.write().unwrap_or_else(|p| p.into_inner());
        match list.binary_search_by(|s| s.id.cmp(&slot.id)) {
            Ok(i) => list[i] = slot,
            Err(i) => list.insert(i, slot),
        }
    }

    /// Removes the scene with this id from the list.
    pub(crate) fn remove_slot(&self, id: &str) {
        self.slots
            .write()
            .unwrap_or_else(|p| p.into_inner())
            .retain(|s| s.id != id);
    }

    pub fn slot(&self, id: &str) -> Result<Arc<SceneSlot>, AppError> {
        let list = self.slots.read().unwrap_or_else(|p| p.into_inner());
        list.iter().find(|s| s.id == id).cloned().ok_or_else(|| {
            let known: Vec<&str> = list.iter().map(|s| s.id.as_str()).collect();
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

    /// True when every one of the server's own scenes is ready or failed. Uploaded scenes
    /// do not count: an upload's bake must not take a serving replica out of rotation.
    pub fn settled(&self) -> bool {
        self.slots()
            .iter()
            .filter(|s| !s.uploaded)
            .all(|s| matches!(s.status().0, "ready" | "failed"))
    }
}
