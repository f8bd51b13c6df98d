//! `GET` and `POST /api/scenes/{id}/report`: the printable design report
//! ([`crate::model::design_report`]) of a lighting state given as `render.png` takes it,
//! with a relit image per camera. All of it runs on the blocking pool.

use std::time::Instant;

use axum::extract::Query;
use axum::response::Response;

use super::made;
use super::render::render_image;
use crate::model::design_report::{CameraImage, DesignReport, ReportMeta, MAX_META_CHARS};
use crate::model::Lighting;
use crate::render::pipeline::RenderOptions;
use crate::render::Camera;
use crate::server::openapi::{PostErrors, QueryErrors, ReportHtml, SceneIdParam};
use crate::server::parse::{shorten, ReadyScene, ScenePost};
use crate::server::requests::render::{RenderAsk, RenderQuery, ReportBody};
use crate::server::requests::{RenderRequest, Resolve};
use crate::server::views::render_estimate;
use crate::server::{AppError, AppState, Ready};

/// The images' size unless the query gives `w`/`h`, pixels.
const IMAGE_SIZE: (u32, u32) = (640, 400);

/// The title block's words of the report's query.
#[derive(utoipa::IntoParams)]
#[into_params(parameter_in = Query)]
#[allow(dead_code)]
pub(crate) struct ReportQuery {
    /// The report's title (default "Lighting design report"); at most 200 characters.
    #[param(max_length = 200)]
    title: Option<String>,
    /// The project's name; at most 200 characters.
    #[param(max_length = 200)]
    project: Option<String>,
    /// Who made it; at most 200 characters.
    #[param(max_length = 200)]
    author: Option<String>,
}

/// The report's query: `title`, `project` and `author` (422 when one is too long), and
/// the rest as `render.png` takes it.
fn read(q: &[(String, String)]) -> Result<(ReportMeta, RenderRequest), AppError> {
    let mut meta = ReportMeta::default();
    let req = RenderRequest::from_query_and(q, |p| {
        let slot = match p.name {
            "title" => &mut meta.title,
            "project" => &mut meta.project,
            "author" => &mut meta.author,
            _ => return Ok(false),
        };
        *slot = meta_word(p.written, p.value)?;
        Ok(true)
    })?;
    Ok((meta, req))
}

/// One image of the report: the camera preset it shows, and how.
struct ReportImage {
    camera: String,
    options: RenderOptions,
}

/// The report's lighting state and images: the query's camera, else every preset, at the
/// query's size, else [`IMAGE_SIZE`].
fn resolve(req: &RenderRequest, ready: &Ready) -> Result<(Lighting, Vec<ReportImage>), AppError> {
    let m = &ready.model;
    let cameras = &m.baked.scene.cameras;
    if cameras.is_empty() && req.camera_preset().is_none() {
        return Ok((req.lighting(m)?, vec![]));
    }
    let RenderAsk {
        lighting, options, ..
    } = req.resolve(m)?;
    if let Some(id) = req.camera_preset() {
        let camera = id.to_string();
        return Ok((lighting, vec![ReportImage { camera, options }]));
    }
    let (w, h) = if req.has_size() {
        (options.camera.width, options.camera.height)
    } else {
        IMAGE_SIZE
    };
    let images = cameras
        .iter()
        .map(|c| ReportImage {
            camera: c.id.clone(),
            options: RenderOptions {
                camera: Camera::from_def(c, w, h),
                ..options.clone()
            },
        })
        .collect();
    Ok((lighting, images))
}

/// `GET …/report?light.window_row=0.5&title=…&project=…&author=…`
#[utoipa::path(get, path = "/api/scenes/{id}/report", operation_id = "report", tags = ["scenes"],
    summary = "A printable design report (HTML, self-contained: print it to PDF from a browser) of a lighting state, given in the query as render.png takes it (`light.<group>=<intensity>` or `light.<group>=r,g,b`, exposure, tonemap, mode, quality; w/h size the images, default 640×400; `camera` limits them to that preset, else one per camera preset). It holds a title block, the luminaire schedule, per grid a false-colour plan with Ēm, Emin, Emax, U₀, UGR and pass or fail against the grid's requirements, the assumptions (maintenance factors, reflectances), the relit images, and installed power with its density. A parameter given twice, an unknown parameter or a value that is not a number where one is expected is a 400; values out of range, unknown cameras and light groups, and a title, project or author over 200 characters are 422s.",
    params(SceneIdParam, ReportQuery, RenderQuery),
    responses(ReportHtml, QueryErrors))]
