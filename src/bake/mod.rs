//! Bake orchestration: scene folder → mesh → BVH → form factors → transfer → cache.
//!
//! [`load_or_bake`] is the one entry point used by the CLI and the server. It reports
//! progress through a callback (stage, fraction 0..1 of that stage) and never panics on
//! bad input: every failure is a [`BakeError`].

use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::{DVec3, Vec3A};
use serde::Serialize;

use crate::geometry::bvh::Bvh;
use crate::geometry::glazing::Glazing;
pub mod cache;
mod error;
mod memory;
pub mod shard;
pub use error::BakeError;
pub use memory::*;

use crate::geometry::mesh::Mesh;
use crate::scene::{is_two_sided, Scene, TransferChoice};
use crate::transport::formfactor::{self, FormFactorOptions};
use crate::transport::hierarchy::closure::Sides;
use crate::transport::hierarchy::{HierarchyOptions, Plan, COARSE_CLUSTERS};
use crate::transport::transfer::{Coupling, Transfer, TransferMode};
use cache::CacheError;

/// Largest patch count the mesher builds, whatever the mode: a bound on meshing memory
/// (about 1 KiB per patch). The real limit of a scene is the memory budget, checked from
/// the estimated patch count before meshing and from the real one after.
pub const DEFAULT_MAX_PATCHES: usize = 4_000_000;

/// Largest relative residual a bake accepts (`‖S − (B − ρH)‖∞ / ‖S‖∞` over the group
/// columns). Converged solves end near 1e-6; a larger or non-finite residual means the
/// solve diverged, and the bake fails with [`BakeError::Diverged`] instead of caching it.
pub const MAX_RESIDUAL: f64 = 1e-2;

pub use crate::budget::human_bytes;

/// Where baked transfers are kept.
#[derive(Debug, Clone, Copy)]
pub enum CachePolicy<'a> {
    /// Always bake, never touch disk.
    Off,
    /// Load if valid, else bake and write.
    ReadWrite(&'a Path),
    /// Load only; a missing or invalid entry is an error.
    ReadOnly(&'a Path),
    /// Bake even if a valid entry exists, then write (`relight bake --force`).
    Rebuild(&'a Path),
}

impl<'a> CachePolicy<'a> {
    /// The cache folder, if any.
    fn dir(self) -> Option<&'a Path> {
        match self {
            CachePolicy::Off => None,
            CachePolicy::ReadWrite(d) | CachePolicy::ReadOnly(d) | CachePolicy::Rebuild(d) => {
                Some(d)
            }
        }
    }
}

/// Bake settings beyond `scene.toml`.
#[derive(Debug, Clone, Copy)]
pub struct BakeOptions {
    pub ff: FormFactorOptions,
    /// Refinement of the hierarchical mode.
    pub hier: HierarchyOptions,
    pub max_patches: usize,
    /// Overrides the scene's mesh size (metres), for convergence studies.
    pub max_edge: Option<f64>,
    /// Overrides the scene's transfer mode.
    pub mode: Option<TransferMode>,
    /// Overrides the scene's transfer choice (`auto` included) when `mode` is None: the
    /// CLI's `--transfer`.
    pub choice: Option<TransferChoice>,
    /// Most bytes a bake (or a cached load) may need, by [`estimate_bake_bytes`] /
    /// [`estimate_load_bytes`]; a scene above it fails before the large allocations with
    /// [`BakeError::OverBudget`]. None: unlimited.
    pub memory_budget: Option<u64>,
}

impl Default for BakeOptions {
    fn default() -> Self {
        BakeOptions {
            ff: FormFactorOptions::default(),
            hier: HierarchyOptions::default(),
            max_patches: DEFAULT_MAX_PATCHES,
            max_edge: None,
            mode: None,
            choice: None,
            memory_budget: None,
        }
    }
}

/// Stages reported to the progress callback.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stage {
    Loading,
    FormFactors,
    Solving,
    Writing,
}

impl Stage {
    /// Overall progress 0..1 for a fraction of this stage.
    pub fn overall(self, frac: f64) -> f64 {
        let (a, b) = match self {
            Stage::Loading => (0.0, 0.02),
            Stage::FormFactors => (0.02, 0.75),
            Stage::Solving => (0.75, 0.97),
            Stage::Writing => (0.97, 1.0),
        };
        a + (b - a) * frac.clamp(0.0, 1.0)
    }
}

