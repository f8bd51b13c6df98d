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
use crate::model::sky_state::SkyState;
use crate::model::{Cancel, Lighting};
use crate::render::daylight::{daylight_pixels, DaylightScene, SunView};
use crate::render::pipeline::{self, Frame, Quality, RenderOptions};
use crate::render::ViewBuffer;
use crate::server::openapi::{PostErrors, QueryErrors, RenderImage, RenderPng, SceneIdParam};
use crate::server::parse::{ReadyScene, ScenePost};
use crate::server::requests::render::RenderQuery;
use crate::server::requests::RenderRequest;
use crate::server::views::{render_estimate, view_for};
use crate::server::{AppError, AppState, Ready};

/// Renders and encodes through the view cache.
pub(super) fn render_image(
    state: &AppState,
    ready: &Ready,
    lighting: &Lighting,
    sky: Option<&SkyState>,
    o: &RenderOptions,
    cancel: &Cancel,
) -> Result<pipeline::Rendered, AppError> {
    let entry = view_for(state, ready, &o.camera);
    let finals = if o.quality == Quality::Final && !o.falsecolor {
        pipeline::needs_groups(lighting)?;
        let f = entry.final_images(ready, &o.camera, &state.config.final_settings, cancel)?;
        // The entry grew by its final images: keep the cache within bounds.
        super::super::views::trim(state);
        Some(f)
    } else {
        None
    };
    if let Some(sky) = sky {
        let daylight = match &finals {
            Some(_) => {
                let d = entry.final_daylight(
                    ready,
                    &o.camera,
                    sky,
                    &state.config.final_settings,
                    cancel,
                )?;
                super::super::views::trim(state);
                Some(d)
            }
            None => None,
        };
        let finals = finals.as_deref().zip(daylight.as_deref());
        return render_under_sky(ready, &entry, lighting, sky, finals, o);
    }
    if let Some(f) = &finals {
        let frame = Frame {
            view: &entry.buffer,
            groups: Some(f),
            shading: ready.shading(),
        };
        return pipeline::render(&ready.model, frame, lighting, o).map_err(AppError::from);
    }
    let groups = match lighting {
        Lighting::Groups(_) if !o.falsecolor => {
            let g = entry.group_images(ready);
            // The entry may have grown by its group images: keep the cache within bounds.
            super::super::views::trim(state);
            g
        }
        _ => None,
    };
    let frame = Frame {
        view: &entry.buffer,
        groups,
        shading: ready.shading(),
    };
    pipeline::render(&ready.model, frame, lighting, o).map_err(AppError::from)
}

/// [`render_image`] under a sky. At `fast` quality the daylight is the patches' plus the
/// sun traced per pixel (with shadows) and the sky seen out of the scene, and the light
/// groups the patches'. At `final` quality, `finals` holds the groups' images and the
/// daylight's (the sun traced, the sky and the interreflection gathered per pixel).
fn render_under_sky(
    ready: &Ready,
    entry: &crate::server::views::View,
    lighting: &Lighting,
    sky: &SkyState,
    finals: Option<(&crate::render::GroupImages, &crate::render::GroupImages)>,
    o: &RenderOptions,
) -> Result<pipeline::Rendered, AppError> {
    if let (Some((f, day)), Lighting::Groups(w)) = (finals, lighting) {
        // Final quality: the groups' images and the daylight's, nothing from the patches.
        let mut rad = day.linear(&[crate::color::Rgb::ONE]);
        for (r, g) in rad.iter_mut().zip(f.linear(w)) {
            *r += g;
        }
        return pipeline::render_radiance(&rad, o).map_err(AppError::from);
    }
    let m = &ready.model;
    let day = m.patch_daylight_without_sun(sky)?;
    let (mut b, mut h) = (day.b, day.h);
    if let Lighting::Groups(w) = lighting {
        let t = &m.baked.transfer;
        let mut more = vec![0f32; b.len()];
        t.relight_into(w, &mut more);
        b.iter_mut().zip(&more).for_each(|(a, x)| *a += x);
        t.illuminance_into(w, &mut more);
        h.iter_mut().zip(&more).for_each(|(a, x)| *a += x);
    }
    let site = m.site()?;
    let sun = sky
        .sun_direction(site)
        .map(|(direction, normal_illuminance)| SunView {
            direction,
            normal_illuminance,
        });
    let scene = DaylightScene {
        mesh: &m.baked.mesh,
        bvh: &m.baked.bvh,
        glazing: &m.baked.glazing,
        rho: &m.baked.transfer.rho,
        reach: m.reach_length(),
    };
    let (rad, lux) = daylight_pixels(&scene, &entry.buffer, &o.camera, sun, &|d| {
        sky.luminance(site, d)
    });
    let frame = Frame {
        view: &entry.buffer,
        groups: None,
        shading: ready.shading(),
    };
    pipeline::render_values(frame, &b, &h, (&rad, &lux), o).map_err(AppError::from)
}

async fn respond(
    state: Arc<AppState>,
    ready: Arc<Ready>,
    lighting: Lighting,
    sky: Option<SkyState>,
    o: RenderOptions,
) -> Result<Response, AppError> {
    let t0 = Instant::now();
    let format = o.format;
    let mut bytes = render_estimate(&state, &ready, &o);
    if sky.is_some() {
        // Per-pixel daylight (two RGB images) and per-patch daylight (b, h and a column).
        let px = o.camera.width as u64 * o.camera.height as u64;
        bytes += 24 * px + 36 * ready.model.patches() as u64;
        if o.quality == Quality::Final && !o.falsecolor {
            // The daylight's own `final` image, built per sky.
            bytes +=
                crate::render::final_gather::estimate_bytes(&o.camera, 1, ready.gather_points());
        }
    }
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
    let lighting = req.lighting(&ready.model)?;
    let sky = req.sky(&ready.model)?;
    let o = req.options(&ready.model)?;
    respond(state, ready, lighting, sky, o).await
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
    let req = RenderRequest::from_query(&q)?;
    let lighting = req.lighting(&ready.model)?;
    let o = req.options(&ready.model)?;
    respond(state, ready, lighting, None, o).await
}
