//! The on-disk cache of baked transfers.
//!
//! File name: `<scene-id>-<key>.rlt` in the cache folder, where `key` is the first 16 hex
//! digits of an XXH3-128 over the format and algorithm versions, every scene file
//! (name and bytes) and every setting that changes the result. Layout:
//!
//! ```text
//! 8 bytes   magic "RLTRANS\0"
//! u32 LE    format version (FORMAT_VERSION)
//! u32 LE    header length H
//! H bytes   JSON header (Header): versions, full key, settings, patch count,
//!           mesh fingerprint, mode, solve info and the section table
//!           (name, byte offset from the start of the data area, byte length, XXH3-64)
//! ...       sections, little-endian f32 / u32 arrays, back to back
//! ```
//!
//! Files are written to a temporary name in the same folder
//! (`.relight-tmp-<pid>-<nonce>-<entry>`, see [`TEMP_PREFIX`]), synced, then renamed: a
//! reader never sees a half-written file. Temporary files that a dead writer left behind are
//! removed by [`remove_stale_temps`] once they are [`STALE_TEMP_AGE`] old.
//!
//! Reading trusts nothing in the file: the header length and every section's offset and
//! length are checked against the file's actual size and against the sizes the patch count
//! implies, before anything is allocated. Every section's checksum is verified on load;
//! any mismatch, a foreign magic, another format version or another key makes the entry
//! invalid, and the caller rebakes (or, read-only, reports the scene as failed).

use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Write};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use xxhash_rust::xxh3::Xxh3;

use crate::transport::solve::ChannelLu;
use crate::transport::transfer::{Factored, GroupColumns, SolveInfo, Transfer, TransferMode};

pub const MAGIC: &[u8; 8] = b"RLTRANS\0";
/// Bump when the file layout changes.
pub const FORMAT_VERSION: u32 = 2;
/// Bump when the numbers a bake produces change (meshing, form factors, solver).
pub const ALGORITHM_VERSION: u32 = 1;

/// Errors name the cache file by its file name only (never the cache folder's path, which
/// the server would otherwise show to clients).
#[derive(Debug, thiserror::Error)]
pub enum CacheError {
    #[error("{}: {source}", short(path))]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: not a relight cache file (bad magic)", short(path))]
    Foreign { path: PathBuf },
    #[error(
        "{}: cache format version {found}, this build reads {FORMAT_VERSION}",
        short(path)
    )]
    Version { path: PathBuf, found: u32 },
    #[error("{}: {message}", short(path))]
    Corrupt { path: PathBuf, message: String },
}

fn short(p: &Path) -> String {
    p.file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Name prefix of relight's temporary cache files.
pub const TEMP_PREFIX: &str = ".relight-tmp-";
/// A temporary file not modified for this long belongs to a dead writer (a live writer
/// writes continuously, then renames within seconds of its last write).
pub const STALE_TEMP_AGE: std::time::Duration = std::time::Duration::from_secs(600);
/// Largest JSON header accepted, bytes.
pub const MAX_HEADER_BYTES: usize = 16 << 20;

/// Removes relight's temporary files in `dir` (names starting with [`TEMP_PREFIX`], and the
/// `.<entry>.rlt.tmp-<pid>` names of earlier versions) that were not modified for
/// [`STALE_TEMP_AGE`]: files a writer left behind when it died between creating and renaming
/// them. Several processes may share a cache folder, so a younger file may still be
/// written and is left alone. Only regular files are removed (never symlinks or folders).
/// Returns how many were removed. Cheap: one directory listing, one `lstat` per candidate.
pub fn remove_stale_temps(dir: &Path) -> usize {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return 0;
    };
    let now = std::time::SystemTime::now();
    let mut removed = 0;
    for e in rd.flatten() {
        let name = e.file_name();
        let name = name.to_string_lossy();
        let ours =
            name.starts_with(TEMP_PREFIX) || (name.starts_with('.') && name.contains(".rlt.tmp-"));
        if !ours {
            continue;
        }
        let Ok(meta) = std::fs::symlink_metadata(e.path()) else {
            continue;
        };
        let old = meta
            .modified()
            .ok()
            .and_then(|m| now.duration_since(m).ok())
            .is_some_and(|age| age >= STALE_TEMP_AGE);
        if meta.is_file() && old && std::fs::remove_file(e.path()).is_ok() {
            tracing::info!("removed stale temporary cache file {name}");
            removed += 1;
        }
    }
    removed
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Section {
    pub name: String,
    pub offset: u64,
    pub len: u64,
    pub xxh3: String,
}

/// The JSON header of a cache file.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Header {
    pub format_version: u32,
    pub algorithm_version: u32,
    pub relight_version: String,
    pub scene_id: String,
    pub key: String,
    pub settings: serde_json::Value,
    pub patch_count: usize,
    pub mesh_fingerprint: String,
    pub mode: TransferMode,
    pub groups: usize,
    /// Per group: luminaire flux and its part landing on patches, lm per channel.
    #[serde(default)]
    pub group_flux: Vec<[[f64; 3]; 2]>,
    pub channel_lu: Option<[u8; 3]>,
    pub lu_count: usize,
    pub info: SolveInfo,
    pub sections: Vec<Section>,
}

