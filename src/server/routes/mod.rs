//! The routes, one file per resource. Handlers parse the request ([`super::parse`]), ask
//! the scene's [`crate::model::Model`], and shape the answer; they compute nothing
//! themselves. Work that scales with the input runs through [`super::AppState::heavy`].

use axum::http::{header, HeaderMap};
use axum::response::{IntoResponse, Response};

use super::AppError;

pub mod batch;
pub mod illuminance;
pub mod optimize;
pub mod radiosity;
pub mod render;
pub mod scenes;
pub mod service;

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
