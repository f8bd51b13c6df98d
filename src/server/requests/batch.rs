//! The body of `POST …/batch`: lighting states and what to report for each.

use serde::Deserialize;
use serde_json::json;
use utoipa::openapi::schema::Schema;
use utoipa::openapi::RefOr;
use utoipa::ToSchema;

use super::{lit_request, names, object_only, raw, schema_ref, some, Resolve};
use crate::input_limits::{MAX_BATCH_STATES, MAX_REQUEST_LUMINAIRES};
use crate::model::batch::BatchReport;
use crate::model::Model;
use crate::server::parse::{grid_list, surface_list};
use crate::server::AppError;

lit_request! {
    /// Group settings (`lights`) or, in factored mode, a per-patch `emission`; not both.
    LightingState, "an object {lights} or {emission}" {}
}

impl LightingState {
    /// How many luminaires the state places.
    pub(crate) fn luminaire_count(&self) -> usize {
        self.luminaires.as_ref().map_or(0, |l| l.len())
    }

    /// Whether the state needs a solve (a per-patch emission or placed luminaires), which
    /// the batch's work limit counts.
    pub(crate) fn is_emission(&self) -> bool {
        self.emission.is_some() || self.luminaires.is_some()
    }
}

fn states_schema() -> RefOr<Schema> {
    raw(
        json!({"type": "array", "minItems": 1, "maxItems": MAX_BATCH_STATES,
        "items": schema_ref("LightingState")}),
    )
}

fn batch_surfaces() -> RefOr<Schema> {
    names("Surfaces to report (default: all).")
}

fn batch_grids() -> RefOr<Schema> {
    names("Grid ids: also return grid statistics for each state (for a state of light groups a weighted sum of the stored responses; with luminaires placed per request or an emission, traced and gathered at each point).")
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
    radiosity: bool,
    #[serde(default)]
    #[schema(schema_with = batch_grids)]
    grids: Vec<String>,
}

object_only!(BatchRequest, "a JSON object");

impl Resolve for BatchRequest {
    type Resolved = BatchReport;

    /// What to report for each state: the grids, the surfaces (absent: all) and whether
    /// the radiosity; with the states' count checked.
    fn resolve(&self, model: &Model) -> Result<BatchReport, AppError> {
        let grids = grid_list(&self.grids, model)?;
        if self.states.is_empty() || self.states.len() > MAX_BATCH_STATES {
            return Err(AppError::Invalid(format!(
                "'states' has {} entries; give 1 to {MAX_BATCH_STATES}",
                self.states.len()
            )));
        }
        let placed: usize = self.states.iter().map(|s| s.luminaire_count()).sum();
        if placed > MAX_REQUEST_LUMINAIRES {
            return Err(AppError::Invalid(format!(
                "the states place {placed} luminaires in all; at most {MAX_REQUEST_LUMINAIRES} per batch"
            )));
        }
        let surfaces = match &self.surfaces {
            Some(names) => surface_list(names, model)?,
            None => (0..model.baked.scene.surfaces.len()).collect(),
        };
        Ok(BatchReport {
            grids,
            surfaces,
            radiosity: self.radiosity,
        })
    }
}
