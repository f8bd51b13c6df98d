//! The routes, one file per resource. Handlers take the ready scene (with the server
//! state) and the typed request ([`super::parse::ReadyScene`], [`super::parse::StrictJson`],
//! or both at once for a POST on a scene, [`super::parse::ScenePost`]), ask the scene's
//! [`crate::model::Model`], and shape the answer; they compute nothing themselves. Work
//! that scales with the input runs through [`super::AppState::heavy`].

use std::fmt::Display;
use std::time::Instant;

use axum::http::{header, HeaderMap, HeaderName};
use axum::response::{IntoResponse, Response};

use crate::model::query::IlluminanceQuery;
use crate::model::Model;

pub(crate) mod annual;
pub(crate) mod batch;
pub(crate) mod daylight;
pub(crate) mod export;
pub(crate) mod glare;
pub(crate) mod illuminance;
pub(crate) mod optimize;
pub(crate) mod radiosity;
pub(crate) mod render;
pub(crate) mod report;
pub(crate) mod scenes;
pub(crate) mod service;
pub(crate) mod upload;

pub(crate) fn wants_binary(headers: &HeaderMap) -> bool {
    headers
        .get(header::ACCEPT)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|a| a.contains("application/octet-stream"))
}

pub(crate) fn binary(floats: Vec<f32>, n: usize, layout: &'static str) -> Response {
    let bytes: Vec<u8> = bytemuck::cast_slice(&floats).to_vec();
    (
        [
            (header::CONTENT_TYPE, "application/octet-stream".to_string()),
            (
                header::HeaderName::from_static("x-relight-patches"),
                n.to_string(),
            ),
            (
                header::HeaderName::from_static("x-relight-layout"),
                layout.to_string(),
            ),
        ],
        bytes,
    )
        .into_response()
}

/// The points on `grids`.
pub(crate) fn grid_points(model: &Model, grids: &[usize]) -> usize {
    grids.iter().map(|&g| model.grids[g].len()).sum()
}

/// What a point query is, for refusals: "`what` at n points and m grid points".
pub(crate) fn at_points(what: &str, model: &Model, q: &IlluminanceQuery) -> String {
    format!(
        "{what} at {} points and {} grid points",
        q.points.len(),
        grid_points(model, &q.grids)
    )
}

/// Sets header `name` to `value`'s text, unless that is not a valid header value.
pub(crate) fn put(resp: &mut Response, name: HeaderName, value: impl Display) {
    if let Ok(v) = value.to_string().parse() {
        resp.headers_mut().insert(name, v);
    }
}

/// An answer made on request and not to be cached (an image, an export): its bytes, the
/// server time since `t0` in header `timing` (ms) and the exposure used, if any.
pub(crate) fn made(
    content_type: &str,
    bytes: Vec<u8>,
    (timing, t0): (&'static str, Instant),
    exposure: Option<f32>,
) -> Response {
    let mut resp = (
        [
            (header::CONTENT_TYPE, content_type.to_string()),
            (header::CACHE_CONTROL, "no-store".to_string()),
        ],
        bytes,
    )
        .into_response();
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    put(
        &mut resp,
        HeaderName::from_static(timing),
        format!("{ms:.3}"),
    );
    if let Some(ev) = exposure {
        let name = HeaderName::from_static("x-relight-exposure");
        put(&mut resp, name, format!("{ev:.3}"));
    }
    resp
}
