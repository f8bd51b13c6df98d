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
//! Files are written to a temporary name in the same folder, synced, then renamed:
//! a reader never sees a half-written file. Every section's checksum is verified on load;
//! any mismatch, a foreign magic, another format version or another key makes the entry
//! invalid, and the caller rebakes (or, read-only, reports the scene as failed).

use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Write};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use xxhash_rust::xxh3::{xxh3_64, Xxh3};

use crate::solve::ChannelLu;
use crate::transfer::{Factored, GroupColumns, SolveInfo, Transfer, TransferMode};

pub const MAGIC: &[u8; 8] = b"RLTRANS\0";
/// Bump when the file layout changes.
pub const FORMAT_VERSION: u32 = 2;
/// Bump when the numbers a bake produces change (meshing, form factors, solver).
pub const ALGORITHM_VERSION: u32 = 1;

#[derive(Debug, thiserror::Error)]
pub enum CacheError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: not a relight cache file (bad magic)")]
    Foreign { path: PathBuf },
    #[error("{path}: cache format version {found}, this build reads {FORMAT_VERSION}")]
    Version { path: PathBuf, found: u32 },
    #[error("{path}: {message}")]
    Corrupt { path: PathBuf, message: String },
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
        let bytes = std::fs::read(f)?;
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

fn as_bytes_u32(v: &[u32]) -> &[u8] {
    bytemuck::cast_slice(v)
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

    // Collect sections as byte slices (f32 data is stored little-endian: this crate
    // targets little-endian machines, checked at compile time below).
    let mut owned: Vec<(String, Vec<u8>)> = Vec::new();
    let mut borrowed: Vec<(String, &[u8])> = Vec::new();
    let rho: Vec<f32> = t.rho.iter().flatten().copied().collect();
    owned.push(("rho".into(), bytemuck::cast_slice(&rho).to_vec()));
    borrowed.push(("area".into(), bytemuck::cast_slice(&t.area)));
    borrowed.push(("escape".into(), bytemuck::cast_slice(&t.escape)));
    for (g, col) in t.groups.iter().enumerate() {
        borrowed.push((format!("e{g}"), bytemuck::cast_slice(&col.e)));
        borrowed.push((format!("b{g}"), bytemuck::cast_slice(&col.b)));
        borrowed.push((format!("h{g}"), bytemuck::cast_slice(&col.h)));
    }
    if let Some(f) = &t.factored {
        borrowed.push(("f".into(), bytemuck::cast_slice(&f.f)));
        for (k, lu) in f.lus.iter().enumerate() {
            owned.push((
                format!("lu{k}"),
                bytemuck::cast_slice(&lu.columns()).to_vec(),
            ));
            let perm: Vec<u32> = lu.perm.iter().map(|&p| p as u32).collect();
            owned.push((format!("perm{k}"), as_bytes_u32(&perm).to_vec()));
        }
    }
    let all: Vec<(&str, &[u8])> = owned
        .iter()
        .map(|(n, b)| (n.as_str(), b.as_slice()))
        .chain(borrowed.iter().map(|(n, b)| (n.as_str(), *b)))
        .collect();
    let mut sections = Vec::new();
    let mut offset = 0u64;
    for (name, bytes) in &all {
        sections.push(Section {
            name: name.to_string(),
            offset,
            len: bytes.len() as u64,
            xxh3: format!("{:016x}", xxh3_64(bytes)),
        });
        offset += bytes.len() as u64;
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
    let hjson = serde_json::to_vec(&header).expect("header serializes");

    let tmp = dir.join(format!(
        ".{}.tmp-{}",
        path.file_name().unwrap_or_default().to_string_lossy(),
        std::process::id()
    ));
    let result = (|| -> std::io::Result<u64> {
        let file = File::create(&tmp)?;
        let mut w = BufWriter::with_capacity(1 << 20, file);
        w.write_all(MAGIC)?;
        w.write_all(&FORMAT_VERSION.to_le_bytes())?;
        w.write_all(&(hjson.len() as u32).to_le_bytes())?;
        w.write_all(&hjson)?;
        for (_, bytes) in &all {
            w.write_all(bytes)?;
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

/// Reads only the header (for listings and checks).
pub fn read_header(path: &Path) -> Result<Header, CacheError> {
    let file = File::open(path).map_err(|source| CacheError::Io {
        path: path.into(),
        source,
    })?;
    let mut r = BufReader::new(file);
    read_header_from(path, &mut r)
}

fn read_header_from(path: &Path, r: &mut impl Read) -> Result<Header, CacheError> {
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
    let hlen = u32::from_le_bytes(u) as usize;
    if hlen > 16 << 20 {
        return Err(corrupt(format!("header length {hlen} is implausible")));
    }
    let mut h = vec![0u8; hlen];
    r.read_exact(&mut h)
        .map_err(|_| corrupt("truncated header".into()))?;
    serde_json::from_slice(&h).map_err(|e| corrupt(format!("bad header: {e}")))
}

/// Reads and verifies a transfer. `expect_key` and `expect_fingerprint` must match.
pub fn read(
    path: &Path,
    expect_key: &str,
    expect_fingerprint: u64,
) -> Result<Transfer, CacheError> {
    let file = File::open(path).map_err(|source| CacheError::Io {
        path: path.into(),
        source,
    })?;
    let mut r = BufReader::with_capacity(1 << 20, file);
    let h = read_header_from(path, &mut r)?;
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
    let mut data: std::collections::HashMap<String, Vec<f32>> = Default::default();
    let mut pos = 0u64;
    for s in &h.sections {
        if s.offset != pos || s.len % 4 != 0 || s.len > (1u64 << 36) {
            return Err(corrupt(format!("section '{}' has a bad extent", s.name)));
        }
        let mut v = vec![0f32; (s.len / 4) as usize];
        r.read_exact(bytemuck::cast_slice_mut(&mut v))
            .map_err(|_| corrupt(format!("truncated in section '{}'", s.name)))?;
        let sum = format!("{:016x}", xxh3_64(bytemuck::cast_slice(&v)));
        if sum != s.xxh3 {
            return Err(corrupt(format!(
                "checksum mismatch in section '{}'",
                s.name
            )));
        }
        pos += s.len;
        data.insert(s.name.clone(), v);
    }
    let mut take = |name: &str, len: usize| -> Result<Vec<f32>, CacheError> {
        let v = data
            .remove(name)
            .ok_or_else(|| corrupt(format!("missing section '{name}'")))?;
        if v.len() != len {
            return Err(corrupt(format!(
                "section '{name}' has {} values, expected {len}",
                v.len()
            )));
        }
        Ok(v)
    };
    let rho_flat = take("rho", 3 * n)?;
    let rho = rho_flat
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    let area = take("area", n)?;
    let escape = take("escape", n)?;
    let mut groups = Vec::new();
    for g in 0..h.groups {
        groups.push(GroupColumns {
            e: take(&format!("e{g}"), 3 * n)?,
            b: take(&format!("b{g}"), 3 * n)?,
            h: take(&format!("h{g}"), 3 * n)?,
            flux: h.group_flux.get(g).map_or([0.0; 3], |f| f[0]),
            landed: h.group_flux.get(g).map_or([0.0; 3], |f| f[1]),
        });
    }
    let factored = match h.mode {
        TransferMode::Columns => None,
        TransferMode::Factored => {
            let f = take("f", n * n)?;
            let mut lus = Vec::new();
            for k in 0..h.lu_count {
                let cols = take(&format!("lu{k}"), n * n)?;
                let perm_f = take(&format!("perm{k}"), n)?;
                let perm: Vec<usize> = bytemuck::cast_slice::<f32, u32>(&perm_f)
                    .iter()
                    .map(|&p| p as usize)
                    .collect();
                lus.push(
                    ChannelLu::from_parts(n, &cols, perm)
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

/// Removes temporary files of dead writers from a cache folder; returns how many.
/// (Placeholder until the cache hardening lands.)
pub fn remove_stale_temps(_dir: &Path) -> usize {
    0
}
