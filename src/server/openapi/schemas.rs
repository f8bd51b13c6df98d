//! The answers' schemas. The handlers answer with JSON built from the query model's
//! serde types ([`crate::model`]) or, for scene listings and batches, assembled in the
//! routes; these types only describe those answers for the document (they are never
//! built). `tests` below serializes real model answers and checks them against these
//! schemas, and schemathesis checks every answer of a running server.

#![allow(dead_code)]

use std::collections::BTreeMap;

use serde_json::json;
use utoipa::openapi::schema::Schema;
use utoipa::openapi::RefOr;
use utoipa::{PartialSchema, ToSchema};

use crate::server::requests::raw;

/// An RGB triple, or a point or vector in metres.
pub(crate) struct Rgb;

impl PartialSchema for Rgb {
    fn schema() -> RefOr<Schema> {
        raw(json!({"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3}))
    }
}
impl ToSchema for Rgb {}

/// `[columns, rows]` of a work plane (x fastest), or null.
fn layout() -> RefOr<Schema> {
    raw(
        json!({"oneOf": [{"type": "array", "items": {"type": "integer", "minimum": 0}, "minItems": 2, "maxItems": 2}, {"type": "null"}],
        "description": "[columns, rows] of a work plane (x fastest), or null."}),
    )
}

/// RFC 9457 problem document.
#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ProblemDetails {
    #[schema(schema_with = about_blank)]
    r#type: String,
    title: String,
    #[schema(minimum = 400, maximum = 599)]
    status: u16,
    detail: String,
    /// 503 while a scene bakes: its progress.
    #[schema(nullable = false, minimum = 0, maximum = 1)]
    progress: Option<f64>,
}

fn about_blank() -> RefOr<Schema> {
    raw(json!({"type": "string", "enum": ["about:blank"]}))
}

/// Light-group facts.
#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct GroupInfo {
    id: String,
    name: String,
    /// Default intensity.
    intensity: f64,
    /// Default colour.
    #[schema(value_type = Rgb)]
    color: [f64; 3],
    /// m²
    emitting_area: f64,
    /// Flux at intensity 1, colour white, lm.
    lumens: f64,
    #[schema(minimum = 0)]
    luminaires: u64,
    /// Electrical power of the luminaires at intensity 1, W, when every one gives it.
    #[schema(required = true)]
    watts: Option<f64>,
}

fn scene_status() -> RefOr<Schema> {
    raw(json!({"type": "string", "enum": ["queued", "baking", "ready", "failed"]}))
}

fn transfer_mode() -> RefOr<Schema> {
    raw(json!({"type": "string", "enum": ["factored", "columns", "hierarchical"]}))
}

/// A scene's slot: its status and, once ready, its size and light groups.
#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SceneSummary {
    id: String,
    name: String,
    #[schema(schema_with = scene_status)]
    status: String,
    #[schema(minimum = 0, maximum = 1)]
    progress: f64,
    /// Ready scenes.
    #[schema(nullable = false, minimum = 0)]
    patches: Option<u64>,
    /// Ready scenes.
    #[schema(nullable = false)]
    lights: Option<Vec<GroupInfo>>,
    /// Ready scenes.
    #[schema(nullable = false, schema_with = transfer_mode)]
    transfer: Option<String>,
    /// Failed scenes.
    #[schema(nullable = false)]
    error: Option<String>,
}

/// Every scene.
#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SceneList {
    scenes: Vec<SceneSummary>,
}

/// Whether every scene is ready or failed, with every scene's status.
#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct Readiness {
    ready: bool,
    scenes: Vec<SceneSummary>,
}

#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Units {
    length: String,
    source_units: String,
    scale_to_m: f64,
    radiosity: String,
    illuminance: String,
    flux: String,
}

#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Bounds {
    #[schema(value_type = Rgb)]
    min: [f64; 3],
    #[schema(value_type = Rgb)]
    max: [f64; 3],
}