/// Timings and sizes of a bake or load.
#[derive(Debug, Clone, Default, Serialize)]
pub struct BakeStats {
    pub patches: usize,
    pub from_cache: bool,
    /// Seconds spent on form factors (0 when loaded).
    pub form_factor_s: f64,
    /// Seconds spent factoring and solving columns (0 when loaded).
    pub solve_s: f64,
    /// Seconds to read and verify the cache entry (0 when baked).
    pub load_s: f64,
    pub cache_bytes: u64,
    pub cache_path: Option<PathBuf>,
    /// Relative residual of the group columns.
    pub residual: f64,
    /// Why an existing cache entry was not used, if one was found.
    pub cache_note: Option<String>,
}

/// A scene ready to serve.
pub struct Baked {
    pub scene: Scene,
    pub mesh: Mesh,
    pub bvh: Bvh,
    /// The scene's glazing, for the rays of daylight.
    pub glazing: Glazing,
    pub transfer: Transfer,
    pub stats: BakeStats,
}

/// Corner triples in single precision, for the ray structures.
fn single<'a>(corners: impl Iterator<Item = &'a [DVec3; 3]>) -> Vec<[Vec3A; 3]> {
    corners
        .map(|c| c.map(|p| Vec3A::from(p.as_vec3())))
        .collect()
}

/// BVH over the scene's input triangles (ids = scene triangle indices).
pub fn scene_bvh(scene: &Scene) -> Bvh {
    Bvh::new(&single(scene.triangles.iter().map(|t| &t.p)))
}

/// The scene's glazing panes with their transmittances.
pub fn scene_glazing(scene: &Scene) -> Glazing {
    let tris = single(scene.glazing.iter().map(|g| &g.p));
    Glazing::new(
        &tris,
        scene.glazing.iter().map(|g| g.transmittance).collect(),
    )
}

/// The sides of each scene triangle that are patches, for the closure rays: the front
/// (counter-clockwise), or both for a two-sided surface.
pub fn triangle_sides(scene: &Scene) -> Vec<Sides> {
    scene
        .triangles
        .iter()
        .map(|t| {
            if is_two_sided(t, &scene.materials, &scene.surfaces) {
                Sides::Both
            } else {
                Sides::Front((t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).normalize_or_zero())
            }
        })
        .collect()
}

/// Settings that change the result, as stored in the cache header and hashed into its key.
pub fn settings_json(scene: &Scene, opts: &BakeOptions, max_edge: f64) -> serde_json::Value {
    serde_json::json!({
        "max_edge_m": max_edge,
        "form_factors": opts.ff,
        "hierarchy": opts.hier,
        "transfer": opts.mode.map(|m| serde_json::to_value(m).unwrap_or_default())
            .unwrap_or_else(|| serde_json::to_value(opts.choice.unwrap_or(scene.transfer)).unwrap_or_default()),
        "column_tol": crate::transport::transfer::COLUMN_TOL,
    })
}

/// A scene meshed and checked, ready to load from the cache or to bake.
struct Prepared {
    scene: Scene,
    mesh: Mesh,
    bvh: Bvh,
    mode: TransferMode,
    memory: MemoryEstimate,
    settings: serde_json::Value,
    /// The cache entry's path and key, under a cache policy.
    entry: Option<(PathBuf, String)>,
}

