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
//! The document is checked against the running server by schemathesis
//! (`tests/schemathesis/run.sh`, run by `.ci/run`): every status code, content type,
//! header and body the server gives must be described here, and every request the
//! schemas call invalid must be refused.

use std::borrow::Cow;
use std::collections::BTreeMap;

use serde_json::{json, Value};
use utoipa::openapi::header::{Header, HeaderBuilder};
use utoipa::openapi::response::{Response, ResponseBuilder};
use utoipa::openapi::schema::Schema;
use utoipa::openapi::{ContentBuilder, Ref, RefOr, Required};
use utoipa::{IntoParams, IntoResponses, Modify, OpenApi, PartialSchema, ToResponse, ToSchema};

use super::error::ProblemDetails;
use super::requests::batch::LightingState;
use super::requests::glare::Observer;
use super::requests::illuminance::Point;
use super::requests::lighting::{Color, Direction, Emission, LightSetting, Lights, Position};
use super::requests::optimize::Target;
use super::requests::render::Exposure;
use super::requests::{raw, BatchRequest, GlareRequest, IlluminanceRequest, OptimizeRequest};
use super::requests::{AnnualRequest, DaylightRequest, RadiosityRequest, RenderRequest};
use super::routes;
use crate::schema::Rgb;

/// The `{id}` of every scene route.
#[derive(IntoParams)]
#[into_params(parameter_in = Path)]
#[allow(dead_code)]
pub(crate) struct SceneIdParam {
    /// Scene id: the scene's folder name, as listed by GET /api/scenes.
    #[param(example = "cornell-box", min_length = 1)]
    id: String,
}

/// A problem document answer.
fn problem(description: &str) -> Response {
    ResponseBuilder::new()
        .description(description)
        .content(
            "application/problem+json",
            ContentBuilder::new()
                .schema(Some(Ref::from_schema_name("ProblemDetails")))
                .build(),
        )
        .build()
}

/// Declares a shared error answer (a component of the document's `responses`).
macro_rules! problem_response {
    ($name:ident, $description:literal) => {
        pub(crate) struct $name;
        impl<'r> ToResponse<'r> for $name {
            fn response() -> (&'r str, RefOr<Response>) {
                (stringify!($name), problem($description).into())
            }
        }
    };
}

problem_response!(
    BadRequest,
    "Malformed JSON, or a request body that could not be read."
);
problem_response!(BadQuery, "A malformed query: an unknown parameter, one given twice, or a value that is not a number where one is expected.");
problem_response!(NotFound, "Unknown scene.");
problem_response!(
    Unauthorized,
    "A scene write without the admin token (`Authorization: Bearer <token>`), or with a wrong one."
);
problem_response!(
    Forbidden,
    "Scene writes are disabled: the server has no admin token (--admin-token), or is read-only."
);
problem_response!(
    Conflict,
    "The scene is one of the server's own (not uploaded), or it is queued or baking."
);
problem_response!(
    TooLarge,
    "The body exceeds the size limit (16 MiB by default, --body-limit)."
);
problem_response!(
    UnsupportedMediaType,
    "A body whose Content-Type is not JSON (application/json or …/…+json)."
);
problem_response!(Invalid, "Well-formed JSON with invalid content: not an object, a repeated key, unknown fields, unknown light groups, surfaces, grids or cameras, a wrong emission length, NaN, infinite, negative or out-of-range values, a colour that is not three numbers; or a request too large for the memory budget.");

/// 503, with `Retry-After`.
pub(crate) struct Unavailable;

impl<'r> ToResponse<'r> for Unavailable {
    fn response() -> (&'r str, RefOr<Response>) {
        let mut r = problem("The scene is still baking (with `progress`) or failed to load (with its error); or the server is shedding load, its memory budget is momentarily full, or the request did not finish within the time limit. Retry after the given seconds.");
        let retry = HeaderBuilder::new()
            .schema(raw(json!({"type": "integer", "minimum": 0})))
            .description(Some("Seconds to wait before retrying."))
            .build();
        r.headers.insert("Retry-After".into(), retry);
        ("Unavailable", r.into())
    }
}

/// Declares a schema component given as JSON Schema (binary and text answers).
macro_rules! raw_schema {
    ($name:ident, $schema:expr) => {
        pub(crate) struct $name;
        impl PartialSchema for $name {
            fn schema() -> RefOr<Schema> {
                raw($schema)
            }
        }
        impl ToSchema for $name {
            fn name() -> Cow<'static, str> {
                Cow::Borrowed(stringify!($name))
            }
        }
    };
}

/// A binary answer.
fn binary(description: &str) -> Value {
    json!({"description": description, "contentMediaType": "application/octet-stream"})
}

