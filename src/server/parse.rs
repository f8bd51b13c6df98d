//! Request parsing: the JSON body (content type, size, strictness), lighting states,
//! numbers in the f32 range and limits the engine computes with, points, and lists of ids
//! (each id at most once). Every mistake becomes a precise 422 naming the field.

use std::sync::Arc;

use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::Path;
use axum::http::{HeaderMap, StatusCode};
use glam::DVec3;
use serde_json::{Map, Value};

use super::json::kind;
use super::{AppError, AppState, Ready};
use crate::color::Rgb;
pub use crate::model::lighting::MAX_EMISSION;
use crate::model::lighting::{LightState, MAX_INTENSITY};
pub use crate::model::Lighting;

/// Most lighting states in one batch.
pub const MAX_BATCH: usize = 1000;

/// Most points in one illuminance request.
pub const MAX_POINTS: usize = 10_000;

/// Largest coordinate accepted in a request (points, cameras), metres.
pub const MAX_COORDINATE: f64 = 1e6;

/// The `{id}` of a scene route. A path segment that is not valid UTF-8 (or otherwise
/// unreadable) names no scene: 404 as a problem document, like any unknown scene.
pub struct SceneId(pub String);

impl<S: Send + Sync> axum::extract::FromRequestParts<S> for SceneId {
    type Rejection = AppError;

    async fn from_request_parts(
        parts: &mut axum::http::request::Parts,
        state: &S,
    ) -> Result<Self, Self::Rejection> {
        match Path::<String>::from_request_parts(parts, state).await {
            Ok(Path(id)) => Ok(SceneId(id)),
            Err(e) => Err(AppError::NotFound(format!(
                "no such scene: the scene id in the path is not readable ({})",
                shorten(&e.body_text())
            ))),
        }
    }
}

/// Bodies above this size are parsed on the blocking pool, under the memory budget.
pub const INLINE_PARSE_BYTES: usize = 64 << 10;

/// Bytes of parsed `serde_json::Value` per byte of JSON text, at most (arrays of small
/// numbers are the worst case).
const PARSED_BYTES_PER_BYTE: u64 = 12;