impl Prepared {
    /// Loads the scene, meshes it within the patch limit, and resolves mode and cache key.
    fn new(dir: &Path, policy: CachePolicy<'_>, opts: &BakeOptions) -> Result<Prepared, BakeError> {
        let scene = Scene::load(dir)?;
        let max_edge = match opts.max_edge {
            Some(e) if e.is_finite() && e > 0.0 => e,
            Some(e) => {
                return Err(BakeError::BadOption {
                    scene: scene.id.clone(),
                    message: format!("max_edge = {e}: must be a positive length in metres"),
                })
            }
            None => scene.mesh.max_edge,
        };
        let too_large = |patches: u64, max: usize, estimated: bool| BakeError::TooLarge {
            scene: scene.id.clone(),
            patches,
            max,
            estimated,
        };
        // The memory budget, from the lower bound of the patch count, before meshing.
        if let Some(budget) = opts.memory_budget {
            let at_least = crate::geometry::mesh::estimate_patches(&scene, max_edge)
                .min(usize::MAX as u64) as usize;
            let mode = opts.mode.unwrap_or_else(|| {
                TransferMode::resolve(opts.choice.unwrap_or(scene.transfer), at_least)
            });
            let needed = estimate_bake_bytes(at_least, mode, memory::solved_columns(&scene), 1);
            if needed > budget {
                return Err(BakeError::OverBudget {
                    scene: scene.id.clone(),
                    needed,
                    budget,
                    patches: at_least,
                    mode,
                    action: "bake",
                });
            }
        }
        let mesh = Mesh::try_build_with(&scene, max_edge, opts.max_patches)
            .map_err(|e| too_large(e.at_least, e.limit, e.estimated))?;
        let n = mesh.len();
        if n > opts.max_patches {
            return Err(too_large(n as u64, opts.max_patches, false));
        }
        let mode = opts
            .mode
            .unwrap_or_else(|| TransferMode::resolve(opts.choice.unwrap_or(scene.transfer), n));
        let settings = settings_json(&scene, opts, max_edge);
        let entry = match policy.dir() {
            None => None,
            Some(d) => {
                let key =
                    cache::cache_key(&scene.files, &settings).map_err(|source| BakeError::Io {
                        path: PathBuf::from(&scene.id),
                        source,
                    })?;
                Some((cache::entry_path(d, &scene.id, &key), key))
            }
        };
        Ok(Prepared {
            memory: memory_estimate(&scene, &mesh, mode),
            bvh: scene_bvh(&scene),
            scene,
            mesh,
            mode,
            settings,
            entry,
        })
    }

    /// Refuses `needed` bytes over the budget, for `action` (bake or load).
    fn check_budget(
        &self,
        opts: &BakeOptions,
        needed: u64,
        action: &'static str,
    ) -> Result<(), BakeError> {
        match opts.memory_budget {
            Some(budget) if needed > budget => Err(BakeError::OverBudget {
                scene: self.scene.id.clone(),
                needed,
                budget,
                patches: self.mesh.len(),
                mode: self.mode,
                action,
            }),
            _ => Ok(()),
        }
    }

    fn done(self, mut transfer: Transfer, stats: BakeStats) -> Baked {
        if let Some(h) = &transfer.hierarchy {
            transfer.coarse = Some(h.coarse(&self.mesh, &self.bvh, &transfer.rho, COARSE_CLUSTERS));
        }
        Baked {
            glazing: scene_glazing(&self.scene),
            scene: self.scene,
            mesh: self.mesh,
            bvh: self.bvh,
            transfer,
            stats,
        }
    }
}

/// Loads the scene at `dir` and its transfer from the cache, or bakes it.
pub fn load_or_bake(
    dir: &Path,
    cache_policy: CachePolicy<'_>,
    opts: &BakeOptions,
    progress: &(dyn Fn(Stage, f64) + Sync),
) -> Result<Baked, BakeError> {
    progress(Stage::Loading, 0.0);
    if let CachePolicy::ReadWrite(d) | CachePolicy::Rebuild(d) = cache_policy {
        cache::remove_stale_temps(d);
    }
    let p = Prepared::new(dir, cache_policy, opts)?;
    let mut stats = BakeStats {
        patches: p.mesh.len(),
        ..Default::default()
    };
    if !matches!(cache_policy, CachePolicy::Rebuild(_)) {
        if let Some(transfer) = try_cache(&p, cache_policy, opts, &mut stats)? {
            progress(Stage::Writing, 1.0);
            return Ok(p.done(transfer, stats));
        }
    }
    p.check_budget(opts, p.memory.bake, "bake")?;
    let t0 = Instant::now();
    let ff_progress = |x| progress(Stage::FormFactors, x);
    let direct = crate::transport::direct::group_direct(&p.scene, &p.mesh, &p.bvh);
    let sky = sky_direct(&p.scene, &p.mesh, &p.bvh);
    let coupling = match p.mode {
        TransferMode::Hierarchical => {
            let (plan, front) = hierarchy_plan(&p, &direct);
            let all = plan.plane_roots().to_vec();
            let part = plan.part(&all, &p.bvh, &front, opts.hier, opts.ff, &ff_progress);
            let (h, escape) = plan
                .assemble(vec![part], opts.hier)
                .expect("one part over every plane covers the scene");
            Coupling::Links(Box::new(h), escape)
        }
        _ => Coupling::Dense(formfactor::compute(&p.mesh, &p.bvh, &opts.ff, &ff_progress)),
    };
    stats.form_factor_s = t0.elapsed().as_secs_f64();
    finish(p, coupling, &direct, sky, cache_policy, stats, progress)
}

