//! The OpenAPI 3.1 description of the API, served at `/api/openapi.json`, generated from
//! the code: the operations from the handlers' `#[utoipa::path]` attributes (in
//! [`super::routes`]), the request bodies from the types the handlers deserialize
//! ([`super::requests`]), with the limits from the constants the checks use, and the
//! answers from the types the handlers serialize: the query model's (`crate::model`,
//! deriving `ToSchema` with the `server` feature) and the server's own (scene listings,
//! readiness, batches, problem documents). Only the JSON of per-patch radiosity is
//! written by hand, for speed; `routes::radiosity::RadiosityResponse` describes it.
//! `tests` checks real answers against the document.
//!
//! Every `#[utoipa::path]` is written in one compact style: method, path, operation id and
//! `tags = [..]` on the first line, then the summary, then parameters, body and
//! responses. (rustfmt leaves an attribute with an array or a `json!` alone, where it would
//! spread a plain one over a line per key.)
//!
//! The document is checked against the running server by schemathesis
//! (`tests/schemathesis/run.sh`, run by `.ci/run`): every status code, content type,
//! header and body the server gives must be described here, and every request the
//! schemas call invalid must be refused.

use serde_json::{json, Value};
use utoipa::openapi::schema::Schema;
use utoipa::openapi::{RefOr, Required};
use utoipa::{IntoParams, Modify, OpenApi};

use super::error::ProblemDetails;
use super::requests::batch::LightingState;
use super::requests::glare::Observer;
use super::requests::illuminance::Point;
use super::requests::lighting::{Color, Direction, Emission, LightSetting, Lights, Position};
use super::requests::optimize::Target;
use super::requests::render::Exposure;
use super::requests::{AnnualRequest, DaylightRequest, RadiosityRequest, RenderRequest};
use super::requests::{BatchRequest, GlareRequest, IlluminanceRequest, OptimizeRequest};
use super::routes;
use crate::schema::Rgb;

mod responses;

pub(crate) use responses::*;

/// The `{id}` of every scene route.
#[derive(IntoParams)]
#[into_params(parameter_in = Path)]
#[allow(dead_code)]
pub(crate) struct SceneIdParam {
    /// Scene id: the scene's folder name, as listed by GET /api/scenes.
    #[param(example = "cornell-box", min_length = 1)]
    id: String,
}

/// The `{id}` of the routes whose documented example names the office's grids and groups
/// (`/optimize`): its example is the office, so that example and id go together.
#[derive(IntoParams)]
#[into_params(parameter_in = Path)]
#[allow(dead_code)]
pub(crate) struct OfficeIdParam {
    /// Scene id: the scene's folder name, as listed by GET /api/scenes.
    #[param(example = "office", min_length = 1)]
    id: String,
}

/// Constraints between fields, which the derived schemas cannot say.
struct Constraints;

impl Modify for Constraints {
    fn modify(&self, api: &mut utoipa::openapi::OpenApi) {
        use utoipa::openapi::security::{HttpAuthScheme, HttpBuilder, SecurityScheme};
        if let Some(c) = api.components.as_mut() {
            c.add_security_scheme(
                "admin_token",
                SecurityScheme::Http(
                    HttpBuilder::new()
                        .scheme(HttpAuthScheme::Bearer)
                        .description(Some("The server's --admin-token (RELIGHT_ADMIN_TOKEN)."))
                        .build(),
                ),
            );
        }
        // Bodies that may be left out (an empty body means the defaults).
        for path in ["radiosity", "illuminance", "render", "export.glb", "report"] {
            let item = api
                .paths
                .paths
                .get_mut(&format!("/api/scenes/{{id}}/{path}"));
            if let Some(body) = item.and_then(|i| i.post.as_mut()?.request_body.as_mut()) {
                body.required = Some(Required::False);
            }
        }
        let Some(components) = api.components.as_mut() else {
            return;
        };
        let mut add = |name: &str, key: &str, value: Value| {
            if let Some(RefOr::T(Schema::Object(o))) = components.schemas.get_mut(name) {
                o.extensions
                    .get_or_insert_with(Default::default)
                    .insert(key.into(), value);
            }
        };
        // Every lighting request takes `lights` or `emission`, never both.
        let not_both = json!({"required": ["lights", "emission"]});
        for name in [
            "LightingState",
            "RadiosityRequest",
            "IlluminanceRequest",
            "RenderRequest",
        ] {
            add(name, "not", not_both.clone());
        }
        add(
            "RenderRequest",
            "allOf",
            json!([{"not": {"required": ["mode", "format"],
            "properties": {"mode": {"const": "falsecolor"}, "format": {"const": "exr"}}}}]),
        );
        add(
            "Target",
            "anyOf",
            json!([{"required": ["eavg_min"]}, {"required": ["emin_min"]}, {"required": ["u0_min"]}]),
        );
        add(
            "RadiosityResponse",
            "oneOf",
            json!([{"required": ["radiosity"]}, {"required": ["illuminance"]}]),
        );
    }
}