raw_schema!(HealthText, json!({"type": "string", "enum": ["ok"]}));
raw_schema!(MetricsText, json!({"type": "string"}));
raw_schema!(Document, json!({"type": "object"}));
raw_schema!(
    PatchesBinary,
    binary("32 bytes per patch, little-endian: u32 surface index, f32 area, f32×3 centroid, f32×3 unit normal.")
);
raw_schema!(
    MeshBinary,
    binary("Little-endian: \"RLMESH01\"; u32 nv, nt, nw; f32 position[nv][3] (m); u32 triangle[nt][3] (counter-clockwise from the lit side); u32 surface[nt]; u32 start[nv+1]; u32 patch[nw]; f32 weight[nw].")
);
raw_schema!(
    RadiosityBinary,
    binary("With `Accept: application/octet-stream`: n × 3 little-endian f32, [r, g, b] radiosity (lm/m²) or illuminance (lx) of each patch in patch order.")
);
raw_schema!(
    GlbModel,
    binary("glTF 2.0 binary: one unlit mesh with POSITION (m), COLOR_0 (linear display values after exposure and tone map) and, when relightable, one `_LIGHT_<GROUP>` float VEC3 attribute per light group (radiance at intensity 1, white, cd/m²); `asset.extras.relight` gives the exposure, tone map, groups (id, name, attribute, weight) and surfaces (triangle ranges).")
);
raw_schema!(
    ZipArchive,
    binary("A zip archive of a scene folder: one .obj (with its .mtl files, textures and IES files) or one .gltf/.glb (with its buffers and images), and an optional scene.toml; one folder around everything is unwrapped.")
);
raw_schema!(PngImage, binary("PNG, 8-bit RGB."));
raw_schema!(JpegImage, binary("JPEG, 8-bit RGB."));
raw_schema!(
    ExrImage,
    binary("OpenEXR: linear radiance B/π, lm/(m²·sr), 32-bit float RGB.")
);
raw_schema!(
    Millis,
    json!({"type": "number", "minimum": 0, "description": "Server time, ms."})
);

/// Declares the error answers an operation shares with others, by status.
macro_rules! errors {
    ($name:ident, [$(($code:literal, $response:literal)),+]) => {
        pub(crate) struct $name;
        impl IntoResponses for $name {
            fn responses() -> BTreeMap<String, RefOr<Response>> {
                [$(($code.to_string(), RefOr::Ref(Ref::from_response_name($response)))),+]
                    .into_iter()
                    .collect()
            }
        }
    };
}

// Every scene endpoint: unknown scene, and 503 while the scene bakes, when it failed, when
// the server sheds load or runs out of its memory budget, or when the request times out.
errors!(SceneErrors, [("404", "NotFound"), ("503", "Unavailable")]);
// A GET whose answer grows with the scene: 422 when building it would take more than one
// request's share of the memory budget.
errors!(
    SizedGetErrors,
    [
        ("404", "NotFound"),
        ("422", "Invalid"),
        ("503", "Unavailable")
    ]
);
// A POST with a JSON body.
errors!(
    PostErrors,
    [
        ("400", "BadRequest"),
        ("404", "NotFound"),
        ("413", "TooLarge"),
        ("415", "UnsupportedMediaType"),
        ("422", "Invalid"),
        ("503", "Unavailable")
    ]
);
// A scene write (upload or delete): token, id, body and state.
errors!(
    WriteErrors,
    [
        ("401", "Unauthorized"),
        ("403", "Forbidden"),
        ("404", "NotFound"),
        ("409", "Conflict"),
        ("413", "TooLarge"),
        ("415", "UnsupportedMediaType"),
        ("422", "Invalid"),
        ("503", "Unavailable")
    ]
);
// A GET with a query.
errors!(
    QueryErrors,
    [
        ("400", "BadQuery"),
        ("404", "NotFound"),
        ("422", "Invalid"),
        ("503", "Unavailable")
    ]
);

/// A header of an answer.
fn header(schema: impl Into<RefOr<Schema>>, description: &str) -> Header {
    HeaderBuilder::new()
        .schema(schema)
        .description(Some(description))
        .build()
}

/// The schema component `T`.
fn of<T: ToSchema>() -> Ref {
    Ref::from_schema_name(T::name())
}

/// A 200 answer: its description, headers and content (media type and schema).
fn ok(
    description: &str,
    headers: Vec<(&str, Header)>,
    content: Vec<(&str, Ref)>,
) -> BTreeMap<String, RefOr<Response>> {
    let mut r = ResponseBuilder::new().description(description);
    for (name, h) in headers {
        r = r.header(name, h);
    }
    for (media, schema) in content {
        r = r.content(media, ContentBuilder::new().schema(Some(schema)).build());
    }
    BTreeMap::from([("200".to_string(), RefOr::T(r.build()))])
}

