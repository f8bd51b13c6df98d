//! `POST /api/scenes/{id}/batch`: up to [`MAX_BATCH`] lighting states in one request,
//! each answered with surface illuminance (lux), the power balance (lm), and optionally
//! grids and per-patch radiosity (lm/m²).

use std::sync::Arc;

use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::State;
use axum::http::HeaderMap;
use axum::response::IntoResponse;
use axum::Json;
use serde_json::{json, Value};

use super::ApiResult;
use crate::model::query::BYTES_PER_PATCH_ANSWER;
use crate::model::report::PowerReport;
use crate::model::Lighting;
use crate::server::parse::{
    begin, check_keys, flag, grid_list, parse_lighting, surface_list, SceneId, MAX_BATCH,
};
use crate::server::{AppError, AppState};

pub async fn batch(
    State(state): State<Arc<AppState>>,
    SceneId(id): SceneId,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult {
    let (ready, body) = begin(
        &state,
        &id,
        &headers,
        body,
        &["states", "surfaces", "radiosity", "grids"],
    )
    .await?;
    let grids = grid_list(body.get("grids"), &ready)?;
    let states = body
        .get("states")
        .and_then(Value::as_array)
        .ok_or_else(|| AppError::Invalid("'states' must be an array of lighting states".into()))?;
    if states.is_empty() || states.len() > MAX_BATCH {
        return Err(AppError::Invalid(format!(
            "'states' has {} entries; give 1 to {MAX_BATCH}",
            states.len()
        )));
    }
    let with_radiosity = flag(&body, "radiosity")?;
    let mut surfaces = surface_list(body.get("surfaces"), &ready)?;
    if body.get("surfaces").is_none() {
        surfaces = (0..ready.baked.scene.surfaces.len()).collect();
    }
    // Memory: every emission state holds a per-patch vector; every answer holds its
    // surfaces, grids and (when asked) radiosity as JSON values, then as text.
    let n = ready.patches() as u64;
    let emission_states = states
        .iter()
        .filter(|s| s.get("emission").is_some())
        .count() as u64;
    let grid_points: u64 = grids.iter().map(|&g| ready.grids[g].len() as u64).sum();
    let per_state =
        400 * surfaces.len() as u64 + 48 * grid_points + if with_radiosity { 150 * n } else { 0 };
    let bytes =
        2 * states.len() as u64 * per_state + emission_states * 12 * n + BYTES_PER_PATCH_ANSWER * n;
    let what = format!("a batch of {} states", states.len());
    let r = ready.clone();
    let results = state
        .heavy(bytes, &what, move |cancel| {
            let states = body.get("states").and_then(Value::as_array).map_or(&[][..], |v| v);
            let mut results = Vec::with_capacity(states.len());
            for (k, s) in states.iter().enumerate() {
                cancel.check()?;
                let at = |e: AppError| AppError::Invalid(format!("states[{k}]: {e}"));
                let obj = s
                    .as_object()
                    .ok_or_else(|| AppError::Invalid(format!("states[{k}] must be an object")))?;
                check_keys(obj, &["lights", "emission"]).map_err(at)?;
                let l = parse_lighting(obj, &r).map_err(at)?;
                let sol = r.solve(&l)?;
                let mut v = json!({
                    "surfaces": r.surface_stats(&surfaces, &sol.h),
                    "power": PowerReport::new(r.baked.transfer.power(&sol)),
                });
                if with_radiosity {
                    let rgb: &[[f32; 3]] = bytemuck::cast_slice(&sol.b);
                    v["radiosity"] = json!(rgb);
                }
                if !grids.is_empty() {
                    let Lighting::Groups(w) = l else {
                        return Err(at(AppError::Invalid(
                            "grids need light-group states (per-patch emission has no grid columns)".into(),
                        )));
                    };
                    v["grids"] = json!(r.grid_answers(&grids, &w));
                }
                results.push(v);
            }
            Ok(results)
        })
        .await?;
    Ok(Json(json!({ "unit": {"illuminance": "lx", "radiosity": "lm/m2", "power": "lm"}, "results": results })).into_response())
}
