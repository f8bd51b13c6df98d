//! The bodies of `POST …/radiosity`, `…/illuminance`, `…/batch` and `…/optimize`, and
//! their conversions to the query model's terms.

use glam::DVec3;
use serde::Deserialize;
use serde_json::json;
use utoipa::openapi::schema::Schema;
use utoipa::openapi::RefOr;
use utoipa::ToSchema;

use super::lighting::{light_weights, lighting, Direction, Emission, Lights, Position};
use super::{choice_impls, object_only, raw, schema_ref, some, Choice};
use crate::color::Rgb;
use crate::model::optimize::{GridTarget, MAX_TARGET_LUX};
use crate::model::query::{IlluminanceQuery, Quantity};
use crate::model::Lighting;
use crate::server::json::FIELD;
use crate::server::parse::{
    bounded_triple, direction, grid_list, group_list, number, surface_list, MAX_BATCH,
    MAX_COORDINATE, MAX_POINTS,
};
use crate::server::{AppError, Ready};

/// `quantity`: what a radiosity request answers per patch.
#[derive(Debug, Clone, Copy)]
pub(crate) struct QuantityName(pub Quantity);

impl Default for QuantityName {
    fn default() -> Self {
        QuantityName(Quantity::Radiosity)
    }
}

impl Choice for QuantityName {
    const NAMES: &'static [&'static str] = &["radiosity", "illuminance"];
    fn pick(s: &str) -> Option<Self> {
        match s {
            "radiosity" => Some(QuantityName(Quantity::Radiosity)),
            "illuminance" => Some(QuantityName(Quantity::Illuminance)),
            _ => None,
        }
    }
    fn refuse(got: &str) -> String {
        format!("'{FIELD}' must be \"radiosity\" (lm/m2, leaving) or \"illuminance\" (lux, arriving), got \"{got}\"")
    }
}

choice_impls!(
    QuantityName,
    "radiosity: B, lm/m² leaving each patch; illuminance: H, lux arriving at each patch."
);

/// A lighting state and what to return.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(remote = "Self", deny_unknown_fields)]
pub(crate) struct RadiosityRequest {
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false)]
    lights: Option<Lights>,
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false)]
    emission: Option<Emission>,
    /// Also return per-surface area-weighted averages.
    #[serde(default)]
    #[schema(default = false)]
    pub surfaces: bool,
    #[serde(default)]
    #[schema(inline)]
    pub quantity: QuantityName,
    /// Daylight from this sky (a scene with a [site]) added to the light groups' light.
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false)]
    sky: Option<crate::model::sky_state::SkySpec>,
}

object_only!(RadiosityRequest, "a JSON object");

impl RadiosityRequest {
    pub(crate) fn lighting(&self, ready: &Ready) -> Result<Lighting, AppError> {
        lighting(self.lights.as_ref(), self.emission.as_ref(), ready)
    }

    /// The sky, resolved for the scene's site.
    pub(crate) fn sky(
        &self,
        ready: &Ready,
    ) -> Result<Option<crate::model::sky_state::SkyState>, AppError> {
        match &self.sky {
            None => Ok(None),
            Some(spec) => Ok(Some(spec.resolve(ready.site()?)?)),
        }
    }
}

/// A receiver: a point and the normal of the surface it lies on.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(remote = "Self", deny_unknown_fields)]
pub(crate) struct Point {
    position: Position,
    normal: Direction,
}

object_only!(Point, "an object {position, normal}");

pub(super) fn points_schema() -> RefOr<Schema> {
    raw(
        json!({"type": "array", "maxItems": MAX_POINTS, "items": schema_ref("Point"),
        "description": "Receivers, e.g. [{\"position\": [0.278, 0.1, 0.278], \"normal\": [0, 1, 0]}]. Each point gathers from every patch it sees: thousands of points take seconds."}),
    )
}

/// A list of names, each at most once.
fn names(description: &str) -> RefOr<Schema> {
    raw(
        json!({"type": "array", "items": {"type": "string", "minLength": 1}, "uniqueItems": true,
        "description": description}),
    )
}

pub(super) fn report_surfaces() -> RefOr<Schema> {
    names("Surfaces to report (default: all when no points or grids are asked for).")
}

pub(super) fn grid_ids() -> RefOr<Schema> {
    names("Calculation grid ids from scene.toml.")
}

