//! Sharded hierarchical bakes: the expensive part of a bake (link refinement and the
//! closure rays) split over processes or machines that share the cache folder.
//!
//! - `relight bake SCENE --shard K/N` meshes the scene, computes the links and closure
//!   hits of the receivers in shard K ([`Plan::shards`] deals the planes into N shares of
//!   similar patch counts), and writes them to a checksummed shard file (written to a
//!   temporary name, then renamed; re-running a shard replaces it). A small status file
//!   beside it reports its progress.
//! - `relight bake SCENE --merge` checks that shards 0..N are all present, of this scene's
//!   cache key and mesh, and intact; assembles the hierarchy ([`Plan::assemble`], the same
//!   bits as a one-process bake), solves it and writes the normal cache entry. The shard
//!   files are removed once the entry is written.
//!
//! Shard file: `"RLSHARD\0" | u32 LE version | u32 LE header length H | H bytes JSON
//! header | links × 13 bytes (receiver u32, source u32, factor f32, visibility u8) |
//! hits × 12 bytes (patch u32, hit fraction f64)`, all little-endian, with the XXH3-64 of
//! the data in the header ([`file`]).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use serde::Serialize;

use super::{cache, finish, hierarchy_plan, BakeError, BakeOptions, BakeStats, Baked, Prepared};
use super::{CachePolicy, Stage};
use crate::transport::transfer::{Coupling, TransferMode};

mod file;

use file::{read_shard, write_shard, Header, VERSION};

/// Most shards of one bake.
pub const MAX_SHARDS: usize = 10_000;

/// Shard K of N.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ShardId {
    pub k: usize,
    pub n: usize,
}

impl ShardId {
    /// Parses `K/N` (0 ≤ K < N ≤ [`MAX_SHARDS`]). An empty K (`/N`) takes the index from
    /// `JOB_COMPLETION_INDEX`, as a Kubernetes Indexed Job sets it in every pod.
    pub fn parse(s: &str) -> Result<ShardId, String> {
        let (k, n) = s
            .split_once('/')
            .ok_or_else(|| format!("--shard {s}: give K/N, e.g. 2/8"))?;
        let n: usize = n
            .trim()
            .parse()
            .map_err(|_| format!("--shard {s}: N must be a whole number"))?;
        let k = if k.trim().is_empty() {
            std::env::var("JOB_COMPLETION_INDEX").map_err(|_| {
                format!("--shard {s}: no K given and JOB_COMPLETION_INDEX is not set")
            })?
        } else {
            k.to_string()
        };
        let k: usize = k
            .trim()
            .parse()
            .map_err(|_| format!("--shard {s}: K must be a whole number (got {k:?})"))?;
        if n == 0 || n > MAX_SHARDS {
            return Err(format!("--shard {s}: N must be 1 to {MAX_SHARDS}"));
        }
        if k >= n {
            return Err(format!(
                "--shard {s}: K must be below N (shards are 0 to {})",
                n - 1
            ));
        }
        Ok(ShardId { k, n })
    }
}

/// What one shard did.
#[derive(Debug, Clone, Serialize)]
pub struct ShardReport {
    pub path: PathBuf,
    pub patches: usize,
    pub planes: usize,
    pub links: u64,
    pub seconds: f64,
    pub bytes: u64,
}

/// A shard's state for `--merge --status`.
#[derive(Debug, Clone, Serialize)]
pub struct ShardState {
    pub shard: usize,
    pub shards: usize,
    /// "done" (its file is present), "running" (its status file reports progress) or
    /// "missing".
    pub state: &'static str,
    pub progress: f64,
}

/// The file of shard `id` of the bake with cache key `key`.
pub fn shard_path(cache: &Path, scene_id: &str, key: &str, id: ShardId) -> PathBuf {
    cache.join(format!("{scene_id}-{key}.shard-{}-of-{}.rls", id.k, id.n))
}

fn status_path(shard: &Path) -> PathBuf {
    shard.with_extension("status.json")
}

fn shard_error(scene: &str, message: String) -> BakeError {
    BakeError::Shards {
        scene: scene.to_string(),
        message,
    }
}

