//! `POST /api/scenes/{id}/render` and `GET /api/scenes/{id}/render.png`: relit images
//! through [`crate::render::pipeline`], with views from the server's cache
//! ([`super::super::views`]). All of it runs on the blocking pool.

use std::sync::Arc;
use std::time::Instant;

use axum::extract::Query;
use axum::http::HeaderName;
use axum::response::Response;

use super::{made, put};
use crate::budget::human_bytes;
use crate::color::Rgb;
use crate::model::sky_state::SkyState;
use crate::model::{Cancel, Lighting};
use crate::render::pipeline::{self, Daylit, Frame, RenderOptions};
use crate::render::ViewBuffer;
use crate::server::openapi::{PostErrors, QueryErrors, RenderImage, RenderPng, SceneIdParam};
use crate::server::parse::{ReadyScene, ScenePost};
use crate::server::requests::render::{RenderAsk, RenderQuery};
use crate::server::requests::{RenderRequest, Resolve};
use crate::server::views::{self, render_estimate, view_for};
use crate::server::{AppError, AppState, Ready};

/// Renders and encodes through the view cache, under `sky` when given: the view and its
/// images come from the cache (built there when missing), the image from
/// [`pipeline::render`] or [`pipeline::render_daylit`].
pub(super) fn render_image(
    state: &AppState,
    ready: &Ready,
    lighting: &Lighting,
    sky: Option<&SkyState>,
    o: &RenderOptions,
    cancel: &Cancel,
) -> Result<pipeline::Rendered, AppError> {
    let entry = view_for(state, ready, &o.camera);
    let settings = &state.config.final_settings;
    let (mut finals, mut daylight) = (None, None);
    let state_weight = Lighting::Groups(vec![Rgb::ONE]);
    let mut lighting = lighting;
    if pipeline::wants_finals(o) {
        finals = Some(if let Lighting::Groups(_) = lighting {
            entry.final_images(ready, &o.camera, settings, cancel)?
        } else {
            // One image for this state, at unit weight.
            let image = entry.final_state(ready, &o.camera, lighting, settings, cancel)?;
            lighting = &state_weight;
            image
        });
        if let Some(sky) = sky {
            daylight = Some(entry.final_daylight(ready, &o.camera, sky, settings, cancel)?);
        }
        // The entry grew by its final images: keep the cache within bounds.
        views::trim(state);
    }
    let groups = match (&finals, sky, lighting) {
        (Some(f), _, _) => Some(&**f),
        // Under a sky, the patches' light groups; else per-group images when worth it.
        (None, None, Lighting::Groups(_)) if !o.falsecolor => {
            let g = entry.group_images(ready);
            // The entry may have grown by its group images: keep the cache within bounds.
            views::trim(state);
            g
        }
        _ => None,
    };
    let frame = Frame {
        view: &entry.buffer,
        groups,
        shading: ready.shading(),
    };
    let m = &ready.model;
    Ok(match sky {
        Some(sky) => {
            let final_image = daylight.as_deref();
            pipeline::render_daylit(m, frame, lighting, Daylit { sky, final_image }, o)
        }
        None => pipeline::render(m, frame, lighting, o),
    }?)
}

async fn respond(
    state: Arc<AppState>,
    ready: Arc<Ready>,
    ask: RenderAsk,
) -> Result<Response, AppError> {
    let RenderAsk {
        lighting,
        sky,
        options: o,
    } = ask;
    let t0 = Instant::now();
    let format = o.format;
    let bytes = render_estimate(&state, &ready, &o, &lighting, sky.is_some());
    let what = format!(
        "a {}×{} render (view buffer up to {})",
        o.camera.width,
        o.camera.height,
        human_bytes(ViewBuffer::estimate_bytes(&o.camera))
    );
    let st = state.clone();
    let r = state
        .heavy(bytes, &what, move |cancel| {
            render_image(&st, &ready, &lighting, sky.as_ref(), &o, cancel)
        })
        .await?;
    let timing = ("x-relight-render-ms", t0);
    let mut resp = made(format.content_type(), r.bytes, timing, r.exposure);
    if let Some((lo, hi)) = r.range {
        let name = HeaderName::from_static("x-relight-falsecolor-lux");
        put(&mut resp, name, format!("{lo},{hi}"));
    }
    Ok(resp)
}

#[utoipa::path(post, path = "/api/scenes/{id}/render", operation_id = "render", tags = ["scenes"],
    summary = "A relit image from a camera preset or a full camera; with `sky`, daylight is added (the sun traced per pixel, the sky seen through openings).",
    params(SceneIdParam),
    request_body(content = RenderRequest, content_type = "application/json",
        description = "An empty body is a 512×512 PNG from the first camera preset in the default lighting state.",
        example = json!({"camera": "front", "width": 256, "height": 256, "lights": {"ceiling": 0.5}, "format": "png"})),
    responses(RenderImage, PostErrors))]
pub(crate) async fn render_post(
    ScenePost(ready, state, req): ScenePost<RenderRequest>,
) -> Result<Response, AppError> {
    let ask = req.resolve(&ready.model)?;
    respond(state, ready, ask).await
}

/// `GET …/render.png?camera=front&w=512&h=512&light.ceiling=0.5&exposure=0&mode=falsecolor`
#[utoipa::path(get, path = "/api/scenes/{id}/render.png", operation_id = "renderPng", tags = ["scenes"],
    summary = "A relit PNG for quick use from a browser or curl, e.g. ?camera=front&w=512&h=512&light.ceiling=0.5. Besides the parameters below it takes `width`/`height` (aliases of w/h) and `light.<group>=<intensity>` or `light.<group>=r,g,b` (intensity 1 at that colour) for each light group. A parameter given twice, an unknown parameter or a value that is not a number where one is expected is a 400; values out of range, unknown cameras and light groups are 422s.",
    params(SceneIdParam, RenderQuery),
    responses(RenderPng, QueryErrors))]
pub(crate) async fn render_get(
    ReadyScene(ready, state): ReadyScene,
    Query(q): Query<Vec<(String, String)>>,
) -> Result<Response, AppError> {
    let ask = RenderRequest::from_query(&q)?.resolve(&ready.model)?;
    respond(state, ready, ask).await
}
