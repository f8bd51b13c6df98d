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
//!
//! - `format.rs`: the layout constants, the JSON header and the section table a header
//!   must list.
//! - `writer.rs` / `reader.rs`: writing a transfer atomically; reading and verifying one.
//! - `folder.rs`: the cache key, entry names, pruning and stale temporary files.

mod folder;
mod format;
mod reader;
mod writer;

use std::path::{Path, PathBuf};

pub(crate) use folder::temp_path;
pub use folder::{
    cache_key, entry_path, prune, remove_entries, remove_stale_temps, STALE_TEMP_AGE, TEMP_PREFIX,
};
use format::FORMAT_VERSION;
pub use format::{Header, Section};
pub use reader::{read, read_header};
pub use writer::write;

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

#[cfg(not(target_endian = "little"))]
compile_error!("the relight cache format is little-endian; this target is not");