/// Meshes the scene (hierarchical mode only) and resolves its cache entry.
fn prepare(dir: &Path, cache: &Path, opts: &BakeOptions) -> Result<(Prepared, String), BakeError> {
    let p = Prepared::new(dir, CachePolicy::ReadWrite(cache), opts)?;
    if p.mode != TransferMode::Hierarchical {
        return Err(shard_error(
            &p.scene.id,
            format!(
                "sharded bakes need the hierarchical mode, and this scene resolves to {} \
                 (pass --transfer hierarchical, or set transfer = \"hierarchical\" in scene.toml)",
                p.mode.name()
            ),
        ));
    }
    let key = p.entry.as_ref().map(|(_, k)| k.clone()).unwrap_or_default();
    Ok((p, key))
}

/// Computes shard `id` of the scene at `dir` into its shard file under `cache`.
/// `progress` gets the shard's finished fraction (also written to its status file).
pub fn bake_shard(
    dir: &Path,
    cache: &Path,
    id: ShardId,
    opts: &BakeOptions,
    progress: &(dyn Fn(f64) + Sync),
) -> Result<ShardReport, BakeError> {
    let t0 = Instant::now();
    cache::remove_stale_temps(cache);
    let (p, key) = prepare(dir, cache, opts)?;
    p.check_budget(opts, p.memory.bake, "bake")?;
    let path = shard_path(cache, &p.scene.id, &key, id);
    let io = |source| BakeError::Io {
        path: PathBuf::from(&p.scene.id),
        source,
    };
    std::fs::create_dir_all(cache).map_err(io)?;
    let status = status_path(&path);
    let write_status = |state: &str, x: f64| {
        let s = serde_json::json!({"scene": p.scene.id, "shard": id.k, "shards": id.n,
                                   "state": state, "progress": x});
        let tmp = cache::temp_path(cache, &status);
        if std::fs::write(&tmp, s.to_string()).is_ok() {
            let _ = std::fs::rename(&tmp, &status);
        }
    };
    write_status("running", 0.0);
    let direct = crate::transport::direct::group_direct(&p.scene, &p.mesh, &p.bvh);
    let (plan, front) = hierarchy_plan(&p, &direct);
    let roots = plan.shards(id.n).swap_remove(id.k);
    let last = AtomicU64::new(0);
    let part = plan.part(&roots, &p.bvh, &front, opts.hier, opts.ff, &|x| {
        progress(x);
        let pct = (x * 100.0) as u64;
        if pct > last.fetch_max(pct, Ordering::Relaxed) {
            write_status("running", x);
        }
    });
    let header = Header {
        format_version: VERSION,
        scene_id: p.scene.id.clone(),
        key,
        mesh_fingerprint: format!("{:016x}", p.mesh.fingerprint()),
        shard: id.k,
        shards: id.n,
        roots: part.roots.clone(),
        links: part.links.len() as u64,
        hits: part.hits.len() as u64,
        refine_s: part.refine_s,
        closure_s: part.closure_s,
        xxh3: String::new(),
    };
    let bytes = write_shard(cache, &path, header, &part).map_err(io)?;
    write_status("done", 1.0);
    Ok(ShardReport {
        path,
        patches: part.hits.len(),
        planes: part.roots.len(),
        links: part.links.len() as u64,
        seconds: t0.elapsed().as_secs_f64(),
        bytes,
    })
}

