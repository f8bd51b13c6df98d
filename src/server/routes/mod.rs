//! The routes, one file per resource. Handlers parse the request ([`super::parse`]), ask
//! the scene's [`crate::model::Model`], and shape the answer; they compute nothing
//! themselves. Work that scales with the input runs through [`super::AppState::heavy`].

use axum::http::{header, HeaderMap};
use axum::response::{IntoResponse, Response};

use super::AppError;

pub(crate) mod annual;
pub(crate) mod batch;
pub(crate) mod daylight;
pub(crate) mod export;
pub(crate) mod illuminance;
pub(crate) mod optimize;
pub(crate) mod radiosity;
pub(crate) mod render;
pub(crate) mod scenes;
pub(crate) mod service;
pub(crate) mod upload;

pub(crate) type ApiResult = Result<Response, AppError>;

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
