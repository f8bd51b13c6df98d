//! `POST /api/scenes/{id}/optimize`: the least-flux dimming levels of the free light
//! groups that meet illuminance targets (lux, U₀) on calculation grids.

use axum::Json;

use crate::model::optimize::OptimizeAnswer;
use crate::server::openapi::{OfficeIdParam, PostErrors};
use crate::server::parse::ScenePost;
use crate::server::requests::{OptimizeRequest, Resolve};
use crate::server::AppError;

#[utoipa::path(post, path = "/api/scenes/{id}/optimize", operation_id = "optimize", tags = ["scenes"],
    summary = "Dimming levels (0..1 per free group, modelled colours) that meet grid targets with the least emitted flux: a linear program over the precomputed grid responses. With `candidates` (positions × photometric files) it also chooses which luminaires to install and their levels, at most one file per position (a mixed-integer program). 422 explains unreachable targets.",
    params(OfficeIdParam),
    request_body(content = OptimizeRequest, content_type = "application/json",
        description = "Targets per grid, the free groups and the state of the others.",
        example = json!({"targets": [{"grid": "desk", "eavg_min": 500, "u0_min": 0.6}]})),
    responses((status = 200, description = "The levels, flux, power and achieved statistics.", body = OptimizeAnswer), PostErrors))]
pub(crate) async fn optimize(
    ScenePost(ready, state, req): ScenePost<OptimizeRequest>,
) -> Result<Json<OptimizeAnswer>, AppError> {
    let ask = req.resolve(&ready.model)?;
    let m = &ready.model;
    let placed = !ask.changes.is_empty() || !ask.candidates.is_empty();
    let variables = ask.free.len() + ask.candidates.len();
    let bytes = m.optimize_bytes(variables, &ask.targets, placed);
    let rows: usize = ask.targets.iter().map(|t| m.grids[t.grid].len()).sum();
    let what = format!(
        "optimizing {} groups over {rows} grid points",
        ask.free.len()
    );
    let answer = state
        .heavy(bytes, &what, move |_| {
            let m = &ready.model;
            let (changes, candidates) = (&ask.changes, &ask.candidates);
            Ok(m.optimize_layout(&ask.base, changes, &ask.free, &ask.targets, candidates)?)
        })
        .await?;
    Ok(Json(answer))
}
