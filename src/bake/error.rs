//! [`BakeError`]: why a scene could not be made ready, each message naming the scene by
//! its id (never an absolute path).

use std::path::{Path, PathBuf};

use super::cache::CacheError;
use crate::budget::human_bytes;
use crate::scene::SceneError;
use crate::transport::transfer::TransferMode;

/// Why a bake (or a cached load) failed.
#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(
        "{scene}: meshing {} {patches} patches, more than the limit of {max}; \
         raise [mesh] max_edge or lower target_patches in scene.toml",
        if *estimated { "would give at least" } else { "gives" }
    )]
    TooLarge {
        scene: String,
        /// The patch count, or a lower bound of it when `estimated`.
        patches: u64,
        max: usize,
        /// True when the count is the pre-meshing estimate ([`crate::geometry::mesh::estimate_patches`]).
        estimated: bool,
    },
    #[error(
        "{scene}: needs about {} to {action} {} patches in {} mode; the memory budget is {}",
        human_bytes(*needed),
        thousands(*patches as u64),
        mode_name(*mode),
        human_bytes(*budget)
    )]
    OverBudget {
        scene: String,
        /// Estimated peak bytes ([`estimate_bake_bytes`] or [`estimate_load_bytes`]).
        needed: u64,
        /// [`BakeOptions::memory_budget`].
        budget: u64,
        patches: usize,
        mode: TransferMode,
        /// "bake" or "load".
        action: &'static str,
    },
    #[error("{scene}: {message}")]
    BadOption { scene: String, message: String },
    #[error(
        "{scene}: the radiosity solve did not converge (relative residual {residual:e}); \
         nothing was cached. Check the model for overlapping two-sided faces, or bake \
         with --transfer factored at a coarser [mesh] max_edge"
    )]
    Diverged { scene: String, residual: f64 },
    #[error(
        "{scene}: no baked transfer in the cache ({}) and the server is read-only: \
         run `relight bake` first",
        file_name(path)
    )]
    NotCached { scene: String, path: PathBuf },
    #[error("{scene}: cache entry rejected in read-only mode: {source}")]
    BadCache {
        scene: String,
        #[source]
        source: CacheError,
    },
    /// A sharded bake's shards are missing, foreign, corrupt or do not fit together.
    #[error("{scene}: {message}")]
    Shards { scene: String, message: String },
    /// `path` is the scene id (errors never show absolute paths).
    #[error("{path}: cannot read scene files for the cache key: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

fn mode_name(m: TransferMode) -> &'static str {
    m.name()
}

/// 39000 → "39,000".
fn thousands(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::with_capacity(s.len() + s.len() / 3);
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}