/// Hash of everything that determines a bake.
pub fn cache_key(files: &[PathBuf], settings: &serde_json::Value) -> std::io::Result<String> {
    let mut h = Xxh3::new();
    h.update(b"relight-cache");
    h.update(&FORMAT_VERSION.to_le_bytes());
    h.update(&ALGORITHM_VERSION.to_le_bytes());
    for f in files {
        let name = f.file_name().unwrap_or_default().to_string_lossy();
        h.update(name.as_bytes());
        let bytes = crate::scene::read_regular_file(f, crate::limits::MAX_OBJ_BYTES)?;
        h.update(&(bytes.len() as u64).to_le_bytes());
        h.update(&bytes);
    }
    h.update(settings.to_string().as_bytes());
    Ok(format!("{:032x}", h.digest128()))
}

/// Path of the cache entry for a scene and key.
pub fn entry_path(dir: &Path, scene_id: &str, key: &str) -> PathBuf {
    dir.join(format!("{scene_id}-{}.rlt", &key[..16]))
}

/// One section's data, as it is written.
enum Data<'a> {
    Bytes(Vec<u8>),
    Slice(&'a [u8]),
    /// An LU, streamed column by column from its matrix (no copy of n² floats).
    Lu(&'a ChannelLu),
}

impl Data<'_> {
    fn len(&self) -> u64 {
        match self {
            Data::Bytes(b) => b.len() as u64,
            Data::Slice(b) => b.len() as u64,
            Data::Lu(lu) => 4 * (lu.lu.nrows() as u64) * (lu.lu.ncols() as u64),
        }
    }

    fn each_chunk(&self, f: &mut dyn FnMut(&[u8]) -> std::io::Result<()>) -> std::io::Result<()> {
        match self {
            Data::Bytes(b) => f(b),
            Data::Slice(b) => f(b),
            Data::Lu(lu) => {
                for j in 0..lu.lu.ncols() {
                    f(bytemuck::cast_slice(lu.lu.col_as_slice(j)))?;
                }
                Ok(())
            }
        }
    }

    fn xxh3(&self) -> u64 {
        let mut h = Xxh3::new();
        let _ = self.each_chunk(&mut |b| {
            h.update(b);
            Ok(())
        });
        h.digest()
    }
}

