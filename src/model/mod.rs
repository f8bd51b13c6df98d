//! The query layer: everything a client can ask of a baked scene, in engine terms.
//!
//! A [`Model`] is a baked scene plus what its queries precompute once: light-group facts
//! ([`GroupInfo`]) and calculation grids with per-group responses
//! ([`grid::GridResponse`]). The CLI, the HTTP server and the examples all answer through
//! its methods; none of them computes on the engine's data itself. The model knows
//! nothing of HTTP or JSON text; its answers are serde types that the server and the CLI
//! print as they like.
//!
//! - [`lighting`]: the one grammar of a lighting state ([`LightState`]: group id →
//!   intensity and colour) and [`Lighting`], a state resolved against a scene (per-group
//!   RGB weights, or a per-patch emission vector).
//! - [`query`]: per-patch radiosity B (lm/m²) or illuminance H (lux), per-surface
//!   statistics, illuminance at points and on grids, luminaire power.
//! - [`batch`]: many states in one query, the emission states solved together (a
//!   [`batch::BatchPlan`] checks the count and the hierarchical mode's cost first).
//! - [`optimize`]: least-flux dimming levels under grid targets.
//! - [`report`]: per-surface averages and the power balance.
//! - [`design_report`]: the printable design report (schedule, grids, plans, power).
//! - [`compliance`]: maintained values (the maintenance factor) and EN 12464-1
//!   requirements per grid (Ēm, U₀, UGR_L, Ra), pass or fail.
//! - [`glare`]: the CIE Unified Glare Rating at observers, linear in the light groups.
//! - [`sky_state`]: the grammar of a sky ([`sky_state::SkySpec`]) and a sky resolved for the site.
//! - [`daylight`]: daylight on surfaces, points and grids, and the point-gather cache.
//! - [`annual`]: climate-based metrics over a year of weather (sDA, ASE, UDI, EN 17037).
//! - [`daylight_metrics`]: those metrics and the daylight-factor statistics as pure
//!   functions of illuminance values, with their thresholds as named constants.
//! - [`info`]: what the scene is made of (units, bounds, luminaires, grids, surfaces,
//!   patches), for clients.
//!
//! With the `server` feature, the answer types derive `utoipa::ToSchema`: the OpenAPI
//! document describes them as they serialize (see `crate::schema`).
//!
//! Errors are [`QueryError`]s: always the client's mistake (a 4xx over HTTP), never a bug.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use crate::bake::Baked;
use crate::color::{Rgb, Rgb64};

pub mod annual;
pub mod batch;
pub mod compliance;
pub mod daylight;
pub mod daylight_metrics;
pub mod design_report;
pub mod error;
pub mod glare;
pub mod grid;
pub mod info;
pub mod lighting;
pub mod optimize;
pub mod placed;
pub mod query;
pub mod report;
pub mod sky_state;

pub use error::QueryError;
pub use lighting::{LightSetting, LightState, Lighting};

/// Light-group facts (defaults from `scene.toml`, emitting area, flux at unit weight).
#[derive(Debug, Clone, serde::Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct GroupInfo {
    pub id: String,
    pub name: String,
    /// Default intensity.
    #[cfg_attr(feature = "server", schema(value_type = f64))]
    pub intensity: f32,
    /// Default colour.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub color: Rgb,
    /// Area of the emitting patches, m².
    pub emitting_area: f64,
    /// Luminous flux at intensity 1, colour white, lm (emissive surfaces and luminaires).
    pub lumens: f64,
    /// Point luminaires in the group.
    pub luminaires: usize,
    /// Electrical power of the luminaires at intensity 1, W, when every one gives it; else
    /// null.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub watts: Option<f64>,
}