/// Parses a JSON object body: 413 for size, 415 for a content type that is not JSON,
/// 400 for syntax, 422 for a non-object or a repeated key. An empty body is `{}`.
/// Large bodies are parsed off the async runtime.
pub async fn parse_body(
    state: &Arc<AppState>,
    headers: &HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> Result<Map<String, Value>, AppError> {
    let body = body.map_err(|e| {
        if e.status() == StatusCode::PAYLOAD_TOO_LARGE {
            AppError::TooLarge(format!(
                "the request body exceeds the limit of {} bytes (--body-limit)",
                state.config.body_limit
            ))
        } else {
            AppError::BadRequest(e.body_text())
        }
    })?;
    if body.is_empty() {
        return Ok(Map::new());
    }
    super::json::require_json(headers)?;
    if body.len() <= INLINE_PARSE_BYTES {
        return super::json::parse_object(&body);
    }
    let what = format!(
        "parsing a {} request body",
        crate::budget::human_bytes(body.len() as u64)
    );
    state
        .heavy(
            PARSED_BYTES_PER_BYTE * body.len() as u64,
            &what,
            move |_| super::json::parse_object(&body),
        )
        .await
}

pub fn check_keys(body: &Map<String, Value>, allowed: &[&str]) -> Result<(), AppError> {
    for k in body.keys() {
        if !allowed.contains(&k.as_str()) {
            return Err(AppError::Invalid(format!(
                "unknown field '{k}' (expected: {})",
                allowed.join(", ")
            )));
        }
    }
    Ok(())
}

pub fn number(v: &Value, what: &str) -> Result<f64, AppError> {
    let x = v
        .as_f64()
        .ok_or_else(|| AppError::Invalid(format!("{what} must be a number, got {}", shown(v))))?;
    // Numbers are computed in f32: anything beyond its range would become infinite.
    if !x.is_finite() || x.abs() > f32::MAX as f64 {
        return Err(AppError::Invalid(format!(
            "{what} must be finite in 32-bit floating point (|x| ≤ 3.4e38), got {}",
            num(x)
        )));
    }
    Ok(x)
}

/// A number for a message: plain when moderate, else in exponent form.
pub fn num(x: f64) -> String {
    if x == 0.0 || (1e-4..1e7).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A JSON value for a message, cut short.
pub fn shown(v: &Value) -> String {
    shorten(&v.to_string())
}

/// A number in `[lo, hi]` (both finite, within f32 range).
pub fn bounded(v: &Value, what: &str, lo: f64, hi: f64) -> Result<f64, AppError> {
    let x = number(v, what)?;
    if x > hi {
        return Err(AppError::Invalid(format!(
            "{what} = {} exceeds the limit: must be in [{}, {}]",
            num(x),
            num(lo),
            num(hi)
        )));
    }
    if x < lo {
        return Err(AppError::Invalid(format!(
            "{what} = {}: must be ≥ {} (the range is [{}, {}])",
            num(x),
            num(lo),
            num(lo),
            num(hi)
        )));
    }
    Ok(x)
}

/// Three numbers, each in `[-limit, limit]`.
pub fn bounded_triple(v: &Value, what: &str, limit: f64) -> Result<[f64; 3], AppError> {
    let t = triple(v, what)?;
    if t.iter().any(|x| x.abs() > limit) {
        return Err(AppError::Invalid(format!(
            "{what} = [{}, {}, {}]: each coordinate must be within ±{}",
            num(t[0]),
            num(t[1]),
            num(t[2]),
            num(limit)
        )));
    }
    Ok(t)
}

/// A direction: three numbers, not all zero, normalised (the scaling keeps huge and tiny
/// components from overflowing or vanishing).
pub fn direction(v: &Value, what: &str) -> Result<DVec3, AppError> {
    let d = DVec3::from_array(triple(v, what)?);
    let m = d.abs().max_element();
    if !(m > 0.0 && m.is_finite()) {
        return Err(AppError::Invalid(format!("{what} must not be zero")));
    }
    let u = (d / m).normalize();
    if !u.is_finite() || u.length() < 0.5 {
        return Err(AppError::Invalid(format!(
            "{what} is not a usable direction"
        )));
    }
    Ok(u)
}

pub fn triple(v: &Value, what: &str) -> Result<[f64; 3], AppError> {
    let arr = v.as_array().filter(|a| a.len() == 3).ok_or_else(|| {
        AppError::Invalid(format!(
            "{what} must be an array of three numbers, got {}",
            shown(v)
        ))
    })?;
    Ok([
        number(&arr[0], what)?,
        number(&arr[1], what)?,
        number(&arr[2], what)?,
    ])
}

/// `"lights": {"<group>": 0.5 | {"intensity": 0.5, "color": [r, g, b]}}` → per-group weights.
pub fn parse_lights(v: Option<&Value>, ready: &Ready) -> Result<Vec<Rgb>, AppError> {
    let scene = &ready.baked.scene;
    let mut state = LightState::default();
    if let Some(v) = v {
        let obj = v.as_object().ok_or_else(|| {
            AppError::Invalid(format!(
                "'lights' must be an object of group settings, got {}",
                shown(v)
            ))
        })?;
        for (id, s) in obj {
            let (mut level, mut color) = (None, None);
            match s {
                Value::Object(o) => {
                    for k in o.keys() {
                        if k != "intensity" && k != "color" {
                            return Err(AppError::Invalid(format!(
                                "light '{}': unknown field '{k}' (expected intensity, color)",
                                shorten(id)
                            )));
                        }
                    }
                    if let Some(i) = o.get("intensity") {
                        level = Some(intensity(i, &format!("light '{id}' intensity"))?);
                    }
                    if let Some(c) = o.get("color") {
                        let what = format!("light '{id}' color");
                        let t = triple(c, &what)?;
                        for x in t {
                            bounded(&Value::from(x), &what, 0.0, MAX_INTENSITY as f64)?;
                        }
                        color = Some(t.map(|x| x as f32));
                    }
                }
                other => level = Some(intensity(other, &format!("light '{id}'"))?),
            }
            state.set(scene, id, level, color)?;
        }
    }
    Ok(ready.weights(&state)?)
}

/// An intensity (dimming factor) in `[0, MAX_INTENSITY]`.
pub(crate) fn intensity(v: &Value, what: &str) -> Result<f32, AppError> {
    Ok(bounded(v, what, 0.0, MAX_INTENSITY as f64)? as f32)
}

/// Per-patch emission, dense `[[r,g,b], …]` or sparse `{"<index>": [r,g,b]}`, lm/m².
pub(crate) fn parse_emission(v: &Value, ready: &Ready) -> Result<Vec<f32>, AppError> {
    ready.require_factored()?;
    let n = ready.patches();
    let mut e = vec![0f32; 3 * n];
    let mut put = |i: usize, val: &Value| -> Result<(), AppError> {
        let rgb = ready.emission_value(i, triple(val, &format!("emission[{i}]"))?)?;
        e[3 * i..3 * i + 3].copy_from_slice(&rgb);
        Ok(())
    };
    match v {
        Value::Array(a) => {
            if a.len() != n {
                return Err(AppError::Invalid(format!(
                    "emission has {} entries; the scene has {n} patches (one [r,g,b] per patch)",
                    a.len()
                )));
            }
            for (i, val) in a.iter().enumerate() {
                put(i, val)?;
            }
        }
        Value::Object(o) => {
            for (k, val) in o {
                // Canonical decimal indices only: "+1", "01" or " 1" would alias patch 1.
                let i: usize = k
                    .parse()
                    .ok()
                    .filter(|i: &usize| i.to_string() == *k)
                    .ok_or_else(|| {
                        AppError::Invalid(format!(
                            "emission key '{}' is not a patch index (a decimal number without sign or leading zeros)",
                            k.chars().take(40).collect::<String>()
                        ))
                    })?;
                put(i, val)?;
            }
        }
        other => {
            return Err(AppError::Invalid(format!(
                "emission must be an array of [r,g,b] per patch or an object of patch index → [r,g,b], got {}",
                kind(other)
            )))
        }
    }
    Ok(e)
}

pub fn parse_lighting(body: &Map<String, Value>, ready: &Ready) -> Result<Lighting, AppError> {
    match (body.get("lights"), body.get("emission")) {
        (Some(_), Some(_)) => Err(AppError::Invalid(
            "give either 'lights' (group settings) or 'emission' (per patch), not both".into(),
        )),
        (_, Some(e)) => Ok(Lighting::Emission(parse_emission(e, ready)?)),
        (l, None) => Ok(Lighting::Groups(parse_lights(l, ready)?)),
    }
}

pub(crate) fn surface_list(v: Option<&Value>, ready: &Ready) -> Result<Vec<usize>, AppError> {
    let scene = &ready.baked.scene;
    let Some(v) = v else { return Ok(vec![]) };
    let arr = v.as_array().ok_or_else(|| {
        AppError::Invalid(format!(
            "'surfaces' must be an array of surface names, got {}",
            kind(v)
        ))
    })?;
    let mut out: Vec<usize> = Vec::with_capacity(arr.len().min(scene.surfaces.len()));
    for s in arr {
        let name = s.as_str().ok_or_else(|| {
            AppError::Invalid(format!("surface names must be strings, got {}", kind(s)))
        })?;
        let i = scene.surface_index(name).ok_or_else(|| {
            AppError::Invalid(format!(
                "unknown surface '{}' (known: {})",
                shorten(name),
                shorten(
                    &scene
                        .surfaces
                        .iter()
                        .map(|s| s.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            ))
        })?;
        if out.contains(&i) {
            return Err(AppError::Invalid(format!(
                "surface '{name}' is listed twice in 'surfaces'"
            )));
        }
        out.push(i);
    }
    Ok(out)
}

pub use crate::model::error::shorten;

/// An optional boolean field (absent = false).
pub(crate) fn flag(body: &Map<String, Value>, key: &str) -> Result<bool, AppError> {
    match body.get(key) {
        None => Ok(false),
        Some(Value::Bool(b)) => Ok(*b),
        Some(v) => Err(AppError::Invalid(format!(
            "'{key}' must be true or false, got {}",
            shown(v)
        ))),
    }
}

/// The common start of a POST handler: the ready scene and the parsed body, whose
/// top-level fields must be among `allowed`.
pub async fn begin(
    state: &Arc<AppState>,
    id: &str,
    headers: &HeaderMap,
    body: Result<Bytes, BytesRejection>,
    allowed: &[&str],
) -> Result<(Arc<Ready>, Map<String, Value>), AppError> {
    let ready = state.slot(id)?.ready()?;
    let body = parse_body(state, headers, body).await?;
    check_keys(&body, allowed)?;
    Ok((ready, body))
}

pub(crate) fn parse_points(v: &Value) -> Result<Vec<(DVec3, DVec3)>, AppError> {
    let arr = v
        .as_array()
        .ok_or_else(|| AppError::Invalid(format!("'points' must be an array, got {}", kind(v))))?;
    if arr.len() > MAX_POINTS {
        return Err(AppError::Invalid(format!(
            "{} points requested; the limit is {MAX_POINTS} per request",
            arr.len()
        )));
    }
    arr.iter()
        .enumerate()
        .map(|(k, p)| {
            let o = p.as_object().ok_or_else(|| {
                AppError::Invalid(format!(
                    "points[{k}] must be {{\"position\": [x,y,z], \"normal\": [x,y,z]}}"
                ))
            })?;
            for key in o.keys() {
                if key != "position" && key != "normal" {
                    return Err(AppError::Invalid(format!(
                        "points[{k}]: unknown field '{key}'"
                    )));
                }
            }
            let pos = bounded_triple(
                o.get("position").unwrap_or(&Value::Null),
                &format!("points[{k}].position"),
                MAX_COORDINATE,
            )?;
            let n = direction(
                o.get("normal").unwrap_or(&Value::Null),
                &format!("points[{k}].normal"),
            )?;
            Ok((DVec3::from_array(pos), n))
        })
        .collect()
}

/// Grid indices from a list of grid ids.
pub(crate) fn grid_list(v: Option<&Value>, ready: &Ready) -> Result<Vec<usize>, AppError> {
    let Some(v) = v else { return Ok(vec![]) };
    let arr = v.as_array().ok_or_else(|| {
        AppError::Invalid(format!(
            "'grids' must be an array of grid ids, got {}",
            kind(v)
        ))
    })?;
    let mut out = Vec::with_capacity(arr.len().min(ready.grids.len()));
    for g in arr {
        let i = grid_index(g, ready)?;
        if out.contains(&i) {
            return Err(AppError::Invalid(format!(
                "grid '{}' is listed twice in 'grids'",
                ready.grids[i].grid.id
            )));
        }
        out.push(i);
    }
    Ok(out)
}

/// The index of the grid named by `g` (a string id).
pub(crate) fn grid_index(g: &Value, ready: &Ready) -> Result<usize, AppError> {
    let id = g
        .as_str()
        .ok_or_else(|| AppError::Invalid(format!("grid ids must be strings, got {}", kind(g))))?;
    Ok(ready.grid_index(id)?)
}
