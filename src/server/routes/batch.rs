//! `POST /api/scenes/{id}/batch`: up to `MAX_BATCH_STATES` lighting states in one request,
//! each answered with surface illuminance (lux), the power balance (lm), and optionally
//! grids and per-patch radiosity (lm/m²).

use axum::Json;
use serde::Serialize;
use std::collections::BTreeMap;
use utoipa::ToSchema;

use crate::model::query::GridAnswer;
use crate::model::report::{PowerReport, SurfaceIlluminance};
use crate::schema::{lm, lm_per_m2, lx};
use crate::server::openapi::{PostErrors, SceneIdParam};
use crate::server::parse::ScenePost;
use crate::server::requests::{BatchRequest, Resolve};
use crate::server::AppError;

/// The units of the results.
#[derive(Serialize, ToSchema)]
pub(crate) struct BatchUnits {
    #[schema(schema_with = lx)]
    illuminance: &'static str,
    #[schema(schema_with = lm_per_m2)]
    radiosity: &'static str,
    #[schema(schema_with = lm)]
    power: &'static str,
}

/// One lighting state's answer.
#[derive(Serialize, ToSchema)]
pub(crate) struct BatchResult {
    /// Illuminance statistics, lx, by surface id.
    surfaces: BTreeMap<String, SurfaceIlluminance>,
    power: PowerReport,
    /// With radiosity = true: B per patch, lm/m², in patch order.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schema(nullable = false, value_type = Option<Vec<crate::schema::Rgb>>)]
    radiosity: Option<Vec<crate::color::Rgb>>,
    /// With grids: by grid id.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schema(nullable = false)]
    grids: Option<BTreeMap<String, GridAnswer>>,
}

/// One result per state, in request order.
#[derive(Serialize, ToSchema)]
pub(crate) struct BatchResponse {
    #[schema(inline)]
    unit: BatchUnits,
    #[schema(inline)]
    results: Vec<BatchResult>,
}

#[utoipa::path(post, path = "/api/scenes/{id}/batch", operation_id = "batch", tags = ["scenes"],
    summary = "Up to 1000 lighting states in one request, each with surface illuminance statistics and the power balance.",
    params(SceneIdParam),
    request_body(content = BatchRequest, content_type = "application/json",
        description = "The lighting states and what to report.",
        example = json!({"states": [{"lights": {"ceiling": 0.25}}, {"lights": {"ceiling": 1}}], "surfaces": ["floor"]})),
    responses((status = 200, description = "One result per state, in request order.", body = BatchResponse), PostErrors))]
pub(crate) async fn batch(
    ScenePost(ready, state, req): ScenePost<BatchRequest>,
) -> Result<Json<BatchResponse>, AppError> {
    let m = &ready.model;
    let report = req.resolve(m)?;
    let states = &req.states;
    // Refused here, in microseconds, when the transfer cannot solve the emission states
    // or (hierarchical) they would take too long.
    let emission_states = states.iter().filter(|s| s.is_emission()).count();
    let plan = m.plan_batch(states.len(), emission_states)?;
    let bytes = m.batch_bytes(&plan, &report);
    let what = format!("a batch of {} states", states.len());
    let results = state
        .heavy(bytes, &what, move |cancel| {
            let (m, states) = (&ready.model, &req.states);
            let at = |k: usize, e: AppError| AppError::Invalid(format!("states[{k}]: {e}"));
            let mut results = Vec::with_capacity(states.len());
            m.solve_each(
                &plan,
                |k| states[k].lighting(m).map_err(|e| at(k, e)),
                cancel,
                |_, l, sol| {
                    let radiosity = report
                        .radiosity
                        .then(|| crate::color::Rgb::column(&sol.b).to_vec());
                    let grid_answers = if report.grids.is_empty() {
                        None
                    } else {
                        Some(m.state_grid_answers(&l, &sol, &report.grids, cancel)?)
                    };
                    results.push(BatchResult {
                        surfaces: m.surface_stats(&report.surfaces, &sol.h),
                        power: PowerReport::new(m.baked.transfer.power(&sol)),
                        radiosity,
                        grids: grid_answers,
                    });
                    Ok(())
                },
            )?;
            Ok(results)
        })
        .await?;
    let unit = BatchUnits {
        illuminance: "lx",
        radiosity: "lm/m2",
        power: "lm",
    };
    Ok(Json(BatchResponse { unit, results }))
}
