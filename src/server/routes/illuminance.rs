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
use crate::model::query::IlluminanceQuery;
use crate::server::parse::{begin, grid_list, parse_lighting, parse_points, surface_list, SceneId};
use crate::server::AppState;

pub async fn illuminance(
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
        &["lights", "emission", "surfaces", "points", "grids"],
    )
    .await?;
    let lighting = parse_lighting(&body, &ready)?;
    let mut q = IlluminanceQuery {
        surfaces: surface_list(body.get("surfaces"), &ready)?,
        grids: grid_list(body.get("grids"), &ready)?,
        points: body
            .get("points")
            .map(parse_points)
            .transpose()?
            .unwrap_or_default(),
    };
    // Nothing asked for: every surface.
    if q.surfaces.is_empty()
        && q.points.is_empty()
        && q.grids.is_empty()
        && body.get("surfaces").is_none()
    {
        q.surfaces = (0..ready.baked.scene.surfaces.len()).collect();
    }
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
