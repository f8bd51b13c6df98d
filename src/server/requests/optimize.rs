//! The body of `POST …/optimize`: illuminance targets on grids, the free light groups
//! and the state of the others.

use serde::Deserialize;
use serde_json::json;
use utoipa::openapi::schema::Schema;
use utoipa::openapi::RefOr;
use utoipa::ToSchema;

use super::lighting::{lighting, Direction, Lights, LuminaireEntry, Position};
use super::{object_only, raw, schema_ref, some, Resolve};
use crate::color::Rgb;
use crate::model::optimize::{Candidate, GridTarget, MAX_TARGET_LUX};
use crate::model::placed::LuminaireChange;
use crate::model::placed::{place, LuminairePlacement, Photometry};
use crate::model::{Lighting, Model};
use crate::server::parse::{group_list, number};
use crate::server::AppError;

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
    /// The highest UGR at the grid's four seated task observers (CIE 117)
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false, schema_with = ugr_bound)]
    ugr_max: Option<f64>,
}

object_only!(
    Target,
    "an object {grid, eavg_min, emin_min, u0_min, ugr_max}"
);

fn ugr_bound() -> RefOr<Schema> {
    raw(
        json!({"type": "number", "minimum": 5, "maximum": 40, "description": "The highest UGR at the grid's task observers (seated eyes at the middle of its edges, looking across it). Needs eavg_min or emin_min."}),
    )
}

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
    /// Luminaires added, moved, re-aimed, swapped or removed for this request only, at
    /// most 1,000 (factored and hierarchical transfers): one in a free group dims with it,
    /// any other is held at its weight.
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false, max_items = 1000)]
    luminaires: Option<Vec<LuminaireEntry>>,
    /// Luminaires the optimizer may install: positions × photometric files, at most one
    /// file per position, each installed one dimmed like a free group.
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false)]
    candidates: Option<Candidates>,
}

/// Most candidates (positions × photometric files) in one request: each is solved once.
pub const MAX_CANDIDATES: usize = 200;

/// Candidate luminaires: every photometric file at every position.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(remote = "Self", deny_unknown_fields)]
pub(crate) struct Candidates {
    /// Photometric centres, metres, inside the scene's bounds.
    #[schema(min_items = 1, max_items = 200)]
    positions: Vec<Position>,
    /// Photometric files of the scene folder offered at every position.
    #[schema(min_items = 1, max_items = 8)]
    photometry: Vec<String>,
    /// Photometric axis of every candidate (default straight down, −Y).
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false)]
    aim: Option<Direction>,
}

object_only!(Candidates, "an object {positions, photometry, aim}");

impl Candidates {
    /// Every (position, file) pair as a luminaire at unit weight in no group, checked as a
    /// placed luminaire is (bounds, file); `c<position>_<file>` ids.
    fn resolve(&self, model: &Model) -> Result<Vec<Candidate>, AppError> {
        let (np, nf) = (self.positions.len(), self.photometry.len());
        if np == 0 || nf == 0 || np * nf > MAX_CANDIDATES {
            return Err(AppError::Invalid(format!(
                "candidates: {np} positions × {nf} photometric files; give at least one of \
                 each, at most {MAX_CANDIDATES} pairs"
            )));
        }
        model.require_factored()?;
        let scene = &model.baked.scene;
        let none = vec![Rgb::ZERO; scene.lights.len()];
        let mut out = Vec::with_capacity(np * nf);
        for (p, at) in self.positions.iter().enumerate() {
            for (f, file) in self.photometry.iter().enumerate() {
                let entry = LuminairePlacement {
                    id: format!("c{p}_{f}"),
                    position: Some(at.0 .0),
                    aim: self.aim.map(|a| a.0 .0),
                    photometry: Some(Photometry::File(file.clone())),
                    ..Default::default()
                };
                let placed =
                    place(scene, model.patches(), none.clone(), &[entry]).map_err(|e| {
                        // The entry's own words, named as the request gives it.
                        let m = e.to_string();
                        let m = m
                            .split_once("): ")
                            .map_or(m.as_str(), |(_, m)| m)
                            .to_string();
                        AppError::Invalid(format!(
                            "candidates.positions[{p}] with candidates.photometry[{f}]: {m}"
                        ))
                    })?;
                let change =
                    placed.changes.into_iter().next().ok_or_else(|| {
                        AppError::Internal("a candidate made no luminaire".into())
                    })?;
                out.push(Candidate {
                    position: p,
                    change,
                });
            }
        }
        Ok(out)
    }
}

object_only!(OptimizeRequest, "a JSON object");

/// What the optimizer is given.
pub(crate) struct OptimizeAsk {
    /// The weights of every group; the free groups' are replaced by the levels found.
    pub base: Vec<Rgb>,
    /// Luminaires placed, moved or removed for the request.
    pub changes: Vec<LuminaireChange>,
    /// Luminaires the optimizer may install.
    pub candidates: Vec<Candidate>,
    /// The groups the optimizer may dim.
    pub free: Vec<usize>,
    pub targets: Vec<GridTarget>,
}

impl Resolve for OptimizeRequest {
    type Resolved = OptimizeAsk;

    fn resolve(&self, model: &Model) -> Result<OptimizeAsk, AppError> {
        let lit = lighting(Some(&self.lights), None, self.luminaires.as_deref(), model)?;
        let (base, changes) = match lit {
            Lighting::Placed(p) => (p.weights, p.changes),
            Lighting::Groups(w) => (w, vec![]),
            Lighting::Emission(_) => unreachable!("no emission was given"),
        };
        let free = match &self.groups {
            None => (0..model.baked.scene.lights.len()).collect(),
            Some(ids) if ids.is_empty() => {
                return Err(AppError::Invalid(
                    "'groups' must be a non-empty array of light group ids, got []".into(),
                ))
            }
            Some(ids) => group_list(ids, model)?,
        };
        let candidates = match &self.candidates {
            Some(c) => c.resolve(model)?,
            None => vec![],
        };
        Ok(OptimizeAsk {
            base,
            changes,
            candidates,
            free,
            targets: self.targets(model)?,
        })
    }
}

impl OptimizeRequest {
    /// One target per grid, each checked.
    fn targets(&self, model: &Model) -> Result<Vec<GridTarget>, AppError> {
        if self.targets.is_empty() {
            return Err(AppError::Invalid(
                "'targets' must be a non-empty array like [{\"grid\": \"desk\", \"eavg_min\": 500, \"u0_min\": 0.6}]".into(),
            ));
        }
        let mut parsed: Vec<GridTarget> = Vec::with_capacity(self.targets.len().min(64));
        for (k, t) in self.targets.iter().enumerate() {
            let gi = model.grid_index(&t.grid)?;
            if parsed.iter().any(|t| t.grid == gi) {
                return Err(AppError::Invalid(format!(
                    "targets[{k}]: grid '{}' already has a target; give one target per grid with all its bounds",
                    model.grids[gi].grid.id
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
                ugr_max: t
                    .ugr_max
                    .map(|x| number(x, &format!("targets[{k}].ugr_max")))
                    .transpose()?,
            };
            g.check(&format!("targets[{k}]"))?;
            parsed.push(g);
        }
        Ok(parsed)
    }
}
