//! `AppError`: every failure of a request, rendered as an RFC 9457 problem document
//! (`application/problem+json`) with a precise `detail`.

use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::Serialize;
use utoipa::openapi::schema::Schema;
use utoipa::openapi::RefOr;
use utoipa::ToSchema;

#[derive(Debug, thiserror::Error)]
pub enum AppError {
    /// 400: the body is not valid JSON (or a query string is malformed).
    #[error("{0}")]
    BadRequest(String),
    /// 401: a write without the admin token, or with a wrong one.
    #[error("{0}")]
    Unauthorized(String),
    /// 403: writes are disabled (no admin token configured, or a read-only server).
    #[error("{0}")]
    Forbidden(String),
    /// 409: the write conflicts with the scene's state (bundled, or baking).
    #[error("{0}")]
    Conflict(String),
    /// 404: unknown scene or route.
    #[error("{0}")]
    NotFound(String),
    /// 413: the body exceeds the limit.
    #[error("{0}")]
    TooLarge(String),
    /// 415: wrong content type.
    #[error("{0}")]
    UnsupportedMediaType(String),
    /// 422: well-formed JSON with invalid content (unknown light, wrong length, NaN…).
    #[error("{0}")]
    Invalid(String),
    /// 503: the scene is still baking (with progress) or failed to load.
    #[error("{detail}")]
    Unavailable {
        detail: String,
        progress: Option<f64>,
    },
    /// 500: a bug. Never produced by bad input.
    #[error("{0}")]
    Internal(String),
}

impl AppError {
    pub fn status(&self) -> StatusCode {
        match self {
            AppError::BadRequest(_) => StatusCode::BAD_REQUEST,
            AppError::NotFound(_) => StatusCode::NOT_FOUND,
            AppError::Unauthorized(_) => StatusCode::UNAUTHORIZED,
            AppError::Forbidden(_) => StatusCode::FORBIDDEN,
            AppError::Conflict(_) => StatusCode::CONFLICT,
            AppError::TooLarge(_) => StatusCode::PAYLOAD_TOO_LARGE,
            AppError::UnsupportedMediaType(_) => StatusCode::UNSUPPORTED_MEDIA_TYPE,
            AppError::Invalid(_) => StatusCode::UNPROCESSABLE_ENTITY,
            AppError::Unavailable { .. } => StatusCode::SERVICE_UNAVAILABLE,
            AppError::Internal(_) => StatusCode::INTERNAL_SERVER_ERROR,
        }
    }
}

impl From<crate::model::lighting::LightError> for AppError {
    fn from(e: crate::model::lighting::LightError) -> Self {
        AppError::Invalid(e.to_string())
    }
}

/// A query's mistakes are the client's (422); an abandoned one is 503.
/// A render's failure: its query's error, or an encoder's (500).
impl From<crate::render::pipeline::RenderError> for AppError {
    fn from(e: crate::render::pipeline::RenderError) -> AppError {
        use crate::render::pipeline::RenderError;
        match e {
            RenderError::Query(q) => q.into(),
            RenderError::Encode(m) => AppError::Internal(m),
        }
    }
}

impl From<crate::model::QueryError> for AppError {
    fn from(e: crate::model::QueryError) -> Self {
        match e {
            crate::model::QueryError::Cancelled => AppError::Unavailable {
                detail: e.to_string(),
                progress: None,
            },
            e => AppError::Invalid(e.to_string()),
        }
    }
}

/// RFC 9457 problem document.
#[derive(Serialize, ToSchema)]
pub(crate) struct ProblemDetails {
    #[schema(schema_with = about_blank)]
    r#type: &'static str,
    title: &'static str,
    #[schema(minimum = 400, maximum = 599)]
    status: u16,
    detail: String,
    /// 503 while a scene bakes: its progress.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schema(nullable = false, minimum = 0, maximum = 1)]
    progress: Option<f64>,
}

fn about_blank() -> RefOr<Schema> {
    crate::schema::words(&["about:blank"])
}

impl IntoResponse for AppError {
    fn into_response(self) -> Response {
        let status = self.status();
        if status.is_server_error() && status != StatusCode::SERVICE_UNAVAILABLE {
            tracing::error!("internal error: {self}");
        }
        let progress = match &self {
            AppError::Unavailable { progress, .. } => *progress,
            _ => None,
        };
        let body = ProblemDetails {
            r#type: "about:blank",
            title: status.canonical_reason().unwrap_or("Error"),
            status: status.as_u16(),
            detail: self.to_string(),
            progress,
        };
        let mut resp = (status, Json(body)).into_response();
        resp.headers_mut().insert(
            header::CONTENT_TYPE,
            header::HeaderValue::from_static("application/problem+json"),
        );
        if status == StatusCode::UNAUTHORIZED {
            resp.headers_mut().insert(
                header::WWW_AUTHENTICATE,
                header::HeaderValue::from_static("Bearer realm=\"relight\""),
            );
        }
        if status == StatusCode::SERVICE_UNAVAILABLE {
            resp.headers_mut()
                .insert(header::RETRY_AFTER, header::HeaderValue::from_static("2"));
        }
        resp
    }
}