#[derive(OpenApi)]
#[openapi(
    info(
        title = "relight",
        description = "Relights static scenes from a precomputed radiosity transfer. Units: radiosity and exitance in lm/m² (per linear RGB channel), illuminance in lux, flux in lumens, lengths in metres. The luminous value of an RGB triple is Y = 0.2126 R + 0.7152 G + 0.0722 B. Request bodies are JSON objects sent as application/json; repeated keys are refused. Errors are RFC 9457 problem documents."
    ),
    tags((name = "scenes"), (name = "service")),
    paths(
        routes::service::healthz,
        routes::service::readyz,
        routes::service::metrics,
        routes::service::openapi,
        routes::scenes::list_scenes,
        routes::scenes::scene_details,
        routes::scenes::patches,
        routes::scenes::mesh,
        routes::scenes::mesh_preview,
        routes::render::render_get,
        routes::export::export_glb,
        routes::export::export_glb_post,
        routes::report::report,
        routes::report::report_post,
        routes::radiosity::radiosity,
        routes::illuminance::illuminance,
        routes::daylight::daylight,
        routes::annual::annual,
        routes::batch::batch,
        routes::optimize::optimize,
        routes::glare::glare,
        routes::render::render_post,
        routes::upload::put_scene,
        routes::upload::delete_scene,
    ),
    components(
        schemas(
            Color, Position, Direction, LightSetting, Lights, Emission, LightingState, Point,
            Target, Exposure, RadiosityRequest, IlluminanceRequest, BatchRequest,
            super::requests::optimize::Candidates,
            OptimizeRequest, RenderRequest, ProblemDetails, Rgb, Millis, DaylightRequest, AnnualRequest,
            GlareRequest, Observer, super::requests::export::ExportBody,
            super::requests::render::ReportBody,
            PngImage, JpegImage, ExrImage, GlbModel, MeshBinary, ReportDocument, PatchesBinary,
            RadiosityBinary, crate::server::routes::radiosity::RadiosityResponse,
            crate::server::routes::scenes::Patches,
            crate::model::sky_state::SkySpec, crate::model::sky_state::SunPosition,
        ),
        responses(BadRequest, BadQuery, NotFound, Unauthorized, Forbidden, Conflict, TooLarge, UnsupportedMediaType, Invalid, Unavailable),
    ),
    modifiers(&Constraints),
)]
struct ApiDoc;

/// Response headers that every 200 answer of a scene's path (under `/api/scenes/{id}/`)
/// and method carries (utoipa's headers have no `required`).
const REQUIRED_HEADERS: &[(&str, &str, &[&str])] = &[
    ("mesh", "get", &["X-Relight-Layout"]),
    ("render", "post", &["X-Relight-Render-Ms", "Cache-Control"]),
    (
        "render.png",
        "get",
        &["X-Relight-Render-Ms", "Cache-Control"],
    ),
    ("report", "get", &["X-Relight-Report-Ms", "Cache-Control"]),
    ("report", "post", &["X-Relight-Report-Ms", "Cache-Control"]),
];

/// The document.
pub(crate) fn spec() -> Value {
    let mut doc = serde_json::to_value(ApiDoc::openapi()).expect("the document serializes");
    for (path, method, names) in REQUIRED_HEADERS {
        for name in *names {
            let header = doc
                .get_mut("paths")
                .and_then(|p| {
                    p.get_mut(format!("/api/scenes/{{id}}/{path}"))?
                        .get_mut(*method)
                })
                .and_then(|m| m.get_mut("responses"))
                .and_then(|r| r.get_mut("200")?.get_mut("headers")?.get_mut(*name))
                .and_then(Value::as_object_mut);
            if let Some(h) = header {
                h.insert("required".into(), json!(true));
            }
        }
    }
    if let Some(h) = doc
        .pointer_mut("/components/responses/Unavailable/headers/Retry-After")
        .and_then(Value::as_object_mut)
    {
        h.insert("required".into(), json!(true));
    }
    close_answers(&mut doc);
    doc
}

/// Answers are closed: an answer object has the keys its schema lists and no other.
/// Said here once for every schema an answer reaches, rather than by each answer type
/// (serde's `deny_unknown_fields`, which utoipa reads, is for types that are deserialized).
fn close_answers(doc: &mut Value) {
    const COMPONENT: &str = "#/components/schemas/";
    fn refs(v: &Value, out: &mut Vec<String>) {
        match v {
            Value::Object(m) => {
                for (k, x) in m {
                    match (k.as_str(), x) {
                        ("$ref", Value::String(r)) => {
                            out.extend(r.strip_prefix(COMPONENT).map(String::from))
                        }
                        _ => refs(x, out),
                    }
                }
            }
            Value::Array(a) => a.iter().for_each(|x| refs(x, out)),
            _ => {}
        }
    }
    // Closes an object schema and the schemas inside it.
    fn close(schema: &mut Value) {
        let Some(m) = schema.as_object_mut() else {
            return;
        };
        if let Some(props) = m.get_mut("properties").and_then(Value::as_object_mut) {
            props.values_mut().for_each(close);
            m.entry("additionalProperties")
                .or_insert(Value::Bool(false));
        }
        for key in ["items", "additionalProperties", "not"] {
            if let Some(s) = m.get_mut(key) {
                close(s);
            }
        }
        for key in ["oneOf", "anyOf", "allOf"] {
            if let Some(Value::Array(a)) = m.get_mut(key) {
                a.iter_mut().for_each(close);
            }
        }
    }
    // Every schema an answer reaches: from the operations' and the shared responses.
    let mut todo = vec![];
    for path in doc["paths"]
        .as_object()
        .into_iter()
        .flat_map(|p| p.values())
    {
        for op in path.as_object().into_iter().flat_map(|o| o.values()) {
            refs(&op["responses"], &mut todo);
        }
    }
    refs(&doc["components"]["responses"], &mut todo);
    let mut answers = std::collections::BTreeSet::new();
    while let Some(name) = todo.pop() {
        if answers.insert(name.clone()) {
            refs(&doc["components"]["schemas"][&name], &mut todo);
        }
    }
    for name in answers {
        if let Some(schema) = doc["components"]["schemas"].get_mut(&name) {
            close(schema);
        }
    }
}

#[cfg(test)]
mod tests;