/// The shard files of the bake with key `key`, by shard index: every index of one N must
/// be present exactly once.
fn find_shards(cache: &Path, scene_id: &str, key: &str) -> Result<Vec<(ShardId, PathBuf)>, String> {
    let prefix = format!("{scene_id}-{key}.shard-");
    let mut found: Vec<(ShardId, PathBuf)> = Vec::new();
    // A cache folder that does not exist yet holds no shards.
    let entries = match std::fs::read_dir(cache) {
        Ok(rd) => Some(rd),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(format!("cannot list the cache folder: {e}")),
    };
    for e in entries.into_iter().flatten().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let Some(rest) = name
            .strip_prefix(&prefix)
            .and_then(|r| r.strip_suffix(".rls"))
        else {
            continue;
        };
        let id = rest
            .split_once("-of-")
            .and_then(|(k, n)| {
                Some(ShardId {
                    k: k.parse().ok()?,
                    n: n.parse().ok()?,
                })
            })
            .filter(|id| id.k < id.n && id.n <= MAX_SHARDS)
            .ok_or_else(|| format!("{name}: not a shard file name"))?;
        found.push((id, e.path()));
    }
    if found.is_empty() {
        return Err(
            "no shard files for this scene and settings in the cache folder; run \
                    `relight bake SCENE --shard K/N` for K = 0..N first"
                .into(),
        );
    }
    let mut ns: Vec<usize> = found.iter().map(|(id, _)| id.n).collect();
    ns.sort_unstable();
    ns.dedup();
    if ns.len() > 1 {
        return Err(format!(
            "shards of different counts are present (N = {}); remove the stale ones",
            ns.iter()
                .map(|n| n.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let n = ns[0];
    found.sort_by_key(|(id, _)| id.k);
    let missing: Vec<String> = (0..n)
        .filter(|k| !found.iter().any(|(id, _)| id.k == *k))
        .map(|k| k.to_string())
        .collect();
    if !missing.is_empty() {
        return Err(format!("missing shard(s) {} of {n}", missing.join(", ")));
    }
    Ok(found)
}

/// Merges the shards of the scene at `dir` into its cache entry: checks them, assembles
/// the hierarchy, solves it and writes the entry; then removes the shard files.
pub fn merge(
    dir: &Path,
    cache: &Path,
    opts: &BakeOptions,
    progress: &(dyn Fn(Stage, f64) + Sync),
) -> Result<Baked, BakeError> {
    progress(Stage::Loading, 0.0);
    let (p, key) = prepare(dir, cache, opts)?;
    p.check_budget(opts, p.memory.bake, "bake")?;
    let id = p.scene.id.clone();
    let files = find_shards(cache, &id, &key).map_err(|m| shard_error(&id, m))?;
    let t0 = Instant::now();
    let fingerprint = p.mesh.fingerprint();
    let mut parts = Vec::with_capacity(files.len());
    for (k, (sid, path)) in files.iter().enumerate() {
        parts.push(read_shard(path, &key, fingerprint, *sid).map_err(|m| shard_error(&id, m))?);
        progress(
            Stage::FormFactors,
            0.5 * (k + 1) as f64 / files.len() as f64,
        );
    }
    let direct = crate::transport::direct::group_direct(&p.scene, &p.mesh, &p.bvh);
    let (plan, _) = hierarchy_plan(&p, &direct);
    let sky = super::sky_direct(&p.scene, &p.mesh, &p.bvh);
    let (h, escape) = plan
        .assemble(parts, opts.hier)
        .map_err(|m| shard_error(&id, format!("the shards do not fit together: {m}")))?;
    let stats = BakeStats {
        patches: p.mesh.len(),
        form_factor_s: t0.elapsed().as_secs_f64(),
        ..Default::default()
    };
    let baked = finish(
        p,
        Coupling::Links(Box::new(h), escape),
        &direct,
        sky,
        CachePolicy::ReadWrite(cache),
        stats,
        progress,
    )?;
    if baked.stats.cache_path.is_some() {
        for (_, path) in &files {
            let _ = std::fs::remove_file(path);
            let _ = std::fs::remove_file(status_path(path));
        }
    }
    Ok(baked)
}

/// Which shards of the scene's bake are done, running or missing, for N shards (found
/// from the files when None).
pub fn status(
    dir: &Path,
    cache: &Path,
    opts: &BakeOptions,
    n: Option<usize>,
) -> Result<Vec<ShardState>, BakeError> {
    let (p, key) = prepare(dir, cache, opts)?;
    let id = p.scene.id.clone();
    let prefix = format!("{id}-{key}.shard-");
    let n = match n {
        Some(n) => n,
        None => std::fs::read_dir(cache)
            .into_iter()
            .flatten()
            .flatten()
            .filter_map(|e| {
                let name = e.file_name().to_string_lossy().into_owned();
                let rest = name.strip_prefix(&prefix)?;
                let n = rest.split_once("-of-")?.1.split('.').next()?;
                n.parse::<usize>().ok()
            })
            .max()
            .ok_or_else(|| {
                shard_error(
                    &id,
                    "no shard or status files for this scene and settings".into(),
                )
            })?,
    };
    Ok((0..n.min(MAX_SHARDS))
        .map(|k| {
            let path = shard_path(cache, &id, &key, ShardId { k, n });
            let running = std::fs::read_to_string(status_path(&path))
                .ok()
                .and_then(|s| serde_json::from_str::<serde_json::Value>(&s).ok())
                .and_then(|v| v["progress"].as_f64());
            let (state, progress) = if path.exists() {
                ("done", 1.0)
            } else if let Some(x) = running {
                ("running", x)
            } else {
                ("missing", 0.0)
            };
            ShardState {
                shard: k,
                shards: n,
                state,
                progress,
            }
        })
        .collect())
}