#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraPreset {
    id: String,
    #[schema(value_type = Rgb)]
    position: [f64; 3],
    #[schema(value_type = Rgb)]
    target: [f64; 3],
    #[schema(value_type = Rgb)]
    up: [f64; 3],
    fov_deg: f64,
}

fn distribution() -> RefOr<Schema> {
    raw(json!({"type": "string", "enum": ["isotropic", "spot", "ies"]}))
}

#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Luminaire {
    id: String,
    group: String,
    #[schema(value_type = Rgb)]
    position: [f64; 3],
    #[schema(value_type = Rgb)]
    aim: [f64; 3],
    lumens: f64,
    #[schema(required = true)]
    watts: Option<f64>,
    #[schema(schema_with = distribution)]
    distribution: String,
}

#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct GridInfo {
    id: String,
    name: String,
    #[schema(minimum = 0)]
    count: u64,
    #[schema(schema_with = layout, required = true)]
    layout: Option<[u64; 2]>,
    #[schema(value_type = Rgb)]
    normal: [f64; 3],
    #[schema(value_type = Vec<Rgb>)]
    points: Vec<[f64; 3]>,
}

#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct PatchRange {
    #[schema(minimum = 0)]
    start: u64,
    #[schema(minimum = 0)]
    end: u64,
    #[schema(minimum = 0)]
    count: u64,
}

#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct SurfaceInfo {
    id: String,
    #[schema(minimum = 0)]
    index: u64,
    area: f64,
    #[schema(inline)]
    patches: PatchRange,
    two_sided: bool,
}

#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct BakeInfo {
    seconds: f64,
    from_cache: bool,
    residual: f64,
}

fn ready_status() -> RefOr<Schema> {
    raw(json!({"type": "string", "enum": ["ready"]}))
}

/// Light groups, cameras, luminaires, grids, surfaces, bounds, units and transfer mode.
#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SceneDetails {
    id: String,
    name: String,
    #[schema(schema_with = ready_status)]
    status: String,
    #[schema(minimum = 0)]
    patches: u64,
    #[schema(schema_with = transfer_mode)]
    transfer: String,
    #[schema(inline)]
    units: Units,
    #[schema(inline)]
    bounds: Bounds,
    lights: Vec<GroupInfo>,
    #[schema(inline)]
    cameras: Vec<CameraPreset>,
    #[schema(inline)]
    luminaires: Vec<Luminaire>,
    #[schema(inline)]
    grids: Vec<GridInfo>,
    #[schema(inline)]
    surfaces: Vec<SurfaceInfo>,
    #[schema(inline)]
    bake: BakeInfo,
}

#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct PatchInfo {
    surface: String,
    area: f64,
    #[schema(value_type = Rgb)]
    centroid: [f64; 3],
    #[schema(value_type = Rgb)]
    normal: [f64; 3],
}

/// Per patch, in patch order.
#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct Patches {
    #[schema(inline)]
    patches: Vec<PatchInfo>,
}

/// Area-weighted averages over one surface.
#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct SurfaceAverage {
    area: f64,
    #[schema(value_type = Rgb)]
    radiosity: [f64; 3],
    #[schema(value_type = Rgb)]
    illuminance: [f64; 3],
}

fn radiosity_unit() -> RefOr<Schema> {
    raw(json!({"type": "string", "enum": ["lm/m2", "lx"]}))
}

/// Per-patch radiosity (or incident illuminance), with per-surface averages on request.
#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RadiosityResponse {
    scene: String,
    #[schema(minimum = 0)]
    patches: u64,
    #[schema(schema_with = radiosity_unit)]
    unit: String,
    /// quantity = radiosity: B per patch, lm/m².
    #[schema(nullable = false, value_type = Option<Vec<Rgb>>)]
    radiosity: Option<Vec<[f64; 3]>>,
    /// quantity = illuminance: H per patch, lx.
    #[schema(nullable = false, value_type = Option<Vec<Rgb>>)]
    illuminance: Option<Vec<[f64; 3]>>,
    /// With surfaces = true.
    #[schema(nullable = false, inline)]
    surfaces: Option<BTreeMap<String, SurfaceAverage>>,
}

