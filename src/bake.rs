//! Bake orchestration: scene folder → mesh → BVH → form factors → transfer → cache.
//!
//! [`load_or_bake`] is the one entry point used by the CLI and the server. It reports
//! progress through a callback (stage, fraction 0..1 of that stage) and never panics on
//! bad input: every failure is a [`BakeError`].

use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::Vec3A;
use serde::Serialize;

use crate::bvh::Bvh;
use crate::cache::{self, CacheError};
use crate::formfactor::{self, FormFactorOptions};
use crate::mesh::Mesh;
use crate::scene::{Scene, SceneError};
use crate::transfer::{Transfer, TransferMode};

/// Largest patch count a dense transfer is built for (F alone is 4·n² bytes).
pub const DEFAULT_MAX_PATCHES: usize = 30_000;

#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(
        "{scene}: meshing gives {patches} patches, more than the limit of {max}; \
         raise [mesh] max_edge or lower target_patches in scene.toml"
    )]
    TooLarge {
        scene: String,
        patches: usize,
        max: usize,
    },
    #[error("{scene}: no baked transfer in the cache ({path}) and the server is read-only: run `relight bake` first")]
    NotCached { scene: String, path: PathBuf },
    #[error("{scene}: cache entry rejected in read-only mode: {source}")]
    BadCache {
        scene: String,
        #[source]
        source: CacheError,
    },
    #[error("{path}: cannot read scene files for the cache key: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// Where baked transfers are kept.