/// The headers of an answer made on request and not to be cached (an image, an export):
/// the server time in `timing`, the exposure used, and `Cache-Control: no-store`.
fn made<'a>(timing: &'a str, exposure: &str) -> Vec<(&'a str, Header)> {
    vec![
        (timing, header(of::<Millis>(), "Server time, ms.")),
        ("X-Relight-Exposure", header(f64::schema(), exposure)),
        ("Cache-Control", header(String::schema(), "`no-store`.")),
    ]
}

/// A relit image in one of `content`'s formats.
fn image(description: &str, content: Vec<(&str, Ref)>) -> BTreeMap<String, RefOr<Response>> {
    let mut headers = made(
        "X-Relight-Render-Ms",
        "Shaded 8-bit images: the exposure used, stops.",
    );
    let range = "False colour: `low,high`, the lux range of the log scale.";
    headers.push(("X-Relight-Falsecolor-Lux", header(String::schema(), range)));
    ok(description, headers, content)
}

/// Declares the 200 answer of operations.
macro_rules! answer {
    ($name:ident, $responses:expr) => {
        pub(crate) struct $name;
        impl IntoResponses for $name {
            fn responses() -> BTreeMap<String, RefOr<Response>> {
                $responses
            }
        }
    };
}

// POST …/render.
answer!(
    RenderImage,
    image(
        "The encoded image, in the requested format.",
        vec![
            ("image/png", of::<PngImage>()),
            ("image/jpeg", of::<JpegImage>()),
            ("image/x-exr", of::<ExrImage>()),
        ],
    )
);
// GET …/render.png.
answer!(
    RenderPng,
    image("The PNG image.", vec![("image/png", of::<PngImage>())])
);
// GET …/export.glb.
answer!(GlbFile, {
    let mut headers = made("X-Relight-Export-Ms", "The exposure used, stops.");
    let disposition = "`attachment; filename=\"<id>.glb\"`.";
    headers.push(("Content-Disposition", header(String::schema(), disposition)));
    ok(
        "The .glb file.",
        headers,
        vec![("model/gltf-binary", of::<GlbModel>())],
    )
});
// GET …/mesh and …/mesh/preview.
answer!(
    MeshBuffer,
    ok(
        "One binary buffer.",
        vec![(
            "X-Relight-Layout",
            header(String::schema(), "The layout of the bytes.")
        )],
        vec![("application/octet-stream", of::<MeshBinary>())],
    )
);

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
        for path in ["radiosity", "illuminance", "render"] {
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
            OptimizeRequest, RenderRequest, ProblemDetails, Rgb, Millis, DaylightRequest, AnnualRequest,
            GlareRequest, Observer,
            PngImage, JpegImage, ExrImage, GlbModel, MeshBinary,
            crate::model::sky_state::SkySpec, crate::model::sky_state::SunPosition,
        ),
        responses(BadRequest, BadQuery, NotFound, Unauthorized, Forbidden, Conflict, TooLarge, UnsupportedMediaType, Invalid, Unavailable),
    ),
    modifiers(&Constraints),
)]
struct ApiDoc;

/// Response headers that every such answer carries (utoipa's headers have no
/// `required`): path, method, status, header.
const REQUIRED_HEADERS: &[(&str, &str, &str, &str)] = &[
    ("/api/scenes/{id}/mesh", "get", "200", "X-Relight-Layout"),
    (
        "/api/scenes/{id}/render",
        "post",
        "200",
        "X-Relight-Render-Ms",
    ),
    ("/api/scenes/{id}/render", "post", "200", "Cache-Control"),
    (
        "/api/scenes/{id}/render.png",
        "get",
        "200",
        "X-Relight-Render-Ms",
    ),
    ("/api/scenes/{id}/render.png", "get", "200", "Cache-Control"),
];

/// The document.
pub(crate) fn spec() -> Value {
    let mut doc = serde_json::to_value(ApiDoc::openapi()).expect("the document serializes");
    for (path, method, status, name) in REQUIRED_HEADERS {
        let header = doc
            .get_mut("paths")
            .and_then(|p| p.get_mut(*path)?.get_mut(*method)?.get_mut("responses"))
            .and_then(|r| r.get_mut(*status)?.get_mut("headers")?.get_mut(*name))
            .and_then(Value::as_object_mut);
        if let Some(h) = header {
            h.insert("required".into(), json!(true));
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