/// An illuminance value: luminous (lux) and per channel.
#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct Lux {
    lux: f64,
    #[schema(value_type = Rgb)]
    rgb: [f64; 3],
}

/// Illuminance statistics of one surface.
#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SurfaceIlluminance {
    area: f64,
    avg: Lux,
    min: Lux,
    max: Lux,
    /// Emin / Eavg
    uniformity: f64,
}

fn lx() -> RefOr<Schema> {
    raw(json!({"type": "string", "enum": ["lx"]}))
}

/// One grid's statistics for a lighting state, lux.
#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct GridStats {
    name: String,
    #[schema(schema_with = lx)]
    unit: String,
    #[schema(minimum = 0)]
    count: u64,
    #[schema(schema_with = layout, required = true)]
    layout: Option<[u64; 2]>,
    values: Vec<f64>,
    avg: f64,
    min: f64,
    max: f64,
    /// Emin/Eavg
    u0: f64,
    /// Emin/Emax
    min_max: f64,
}

/// Flux and electrical power of the point luminaires.
#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct LuminairePower {
    luminaire_lumens: f64,
    /// null when some luminaire gives no watts.
    #[schema(required = true)]
    luminaire_watts: Option<f64>,
}

/// Illuminance answers, lux.
#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct IlluminanceResponse {
    #[schema(schema_with = lx)]
    unit: String,
    points: Vec<Lux>,
    surfaces: BTreeMap<String, SurfaceIlluminance>,
    grids: BTreeMap<String, GridStats>,
    /// The luminaires' flux and power in this state; null for a per-patch emission with
    /// points.
    #[schema(required = true)]
    power: Option<LuminairePower>,
}

/// The power balance, lm.
#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct Power {
    #[schema(value_type = Rgb)]
    emitted: [f64; 3],
    #[schema(value_type = Rgb)]
    absorbed: [f64; 3],
    #[schema(value_type = Rgb)]
    escaped: [f64; 3],
    emitted_lm: f64,
    absorbed_lm: f64,
    escaped_lm: f64,
    imbalance: f64,
}

#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct BatchUnits {
    illuminance: String,
    radiosity: String,
    power: String,
}

#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct BatchResult {
    surfaces: BTreeMap<String, SurfaceIlluminance>,
    power: Power,
    /// With radiosity = true.
    #[schema(nullable = false, value_type = Option<Vec<Rgb>>)]
    radiosity: Option<Vec<[f64; 3]>>,
    /// With grids.
    #[schema(nullable = false)]
    grids: Option<BTreeMap<String, GridStats>>,
}

/// One result per state, in request order.
#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct BatchResponse {
    #[schema(inline)]
    unit: BatchUnits,
    #[schema(inline)]
    results: Vec<BatchResult>,
}

#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Level {
    intensity: f64,
    #[schema(value_type = Rgb)]
    color: [f64; 3],
    free: bool,
}

#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Achieved {
    avg: f64,
    min: f64,
    u0: f64,
}

#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct TargetAnswer {
    grid: String,
    #[schema(required = true)]
    eavg_min: Option<f64>,
    #[schema(required = true)]
    emin_min: Option<f64>,
    #[schema(required = true)]
    u0_min: Option<f64>,
    #[schema(inline)]
    achieved: Achieved,
    met: bool,
}

/// The levels, flux, power and achieved statistics.
#[derive(ToSchema, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct OptimizeResponse {
    #[schema(inline)]
    lights: BTreeMap<String, Level>,
    lumens: f64,
    power: LuminairePower,
    #[schema(inline)]
    targets: Vec<TargetAnswer>,
    grids: BTreeMap<String, GridStats>,
    solve_ms: f64,
}