/// The hierarchical mode's starting point (tree, geometry, the sources' glow) and the
/// scene triangles' patch sides for the closure rays.
fn hierarchy_plan(p: &Prepared, direct: &[Option<Vec<f32>>]) -> (Plan, Vec<Sides>) {
    let rho = crate::transport::transfer::patch_rho(&p.scene, &p.mesh);
    let mut sources = crate::transport::transfer::all_sources(&p.scene, &p.mesh, direct);
    let mut emission = vec![0f64; p.mesh.len()];
    for col in crate::transport::transfer::group_emission(&p.scene, &p.mesh) {
        for (e, c) in emission.iter_mut().zip(col.chunks_exact(3)) {
            *e += (c[0] as f64 + c[1] as f64 + c[2] as f64) / 3.0;
        }
    }
    let bounce =
        crate::transport::hierarchy::emitter_bounce(&p.scene, &p.mesh, &p.bvh, &rho, &emission);
    for (s, b) in sources.iter_mut().zip(bounce) {
        *s += b;
    }
    (
        Plan::new(&p.mesh, &rho, &sources).per_group_accuracy(p.scene.per_group_accuracy),
        triangle_sides(&p.scene),
    )
}

/// For a scene with a site, the direct light of every sky patch on every patch.
fn sky_direct(
    scene: &Scene,
    mesh: &Mesh,
    bvh: &Bvh,
) -> Option<crate::transport::transfer::SkyDirect> {
    let glazing = scene_glazing(scene);
    let site = scene.site.as_ref()?;
    let sub = crate::transport::sky_view::subdivision();
    let (lo, hi) = scene.bounds();
    let reach = crate::transport::sky_view::Reach::new(lo, hi);
    Some(crate::transport::transfer::SkyDirect {
        k: sub.patches.len(),
        direct: crate::transport::sky_view::patch_sky_direct(
            mesh, bvh, &glazing, site, &sub, reach,
        ),
    })
}

/// The rest of every bake, from the form factors on: the solve, the grids' responses
/// and the cache entry.
fn finish(
    p: Prepared,
    coupling: Coupling,
    direct: &[Option<Vec<f32>>],
    sky: Option<crate::transport::transfer::SkyDirect>,
    cache_policy: CachePolicy<'_>,
    mut stats: BakeStats,
    progress: &(dyn Fn(Stage, f64) + Sync),
) -> Result<Baked, BakeError> {
    let t1 = Instant::now();
    let mut transfer = Transfer::build(&p.scene, &p.mesh, coupling, direct, sky, p.mode, &|x| {
        progress(Stage::Solving, 0.95 * x)
    });
    (transfer.grids, transfer.grid_gathers) =
        crate::transport::probe::grid_columns(&p.scene, &p.mesh, &p.bvh, &transfer.groups);
    stats.solve_s = t1.elapsed().as_secs_f64();
    stats.residual = transfer.info.residual;
    let residual = transfer.info.residual;
    if residual.is_nan() || residual > MAX_RESIDUAL {
        return Err(BakeError::Diverged {
            scene: p.scene.id.clone(),
            residual: transfer.info.residual,
        });
    }
    if let (Some((path, key)), Some(dir), false) = (
        &p.entry,
        cache_policy.dir(),
        matches!(cache_policy, CachePolicy::ReadOnly(_)),
    ) {
        progress(Stage::Writing, 0.0);
        let fingerprint = p.mesh.fingerprint();
        match cache::write(path, &p.scene.id, key, &p.settings, fingerprint, &transfer) {
            Ok(bytes) => {
                stats.cache_bytes = bytes;
                stats.cache_path = Some(path.clone());
                cache::prune(dir, &p.scene.id, path);
            }
            Err(e) => tracing::warn!("could not write the cache: {e}"),
        }
    }
    progress(Stage::Writing, 1.0);
    Ok(p.done(transfer, stats))
}

