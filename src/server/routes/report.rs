//! `GET /api/scenes/{id}/report`: the printable design report
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
use crate::server::openapi::{QueryErrors, ReportHtml, SceneIdParam};
use crate::server::parse::{shorten, ReadyScene};
use crate::server::requests::render::{given_twice, RenderQuery};
use crate::server::requests::RenderRequest;
use crate::server::views::render_estimate;
use crate::server::{AppError, Ready};

/// The images' size unless the query gives `w`/`h`, pixels.
const IMAGE_SIZE: (u32, u32) = (640, 400);

/// Bytes of report text per grid point (its plan cell and label).
const BYTES_PER_PLAN_POINT: u64 = 320;

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

/// Takes `title`, `project` and `author` out of the query: 400 when one is given twice,
/// 422 when one is too long. The rest is the query of `render.png`.
fn split_meta(q: &[(String, String)]) -> Result<(ReportMeta, Vec<(String, String)>), AppError> {
    let mut meta = ReportMeta::default();
    let mut rest = Vec::with_capacity(q.len());
    for (k, v) in q {
        let slot = match k.as_str() {
            "title" => &mut meta.title,
            "project" => &mut meta.project,
            "author" => &mut meta.author,
            _ => {
                rest.push((k.clone(), v.clone()));
                continue;
            }
        };
        if slot.is_some() {
            return Err(given_twice(k));
        }
        let n = v.chars().count();
        if n > MAX_META_CHARS {
            return Err(AppError::Invalid(format!(
                "{k} has {n} characters (at most {MAX_META_CHARS}): {}",
                shorten(v)
            )));
        }
        let v = v.trim();
        *slot = (!v.is_empty()).then(|| v.to_string());
    }
    Ok((meta, rest))
}

/// The render options of each image: the query's camera, else every preset, at the
/// query's size, else [`IMAGE_SIZE`].
fn image_options(
    req: &RenderRequest,
    q: &[(String, String)],
    ready: &Ready,
) -> Result<Vec<RenderOptions>, AppError> {
    let scene = &ready.model.baked.scene;
    let given = |names: &[&str]| q.iter().any(|(k, _)| names.contains(&k.as_str()));
    if scene.cameras.is_empty() && !given(&["camera"]) {
        return Ok(vec![]);
    }
    let o = req.options(&ready.model)?;
    if given(&["camera"]) {
        return Ok(vec![o]);
    }
    let sized = given(&["w", "width", "h", "height"]);
    let (w, h) = if sized {
        (o.camera.width, o.camera.height)
    } else {
        IMAGE_SIZE
    };
    Ok(scene
        .cameras
        .iter()
        .map(|c| RenderOptions {
            camera: Camera::from_def(c, w, h),
            ..o.clone()
        })
        .collect())
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
    let (meta, rest) = split_meta(&q)?;
    let req = RenderRequest::from_query(&rest)?;
    let lighting = req.lighting(&ready.model)?;
    let Lighting::Groups(w) = lighting.clone() else {
        return Err(AppError::Internal(
            "report: the query gave an emission".into(),
        ));
    };
    let images = image_options(&req, &rest, &ready)?;
    let m = &ready.model;
    let points: u64 = m.grids.iter().map(|g| g.len() as u64).sum();
    let renders = images.iter().map(|o| render_estimate(&state, &ready, o));
    // One image at a time; every encoded image kept (PNG at most 4 bytes a pixel, and
    // its base64 text); the grids' answers and the text.
    let kept: u64 = images
        .iter()
        .map(|o| 10 * o.camera.width as u64 * o.camera.height as u64)
        .sum();
    let q = crate::model::query::IlluminanceQuery {
        grids: (0..m.grids.len()).collect(),
        ..Default::default()
    };
    let bytes = renders.max().unwrap_or(0)
        + kept
        + 2 * m.illuminance_bytes(&q)
        + BYTES_PER_PLAN_POINT * points;
    let what = format!(
        "a design report ({} images, {points} grid points)",
        images.len()
    );
    let st = state.clone();
    let html = state
        .heavy(bytes, &what, move |cancel| {
            let mut shots = Vec::with_capacity(images.len());
            for o in &images {
                cancel.check()?;
                let r = render_image(&st, &ready, &lighting, None, o, cancel)?;
                shots.push(CameraImage {
                    camera: camera_name(&ready, &o.camera),
                    width: o.camera.width,
                    height: o.camera.height,
                    png: r.bytes,
                });
            }
            Ok(DesignReport::assemble(&ready.model, &w, meta, shots, cancel)?.html())
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

/// The preset id a camera came from (matched by position and target), else "view".
fn camera_name(ready: &Ready, cam: &Camera) -> String {
    let same = |a: [f64; 3], b: glam::Vec3| {
        (a[0] as f32 - b.x).abs() < 1e-5
            && (a[1] as f32 - b.y).abs() < 1e-5
            && (a[2] as f32 - b.z).abs() < 1e-5
    };
    ready
        .model
        .baked
        .scene
        .cameras
        .iter()
        .find(|c| same(c.position, cam.position) && same(c.target, cam.target))
        .map_or_else(|| "view".to_string(), |c| c.id.clone())
}
