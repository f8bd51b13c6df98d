//! Input limits: every size, count and number relight accepts from a scene folder, and
//! the limits of requests and lighting states.
//!
//! Scenes may come from people other than the operator (a shared `scenes/` folder, an
//! upload), so loading checks each value *before* it is used to allocate or compute, and
//! refuses anything outside these bounds with a [`crate::scene::SceneError`] that names the
//! file and line. docs/scene-format.md lists the same limits. The last ones bound what a
//! request or a lighting state may ask of a loaded scene, as docs/http-api.md lists them.
//!
//! Lengths are checked in metres, after the `units`/`scale` conversion. Numbers are checked
//! in the type the code computes with (`f32` for OBJ coordinates, `Kd` and `Ke`; `f64`
//! elsewhere): a value that overflows that type is refused, never turned into `inf`/`NaN`.

/// Largest OBJ file, bytes (256 MiB).
pub const MAX_OBJ_BYTES: u64 = 256 << 20;
/// Largest MTL, IES or `scene.toml` file, bytes (16 MiB).
pub const MAX_TEXT_BYTES: u64 = 16 << 20;
/// Largest glTF file (`.gltf` or `.glb`), and largest total of its buffers, bytes (512 MiB).
pub const MAX_GLTF_BYTES: u64 = 512 << 20;
/// Most bytes the compressed buffer views of a glTF file (`EXT_meshopt_compression`) may
/// decode to, over all the views geometry reads (512 MiB): checked before each is allocated.
pub const MAX_GLTF_DECODED_BYTES: u64 = 512 << 20;
/// Deepest glTF node tree (levels below a root node).
pub const MAX_GLTF_DEPTH: usize = 256;
/// Most nodes in the node tree of the glTF scene that is read. The hierarchy must be
/// disjoint strict trees (see `scene::gltf::tree`, checked before any mesh is read), so
/// each node is walked once and this is also the most node instances.
pub const MAX_GLTF_NODE_INSTANCES: usize = 1_000_000;
/// Most `v` lines in an OBJ file (for glTF: vertices over all mesh instances).
pub const MAX_OBJ_VERTICES: usize = 2_000_000;
/// Most triangles in an OBJ file, n − 2 per polygon of n vertices (for glTF: over all mesh
/// instances).
pub const MAX_OBJ_TRIANGLES: usize = 1_000_000;
/// Ear-clipping work per OBJ file, in point-in-triangle tests (a non-convex polygon of n
/// vertices takes about n²; the whole budget about a second); past it, non-convex
/// polygons are fanned with a warning.
pub const MAX_EAR_CLIP_WORK: u64 = 200_000_000;
/// Most `mtllib` statements in an OBJ file.
pub const MAX_MTLLIBS: usize = 64;
/// Most materials (`newmtl`) over all the material libraries of a scene.
pub const MAX_MATERIALS: usize = 10_000;
/// Largest diffuse reflectance a lenient load gives a material: a `Kd` (or a textured
/// `Kd`) with a channel of 1 or more is scaled so its largest channel is this, keeping its
/// colour (`strict = true` refuses it instead).
pub const MAX_KD: f32 = 0.95;
/// Largest texture file (`map_Kd`) read, bytes.
pub const MAX_TEXTURE_BYTES: u64 = 64 << 20;
/// Largest texture decoded, pixels (width × height), and largest side.
pub const MAX_TEXTURE_PIXELS: u64 = 16 << 20;
pub const MAX_TEXTURE_SIDE: u32 = 16_384;
/// Most textures one scene averages.
pub const MAX_TEXTURES: usize = 1_000;

/// Largest absolute coordinate, metres (after unit scaling): OBJ vertices, luminaire and
/// camera positions, grid corners and points.
pub const MAX_COORD_M: f64 = 1e5;
/// Smallest and largest `scale` (factor from OBJ units to metres).
pub const MIN_SCALE: f64 = 1e-6;
pub const MAX_SCALE: f64 = 1e6;

/// Smallest and largest `[mesh] max_edge`, metres (after unit scaling).
pub const MIN_MAX_EDGE_M: f64 = 1e-4;
pub const MAX_MAX_EDGE_M: f64 = 1e6;
/// Largest `[mesh] target_patches` (the bake's own patch limit,
/// [`crate::bake::DEFAULT_MAX_PATCHES`], is usually lower).
pub const MAX_TARGET_PATCHES: usize = 1_000_000;

/// Largest luminous exitance `Ke`, lm/m² per channel.
pub const MAX_EXITANCE: f32 = 1e8;
/// Largest flux of a light group or luminaire (`lumens`), lm.
pub const MAX_LUMENS: f64 = 1e9;
/// Largest default `intensity` of a light group in `scene.toml` (a lighting state may ask
/// for more, [`MAX_STATE_INTENSITY`]).
pub const MAX_DEFAULT_INTENSITY: f64 = 1e3;
/// Largest component of a `color` (light groups and luminaires).
pub const MAX_COLOR: f64 = 1e3;
/// Largest electrical power of a luminaire (`watts`), W.
pub const MAX_WATTS: f64 = 1e7;
/// Largest luminous efficacy (`efficacy`), lm/W (the theoretical maximum is 683).
pub const MAX_EFFICACY: f64 = 1000.0;
/// Colour temperature range (`cct`), kelvin.
pub const MIN_CCT: f64 = 1000.0;
pub const MAX_CCT: f64 = 40_000.0;