/// The cached transfer when the entry is valid; None when it must be baked (missing, or
/// invalid under read-write); an error under read-only.
fn try_cache(
    p: &Prepared,
    policy: CachePolicy<'_>,
    opts: &BakeOptions,
    stats: &mut BakeStats,
) -> Result<Option<Transfer>, BakeError> {
    let Some((path, key)) = &p.entry else {
        return Ok(None);
    };
    if path.exists() {
        p.check_budget(opts, p.memory.load, "load")?;
    }
    let t0 = Instant::now();
    match cache::read(path, key, p.mesh.fingerprint()) {
        Ok(transfer) if !grids_match(&p.scene, &transfer) => {
            let note = "the cached grids differ from scene.toml's; rebaking";
            tracing::warn!("{}: {note}", path.display());
            stats.cache_note = Some(note.into());
            Ok(None)
        }
        Ok(transfer) => {
            stats.from_cache = true;
            stats.load_s = t0.elapsed().as_secs_f64();
            stats.cache_bytes = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
            stats.cache_path = Some(path.clone());
            stats.residual = transfer.info.residual;
            Ok(Some(transfer))
        }
        Err(e) => {
            let missing = matches!(&e, CacheError::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound);
            if let CachePolicy::ReadOnly(_) = policy {
                return Err(if missing {
                    BakeError::NotCached {
                        scene: p.scene.id.clone(),
                        path: path.clone(),
                    }
                } else {
                    BakeError::BadCache {
                        scene: p.scene.id.clone(),
                        source: e,
                    }
                });
            }
            if !missing {
                tracing::warn!("{e}; rebaking");
                stats.cache_note = Some(e.to_string());
            }
            Ok(None)
        }
    }
}

/// True when the transfer holds one response per grid of the scene and light group, each
/// with the grid's number of points.
fn grids_match(scene: &Scene, t: &Transfer) -> bool {
    t.grids.len() == scene.grids.len()
        && t.grid_gathers.len() == scene.grids.len()
        && scene
            .grids
            .iter()
            .zip(&t.grid_gathers)
            .all(|(g, w)| w.points() == g.points.len() || w.points() == 0)
        && scene.grids.iter().zip(&t.grids).all(|(g, cols)| {
            cols.len() == t.groups.len() && cols.iter().all(|c| c.len() == 3 * g.points.len())
        })
}

/// Default cache folder: `$RELIGHT_CACHE`, else `$XDG_CACHE_HOME/relight`, else
/// `~/.cache/relight`, else `.cache/relight` under the working directory.
pub fn default_cache_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("RELIGHT_CACHE") {
        return PathBuf::from(d);
    }
    if let Some(d) = std::env::var_os("XDG_CACHE_HOME") {
        return PathBuf::from(d).join("relight");
    }
    if let Some(h) = std::env::var_os("HOME") {
        return PathBuf::from(h).join(".cache").join("relight");
    }
    PathBuf::from(".cache").join("relight")
}

/// Scene folders under `root` (folders that contain an .obj, .gltf or .glb file, hidden
/// folders excepted), sorted by name.
/// A scene folder's patch count as [`crate::geometry::mesh::estimate_patches`] bounds it
/// from below, at the scene's own `max_edge`, for ordering bakes smallest first; 0 for a
/// folder that does not load (its bake fails at once and shows the error early).
pub fn estimated_patches(dir: &Path) -> u64 {
    match Scene::load(dir) {
        Ok(scene) => crate::geometry::mesh::estimate_patches(&scene, scene.mesh.max_edge),
        Err(_) => 0,
    }
}

pub fn scene_dirs(root: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut out: Vec<PathBuf> = std::fs::read_dir(root)?
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.is_dir())
        // Hidden folders are the server's own (uploads being unpacked, scenes being removed).
        .filter(|p| {
            p.file_name()
                .is_some_and(|n| !n.to_string_lossy().starts_with('.'))
        })
        .filter(|p| {
            std::fs::read_dir(p).is_ok_and(|rd| {
                rd.flatten().any(|e| {
                    e.path().extension().is_some_and(|x| {
                        ["obj", "gltf", "glb"]
                            .iter()
                            .any(|m| x.eq_ignore_ascii_case(m))
                    })
                })
            })
        })
        .collect();
    out.sort();
    Ok(out)
}
