//! The body of `POST …/illuminance`, and the receivers (surfaces, points, grids) that it
//! and the daylight request report on.

use std::collections::BTreeMap;

use glam::DVec3;
use serde::de::MapAccess;
use serde::Deserialize;
use serde_json::json;
use utoipa::openapi::schema::Schema;
use utoipa::openapi::RefOr;
use utoipa::ToSchema;

use super::lighting::{Direction, Position};
use super::{deserialize_by, names, object_only, raw, schema_ref, some, visit_numbers, Resolve};
use crate::input_limits::{MAX_REQUEST_COORD_M, MAX_REQUEST_POINTS};
use crate::model::query::{Factors, IlluminanceQuery};
use crate::model::{Lighting, Model};
use crate::server::parse::{bounded_triple, direction, grid_list, surface_list};
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
        json!({"type": "array", "maxItems": MAX_REQUEST_POINTS, "items": schema_ref("Point"),
        "description": "Receivers, e.g. [{\"position\": [0.278, 0.1, 0.278], \"normal\": [0, 1, 0]}]. Each point gathers from every patch it sees: thousands of points take seconds."}),
    )
}

pub(super) fn report_surfaces() -> RefOr<Schema> {
    names("Surfaces to report (default: all when no points or grids are asked for).")
}

/// Declares, through `$declare` ([`super::request`] or [`super::lit_request`]), a request
/// body that reports illuminance at receivers: the fields of the first `{ … }`, then the
/// receivers `surfaces`, `points` and `grids`, then the fields of the second; and
/// `fn report_query`, the receivers checked ([`report_query`]).
macro_rules! report_request {
    ($declare:ident! {
        $(#[$m:meta])* $name:ident, $expecting:literal { $($before:tt)* } { $($after:tt)* }
    }) => {
        $crate::server::requests::$declare! {
            $(#[$m])*
            $name, $expecting {
                $($before)*
                #[serde(default, deserialize_with = "crate::server::requests::some")]
                #[schema(schema_with = $crate::server::requests::illuminance::report_surfaces)]
                surfaces: Option<Vec<String>>,
                #[serde(default)]
                #[schema(schema_with = $crate::server::requests::illuminance::points_schema)]
                points: Vec<$crate::server::requests::illuminance::Point>,
                #[serde(default)]
                #[schema(schema_with = $crate::server::requests::grid_ids)]
                grids: Vec<String>,
                $($after)*
            }
        }

        impl $name {
            /// Where to report illuminance, checked; nothing asked for means every surface.
            fn report_query(
                &self,
                model: &$crate::model::Model,
            ) -> Result<$crate::model::query::IlluminanceQuery, $crate::server::AppError> {
                $crate::server::requests::illuminance::report_query(
                    self.surfaces.as_deref(),
                    &self.grids,
                    &self.points,
                    model,
                )
            }
        }
    };
}
pub(super) use report_request;

report_request! {
    lit_request! {
        /// A lighting state and where to report illuminance.
        IlluminanceRequest, "a JSON object" {} {
            #[serde(default, deserialize_with = "some")]
            #[schema(schema_with = maintenance_schema)]
            maintenance_factor: Option<MaintenanceFactor>,
            /// Requirements per grid id (EN 12464-1), replacing the scene's; a grid named here is
            /// reported.
            #[serde(default)]
            requirements: BTreeMap<String, crate::scene::Requirements>,
        }
    }
}

/// An illuminance request in the model's terms.
pub(crate) struct IlluminanceAsk {
    pub lighting: Lighting,
    pub query: IlluminanceQuery,
}

impl Resolve for IlluminanceRequest {
    type Resolved = IlluminanceAsk;

    /// The lighting state and the query; nothing asked for means every surface.
    fn resolve(&self, model: &Model) -> Result<IlluminanceAsk, AppError> {
        let lighting = self.lighting(model)?;
        let mut q = self.report_query(model)?;
        q.maintenance = self
            .maintenance_factor
            .as_ref()
            .map(|m| m.factors(model))
            .transpose()?;
        for (id, r) in &self.requirements {
            let gi = model.grid_index(id)?;
            r.check()
                .map_err(|m| AppError::Invalid(format!("requirements['{id}'].{m}")))?;
            if !q.grids.contains(&gi) {
                q.grids.push(gi);
            }
            q.requirements.insert(gi, *r);
        }
        Ok(IlluminanceAsk { lighting, query: q })
    }
}

/// `maintenance_factor`: one factor for every group, or factors by group id (the others
/// keep the scene's).
#[derive(Debug, Clone)]
pub(crate) enum MaintenanceFactor {
    All(f64),
    ByGroup(BTreeMap<String, f64>),
}

deserialize_by! {
    MaintenanceFactor,
    "a number in (0, 1] or an object {group id: number}",
    deserialize_any,
    visit_numbers!(MaintenanceFactor::All);
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
        let mut out = BTreeMap::new();
        while let Some((k, v)) = map.next_entry::<String, f64>()? {
            out.insert(k, v);
        }
        Ok(MaintenanceFactor::ByGroup(out))
    }
}

fn maintenance_schema() -> RefOr<Schema> {
    let factor = json!({"type": "number", "exclusiveMinimum": 0, "maximum": 1});
    raw(
        json!({"oneOf": [factor, {"type": "object", "additionalProperties": factor}],
        "description": "Maintenance factor MF in (0, 1] for every light group, or by group id (the others keep the scene's). Maintained values are MF × initial; default: the scene's factors (scene.toml `maintenance_factor`, 1 when not given)."}),
    )
}

impl MaintenanceFactor {
    /// The query's factors: this one for all, or these over the scene's.
    fn factors(&self, model: &Model) -> Result<Factors, AppError> {
        let check = |what: String, v: f64| {
            if v.is_finite() && v > 0.0 && v <= 1.0 {
                Ok(v)
            } else {
                Err(AppError::Invalid(format!(
                    "{what} = {v}: must be in (0, 1]"
                )))
            }
        };
        let scene = &model.baked.scene;
        match self {
            MaintenanceFactor::All(v) => {
                let v = check("maintenance_factor".into(), *v)?;
                Ok(Factors {
                    groups: vec![v; scene.lights.len()],
                    emission: v,
                })
            }
            MaintenanceFactor::ByGroup(map) => {
                let mut f = model.factors(&IlluminanceQuery::default());
                let ids: Vec<String> = map.keys().cloned().collect();
                for (g, id) in crate::server::parse::group_list(&ids, model)?
                    .into_iter()
                    .zip(&ids)
                {
                    f.groups[g] = check(format!("maintenance_factor['{id}']"), map[id])?;
                }
                Ok(f)
            }
        }
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
        ..Default::default()
    };
    if q.surfaces.is_empty() && q.points.is_empty() && q.grids.is_empty() && surfaces.is_none() {
        q.surfaces = (0..model.baked.scene.surfaces.len()).collect();
    }
    Ok(q)
}

fn points(list: &[Point]) -> Result<Vec<(DVec3, DVec3)>, AppError> {
    if list.len() > MAX_REQUEST_POINTS {
        return Err(AppError::Invalid(format!(
            "{} points requested; the limit is {MAX_REQUEST_POINTS} per request",
            list.len()
        )));
    }
    list.iter()
        .enumerate()
        .map(|(k, p)| {
            let what = format!("points[{k}].position");
            let pos = bounded_triple(p.position.0 .0, &what, MAX_REQUEST_COORD_M)?;
            let n = direction(p.normal.0 .0, &format!("points[{k}].normal"))?;
            Ok((DVec3::from_array(pos), n))
        })
        .collect()
}
