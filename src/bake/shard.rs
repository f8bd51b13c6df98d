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
//! the data in the header.

use std::io::{BufReader, BufWriter, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use serde::{Deserialize, Serialize};
use xxhash_rust::xxh3::Xxh3;

use super::{cache, finish, hierarchy_plan, BakeError, BakeOptions, BakeStats, Baked, Prepared};
use super::{CachePolicy, Stage};
use crate::transport::hierarchy::refine::Link;
use crate::transport::hierarchy::Part;
use crate::transport::transfer::{Coupling, TransferMode};

const MAGIC: &[u8; 8] = b"RLSHARD\0";
const VERSION: u32 = 1;
/// Most shards of one bake.
pub const MAX_SHARDS: usize = 10_000;
const LINK_BYTES: u64 = 13;
const HIT_BYTES: u64 = 12;

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

/// The JSON header of a shard file.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct Header {
    format_version: u32,
    scene_id: String,
    key: String,
    mesh_fingerprint: String,
    shard: usize,
    shards: usize,
    roots: Vec<u32>,
    links: u64,
    hits: u64,
    refine_s: f64,
    closure_s: f64,
    xxh3: String,
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

/// The data section of a part.
fn encode(part: &Part) -> Vec<u8> {
    let mut out = Vec::with_capacity(
        (LINK_BYTES * part.links.len() as u64 + HIT_BYTES * part.hits.len() as u64) as usize,
    );
    for l in &part.links {
        out.extend_from_slice(&l.r.to_le_bytes());
        out.extend_from_slice(&l.s.to_le_bytes());
        out.extend_from_slice(&l.k.to_bits().to_le_bytes());
        out.push(l.vis);
    }
    for &(i, h) in &part.hits {
        out.extend_from_slice(&i.to_le_bytes());
        out.extend_from_slice(&h.to_bits().to_le_bytes());
    }
    out
}

/// Writes a shard file atomically (temporary name, sync, rename); returns its size.
fn write_shard(cache: &Path, path: &Path, mut header: Header, part: &Part) -> std::io::Result<u64> {
    let data = encode(part);
    let mut h = Xxh3::new();
    h.update(&data);
    header.xxh3 = format!("{:016x}", h.digest());
    let hjson = serde_json::to_vec(&header).map_err(std::io::Error::other)?;
    let tmp = cache::temp_path(cache, path);
    let result = (|| {
        let file = std::fs::File::create(&tmp)?;
        let mut w = BufWriter::with_capacity(1 << 20, file);
        w.write_all(MAGIC)?;
        w.write_all(&VERSION.to_le_bytes())?;
        w.write_all(&(hjson.len() as u32).to_le_bytes())?;
        w.write_all(&hjson)?;
        w.write_all(&data)?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        let size = file.metadata()?.len();
        drop(file);
        std::fs::rename(&tmp, path)?;
        Ok(size)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Reads and checks shard file `path` against the bake's key, mesh and shard id.
fn read_shard(path: &Path, key: &str, fingerprint: u64, id: ShardId) -> Result<Part, String> {
    let name = path
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    read_checked_shard(path, key, fingerprint, id)
        .map_err(|m| format!("shard {} of {} ({name}): {m}", id.k, id.n))
}

/// [`read_shard`], its errors without the shard's name.
fn read_checked_shard(
    path: &Path,
    key: &str,
    fingerprint: u64,
    id: ShardId,
) -> Result<Part, String> {
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let size = file.metadata().map_err(|e| e.to_string())?.len();
    let mut r = BufReader::with_capacity(1 << 20, file);
    let (h, hlen) = read_header(&mut r, size)?;
    check_header(&h, key, fingerprint, id)?;
    let data = read_data(&mut r, &h, size - 16 - hlen)?;
    let (links, hits) = decode(&data, h.links);
    Ok(Part {
        roots: h.roots,
        links,
        hits,
        refine_s: h.refine_s,
        closure_s: h.closure_s,
    })
}

/// The header of a shard file of `size` bytes, and its length, once the magic and
/// version are this relight's.
fn read_header(r: &mut impl Read, size: u64) -> Result<(Header, u64), String> {
    let mut pre = [0u8; 16];
    r.read_exact(&mut pre)
        .map_err(|_| "corrupt: too short".to_string())?;
    if &pre[..8] != MAGIC {
        return Err("not a relight shard file".into());
    }
    let version = u32::from_le_bytes([pre[8], pre[9], pre[10], pre[11]]);
    if version != VERSION {
        return Err(format!(
            "shard format {version}, this relight reads {VERSION}"
        ));
    }
    let hlen = u32::from_le_bytes([pre[12], pre[13], pre[14], pre[15]]) as u64;
    if hlen > (16 << 20) || 16 + hlen > size {
        return Err(format!("corrupt: header length {hlen}"));
    }
    let mut hb = vec![0u8; hlen as usize];
    r.read_exact(&mut hb)
        .map_err(|_| "corrupt: truncated header".to_string())?;
    let h: Header = serde_json::from_slice(&hb).map_err(|e| format!("corrupt header: {e}"))?;
    Ok((h, hlen))
}

/// Checks that a shard's header is of this bake: its cache key, mesh and shard id.
fn check_header(h: &Header, key: &str, fingerprint: u64, id: ShardId) -> Result<(), String> {
    if h.key != key {
        return Err(format!(
            "foreign: made for cache key {} (other scene files or settings), this bake is {key}",
            h.key
        ));
    }
    if h.mesh_fingerprint != format!("{fingerprint:016x}") {
        return Err("foreign: made from another mesh".into());
    }
    if (h.shard, h.shards) != (id.k, id.n) {
        return Err(format!(
            "its header says shard {} of {}: renamed or duplicated",
            h.shard, h.shards
        ));
    }
    Ok(())
}

/// The data section, `len` bytes after the header, once its size matches the header's
/// counts and its checksum the header's.
fn read_data(r: &mut impl Read, h: &Header, len: u64) -> Result<Vec<u8>, String> {
    let want = h
        .links
        .checked_mul(LINK_BYTES)
        .and_then(|a| h.hits.checked_mul(HIT_BYTES).and_then(|b| a.checked_add(b)));
    if want != Some(len) {
        return Err(format!(
            "corrupt: {len} data bytes, the header implies {}",
            want.map_or("too many".to_string(), |w| w.to_string())
        ));
    }
    let mut data = vec![0u8; len as usize];
    r.read_exact(&mut data)
        .map_err(|_| "corrupt: truncated data".to_string())?;
    let mut x = Xxh3::new();
    x.update(&data);
    if format!("{:016x}", x.digest()) != h.xxh3 {
        return Err("corrupt: checksum mismatch".into());
    }
    Ok(data)
}

/// The links and closure hits of a data section holding `links` links (the inverse of
/// [`encode`]).
fn decode(data: &[u8], links: u64) -> (Vec<Link>, Vec<(u32, f64)>) {
    let word = |b: &[u8], i: usize| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    let (lb, hb) = data.split_at((links * LINK_BYTES) as usize);
    let links = lb
        .chunks_exact(LINK_BYTES as usize)
        .map(|c| Link {
            r: word(c, 0),
            s: word(c, 4),
            k: f32::from_bits(word(c, 8)),
            vis: c[12],
        })
        .collect();
    let hits = hb
        .chunks_exact(HIT_BYTES as usize)
        .map(|c| {
            let mut f = [0u8; 8];
            f.copy_from_slice(&c[4..12]);
            (word(c, 0), f64::from_bits(u64::from_le_bytes(f)))
        })
        .collect();
    (links, hits)
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
