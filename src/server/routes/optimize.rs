//! `POST /api/scenes/{id}/optimize`: the least-flux dimming levels of the free light
//! groups that meet illuminance targets (lux, U₀) on calculation grids.

use std::sync::Arc;

use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::State;
use axum::http::HeaderMap;
use axum::response::IntoResponse;
use axum::Json;
use serde_json::{Map, Value};

use super::ApiResult;
use crate::model::lighting::known_ids;
use crate::model::optimize::{GridTarget, MAX_TARGET_LUX};
use crate::server::json::kind;
use crate::server::parse::{
    begin, check_keys, grid_index, number, parse_lights, shorten, shown, SceneId,
};
use crate::server::{AppError, AppState, Ready};

pub async fn optimize(
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
        &["targets", "groups", "lights"],
    )
    .await?;
    let base = parse_lights(body.get("lights"), &ready)?;
    let free = free_groups(body.get("groups"), &ready)?;
    let targets = targets(body.get("targets"), &ready)?;
    let bytes = ready.optimize_bytes(free.len(), &targets);
    let rows: usize = targets.iter().map(|t| ready.grids[t.grid].len()).sum();
    let what = format!("optimizing {} groups over {rows} grid points", free.len());
    let r = ready.clone();
    let answer = state
        .heavy(bytes, &what, move |_| {
            Ok(r.optimize(&base, &free, &targets)?)
        })
        .await?;
    Ok(Json(answer).into_response())
}

/// Free groups: the listed ones (each once), else every group.
fn free_groups(v: Option<&Value>, ready: &Ready) -> Result<Vec<usize>, AppError> {
    let scene = &ready.baked.scene;
    let a = match v {
        None => return Ok((0..scene.lights.len()).collect()),
        Some(Value::Array(a)) if !a.is_empty() => a,
        Some(v) => {
            return Err(AppError::Invalid(format!(
                "'groups' must be a non-empty array of light group ids, got {}",
                shown(v)
            )))
        }
    };
    let mut free = Vec::with_capacity(a.len().min(scene.lights.len()));
    for v in a {
        let id = v.as_str().ok_or_else(|| {
            AppError::Invalid(format!("'groups' holds light group ids, got {}", kind(v)))
        })?;
        let g = scene.light_index(id).ok_or_else(|| {
            AppError::Invalid(format!(
                "unknown light group '{}' (known: {})",
                shorten(id),
                known_ids(scene)
            ))
        })?;
        if free.contains(&g) {
            return Err(AppError::Invalid(format!(
                "light group '{id}' is listed twice in 'groups'"
            )));
        }
        free.push(g);
    }
    Ok(free)
}

/// `[{"grid": "desk", "eavg_min": 500, "u0_min": 0.6}, …]`: one target per grid.
fn targets(v: Option<&Value>, ready: &Ready) -> Result<Vec<GridTarget>, AppError> {
    let targets = v
        .and_then(Value::as_array)
        .filter(|a| !a.is_empty())
        .ok_or_else(|| {
            AppError::Invalid(
                "'targets' must be a non-empty array like [{\"grid\": \"desk\", \"eavg_min\": 500, \"u0_min\": 0.6}]".into(),
            )
        })?;
    let mut parsed: Vec<GridTarget> = Vec::new();
    for (k, t) in targets.iter().enumerate() {
        let o = t
            .as_object()
            .ok_or_else(|| AppError::Invalid(format!("targets[{k}] must be an object")))?;
        check_keys(o, &["grid", "eavg_min", "emin_min", "u0_min"])
            .map_err(|e| AppError::Invalid(format!("targets[{k}]: {e}")))?;
        let gi = grid_index(o.get("grid").unwrap_or(&Value::Null), ready)?;
        if parsed.iter().any(|t| t.grid == gi) {
            return Err(AppError::Invalid(format!(
                "targets[{k}]: grid '{}' already has a target; give one target per grid with all its bounds",
                ready.grids[gi].grid.id
            )));
        }
        let t = GridTarget {
            grid: gi,
            eavg_min: bound(o, k, "eavg_min", MAX_TARGET_LUX)?,
            emin_min: bound(o, k, "emin_min", MAX_TARGET_LUX)?,
            u0_min: bound(o, k, "u0_min", 1.0)?,
        };
        t.check(&format!("targets[{k}]"))?;
        parsed.push(t);
    }
    Ok(parsed)
}

fn bound(o: &Map<String, Value>, k: usize, key: &str, max: f64) -> Result<Option<f64>, AppError> {
    o.get(key)
        .map(|v| {
            let x = number(v, &format!("targets[{k}].{key}"))?;
            if !(0.0..=max).contains(&x) {
                return Err(AppError::Invalid(format!(
                    "targets[{k}].{key} = {x}: must be in 0..{max}"
                )));
            }
            Ok(x)
        })
        .transpose()
}