#[derive(Debug, Clone, Copy)]
pub enum CachePolicy<'a> {
    /// Always bake, never touch disk.
    Off,
    /// Load if valid, else bake and write.
    ReadWrite(&'a Path),
    /// Load only; a missing or invalid entry is an error.
    ReadOnly(&'a Path),
}

/// Bake settings beyond `scene.toml`.
#[derive(Debug, Clone, Copy)]
pub struct BakeOptions {
    pub ff: FormFactorOptions,
    pub max_patches: usize,
    /// Overrides the scene's mesh size (metres), for convergence studies.
    pub max_edge: Option<f64>,
    /// Overrides the scene's transfer mode.
    pub mode: Option<TransferMode>,
    /// Refuse a bake estimated to need more bytes than this.
    pub memory_budget: Option<u64>,
}

impl Default for BakeOptions {
    fn default() -> Self {
        BakeOptions {
            ff: FormFactorOptions::default(),
            max_patches: DEFAULT_MAX_PATCHES,
            max_edge: None,
            mode: None,
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
    pub transfer: Transfer,
    pub stats: BakeStats,
}

/// BVH over the scene's input triangles (ids = scene triangle indices).
pub fn scene_bvh(scene: &Scene) -> Bvh {
    let tris: Vec<[Vec3A; 3]> = scene
        .triangles
        .iter()
        .map(|t| t.p.map(|p| Vec3A::from(p.as_vec3())))
        .collect();
    Bvh::new(&tris)
}

/// Settings that change the result, as stored in the cache header and hashed into its key.
pub fn settings_json(scene: &Scene, opts: &BakeOptions, max_edge: f64) -> serde_json::Value {
    serde_json::json!({
        "max_edge_m": max_edge,
        "form_factors": opts.ff,
        "transfer": opts.mode.map(|m| serde_json::to_value(m).unwrap_or_default())
            .unwrap_or_else(|| serde_json::to_value(scene.transfer).unwrap_or_default()),
        "column_tol": crate::transfer::COLUMN_TOL,
    })
}

/// Loads the scene at `dir` and its transfer from the cache, or bakes it.
pub fn load_or_bake(
    dir: &Path,
    cache_policy: CachePolicy<'_>,
    opts: &BakeOptions,
    progress: &(dyn Fn(Stage, f64) + Sync),
) -> Result<Baked, BakeError> {
    progress(Stage::Loading, 0.0);
    let scene = Scene::load(dir)?;
    let max_edge = opts.max_edge.unwrap_or(scene.mesh.max_edge);
    let mesh = Mesh::build_with(&scene, max_edge);
    let n = mesh.len();
    if n > opts.max_patches {
        return Err(BakeError::TooLarge {
            scene: scene.id.clone(),
            patches: n,
            max: opts.max_patches,
        });
    }
    let bvh = scene_bvh(&scene);
    let settings = settings_json(&scene, opts, max_edge);
    let fingerprint = mesh.fingerprint();
    let mut stats = BakeStats {
        patches: n,
        ..Default::default()
    };

    let entry = match cache_policy {
        CachePolicy::Off => None,
        CachePolicy::ReadWrite(d) | CachePolicy::ReadOnly(d) => {
            let key =
                cache::cache_key(&scene.files, &settings).map_err(|source| BakeError::Io {
                    path: scene.dir.clone(),
                    source,
                })?;
            Some((cache::entry_path(d, &scene.id, &key), key))
        }
    };
    if let Some((path, key)) = &entry {
        let t0 = Instant::now();
        match cache::read(path, key, fingerprint) {
            Ok(transfer) => {
                stats.from_cache = true;
                stats.load_s = t0.elapsed().as_secs_f64();
                stats.cache_bytes = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
                stats.cache_path = Some(path.clone());
                stats.residual = transfer.info.residual;
                progress(Stage::Writing, 1.0);
                return Ok(Baked {
                    scene,
                    mesh,
                    bvh,
                    transfer,
                    stats,
                });
            }
            Err(e) => {
                let missing = matches!(&e, CacheError::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound);
                if let CachePolicy::ReadOnly(_) = cache_policy {
                    return Err(if missing {
                        BakeError::NotCached {
                            scene: scene.id.clone(),
                            path: path.clone(),
                        }
                    } else {
                        BakeError::BadCache {
                            scene: scene.id.clone(),
                            source: e,
                        }
                    });
                }
                if !missing {
                    tracing::warn!("{e}; rebaking");
                    stats.cache_note = Some(e.to_string());
                }
            }
        }
    }

    let t0 = Instant::now();
    let f = formfactor::compute(&mesh, &bvh, &opts.ff, &|x| progress(Stage::FormFactors, x));
    stats.form_factor_s = t0.elapsed().as_secs_f64();
    let mode = opts
        .mode
        .unwrap_or_else(|| TransferMode::resolve(scene.transfer, n));
    let t1 = Instant::now();
    let direct = crate::direct::group_direct(&scene, &mesh, &bvh);
    let transfer = Transfer::build(&scene, &mesh, f, &direct, mode, &|x| {
        progress(Stage::Solving, x)
    });
    stats.solve_s = t1.elapsed().as_secs_f64();
    stats.residual = transfer.info.residual;

    if let (Some((path, key)), CachePolicy::ReadWrite(dir)) = (&entry, cache_policy) {
        progress(Stage::Writing, 0.0);
        match cache::write(path, &scene.id, key, &settings, fingerprint, &transfer) {
            Ok(bytes) => {
                stats.cache_bytes = bytes;
                stats.cache_path = Some(path.clone());
                cache::prune(dir, &scene.id, path);
            }
            Err(e) => tracing::warn!("could not write the cache: {e}"),
        }
    }
    progress(Stage::Writing, 1.0);
    Ok(Baked {
        scene,
        mesh,
        bvh,
        transfer,
        stats,
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

/// Scene folders under `root` (folders that contain an .obj file), sorted by name.
pub fn scene_dirs(root: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut out: Vec<PathBuf> = std::fs::read_dir(root)?
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.is_dir())
        .filter(|p| {
            std::fs::read_dir(p).is_ok_and(|rd| {
                rd.flatten().any(|e| {
                    e.path()
                        .extension()
                        .is_some_and(|x| x.eq_ignore_ascii_case("obj"))
                })
            })
        })
        .collect();
    out.sort();
    Ok(out)
}
