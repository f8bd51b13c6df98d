//! The body of `POST …/illuminance`, and the receivers (surfaces, points, grids) that it
//! and the daylight request report on.

use glam::DVec3;
use serde::Deserialize;
use serde_json::json;
use utoipa::openapi::schema::Schema;
use utoipa::openapi::RefOr;
use utoipa::ToSchema;

use super::lighting::{lighting, Direction, Emission, Lights, Position};
use super::{grid_ids, names, object_only, raw, schema_ref, some};
use crate::model::query::IlluminanceQuery;
use crate::model::{Lighting, Model};
use crate::server::parse::{
    bounded_triple, direction, grid_list, surface_list, MAX_COORDINATE, MAX_POINTS,
};
use crate::server::AppError;

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

pub(super) fn report_surfaces() -> RefOr<Schema> {
    names("Surfaces to report (default: all when no points or grids are asked for).")
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
    pub(crate) fn query(&self, model: &Model) -> Result<(Lighting, IlluminanceQuery), AppError> {
        let lighting = lighting(self.lights.as_ref(), self.emission.as_ref(), model)?;
        let q = report_query(self.surfaces.as_deref(), &self.grids, &self.points, model)?;
        Ok((lighting, q))
    }
}

/// Where to report illuminance: surfaces, grids and points, checked; nothing asked for
/// (and `surfaces` left out) means every surface.
pub(super) fn report_query(
    surfaces: Option<&[String]>,
    grids: &[String],
    list: &[Point],
    model: &Model,
) -> Result<IlluminanceQuery, AppError> {
    let mut q = IlluminanceQuery {
        surfaces: surface_list(surfaces.unwrap_or_default(), model)?,
        grids: grid_list(grids, model)?,
        points: points(list)?,
    };
    if q.surfaces.is_empty() && q.points.is_empty() && q.grids.is_empty() && surfaces.is_none() {
        q.surfaces = (0..model.baked.scene.surfaces.len()).collect();
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