/// Writes a transfer atomically. Returns the file size in bytes.
pub fn write(
    path: &Path,
    scene_id: &str,
    key: &str,
    settings: &serde_json::Value,
    mesh_fingerprint: u64,
    t: &Transfer,
) -> Result<u64, CacheError> {
    let io = |source| CacheError::Io {
        path: path.to_path_buf(),
        source,
    };
    let dir = path.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(io)?;

    // Sections in file order (f32 data is stored little-endian: this crate targets
    // little-endian machines, checked at compile time below).
    let mut all: Vec<(String, Data)> = Vec::new();
    let rho: Vec<f32> = t.rho.iter().flatten().copied().collect();
    all.push((
        "rho".into(),
        Data::Bytes(bytemuck::cast_slice(&rho).to_vec()),
    ));
    if let Some(f) = &t.factored {
        for (k, lu) in f.lus.iter().enumerate() {
            all.push((format!("lu{k}"), Data::Lu(lu)));
            let perm: Vec<u32> = lu.perm.iter().map(|&p| p as u32).collect();
            all.push((
                format!("perm{k}"),
                Data::Bytes(bytemuck::cast_slice(&perm).to_vec()),
            ));
        }
    }
    all.push(("area".into(), Data::Slice(bytemuck::cast_slice(&t.area))));
    all.push((
        "escape".into(),
        Data::Slice(bytemuck::cast_slice(&t.escape)),
    ));
    for (g, col) in t.groups.iter().enumerate() {
        all.push((format!("e{g}"), Data::Slice(bytemuck::cast_slice(&col.e))));
        all.push((format!("b{g}"), Data::Slice(bytemuck::cast_slice(&col.b))));
        all.push((format!("h{g}"), Data::Slice(bytemuck::cast_slice(&col.h))));
    }
    if let Some(f) = &t.factored {
        all.push(("f".into(), Data::Slice(bytemuck::cast_slice(&f.f))));
    }
    let mut sections = Vec::new();
    let mut offset = 0u64;
    for (name, data) in &all {
        sections.push(Section {
            name: name.clone(),
            offset,
            len: data.len(),
            xxh3: format!("{:016x}", data.xxh3()),
        });
        offset += data.len();
    }
    let header = Header {
        format_version: FORMAT_VERSION,
        algorithm_version: ALGORITHM_VERSION,
        relight_version: env!("CARGO_PKG_VERSION").into(),
        scene_id: scene_id.into(),
        key: key.into(),
        settings: settings.clone(),
        patch_count: t.n,
        mesh_fingerprint: format!("{mesh_fingerprint:016x}"),
        mode: t.mode,
        groups: t.groups.len(),
        group_flux: t.groups.iter().map(|g| [g.flux, g.landed]).collect(),
        channel_lu: t.factored.as_ref().map(|f| f.channel_lu),
        lu_count: t.factored.as_ref().map_or(0, |f| f.lus.len()),
        info: t.info,
        sections,
    };
    let hjson = serde_json::to_vec(&header).map_err(|e| io(std::io::Error::other(e)))?;

    let tmp = dir.join(format!(
        "{TEMP_PREFIX}{}-{:x}-{}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos()),
        path.file_name().unwrap_or_default().to_string_lossy(),
    ));
    let result = (|| -> std::io::Result<u64> {
        let file = File::create(&tmp)?;
        let mut w = BufWriter::with_capacity(1 << 20, file);
        w.write_all(MAGIC)?;
        w.write_all(&FORMAT_VERSION.to_le_bytes())?;
        w.write_all(&(hjson.len() as u32).to_le_bytes())?;
        w.write_all(&hjson)?;
        for (_, data) in &all {
            data.each_chunk(&mut |b| w.write_all(b))?;
        }
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
    result.map_err(io)
}

/// Bytes before the JSON header: magic, format version, header length.
const PREAMBLE: u64 = 16;

/// Reads only the header (for listings and checks).
pub fn read_header(path: &Path) -> Result<Header, CacheError> {
    let file = File::open(path).map_err(|source| CacheError::Io {
        path: path.into(),
        source,
    })?;
    let size = file
        .metadata()
        .map_err(|source| CacheError::Io {
            path: path.into(),
            source,
        })?
        .len();
    let mut r = BufReader::new(file);
    read_header_from(path, &mut r, size).map(|(h, _)| h)
}

/// The header and its length in bytes.
fn read_header_from(
    path: &Path,
    r: &mut impl Read,
    size: u64,
) -> Result<(Header, u64), CacheError> {
    let corrupt = |message: String| CacheError::Corrupt {
        path: path.into(),
        message,
    };
    let mut magic = [0u8; 8];
    r.read_exact(&mut magic)
        .map_err(|_| corrupt("file too short".into()))?;
    if &magic != MAGIC {
        return Err(CacheError::Foreign { path: path.into() });
    }
    let mut u = [0u8; 4];
    r.read_exact(&mut u)
        .map_err(|_| corrupt("file too short".into()))?;
    let version = u32::from_le_bytes(u);
    if version != FORMAT_VERSION {
        return Err(CacheError::Version {
            path: path.into(),
            found: version,
        });
    }
    r.read_exact(&mut u)
        .map_err(|_| corrupt("file too short".into()))?;
    let hlen = u32::from_le_bytes(u) as u64;
    if hlen > MAX_HEADER_BYTES as u64 {
        return Err(corrupt(format!("header length {hlen} is implausible")));
    }
    if PREAMBLE + hlen > size {
        return Err(corrupt(format!(
            "header length {hlen} runs past the end of the {size}-byte file"
        )));
    }
    let mut h = vec![0u8; hlen as usize];
    r.read_exact(&mut h)
        .map_err(|_| corrupt("truncated header".into()))?;
    let header = serde_json::from_slice(&h).map_err(|e| corrupt(format!("bad header: {e}")))?;
    Ok((header, hlen))
}

/// What a section holds, and its expected length in bytes.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// f32 values.
    Floats,
    /// An n × n column-major LU (read straight into its matrix).
    Lu,
}

/// The sections a header must list, with their kinds and exact lengths in bytes.
fn expected_sections(h: &Header) -> Option<Vec<(String, Kind, u64)>> {
    let n = h.patch_count as u64;
    let vec3 = n.checked_mul(12)?;
    let vec1 = n.checked_mul(4)?;
    let square = n.checked_mul(n)?.checked_mul(4)?;
    let mut out = vec![
        ("rho".to_string(), Kind::Floats, vec3),
        ("area".to_string(), Kind::Floats, vec1),
        ("escape".to_string(), Kind::Floats, vec1),
    ];
    // Every group needs three sections listed in the (bounded) header.
    if h.groups > h.sections.len() {
        return None;
    }
    for g in 0..h.groups {
        for c in ["e", "b", "h"] {
            out.push((format!("{c}{g}"), Kind::Floats, vec3));
        }
    }
    match h.mode {
        TransferMode::Columns => {
            if h.lu_count != 0 {
                return None;
            }
        }
        TransferMode::Factored => {
            if !(1..=3).contains(&h.lu_count) {
                return None;
            }
            out.push(("f".to_string(), Kind::Floats, square));
            for k in 0..h.lu_count {
                out.push((format!("lu{k}"), Kind::Lu, square));
                out.push((format!("perm{k}"), Kind::Floats, vec1));
            }
        }
    }
    Some(out)
}

/// Reads and verifies a transfer. `expect_key` and `expect_fingerprint` must match.
///
/// Nothing is allocated from a number in the file before it is checked: the header length
/// against the file size; then the section table against the sections the patch count,
/// groups and mode imply (names, exact lengths, contiguous offsets), and their total
/// against the bytes left in the file.
pub fn read(
    path: &Path,
    expect_key: &str,
    expect_fingerprint: u64,
) -> Result<Transfer, CacheError> {
    let file = File::open(path).map_err(|source| CacheError::Io {
        path: path.into(),
        source,
    })?;
    let size = file
        .metadata()
        .map_err(|source| CacheError::Io {
            path: path.into(),
            source,
        })?
        .len();
    let mut r = BufReader::with_capacity(1 << 20, file);
    let (h, hlen) = read_header_from(path, &mut r, size)?;
    let corrupt = |message: String| CacheError::Corrupt {
        path: path.into(),
        message,
    };
    if h.key != expect_key {
        return Err(corrupt(
            "stale: built from other scene files or settings".into(),
        ));
    }
    if h.mesh_fingerprint != format!("{expect_fingerprint:016x}") {
        return Err(corrupt("stale: the mesh differs".into()));
    }
    let n = h.patch_count;
    let expected = expected_sections(&h)
        .ok_or_else(|| corrupt("the header's patch count, groups or mode are invalid".into()))?;
    if expected.len() != h.sections.len() {
        return Err(corrupt(format!(
            "{} sections listed, {} expected",
            h.sections.len(),
            expected.len()
        )));
    }
    let mut kinds: std::collections::HashMap<&str, (Kind, u64)> = expected
        .iter()
        .map(|(name, kind, len)| (name.as_str(), (*kind, *len)))
        .collect();
    let mut pos = 0u64;
    let mut plan = Vec::with_capacity(h.sections.len());
    for s in &h.sections {
        let (kind, len) = kinds
            .remove(s.name.as_str())
            .ok_or_else(|| corrupt(format!("unexpected or repeated section '{}'", s.name)))?;
        if s.offset != pos || s.len != len {
            return Err(corrupt(format!(
                "section '{}' has a bad extent (offset {}, length {}; expected {pos}, {len})",
                s.name, s.offset, s.len
            )));
        }
        pos += len;
        plan.push((s, kind));
    }
    let data_start = PREAMBLE + hlen;
    if data_start.checked_add(pos) != Some(size) {
        return Err(corrupt(format!(
            "the sections need {pos} bytes after the header, the file has {}",
            size.saturating_sub(data_start)
        )));
    }

    let mut data: std::collections::HashMap<String, Vec<f32>> = Default::default();
    let mut lu_mats: std::collections::HashMap<String, faer::Mat<f32>> = Default::default();
    for (s, kind) in plan {
        let mut hasher = Xxh3::new();
        let truncated = |_| corrupt(format!("truncated in section '{}'", s.name));
        match kind {
            Kind::Floats => {
                let mut v = vec![0f32; (s.len / 4) as usize];
                r.read_exact(bytemuck::cast_slice_mut(&mut v))
                    .map_err(truncated)?;
                hasher.update(bytemuck::cast_slice(&v));
                data.insert(s.name.clone(), v);
            }
            Kind::Lu => {
                let mut m = faer::Mat::<f32>::zeros(n, n);
                for j in 0..n {
                    let col = m.col_as_slice_mut(j);
                    r.read_exact(bytemuck::cast_slice_mut(col))
                        .map_err(truncated)?;
                    hasher.update(bytemuck::cast_slice(m.col_as_slice(j)));
                }
                lu_mats.insert(s.name.clone(), m);
            }
        }
        if format!("{:016x}", hasher.digest()) != s.xxh3 {
            return Err(corrupt(format!(
                "checksum mismatch in section '{}'",
                s.name
            )));
        }
    }
    let mut take = |name: &str| -> Result<Vec<f32>, CacheError> {
        data.remove(name)
            .ok_or_else(|| corrupt(format!("missing section '{name}'")))
    };
    let rho_flat = take("rho")?;
    let rho = rho_flat
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    let area = take("area")?;
    let escape = take("escape")?;
    let mut groups = Vec::new();
    for g in 0..h.groups {
        groups.push(GroupColumns {
            e: take(&format!("e{g}"))?,
            b: take(&format!("b{g}"))?,
            h: take(&format!("h{g}"))?,
            flux: h.group_flux.get(g).map_or([0.0; 3], |f| f[0]),
            landed: h.group_flux.get(g).map_or([0.0; 3], |f| f[1]),
        });
    }
    let factored = match h.mode {
        TransferMode::Columns => None,
        TransferMode::Factored => {
            let f = take("f")?;
            let mut lus = Vec::new();
            for k in 0..h.lu_count {
                let lu = lu_mats
                    .remove(&format!("lu{k}"))
                    .ok_or_else(|| corrupt(format!("missing section 'lu{k}'")))?;
                let perm_f = take(&format!("perm{k}"))?;
                let perm: Vec<usize> = bytemuck::cast_slice::<f32, u32>(&perm_f)
                    .iter()
                    .map(|&p| p as usize)
                    .collect();
                lus.push(
                    ChannelLu::from_lu(lu, perm)
                        .ok_or_else(|| corrupt(format!("permutation {k} is invalid")))?,
                );
            }
            let channel_lu = h
                .channel_lu
                .ok_or_else(|| corrupt("factored entry without channel map".into()))?;
            if channel_lu.iter().any(|&c| c as usize >= lus.len()) {
                return Err(corrupt("channel map names a missing factorization".into()));
            }
            Some(Factored { lus, channel_lu, f })
        }
    };
    Ok(Transfer {
        mode: h.mode,
        n,
        rho,
        area,
        escape,
        groups,
        factored,
        info: h.info,
    })
}

/// Removes other entries of the same scene (older keys), keeping `keep`.
pub fn prune(dir: &Path, scene_id: &str, keep: &Path) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    let prefix = format!("{scene_id}-");
    for e in rd.flatten() {
        let p = e.path();
        let name = e.file_name().to_string_lossy().into_owned();
        if p != keep
            && name.starts_with(&prefix)
            && name.ends_with(".rlt")
            && name.len() == prefix.len() + 16 + 4
        {
            let _ = std::fs::remove_file(p);
        }
    }
}

#[cfg(not(target_endian = "little"))]
compile_error!("the relight cache format is little-endian; this target is not");