/// A baked scene ready to answer queries. Immutable once built.
pub struct Model {
    pub baked: Baked,
    /// One entry per light group, in the order of `scene.lights`.
    pub groups: Vec<GroupInfo>,
    /// The scene's calculation grids with their per-group responses.
    pub grids: Vec<grid::GridResponse>,
    /// Gathers of point sets asked before ([`daylight::GatherCache`]).
    pub gathers: daylight::GatherCache,
    /// Observers' views asked before ([`glare::ViewCache`]).
    glare_views: glare::ViewCache,
    /// Per patch and sky patch, luminous radiosity at unit sky luminance (annual metrics).
    annual_radiosity: std::sync::OnceLock<Vec<f32>>,
    /// Per grid, its daylight coefficients (annual metrics).
    annual_cache:
        std::sync::Mutex<std::collections::HashMap<usize, std::sync::Arc<faer::Mat<f32>>>>,
}

/// Bytes per patch held besides the transfer: mesh, BVH, shading vertices, mesh bytes.
const SCENE_BYTES_PER_PATCH: u64 = 400;

impl Model {
    /// Gathers the group facts and the grids' per-group responses (baked into the
    /// transfer).
    pub fn new(mut baked: Baked) -> Model {
        let groups = group_infos(&baked);
        let columns = std::mem::take(&mut baked.transfer.grids);
        let weights = std::mem::take(&mut baked.transfer.grid_gathers);
        let grids = grid::GridResponse::build_all(&baked.scene, &baked.bvh, columns, weights);
        let gathers =
            daylight::GatherCache::for_scene(baked.transfer.n, baked.transfer.sky.is_some());
        Model {
            baked,
            groups,
            grids,
            gathers,
            glare_views: Default::default(),
            annual_radiosity: Default::default(),
            annual_cache: Default::default(),
        }
    }

    /// Bytes this model holds: the transfer, the mesh and BVH, the grid responses and their
    /// gather weights, and the
    /// most its caches of gathers, daylight coefficients and sun directions may hold.
    pub fn bytes(&self) -> u64 {
        let t = &self.baked.transfer;
        let grid_bytes: u64 = self
            .grids
            .iter()
            .map(|g| 16 * g.len() as u64 * (1 + 3 * t.group_count() as u64) + g.gather.bytes())
            .sum();
        t.bytes()
            + SCENE_BYTES_PER_PATCH * t.n as u64
            + grid_bytes
            + self.gathers.limit()
            + t.sky.as_ref().map_or(0, |s| {
                4 * (t.n * s.k) as u64
                    + annual::ANNUAL_CACHE_BYTES as u64
                    + 16 * (daylight::SUN_CACHE_ENTRIES * t.n) as u64
            })
    }

    /// Number of patches.
    pub fn patches(&self) -> usize {
        self.baked.transfer.n
    }
}

fn group_infos(baked: &Baked) -> Vec<GroupInfo> {
    let t = &baked.transfer;
    baked
        .scene
        .lights
        .iter()
        .zip(&t.groups)
        .map(|(l, g)| {
            let mut area = 0.0;
            let mut flux = Rgb64::ZERO;
            for (&a, e) in t.area.iter().zip(Rgb::column(&g.e)) {
                if e.iter().any(|&v| v > 0.0) {
                    area += a as f64;
                    flux += a as f64 * e.to_f64();
                }
            }
            let watts: Option<f64> = l.luminaires.iter().map(|m| m.watts).sum();
            GroupInfo {
                id: l.id.clone(),
                name: l.name.clone(),
                intensity: l.intensity,
                color: l.color,
                emitting_area: area,
                lumens: flux.luminance() + g.flux.luminance(),
                luminaires: l.luminaires.len(),
                watts: if l.luminaires.is_empty() { None } else { watts },
            }
        })
        .collect()
}

/// A cache's lock; one poisoned by a query that panicked is taken over (the caches hold
/// whole entries only).
fn lock<T>(m: &std::sync::Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Raised when whoever asked for a piece of work no longer wants it (an HTTP client that
/// went away, a timed-out request). Long loops check it and stop.
#[derive(Clone, Default)]
pub struct Cancel(Arc<AtomicBool>);

impl Cancel {
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }

    /// Raises the flag.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// `Err` once cancelled, for `?` in loops.
    pub fn check(&self) -> Result<(), QueryError> {
        if self.is_cancelled() {
            Err(QueryError::Cancelled)
        } else {
            Ok(())
        }
    }
}
