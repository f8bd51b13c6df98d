//! `POST /api/scenes/{id}/radiosity`: per-patch radiosity B (lm/m², leaving) or incident
//! illuminance H (lux, arriving) for a lighting state, as JSON or binary f32, with
//! optional per-surface averages.

use std::collections::BTreeMap;

use axum::http::{header, HeaderMap};
use axum::response::{IntoResponse, Response};
use serde_json::Value;
use utoipa::openapi::schema::Schema;
use utoipa::openapi::RefOr;
use utoipa::ToSchema;

use super::{binary, wants_binary};
use crate::model::query::{Quantity, BYTES_PER_PATCH_ANSWER};
use crate::model::report::{surface_averages, SurfaceAverage};
use crate::model::Lighting;
use crate::schema::{words, Rgb};
use crate::server::openapi::{PostErrors, RadiosityAnswer, SceneIdParam};
use crate::server::parse::ScenePost;
use crate::server::requests::radiosity::RadiosityAsk;
use crate::server::requests::{RadiosityRequest, Resolve};
use crate::server::AppError;

fn radiosity_unit() -> RefOr<Schema> {
    words(&["lm/m2", "lx"])
}

// Only describes the answer: `radiosity_text` writes it by hand (tests check the two
// agree).
/// Per-patch radiosity (or incident illuminance), with per-surface averages on request.
#[derive(ToSchema)]
#[allow(dead_code)]
pub(crate) struct RadiosityResponse {
    scene: String,
    /// Number of patches.
    patches: usize,
    #[schema(schema_with = radiosity_unit)]
    unit: &'static str,
    /// quantity = radiosity: B per patch, lm/m².
    #[schema(nullable = false, value_type = Option<Vec<Rgb>>)]
    radiosity: Option<Vec<crate::color::Rgb>>,
    /// quantity = illuminance: H per patch, lx.
    #[schema(nullable = false, value_type = Option<Vec<Rgb>>)]
    illuminance: Option<Vec<crate::color::Rgb>>,
    /// With surfaces = true: by surface id.
    #[schema(nullable = false, inline)]
    surfaces: Option<BTreeMap<String, SurfaceAverage>>,
}

#[utoipa::path(post, path = "/api/scenes/{id}/radiosity", operation_id = "radiosity", tags = ["scenes"],
    summary = "Per-patch radiosity for a lighting state (group settings, or a per-patch emission in factored mode), with daylight added for a `sky`.",
    params(SceneIdParam),
    request_body(content = RadiosityRequest, content_type = "application/json",
        description = "An empty body is the default lighting state.",
        example = json!({"lights": {"ceiling": 0.5}, "surfaces": true})),
    responses(RadiosityAnswer, PostErrors))]
pub(crate) async fn radiosity(
    headers: HeaderMap,
    ScenePost(ready, state, req): ScenePost<RadiosityRequest>,
) -> Result<Response, AppError> {
    let RadiosityAsk {
        lighting,
        sky,
        surfaces: want_surfaces,
        quantity,
    } = req.resolve(&ready.model)?;
    let (key, unit, layout) = match quantity {
        Quantity::Illuminance => (
            "illuminance",
            "lx",
            "f32 LE [patch][r,g,b] incident illuminance, lx",
        ),
        Quantity::Radiosity => (
            "radiosity",
            "lm/m2",
            "f32 LE [patch][r,g,b] radiosity, lm/m2",
        ),
    };
    let n = ready.model.patches();
    let binary_out = wants_binary(&headers);
    // The hot path: group weights and binary out, no surfaces, no sky: one weighted sum (a
    // memory stream of n × groups floats), answered inline.
    if let (Lighting::Groups(w), true, false, None) = (&lighting, binary_out, want_surfaces, &sky) {
        let mut out = vec![0f32; 3 * n];
        ready.model.per_patch_groups(w, quantity, &mut out);
        return Ok(binary(out, n, layout));
    }
    // Everything else (exact solves, JSON text of n triples) runs off the runtime.
    let bytes = BYTES_PER_PATCH_ANSWER * n as u64;
    let what = format!("the radiosity answer for {n} patches");
    state
        .heavy(bytes, &what, move |_| {
            let m = &ready.model;
            let sol = m.solve_daylit(&lighting, sky.as_ref())?;
            let b = &m.baked;
            let surfaces = want_surfaces.then(|| surface_averages(&b.scene, &b.mesh, &sol));
            let values = match quantity {
                Quantity::Illuminance => sol.h,
                Quantity::Radiosity => sol.b,
            };
            if binary_out {
                return Ok(binary(values, n, layout));
            }
            Ok(radiosity_json(&b.scene.id, unit, key, &values, surfaces))
        })
        .await
}

/// Written by hand: the float array dominates, and ryu into one buffer is ~2x faster
/// than going through serde for 30,000 numbers.
fn radiosity_json(
    scene: &str,
    unit: &str,
    key: &str,
    values: &[f32],
    surfaces: Option<BTreeMap<String, SurfaceAverage>>,
) -> Response {
    match radiosity_text(scene, unit, key, values, surfaces) {
        Ok(text) => ([(header::CONTENT_TYPE, "application/json")], text).into_response(),
        Err(e) => AppError::Internal(e.to_string()).into_response(),
    }
}

/// The text of a [`RadiosityResponse`].
fn radiosity_text(
    scene: &str,
    unit: &str,
    key: &str,
    values: &[f32],
    surfaces: Option<BTreeMap<String, SurfaceAverage>>,
) -> serde_json::Result<String> {
    let n = values.len() / 3;
    let mut out = String::with_capacity(40 * n + 256);
    out.push_str(&format!(
        "{{\"scene\":{},\"patches\":{n},\"unit\":\"{unit}\",\"{key}\":[",
        Value::from(scene)
    ));
    let mut fb = ryu::Buffer::new();
    for (i, t) in values.chunks_exact(3).enumerate() {
        if i > 0 {
            out.push(',');
        }
        out.push('[');
        for (c, v) in t.iter().enumerate() {
            if c > 0 {
                out.push(',');
            }
            out.push_str(if v.is_finite() {
                fb.format_finite(*v)
            } else {
                "null"
            });
        }
        out.push(']');
    }
    out.push(']');
    if let Some(s) = surfaces {
        out.push_str(",\"surfaces\":");
        out.push_str(&serde_json::to_string(&s)?);
    }
    out.push('}');
    Ok(out)
}
