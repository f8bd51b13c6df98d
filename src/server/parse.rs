//! Request reading. The extractors of the handlers: the scene id of the path
//! ([`SceneId`]), its ready scene ([`ReadyScene`]) and the JSON body (size, content type,
//! strictness, off the runtime when large) as a typed request ([`StrictJson`] of a
//! [`super::requests`] type), or the two together for a POST on a scene
//! ([`ScenePost`]). Then the checks that follow deserialization: numbers in the
//! f32 range and limits the engine computes with, directions, and lists of ids (each id at
//! most once). Every mistake becomes a precise 422 naming the field.

use std::sync::Arc;

use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::{FromRequest, FromRequestParts, Path, Request};
use axum::http::request::Parts;
use axum::http::{HeaderMap, StatusCode};
use glam::DVec3;
use serde::de::DeserializeOwned;

use super::{AppError, AppState, Ready};
pub(crate) use crate::model::error::shorten;
use crate::model::Model;

/// Bodies above this size are parsed on the blocking pool, under the memory budget.
pub const INLINE_PARSE_BYTES: usize = 64 << 10;

/// Bytes held while parsing, per byte of JSON text, at most: the keys of the object
/// being checked, then the typed request (arrays of small numbers are the worst case).
const PARSED_BYTES_PER_BYTE: u64 = 12;

/// The `{id}` of a scene route. A path segment that is not valid UTF-8 (or otherwise
/// unreadable) names no scene: 404 as a problem document, like any unknown scene.
pub(crate) struct SceneId(pub String);

impl<S: Send + Sync> FromRequestParts<S> for SceneId {
    type Rejection = AppError;

    async fn from_request_parts(parts: &mut Parts, state: &S) -> Result<Self, Self::Rejection> {
        match Path::<String>::from_request_parts(parts, state).await {
            Ok(Path(id)) => Ok(SceneId(id)),
            Err(e) => Err(AppError::NotFound(format!(
                "no such scene: the scene id in the path is not readable ({})",
                shorten(&e.body_text())
            ))),
        }
    }
}

/// The ready scene of a `{id}` route, and the server state: 404 for an unknown scene,
/// 503 while it is queued or baking or when it failed. A POST handler takes it before its
/// body, so these answers come before any about the body.
pub(crate) struct ReadyScene(pub Arc<Ready>, pub Arc<AppState>);

impl FromRequestParts<Arc<AppState>> for ReadyScene {
    type Rejection = AppError;

    async fn from_request_parts(
        parts: &mut Parts,
        state: &Arc<AppState>,
    ) -> Result<Self, Self::Rejection> {
        let SceneId(id) = SceneId::from_request_parts(parts, state).await?;
        Ok(ReadyScene(state.slot(&id)?.ready()?, state.clone()))
    }
}

/// A JSON object body parsed strictly into `T` ([`parse_body`]); the last argument of a
/// handler.
pub(crate) struct StrictJson<T>(pub T);

impl<T: DeserializeOwned + Send + 'static> FromRequest<Arc<AppState>> for StrictJson<T> {
    type Rejection = AppError;

    async fn from_request(req: Request, state: &Arc<AppState>) -> Result<Self, Self::Rejection> {
        let headers = req.headers().clone();
        let body = Bytes::from_request(req, state).await;
        parse_body(state, &headers, body).await.map(StrictJson)
    }
}

/// A POST on a ready scene: the scene ([`ReadyScene`], taken first, so its 404 and 503
/// come before any answer about the body), the server state and the body parsed strictly
/// ([`StrictJson`]); the last argument of a handler.
pub(crate) struct ScenePost<T>(pub Arc<Ready>, pub Arc<AppState>, pub T);

impl<T: DeserializeOwned + Send + 'static> FromRequest<Arc<AppState>> for ScenePost<T> {
    type Rejection = AppError;

    async fn from_request(req: Request, state: &Arc<AppState>) -> Result<Self, Self::Rejection> {
        let (mut parts, body) = req.into_parts();
        let ReadyScene(ready, _) = ReadyScene::from_request_parts(&mut parts, state).await?;
        let request = Request::from_parts(parts, body);
        let StrictJson(body) = StrictJson::from_request(request, state).await?;
        Ok(ScenePost(ready, state.clone(), body))
    }
}