/// A lighting state and where to report illuminance.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(remote = "Self", deny_unknown_fields)]
pub(crate) struct IlluminanceRequest {
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false)]
    lights: Option<Lights>,
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false)]
    emission: Option<Emission>,
    #[serde(default, deserialize_with = "some")]
    #[schema(schema_with = report_surfaces)]
    surfaces: Option<Vec<String>>,
    #[serde(default)]
    #[schema(schema_with = points_schema)]
    points: Vec<Point>,
    #[serde(default)]
    #[schema(schema_with = grid_ids)]
    grids: Vec<String>,
}

object_only!(IlluminanceRequest, "a JSON object");

impl IlluminanceRequest {
    /// The lighting state and the query; nothing asked for means every surface.
    pub(crate) fn query(&self, ready: &Ready) -> Result<(Lighting, IlluminanceQuery), AppError> {
        let lighting = lighting(self.lights.as_ref(), self.emission.as_ref(), ready)?;
        let q = report_query(self.surfaces.as_deref(), &self.grids, &self.points, ready)?;
        Ok((lighting, q))
    }
}

/// Where to report illuminance: surfaces, grids and points, checked; nothing asked for
/// (and `surfaces` left out) means every surface.
pub(super) fn report_query(
    surfaces: Option<&[String]>,
    grids: &[String],
    list: &[Point],
    ready: &Ready,
) -> Result<IlluminanceQuery, AppError> {
    let mut q = IlluminanceQuery {
        surfaces: surface_list(surfaces.unwrap_or_default(), ready)?,
        grids: grid_list(grids, ready)?,
        points: points(list)?,
    };
    if q.surfaces.is_empty() && q.points.is_empty() && q.grids.is_empty() && surfaces.is_none() {
        q.surfaces = (0..ready.baked.scene.surfaces.len()).collect();
    }
    Ok(q)
}

fn points(list: &[Point]) -> Result<Vec<(DVec3, DVec3)>, AppError> {
    if list.len() > MAX_POINTS {
        return Err(AppError::Invalid(format!(
            "{} points requested; the limit is {MAX_POINTS} per request",
            list.len()
        )));
    }
    list.iter()
        .enumerate()
        .map(|(k, p)| {
            let what = format!("points[{k}].position");
            let pos = bounded_triple(p.position.0 .0, &what, MAX_COORDINATE)?;
            let n = direction(p.normal.0 .0, &format!("points[{k}].normal"))?;
            Ok((DVec3::from_array(pos), n))
        })
        .collect()
}

/// Group settings (`lights`) or, in factored mode, a per-patch `emission`; not both.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(remote = "Self", deny_unknown_fields)]
pub(crate) struct LightingState {
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false)]
    lights: Option<Lights>,
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false)]
    emission: Option<Emission>,
}

object_only!(LightingState, "an object {lights} or {emission}");

impl LightingState {
    pub(crate) fn lighting(&self, ready: &Ready) -> Result<Lighting, AppError> {
        lighting(self.lights.as_ref(), self.emission.as_ref(), ready)
    }

    pub(crate) fn is_emission(&self) -> bool {
        self.emission.is_some()
    }
}

fn states_schema() -> RefOr<Schema> {
    raw(
        json!({"type": "array", "minItems": 1, "maxItems": MAX_BATCH,
        "items": schema_ref("LightingState")}),
    )
}

fn batch_surfaces() -> RefOr<Schema> {
    names("Surfaces to report (default: all).")
}

fn batch_grids() -> RefOr<Schema> {
    names("Grid ids: also return grid statistics for each state (light-group states only).")
}

/// Lighting states, answered in order (per-patch emission states are solved together),
/// and what to report for each.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(remote = "Self", deny_unknown_fields)]
pub(crate) struct BatchRequest {
    #[schema(schema_with = states_schema)]
    pub states: Vec<LightingState>,
    #[serde(default, deserialize_with = "some")]
    #[schema(schema_with = batch_surfaces)]
    surfaces: Option<Vec<String>>,
    /// Also return per-patch radiosity for each state.
    #[serde(default)]
    #[schema(default = false)]
    pub radiosity: bool,
    #[serde(default)]
    #[schema(schema_with = batch_grids)]
    grids: Vec<String>,
}

object_only!(BatchRequest, "a JSON object");

impl BatchRequest {
    /// The grids and surfaces to report (absent surfaces: all), with the states' count
    /// checked.
    pub(crate) fn plan(&self, ready: &Ready) -> Result<(Vec<usize>, Vec<usize>), AppError> {
        let grids = grid_list(&self.grids, ready)?;
        if self.states.is_empty() || self.states.len() > MAX_BATCH {
            return Err(AppError::Invalid(format!(
                "'states' has {} entries; give 1 to {MAX_BATCH}",
                self.states.len()
            )));
        }
        let surfaces = match &self.surfaces {
            Some(names) => surface_list(names, ready)?,
            None => (0..ready.baked.scene.surfaces.len()).collect(),
        };
        Ok((grids, surfaces))
    }
}

