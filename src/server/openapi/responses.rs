//! The answers the operations share, as components of the document: problem documents
//! and the error sets of each kind of operation, the binary and text schemas, and the
//! 200 answers of images, exports and meshes with their headers.

use std::borrow::Cow;
use std::collections::BTreeMap;

use serde_json::{json, Value};
use utoipa::openapi::header::{Header, HeaderBuilder};
use utoipa::openapi::response::{Response, ResponseBuilder};
use utoipa::openapi::schema::Schema;
use utoipa::openapi::{ContentBuilder, Ref, RefOr};
use utoipa::{IntoResponses, PartialSchema, ToResponse, ToSchema};

use crate::server::requests::raw;

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
    ReportDocument,
    json!({"type": "string", "description": "A self-contained HTML document (inline CSS, images as data URLs, plans as inline SVG): it loads nothing from elsewhere."})
);
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
// GET …/report.
answer!(ReportHtml, {
    let mut headers = made("X-Relight-Report-Ms", "Not sent.");
    headers.retain(|(name, _)| *name != "X-Relight-Exposure");
    ok(
        "The printable design report.",
        headers,
        vec![("text/html", of::<ReportDocument>())],
    )
});
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
/// JSON, or the same numbers as binary with `Accept: application/octet-stream`; `count`
/// describes the binary answer's `X-Relight-Patches`.
fn json_or_binary(
    description: &str,
    count: &str,
    json: &str,
    binary: Ref,
) -> BTreeMap<String, RefOr<Response>> {
    let layout = "Binary answer: the layout of the bytes.";
    ok(
        description,
        vec![
            ("X-Relight-Patches", header(u64::schema(), count)),
            ("X-Relight-Layout", header(String::schema(), layout)),
        ],
        vec![
            ("application/json", Ref::from_schema_name(json)),
            ("application/octet-stream", binary),
        ],
    )
}
// POST …/radiosity.
answer!(
    RadiosityAnswer,
    json_or_binary(
        "Per-patch radiosity in lm/m² (or, with quantity = illuminance, incident illuminance in lux), in patch order.",
        "Binary answer: the number of patches n.",
        "RadiosityResponse",
        of::<RadiosityBinary>(),
    )
);
// GET …/patches.
answer!(
    PatchesAnswer,
    json_or_binary(
        "Patches in patch order.",
        "Binary answer: the number of patches.",
        "Patches",
        of::<PatchesBinary>(),
    )
);
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