/// Parses a JSON object body into `T`: 413 for size, 415 for a content type that is not
/// JSON, 400 for syntax, 422 for a non-object, a repeated key or content that `T` refuses.
/// An empty body is `{}`. Large bodies are parsed off the async runtime.
async fn parse_body<T: DeserializeOwned + Send + 'static>(
    state: &Arc<AppState>,
    headers: &HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> Result<T, AppError> {
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
        return super::json::decode(b"{}");
    }
    super::json::require_json(headers)?;
    if body.len() <= INLINE_PARSE_BYTES {
        return super::json::parse(&body);
    }
    let what = format!(
        "parsing a {} request body",
        crate::budget::human_bytes(body.len() as u64)
    );
    state
        .heavy(
            PARSED_BYTES_PER_BYTE * body.len() as u64,
            &what,
            move |_| super::json::parse(&body),
        )
        .await
}

/// A number the engine computes with in f32: anything beyond its range would become
/// infinite.
pub(crate) fn number(x: f64, what: &str) -> Result<f64, AppError> {
    if !x.is_finite() || x.abs() > f32::MAX as f64 {
        return Err(AppError::Invalid(format!(
            "{what} must be finite in 32-bit floating point (|x| ≤ 3.4e38), got {}",
            num(x)
        )));
    }
    Ok(x)
}

/// A number for a message: plain when moderate, else in exponent form.
pub(crate) fn num(x: f64) -> String {
    if x == 0.0 || (1e-4..1e7).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A number in `[lo, hi]` (both finite, within f32 range).
pub(crate) fn bounded(x: f64, what: &str, lo: f64, hi: f64) -> Result<f64, AppError> {
    let x = number(x, what)?;
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
pub(crate) fn bounded_triple(t: [f64; 3], what: &str, limit: f64) -> Result<[f64; 3], AppError> {
    for x in t {
        number(x, what)?;
    }
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
pub(crate) fn direction(t: [f64; 3], what: &str) -> Result<DVec3, AppError> {
    for x in t {
        number(x, what)?;
    }
    let d = DVec3::from_array(t);
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

/// Indices of `names` by `index`, each at most once: `twice` says what a repeat is.
fn unique(
    names: &[String],
    index: impl Fn(&str) -> Result<usize, AppError>,
    twice: impl Fn(&str) -> String,
) -> Result<Vec<usize>, AppError> {
    let mut out: Vec<usize> = Vec::with_capacity(names.len().min(1024));
    for name in names {
        let i = index(name)?;
        if out.contains(&i) {
            return Err(AppError::Invalid(twice(name)));
        }
        out.push(i);
    }
    Ok(out)
}

/// Surface indices from surface names (each once).
pub(crate) fn surface_list(names: &[String], model: &Model) -> Result<Vec<usize>, AppError> {
    let scene = &model.baked.scene;
    let index = |name: &str| {
        scene.surface_index(name).ok_or_else(|| {
            let known: Vec<&str> = scene.surfaces.iter().map(|s| s.name.as_str()).collect();
            AppError::Invalid(format!(
                "unknown surface '{}' (known: {})",
                shorten(name),
                shorten(&known.join(", "))
            ))
        })
    };
    unique(names, index, |name| {
        format!("surface '{name}' is listed twice in 'surfaces'")
    })
}

/// Grid indices from grid ids (each once).
pub(crate) fn grid_list(ids: &[String], model: &Model) -> Result<Vec<usize>, AppError> {
    unique(
        ids,
        |id| Ok(model.grid_index(id)?),
        |id| format!("grid '{id}' is listed twice in 'grids'"),
    )
}

/// Light group indices from group ids (each once).
pub(crate) fn group_list(ids: &[String], model: &Model) -> Result<Vec<usize>, AppError> {
    let scene = &model.baked.scene;
    let index = |id: &str| {
        scene.light_index(id).ok_or_else(|| {
            AppError::Invalid(format!(
                "unknown light group '{}' (known: {})",
                shorten(id),
                crate::model::lighting::known_ids(scene)
            ))
        })
    };
    unique(ids, index, |id| {
        format!("light group '{id}' is listed twice in 'groups'")
    })
}
