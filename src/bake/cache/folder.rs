//! The cache folder: entry names (`<scene-id>-<key>.rlt`), the key (XXH3-128 over the
//! format and algorithm versions, every scene file's name and bytes, and the settings),
//! temporary names for atomic writes, and housekeeping: pruning older entries of a scene
//! and removing temporary files a dead writer left (after [`STALE_TEMP_AGE`], 10 minutes).

use std::path::{Path, PathBuf};

use xxhash_rust::xxh3::Xxh3;

use super::format::{ALGORITHM_VERSION, FORMAT_VERSION};

/// Name prefix of relight's temporary cache files.
pub const TEMP_PREFIX: &str = ".relight-tmp-";
/// A temporary file not modified for this long belongs to a dead writer (a live writer
/// writes continuously, then renames within seconds of its last write).
pub const STALE_TEMP_AGE: std::time::Duration = std::time::Duration::from_secs(600);

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

/// A fresh temporary name in `dir` for writing the entry `path`:
/// `.relight-tmp-<pid>-<nonce>-<entry>`.
pub(crate) fn temp_path(dir: &Path, path: &Path) -> PathBuf {
    dir.join(format!(
        "{TEMP_PREFIX}{}-{:x}-{}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos()),
        path.file_name().unwrap_or_default().to_string_lossy(),
    ))
}

/// Hash of everything that determines a bake: the scene's files and the settings.
/// `scene.toml` counts without its `[[cameras]]`, which only place views: adding or
/// moving a camera keeps the baked transfer.
pub fn cache_key(files: &[PathBuf], settings: &serde_json::Value) -> std::io::Result<String> {
    let mut h = Xxh3::new();
    h.update(b"relight-cache");
    h.update(&FORMAT_VERSION.to_le_bytes());
    h.update(&ALGORITHM_VERSION.to_le_bytes());
    for f in files {
        let name = f.file_name().unwrap_or_default().to_string_lossy();
        h.update(name.as_bytes());
        let mut bytes = crate::scene::read_regular_file(f, crate::input_limits::MAX_OBJ_BYTES)?;
        if name == "scene.toml" {
            bytes = without_cameras(bytes);
        }
        h.update(&(bytes.len() as u64).to_le_bytes());
        h.update(&bytes);
    }
    h.update(settings.to_string().as_bytes());
    Ok(format!("{:032x}", h.digest128()))
}

/// `scene.toml` text without its cameras, in a canonical form (the parsed table written
/// back), or the bytes unchanged when they do not parse (the scene's load reports that).
fn without_cameras(bytes: Vec<u8>) -> Vec<u8> {
    let parsed = std::str::from_utf8(&bytes)
        .ok()
        .and_then(|s| s.parse::<toml::Table>().ok());
    match parsed {
        Some(mut t) => {
            t.remove("cameras");
            let mut out = b"scene.toml without cameras\n".to_vec();
            out.extend_from_slice(t.to_string().as_bytes());
            out
        }
        None => bytes,
    }
}

/// Path of the cache entry for a scene and key.
pub fn entry_path(dir: &Path, scene_id: &str, key: &str) -> PathBuf {
    dir.join(format!("{scene_id}-{}.rlt", &key[..16]))
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

/// Removes every entry of a scene (any key); how many were removed.
pub fn remove_entries(dir: &Path, scene_id: &str) -> usize {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return 0;
    };
    let prefix = format!("{scene_id}-");
    let mut n = 0;
    for e in rd.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let key = name
            .strip_prefix(&prefix)
            .and_then(|r| r.strip_suffix(".rlt"));
        if key.is_some_and(|k| k.len() == 16 && k.bytes().all(|b| b.is_ascii_hexdigit()))
            && std::fs::remove_file(e.path()).is_ok()
        {
            n += 1;
        }
    }
    n
}
