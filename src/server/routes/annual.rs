//! `POST /api/scenes/{id}/annual`: climate-based daylight metrics over a year of weather.

use std::sync::Arc;

use axum::Json;

use super::grid_points;
use crate::model::annual::{AnnualAnswer, AnnualQuery};
use crate::server::openapi::{PostErrors, SceneIdParam};
use crate::server::parse::ScenePost;
use crate::server::requests::{AnnualRequest, Resolve};
use crate::server::AppError;

#[utoipa::path(post, path = "/api/scenes/{id}/annual", operation_id = "annual", tags = ["scenes"],
    summary = "Annual climate-based metrics per grid from an EPW weather file (a file in the scene's folder, or its text): sDA300/50 %, ASE1000,250h, useful daylight illuminance bands, EN 17037's minimum level, and per point the occupied hours with at least 300 lx. Every hour is a Perez sky; the sun's direct light is traced per point and hour.",
    params(SceneIdParam),
    request_body(content = AnnualRequest, content_type = "application/json",
        example = json!({"weather": "mannheim.epw", "grids": ["workplane"], "occupied": ["08:00", "18:00"]})),
    responses((status = 200, description = "Annual metrics per grid.", body = AnnualAnswer), PostErrors))]
pub(crate) async fn annual(
    ScenePost(ready, state, req): ScenePost<AnnualRequest>,
) -> Result<Json<AnnualAnswer>, AppError> {
    let ask = req.resolve(&ready.model)?;
    let points = grid_points(&ready.model, &ask.grids);
    // Sized for a leap year, before the file is read.
    let bytes = ready.model.annual_bytes(&ask.grids, 8784);
    let what = format!("annual metrics for {points} grid points");
    let answer = state
        .heavy(bytes, &what, move |cancel| {
            let m = &ready.model;
            let q = AnnualQuery {
                weather: Arc::new(m.weather(&ask.weather)?),
                grids: ask.grids,
                occupied: ask.occupied,
            };
            Ok(m.annual(&q, cancel)?)
        })
        .await?;
    Ok(Json(answer))
}
