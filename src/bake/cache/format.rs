//! The cache file's layout: magic, versions, the JSON header with its section table, and
//! the sections (names, kinds and exact lengths in bytes) a header must list for its
//! patch count, groups and mode.

use serde::{Deserialize, Serialize};

use crate::transport::hierarchy::HierarchyStats;
use crate::transport::transfer::{SolveInfo, TransferMode};

/// The first 8 bytes of every cache file.
pub(super) const MAGIC: &[u8; 8] = b"RLTRANS\0";
/// Bump when the file layout changes.
pub(super) const FORMAT_VERSION: u32 = 7;
/// Bump when the numbers a bake produces change (meshing, form factors, solver,
/// photometry: 3 applies IES tilt data and no longer scales LM-63-2019 tables by their file
/// generation type).
pub(super) const ALGORITHM_VERSION: u32 = 3;
/// Largest JSON header accepted, bytes.
pub(super) const MAX_HEADER_BYTES: usize = 16 << 20;
/// Bytes before the JSON header: magic, format version, header length.
pub(super) const PREAMBLE: u64 = 16;

/// One section of the data area: byte offset from its start, length in bytes, and the
/// XXH3-64 of its bytes (16 hex digits).
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
    /// Factored mode: which irradiance response serves each of R, G, B, and how many
    /// distinct responses there are (sections `resp0`, `resp1`, …).
    pub channel_response: Option<[u8; 3]>,
    pub response_count: usize,
    pub info: SolveInfo,
    /// Hierarchical mode: the number of links, and how the hierarchy was built.
    #[serde(default)]
    pub links: u64,
    #[serde(default)]
    pub hierarchy: Option<HierarchyStats>,
    /// Points of each calculation grid (one section per grid and group).
    #[serde(default)]
    pub grid_points: Vec<usize>,
    /// Weights of each grid's gather (sections `gw{i}o`, the rows + 1 offsets, and
    /// `gw{i}j` and `gw{i}w`, a patch and a weight per entry): per grid its rows (its
    /// points, or 0 where the weights were not kept) and entries.
    #[serde(default)]
    pub grid_weights: Vec<[u64; 2]>,
    /// Sky patches of a daylight transfer (0: none): a section `skyd` (n × K) and one
    /// `sky{k}` (n × 3) per patch.
    #[serde(default)]
    pub sky_patches: usize,
    pub sections: Vec<Section>,
}

/// What a section holds, and its expected length in bytes.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Kind {
    /// f32 values.
    Floats,
    /// An n × n column-major matrix (read straight into it).
    Matrix,
}

/// Sections by name, with their kinds and exact lengths in bytes.
type Sections = Vec<(String, Kind, u64)>;

/// The sections a header must list, with their kinds and exact lengths in bytes.
pub(super) fn expected_sections(h: &Header) -> Option<Sections> {
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
    grid_sections(h, &mut out)?;
    sky_sections(h, &mut out)?;
    match h.mode {
        TransferMode::Columns => {
            if h.response_count != 0 {
                return None;
            }
        }
        TransferMode::Hierarchical => hierarchy_sections(h, &mut out)?,
        TransferMode::Factored => {
            if !(1..=3).contains(&h.response_count) {
                return None;
            }
            for k in 0..h.response_count {
                out.push((format!("resp{k}"), Kind::Matrix, square));
            }
        }
    }
    Some(out)
}

/// Adds one section per grid and group; None when they cannot all be listed.
fn grid_sections(h: &Header, out: &mut Sections) -> Option<()> {
    // Every grid needs one section per group, listed in the (bounded) header.
    if h.grid_points.len().saturating_mul(h.groups) > h.sections.len() {
        return None;
    }
    if h.grid_weights.len() != h.grid_points.len()
        || h.grid_points.len().saturating_mul(3) > h.sections.len()
    {
        return None;
    }
    for (i, &points) in h.grid_points.iter().enumerate() {
        for g in 0..h.groups {
            out.push((
                grid_section(i, g),
                Kind::Floats,
                (points as u64).checked_mul(12)?,
            ));
        }
        let [o, j, w] = gather_sections(i);
        // `grid_points` is 0 for a grid of a scene without light groups (no responses);
        // the weights' rows are the grid's points all the same.
        let [rows, entries] = h.grid_weights[i];
        if rows != 0 && points != 0 && rows != points as u64 {
            return None;
        }
        let offsets = if rows == 0 { 0 } else { rows.checked_add(1)? };
        out.push((o, Kind::Floats, offsets.checked_mul(4)?));
        out.push((j, Kind::Floats, entries.checked_mul(4)?));
        out.push((w, Kind::Floats, entries.checked_mul(4)?));
    }
    Some(())
}

/// The sections of grid `i`'s gather weights: row offsets, patches, weights.
pub(super) fn gather_sections(i: usize) -> [String; 3] {
    [format!("gw{i}o"), format!("gw{i}j"), format!("gw{i}w")]
}

/// Adds the sky's sections (the direct part, one per sky patch), if any; None when they
/// cannot all be listed.
fn sky_sections(h: &Header, out: &mut Sections) -> Option<()> {
    if h.sky_patches == 0 {
        return Some(());
    }
    if h.sky_patches > h.sections.len() {
        return None;
    }
    let n = h.patch_count as u64;
    out.push((
        "skyd".to_string(),
        Kind::Floats,
        n.checked_mul(4)?.checked_mul(h.sky_patches as u64)?,
    ));
    for k in 0..h.sky_patches {
        out.push((sky_section(k), Kind::Floats, n.checked_mul(12)?));
    }
    Some(())
}

/// Adds the hierarchy's sections (its tree and links); None for an inconsistent header.
fn hierarchy_sections(h: &Header, out: &mut Sections) -> Option<()> {
    let n = h.patch_count as u64;
    if h.response_count != 0 || n == 0 {
        return None;
    }
    let links = h.links;
    out.push((
        "children".to_string(),
        Kind::Floats,
        (n - 1).checked_mul(8)?,
    ));
    out.push(("offsets".to_string(), Kind::Floats, n.checked_mul(8)?));
    out.push(("src".to_string(), Kind::Floats, links.checked_mul(4)?));
    out.push(("k".to_string(), Kind::Floats, links.checked_mul(4)?));
    out.push((
        "vis".to_string(),
        Kind::Floats,
        links.div_ceil(4).checked_mul(4)?,
    ));
    out.push(("sigma".to_string(), Kind::Floats, n.checked_mul(4)?));
    Some(())
}

/// The section of grid `i`'s response to group `g`.
pub(super) fn grid_section(i: usize, g: usize) -> String {
    format!("grid{i}g{g}")
}

/// The section of sky patch `k`'s interreflected response.
pub(super) fn sky_section(k: usize) -> String {
    format!("sky{k}")
}