/// Bounds on one grid: at least one; u0_min needs a positive eavg_min or emin_min as well.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(remote = "Self", deny_unknown_fields)]
pub(crate) struct Target {
    #[schema(min_length = 1)]
    grid: String,
    /// lx
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false, schema_with = lux_bound)]
    eavg_min: Option<f64>,
    /// lx
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false, schema_with = lux_bound)]
    emin_min: Option<f64>,
    /// Emin/Eavg
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false, schema_with = ratio_bound)]
    u0_min: Option<f64>,
}

object_only!(Target, "an object {grid, eavg_min, emin_min, u0_min}");

fn lux_bound() -> RefOr<Schema> {
    raw(json!({"type": "number", "minimum": 0, "maximum": MAX_TARGET_LUX, "description": "lx"}))
}

fn ratio_bound() -> RefOr<Schema> {
    raw(json!({"type": "number", "minimum": 0, "maximum": 1, "description": "Emin/Eavg"}))
}

fn targets_schema() -> RefOr<Schema> {
    raw(
        json!({"type": "array", "minItems": 1, "items": schema_ref("Target"),
        "description": "At most one target per grid."}),
    )
}

fn groups_schema() -> RefOr<Schema> {
    raw(
        json!({"type": "array", "minItems": 1, "uniqueItems": true, "items": {"type": "string", "minLength": 1},
        "description": "Groups the optimizer may dim (default: all)."}),
    )
}

/// Targets per grid, the free groups and the state of the others.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(remote = "Self", deny_unknown_fields)]
pub(crate) struct OptimizeRequest {
    #[schema(schema_with = targets_schema)]
    targets: Vec<Target>,
    #[serde(default, deserialize_with = "some")]
    #[schema(schema_with = groups_schema)]
    groups: Option<Vec<String>>,
    /// State of the groups that are not free.
    #[serde(default)]
    lights: Lights,
}

object_only!(OptimizeRequest, "a JSON object");

/// What the optimizer is given: the base weights, the free groups, the targets.
pub(crate) type Problem = (Vec<Rgb>, Vec<usize>, Vec<GridTarget>);

impl OptimizeRequest {
    pub(crate) fn problem(&self, ready: &Ready) -> Result<Problem, AppError> {
        let base = light_weights(Some(&self.lights), ready)?;
        let free = match &self.groups {
            None => (0..ready.baked.scene.lights.len()).collect(),
            Some(ids) if ids.is_empty() => {
                return Err(AppError::Invalid(
                    "'groups' must be a non-empty array of light group ids, got []".into(),
                ))
            }
            Some(ids) => group_list(ids, ready)?,
        };
        Ok((base, free, self.targets(ready)?))
    }

    /// One target per grid, each checked.
    fn targets(&self, ready: &Ready) -> Result<Vec<GridTarget>, AppError> {
        if self.targets.is_empty() {
            return Err(AppError::Invalid(
                "'targets' must be a non-empty array like [{\"grid\": \"desk\", \"eavg_min\": 500, \"u0_min\": 0.6}]".into(),
            ));
        }
        let mut parsed: Vec<GridTarget> = Vec::with_capacity(self.targets.len().min(64));
        for (k, t) in self.targets.iter().enumerate() {
            let gi = ready.grid_index(&t.grid)?;
            if parsed.iter().any(|t| t.grid == gi) {
                return Err(AppError::Invalid(format!(
                    "targets[{k}]: grid '{}' already has a target; give one target per grid with all its bounds",
                    ready.grids[gi].grid.id
                )));
            }
            let bound = |v: Option<f64>, key: &str, max: f64| {
                v.map(|x| {
                    let x = number(x, &format!("targets[{k}].{key}"))?;
                    if !(0.0..=max).contains(&x) {
                        return Err(AppError::Invalid(format!(
                            "targets[{k}].{key} = {x}: must be in 0..{max}"
                        )));
                    }
                    Ok(x)
                })
                .transpose()
            };
            let g = GridTarget {
                grid: gi,
                eavg_min: bound(t.eavg_min, "eavg_min", MAX_TARGET_LUX)?,
                emin_min: bound(t.emin_min, "emin_min", MAX_TARGET_LUX)?,
                u0_min: bound(t.u0_min, "u0_min", 1.0)?,
            };
            g.check(&format!("targets[{k}]"))?;
            parsed.push(g);
        }
        Ok(parsed)
    }
}
