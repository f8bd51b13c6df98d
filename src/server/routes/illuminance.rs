//! `POST /api/scenes/{id}/illuminance`: illuminance in lux on surfaces (statistics), at
//! points and on calculation grids, with the luminaires' flux and power.

use std::sync::Arc;

use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::State;
use axum::http::HeaderMap;
use axum::response::IntoResponse;
use axum::Json;

use super::ApiResult;
use crate::model::query::IlluminanceAnswer;
use crate::server::openapi::{PostErrors, SceneIdParam};
use crate::server::parse::{begin, SceneId};
use crate::server::requests::IlluminanceRequest;
use crate::server::AppState;

#[utoipa::path(post, path = "/api/scenes/{id}/illuminance", operation_id = "illuminance", tag = "scenes",
    summary = "Illuminance per surface (avg, min, max, uniformity), at points (direct light of the luminaires plus light gathered from the solved patches, with occlusion), and on calculation grids (Eavg, Emin, Emax, U0, Emin/Emax), with the luminaires' lumens and watts.",
    params(SceneIdParam),
    request_body(content = IlluminanceRequest, content_type = "application/json",
        description = "An empty body gives every surface in the default lighting state.",
        example = json!({"lights": {"ceiling": {"intensity": 0.8, "color": [1.0, 0.9, 0.8]}}, "surfaces": ["floor"]})),
    responses((status = 200, description = "Illuminance answers in lux.", body = IlluminanceAnswer), PostErrors))]
pub(crate) async fn illuminance(
    State(state): State<Arc<AppState>>,
    SceneId(id): SceneId,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult {
    let (ready, body): (_, IlluminanceRequest) = begin(&state, &id, &headers, body).await?;
    let (lighting, q) = body.query(&ready)?;
    // Group lighting and no points: a weighted sum of precomputed columns, inline.
    if ready.is_cheap(&lighting, &q) {
        let answer = ready.illuminance(&lighting, &q, &Default::default())?;
        return Ok(Json(answer).into_response());
    }
    let bytes = ready.illuminance_bytes(&q);
    let grid_points: usize = q.grids.iter().map(|&g| ready.grids[g].len()).sum();
    let what = format!(
        "illuminance at {} points and {grid_points} grid points",
        q.points.len()
    );
    let r = ready.clone();
    let answer = state
        .heavy(bytes, &what, move |cancel| {
            Ok(r.illuminance(&lighting, &q, cancel)?)
        })
        .await?;
    Ok(Json(answer).into_response())
}
