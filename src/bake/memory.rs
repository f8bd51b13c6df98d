//! Memory estimates of a bake and of a cached load, per transfer mode, checked against
//! the memory budget before the large allocations.

use serde::Serialize;

use crate::geometry::mesh::Mesh;
use crate::scene::Scene;
use crate::transport::hierarchy::{BYTES_PER_LINK, MAX_CLUSTERS};
use crate::transport::transfer::TransferMode;

/// Bytes per patch besides the n×n matrices and the group columns: mesh vertices and patch
/// records, the refinement's edge map, form-factor patch geometry, per-patch arrays (ρ,
/// area, escape), faer's column padding of each n×n matrix, with headroom.
pub const BAKE_BYTES_PER_PATCH: u64 = 2048;
/// Bytes per patch and light group: the n×3 f32 columns alive at once during a solve
/// (emission, direct light, E, B, F·B, the refinement residual, the interleaved e/b/h of
/// the result): at most ~100, with headroom.
pub const BAKE_BYTES_PER_PATCH_GROUP: u64 = 128;
/// Fixed overhead of a bake (BVH over small scenes, thread stacks, scratch).
pub const BAKE_BYTES_BASE: u64 = 32 << 20;
/// Hierarchical mode: links per patch assumed by the estimates (measured counts are in
/// the sizing table in docs/deployment.md; this bounds them).
pub const HIER_LINKS_PER_PATCH: u64 = 600;
/// Hierarchical mode: bytes per link while baking (the 16-byte links of refinement, sorted
/// in place, then the 9-byte stored links) and when loaded (9).
pub const HIER_BAKE_BYTES_PER_LINK: u64 = 25;
/// Hierarchical mode: bytes per patch and light group (or sky patch) of the sweeps: RGB
/// f32 radiosity and gathered irradiance over ~2n nodes (48), the sources (12), with
/// headroom for the extracted columns. Measured on a real apartment model with daylight
/// (53,894 patches, 148 columns): 46 bytes per patch and column beyond the links.
pub const HIER_BYTES_PER_PATCH_GROUP: u64 = 80;

/// Hierarchical mode: the peak bytes of building the coarse transfer
/// ([`crate::transport::hierarchy::Coarse`]) over `patches` patches: with m clusters (at
/// most [`MAX_CLUSTERS`]), the assembly table over clusters and the nodes above them
/// (4·(2m)²), the coarse operator, and per channel its system and answer (4·m² each): 40·m²
/// bytes, of which 12·m² are kept.
pub fn coarse_bytes(patches: usize) -> u64 {
    let m = patches.min(MAX_CLUSTERS) as u64;
    40 * m * m + 8 * patches as u64
}

/// Estimated peak memory of baking `patches` patches in `mode` with `groups` light groups
/// and `lu_count` distinct reflectance channels (1–3: channels with identical ρ over all
/// patches share one factorization; see [`memory_estimate`]).
///
/// - **Both modes** hold the dense form factors `F`: 4·n² bytes (f32, n × n).
/// - **Factored** adds one LU of `(I − ρF)ᵀ` per distinct channel, 4·n² bytes each, and
///   then turns each into its irradiance response `K = F (I − ρF)⁻¹` (4·n², the LU
///   dropped once its response is made): `F`, the LUs and one response more than the LUs
///   dropped are alive at once, `4·n²·(2 + lu_count)`. The cache entry is written from the
///   responses alone, streamed without copies.
/// - **Columns** keeps only `F` (Jacobi needs no factorization): `4·n²`.
/// - **Hierarchical** holds no n × n matrix: [`HIER_LINKS_PER_PATCH`] links per patch at
///   [`HIER_BAKE_BYTES_PER_LINK`] bytes, and [`HIER_BYTES_PER_PATCH_GROUP`] per patch and
///   group for the sweeps, instead of the per-group term below, and [`coarse_bytes`].
/// - Plus [`BAKE_BYTES_PER_PATCH`]·n, [`BAKE_BYTES_PER_PATCH_GROUP`]·n·groups and
///   [`BAKE_BYTES_BASE`].
///
/// Measured peaks (`benches/sizing.sh`) are within this estimate.
pub fn estimate_bake_bytes(
    patches: usize,
    mode: TransferMode,
    groups: usize,
    lu_count: usize,
) -> u64 {
    let n = patches as u64;
    let square = 4u64.saturating_mul(n).saturating_mul(n);
    let matrices = match mode {
        TransferMode::Factored => square.saturating_mul(2 + lu_count.clamp(1, 3) as u64),
        TransferMode::Columns => square,
        TransferMode::Hierarchical => {
            return n
                .saturating_mul(HIER_LINKS_PER_PATCH * HIER_BAKE_BYTES_PER_LINK)
                .saturating_add(n.saturating_mul(BAKE_BYTES_PER_PATCH))
                .saturating_add(
                    n.saturating_mul(groups.max(1) as u64)
                        .saturating_mul(HIER_BYTES_PER_PATCH_GROUP),
                )
                .saturating_add(BAKE_BYTES_BASE)
                .saturating_add(coarse_bytes(patches))
        }
    };
    matrices
        .saturating_add(n.saturating_mul(BAKE_BYTES_PER_PATCH))
        .saturating_add(
            n.saturating_mul(groups.max(1) as u64)
                .saturating_mul(BAKE_BYTES_PER_PATCH_GROUP),
        )
        .saturating_add(BAKE_BYTES_BASE)
}