pub(crate) async fn report(
    ReadyScene(ready, state): ReadyScene,
    Query(q): Query<Vec<(String, String)>>,
) -> Result<Response, AppError> {
    let t0 = Instant::now();
    let (meta, req) = read(&q)?;
    respond(state, ready, meta, req, t0).await
}

#[utoipa::path(post, path = "/api/scenes/{id}/report", operation_id = "reportPost", tags = ["scenes"],
    summary = "The printable design report of GET …/report for any lighting state, given in a JSON body: light groups and luminaires placed per request (added, moved or removed; the schedule lists them and their power counts), the images' camera preset, size and look, and the title block's words.",
    params(SceneIdParam),
    request_body(content = ReportBody, content_type = "application/json",
        description = "An empty object reports the default state with one image per camera preset.",
        example = json!({"lights": {"window_row": 0.8}, "title": "Option B", "width": 320, "height": 200})),
    responses(ReportHtml, PostErrors))]
pub(crate) async fn report_post(
    ScenePost(ready, state, body): ScenePost<ReportBody>,
) -> Result<Response, AppError> {
    let t0 = Instant::now();
    let (words, req) = body.into_parts();
    let mut meta = ReportMeta::default();
    let names = ["title", "project", "author"];
    let slots = [&mut meta.title, &mut meta.project, &mut meta.author];
    for ((slot, word), name) in slots.into_iter().zip(words).zip(names) {
        if let Some(v) = word {
            *slot = meta_word(name, &v)?;
        }
    }
    respond(state, ready, meta, req, t0).await
}

/// A title block's word as given (`name` in messages): 422 over [`MAX_META_CHARS`]
/// characters, None when blank.
fn meta_word(name: &str, value: &str) -> Result<Option<String>, AppError> {
    let n = value.chars().count();
    if n > MAX_META_CHARS {
        return Err(AppError::Invalid(format!(
            "{name} has {n} characters (at most {MAX_META_CHARS}): {}",
            shorten(value)
        )));
    }
    let v = value.trim();
    Ok((!v.is_empty()).then(|| v.to_string()))
}

/// The report of `req`'s lighting state and images with title block `meta`, made on the
/// blocking pool.
async fn respond(
    state: std::sync::Arc<AppState>,
    ready: std::sync::Arc<Ready>,
    meta: ReportMeta,
    req: RenderRequest,
    t0: Instant,
) -> Result<Response, AppError> {
    let (lighting, images) = resolve(&req, &ready)?;
    let m = &ready.model;
    let pixels: Vec<u64> = images
        .iter()
        .map(|i| i.options.camera.width as u64 * i.options.camera.height as u64)
        .collect();
    let renders = images
        .iter()
        .map(|i| render_estimate(&state, &ready, &i.options, &lighting, false));
    let bytes = DesignReport::estimate_bytes(m, &pixels, renders.max().unwrap_or(0));
    let points: usize = m.grids.iter().map(|g| g.len()).sum();
    let what = format!(
        "a design report ({} images, {points} grid points)",
        images.len()
    );
    let st = state.clone();
    let html = state
        .heavy(bytes, &what, move |cancel| {
            let mut shots = Vec::with_capacity(images.len());
            for ReportImage { camera, options: o } in images {
                cancel.check()?;
                let r = render_image(&st, &ready, &lighting, None, &o, cancel)?;
                shots.push(CameraImage {
                    camera,
                    width: o.camera.width,
                    height: o.camera.height,
                    png: r.bytes,
                });
            }
            Ok(DesignReport::assemble(&ready.model, &lighting, meta, shots, cancel)?.html())
        })
        .await?;
    let timing = ("x-relight-report-ms", t0);
    Ok(made(
        "text/html; charset=utf-8",
        html.into_bytes(),
        timing,
        None,
    ))
}