/// Smallest work-plane grid `spacing`, metres (after unit scaling).
pub const MIN_GRID_SPACING_M: f64 = 1e-3;
/// Most points in one grid (work plane or explicit points).
pub const MAX_GRID_POINTS: usize = 20_000;
/// Most points over all the grids of a scene (each costs a gather over every patch).
pub const MAX_GRID_POINTS_TOTAL: usize = 50_000;
/// Most entries in each of `[[lights]]`, `[[grids]]` and `[[cameras]]`.
pub const MAX_TOML_ENTRIES: usize = 10_000;
/// Most `[[luminaires]]` (each adds shadow rays to every patch and grid point).
pub const MAX_LUMINAIRES: usize = 1_000;
/// Most light groups in a scene (`[[lights]]`, luminaire groups, and one per unclaimed
/// emissive material): each carries three n × 3 columns.
pub const MAX_LIGHT_GROUPS: usize = 1_000;

/// Most vertical and most horizontal angles in an IES file.
pub const MAX_IES_ANGLES: usize = 2_000;
/// Most candela values in an IES file (vertical × horizontal angles).
pub const MAX_IES_VALUES: usize = 1_000_000;
/// Largest luminous-opening dimension of a photometric file, metres (IES feet are
/// converted first; EULUMDAT millimetres too).
pub const MAX_OPENING: f64 = 1000.0;
/// Most C planes, γ angles and lamp sets of an EULUMDAT file.
pub const MAX_LDT_PLANES: usize = 1_441;
pub const MAX_LDT_ANGLES: usize = 1_801;
pub const MAX_LDT_LAMP_SETS: usize = 20;
/// Most angle/factor pairs in an IES `TILT=INCLUDE` block.
pub const MAX_IES_TILT_PAIRS: usize = 10_000;
/// Largest candela value of an IES file (after the multiplier and ballast factors), cd.
pub const MAX_CANDELA: f64 = 1e9;
/// Largest number of lamps, candela multiplier, and ballast factors of an IES file.
pub const MAX_IES_LAMPS: f64 = 1e4;
pub const MAX_IES_MULTIPLIER: f64 = 1e6;
pub const MAX_IES_BALLAST: f64 = 100.0;

/// Most entries in an uploaded zip archive (files and folders).
pub const MAX_ARCHIVE_ENTRIES: usize = 1_000;
/// Most bytes an uploaded zip archive may unpack to, in all (1 GiB).
pub const MAX_ARCHIVE_UNPACKED: u64 = 1 << 30;

// # Requests and lighting states
//
// What a request (HTTP or command line) may ask of a loaded scene: checked after the body
// is parsed and before any work, each with a 422 that names the field.

/// Largest intensity of a light group in a lighting state (a dimming factor; 1 = as
/// modelled), and largest channel of its colour filter.
pub const MAX_STATE_INTENSITY: f32 = 1e6;
/// Largest per-patch emission of a lighting state, lm/m² per channel.
pub const MAX_STATE_EMISSION: f64 = 1e9;
/// Most lighting states in one batch.
pub const MAX_BATCH_STATES: usize = 1000;
/// Most points in one illuminance request.
pub const MAX_REQUEST_POINTS: usize = 10_000;
/// Most luminaires placed, moved or removed by one lighting state (`luminaires`; each
/// adds shadow rays to every patch and point).
pub const MAX_REQUEST_LUMINAIRES: usize = 1_000;
/// Most luminaire × patch pairs whose direct light one request traces (placed luminaires,
/// with a moved or removed scene luminaire counted twice): each pair costs 4 to 64 shadow
/// rays, so this bounds a request's tracing at some seconds on two cores (office-floor's
/// 177,222 patches: 282 luminaires). A batch counts its states' luminaires together
/// against [`MAX_REQUEST_LUMINAIRES`].
pub const MAX_PLACED_LUMINAIRE_PATCHES: u64 = 50_000_000;
/// Largest inline photometric text (IES or EULUMDAT) of a request's luminaire, bytes.
pub const MAX_INLINE_PHOTOMETRY_BYTES: usize = 1 << 20;
/// Largest coordinate accepted in a request (points, cameras, observers), metres.
pub const MAX_REQUEST_COORD_M: f64 = 1e6;

/// Most work of the per-patch emission states of one batch in hierarchical mode, in
/// link sweeps of one colour column (3 per state × (links + 2 · nodes) × the sweeps the
/// bake's own solve took; see `model::batch::hierarchy_sweep_work`). A batch predicted
/// over it is refused before any work. Measured over HTTP on 2 busy cores: 196
/// single-patch states on a hierarchical Cornell box (1.0e8 each, 2.0e10 in all) took
/// 7.4 s, so a batch at the limit stays well inside the 60 s request timeout; the
/// refusal takes 3 ms.
pub const MAX_EMISSION_SWEEP_WORK: u64 = 20_000_000_000;

/// A number for a message: plain when moderate, else in exponent form (`1e300`, `1e-9`).
pub(crate) fn num(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 || !v.is_finite() || (1e-4..1e15).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}