/// Estimated peak memory of loading a baked transfer from the cache: in factored mode the
/// irradiance responses (read straight into their final buffers), `4·n²·lu_count`; in
/// columns mode only the group columns. Plus the same per-patch, per-group and base terms as
/// [`estimate_bake_bytes`].
pub fn estimate_load_bytes(
    patches: usize,
    mode: TransferMode,
    groups: usize,
    lu_count: usize,
) -> u64 {
    match mode {
        TransferMode::Factored => {
            let square = 4u64
                .saturating_mul(patches as u64)
                .saturating_mul(patches as u64);
            estimate_bake_bytes(patches, mode, groups, lu_count)
                .saturating_sub(square.saturating_mul(2))
        }
        TransferMode::Hierarchical => {
            let n = patches as u64;
            n.saturating_mul(HIER_LINKS_PER_PATCH * BYTES_PER_LINK)
                .saturating_add(n.saturating_mul(BAKE_BYTES_PER_PATCH))
                .saturating_add(
                    n.saturating_mul(groups.max(1) as u64)
                        .saturating_mul(BAKE_BYTES_PER_PATCH_GROUP),
                )
                .saturating_add(BAKE_BYTES_BASE)
                .saturating_add(coarse_bytes(patches))
        }
        TransferMode::Columns => {
            let n = patches as u64;
            n.saturating_mul(BAKE_BYTES_PER_PATCH)
                .saturating_add(
                    n.saturating_mul(groups.max(1) as u64)
                        .saturating_mul(BAKE_BYTES_PER_PATCH_GROUP),
                )
                .saturating_add(BAKE_BYTES_BASE)
        }
    }
}

/// The light groups plus, for a scene with a site, the sky patches: every one is an RGB
/// response the bake solves and keeps.
pub fn solved_columns(scene: &Scene) -> usize {
    scene.lights.len()
        + if scene.site.is_some() {
            crate::transport::sky_view::subdivision().patches.len()
        } else {
            0
        }
}

/// Memory estimates for one meshed scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct MemoryEstimate {
    pub patches: usize,
    pub mode: TransferMode,
    pub groups: usize,
    /// Distinct reflectance channels (LU factorizations in factored mode).
    pub lu_count: usize,
    /// Peak bytes of a bake ([`estimate_bake_bytes`]).
    pub bake: u64,
    /// Peak bytes of a load from the cache ([`estimate_load_bytes`]).
    pub load: u64,
}

/// Estimates the memory a scene's bake and cached load need, from its mesh: the patch
/// count, the light groups, how many reflectance channels differ (ρ of R, G and B
/// compared over the materials the patches use, as the solver does), and the grids'
/// gather weights.
pub fn memory_estimate(scene: &Scene, mesh: &Mesh, mode: TransferMode) -> MemoryEstimate {
    let mut used = vec![false; scene.materials.len()];
    for p in &mesh.patches {
        if let Some(u) = used.get_mut(p.material as usize) {
            *u = true;
        }
    }
    let kd: Vec<crate::color::Rgb> = scene
        .materials
        .iter()
        .zip(&used)
        .filter(|(_, &u)| u)
        .map(|(m, _)| m.kd)
        .collect();
    let same = |a: usize, b: usize| kd.iter().all(|k| k[a] == k[b]);
    let mut distinct: Vec<usize> = Vec::new();
    for c in 0..3 {
        if !distinct.iter().any(|&d| same(d, c)) {
            distinct.push(c);
        }
    }
    let (n, groups, lu_count) = (mesh.len(), solved_columns(scene), distinct.len());
    // The grids' gather weights (8 bytes each): at most every patch per point, at most
    // MAX_GRID_WEIGHTS.
    let points: u64 = scene.grids.iter().map(|g| g.points.len() as u64).sum();
    let weights = 8 * points
        .saturating_mul(n as u64)
        .min(crate::transport::probe::MAX_GRID_WEIGHTS);
    MemoryEstimate {
        patches: n,
        mode,
        groups,
        lu_count,
        bake: estimate_bake_bytes(n, mode, groups, lu_count).saturating_add(weights),
        load: estimate_load_bytes(n, mode, groups, lu_count).saturating_add(weights),
    }
}
