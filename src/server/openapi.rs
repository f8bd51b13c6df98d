//! The OpenAPI 3.1 description of the API, served at `/api/openapi.json`.
//!
//! The document is checked against the running server by schemathesis
//! (`tests/schemathesis/run.sh`, run by `.ci/run`): every status code, content type,
//! header and body the server gives must be described here, and every request the
//! schemas call invalid must be refused. Numeric limits come from the constants the
//! handlers check, so that the two cannot drift apart.

use serde_json::{json, Map, Value};

use super::parse::{MAX_BATCH, MAX_COORDINATE, MAX_EMISSION, MAX_POINTS};
use crate::model::lighting::MAX_INTENSITY;
use crate::render::pipeline::{MAX_FOV_DEG, MAX_RANGE_LUX, MIN_FOV_DEG, MIN_RANGE_LUX};
use crate::render::MAX_SIDE;

/// Largest magnitude of any number in a request: values are computed in 32-bit floating
/// point, so the handlers refuse anything beyond its range.
const MAX_F32: f64 = f32::MAX as f64;

fn schema_ref(name: &str) -> Value {
    json!({ "$ref": format!("#/components/schemas/{name}") })
}

fn response_ref(name: &str) -> Value {
    json!({ "$ref": format!("#/components/responses/{name}") })
}

/// A JSON 200 answer with the given schema.
fn json_ok(desc: &str, schema: Value) -> Value {
    json!({"description": desc, "content": {"application/json": {"schema": schema}}})
}

fn scene_id() -> Value {
    json!({"$ref": "#/components/parameters/SceneId"})
}

/// A JSON request body (other media types are refused with 415).
fn body(schema: &str, required: bool, desc: &str, example: Value) -> Value {
    json!({
        "required": required,
        "description": desc,
        "content": {"application/json": {"schema": schema_ref(schema), "example": example}}
    })
}

/// The answers every scene endpoint can give besides its own: unknown scene, and 503
/// while the scene bakes, when it failed, when the server sheds load or runs out of its
/// memory budget, or when the request times out.
fn scene_errors() -> Map<String, Value> {
    let mut m = Map::new();
    m.insert("404".into(), response_ref("NotFound"));
    m.insert("503".into(), response_ref("Unavailable"));
    m
}

/// The errors of a GET whose answer grows with the scene, on top of [`scene_errors`]: 422
/// when building it would take more than one request's share of the memory budget.
fn sized_get_errors() -> Map<String, Value> {
    let mut m = scene_errors();
    m.insert("422".into(), response_ref("Invalid"));
    m
}

/// The errors of a POST with a JSON body, on top of [`scene_errors`].
fn post_errors() -> Map<String, Value> {
    let mut m = scene_errors();
    m.insert("400".into(), response_ref("BadRequest"));
    m.insert("413".into(), response_ref("TooLarge"));
    m.insert("415".into(), response_ref("UnsupportedMediaType"));
    m.insert("422".into(), response_ref("Invalid"));
    m
}

fn with(mut errors: Map<String, Value>, ok: Value) -> Value {
    errors.insert("200".into(), ok);
    Value::Object(errors)
}

/// An operation on a scene.
fn scene_op(
    id: &str,
    summary: &str,
    body: Option<Value>,
    params: Vec<Value>,
    responses: Value,
) -> Value {
    let mut parameters = vec![scene_id()];
    parameters.extend(params);
    let mut op = json!({
        "operationId": id,
        "tags": ["scenes"],
        "summary": summary,
        "parameters": parameters,
        "responses": responses,
    });
    if let Some(b) = body {
        op["requestBody"] = b;
    }
    op
}

/// A binary answer.
fn binary(desc: &str) -> Value {
    json!({"description": desc, "contentMediaType": "application/octet-stream"})
}

fn header(desc: &str, schema: Value, required: bool) -> Value {
    json!({"description": desc, "required": required, "schema": schema})
}

/// The paths of the health, metrics and document endpoints.
fn service_paths(paths: &mut Map<String, Value>) {
    paths.insert(
        "/healthz".into(),
        json!({"get": {
            "operationId": "healthz", "tags": ["service"],
            "summary": "Liveness: 200 while the process is up.",
            "responses": {"200": {"description": "The text `ok`.",
                "content": {"text/plain": {"schema": {"type": "string", "const": "ok"}}}}}
        }}),
    );
    paths.insert(
        "/readyz".into(),
        json!({"get": {
            "operationId": "readyz", "tags": ["service"],
            "summary": "Readiness: 200 once every scene is ready or failed, else 503 with every scene's status and progress.",
            "responses": {
                "200": json_ok("Every scene is ready or failed.", schema_ref("Readiness")),
                "503": {"description": "Some scene is still queued or baking.",
                    "content": {"application/json": {"schema": schema_ref("Readiness")}}}
            }
        }}),
    );
    paths.insert(
        "/metrics".into(),
        json!({"get": {
            "operationId": "metrics", "tags": ["service"],
            "summary": "Prometheus metrics: requests and latency per route, bake times.",
            "responses": {"200": {"description": "Prometheus text exposition format 0.0.4.",
                "content": {"text/plain": {"schema": {"type": "string"}}}}}
        }}),
    );
    paths.insert(
        "/api/openapi.json".into(),
        json!({"get": {
            "operationId": "openapi", "tags": ["service"],
            "summary": "This document.",
            "responses": {"200": json_ok("The OpenAPI 3.1 document.", json!({"type": "object"}))}
        }}),
    );
    paths.insert(
        "/api/scenes".into(),
        json!({"get": {
            "operationId": "listScenes", "tags": ["scenes"],
            "summary": "All scenes with status (queued, baking with progress 0..1, ready, failed with error), patch count and light groups.",
            "responses": {"200": json_ok("Scene list.", json!({
                "type": "object", "required": ["scenes"], "additionalProperties": false,
                "properties": {"scenes": {"type": "array", "items": schema_ref("SceneSummary")}}}))}
        }}),
    );
}

/// The GET paths of one scene.
fn scene_get_paths(paths: &mut Map<String, Value>) {
    paths.insert(
        "/api/scenes/{id}".into(),
        json!({"get": scene_op(
            "sceneDetails",
            "Light groups, cameras, luminaires, calculation grids, surfaces (with patch ranges), bounds, units and transfer mode of a scene.",
            None, vec![],
            with(scene_errors(), json_ok("Scene details.", schema_ref("SceneDetails"))),
        )}),
    );
    let patch_headers = json!({
        "X-Relight-Patches": header("Binary answer: the number of patches.", json!({"type": "integer", "minimum": 0}), false),
        "X-Relight-Layout": header("Binary answer: the layout of the bytes.", json!({"type": "string"}), false),
    });
    paths.insert(
        "/api/scenes/{id}/patches".into(),
        json!({"get": scene_op(
            "patches",
            "Per patch: surface, area (m²), centroid and normal (m). JSON, or binary with `Accept: application/octet-stream`.",
            None, vec![],
            with(sized_get_errors(), json!({
                "description": "Patches in patch order.",
                "headers": patch_headers,
                "content": {
                    "application/json": {"schema": schema_ref("Patches")},
                    "application/octet-stream": {"schema": binary(
                        "32 bytes per patch, little-endian: u32 surface index, f32 area, f32×3 centroid, f32×3 unit normal.")}
                }
            })),
        )}),
    );
    paths.insert(
        "/api/scenes/{id}/mesh".into(),
        json!({"get": scene_op(
            "mesh",
            "The shading mesh for client-side drawing: vertices, triangles (one per patch), surface per triangle, and per-vertex patch weights (vertex colour = Σ weight · B[patch]).",
            None, vec![],
            with(sized_get_errors(), json!({
                "description": "One binary buffer.",
                "headers": {"X-Relight-Layout": header("The layout of the bytes.", json!({"type": "string"}), true)},
                "content": {"application/octet-stream": {"schema": binary(
                    "Little-endian: \"RLMESH01\"; u32 nv, nt, nw; f32 position[nv][3] (m); u32 triangle[nt][3] (counter-clockwise from the lit side); u32 surface[nt]; u32 start[nv+1]; u32 patch[nw]; f32 weight[nw].")}}
            })),
        )}),
    );
    let mut render_errors = scene_errors();
    render_errors.insert("400".into(), response_ref("BadQuery"));
    render_errors.insert("422".into(), response_ref("Invalid"));
    let int = |desc: &str| json!({"type": "integer", "minimum": 1, "maximum": MAX_SIDE, "default": 512, "description": desc});
    paths.insert(
        "/api/scenes/{id}/render.png".into(),
        json!({"get": scene_op(
            "renderPng",
            "A relit PNG for quick use from a browser or curl, e.g. ?camera=front&w=512&h=512&light.ceiling=0.5. Besides the parameters below it takes `width`/`height` (aliases of w/h) and `light.<group>=<intensity>` or `light.<group>=r,g,b` (intensity 1 at that colour) for each light group. A parameter given twice, an unknown parameter or a value that is not a number where one is expected is a 400; values out of range, unknown cameras and light groups are 422s.",
            None,
            vec![
                json!({"name": "camera", "in": "query", "description": "Camera preset id from scene.toml (default: the first).", "schema": {"type": "string"}}),
                json!({"name": "w", "in": "query", "description": "Width, pixels.", "schema": int("Width, pixels.")}),
                json!({"name": "h", "in": "query", "description": "Height, pixels.", "schema": int("Height, pixels.")}),
                json!({"name": "exposure", "in": "query", "description": "Stops, or auto (default).", "schema": schema_ref("Exposure")}),
                json!({"name": "mode", "in": "query", "schema": {"type": "string", "enum": ["shaded", "falsecolor"], "default": "shaded"}}),
                json!({"name": "tonemap", "in": "query", "schema": {"type": "string", "enum": ["filmic", "clamp"], "default": "filmic"}}),
            ],
            with(render_errors, json!({
                "description": "The PNG image.",
                "headers": render_headers(),
                "content": {"image/png": {"schema": binary("PNG, 8-bit RGB.")}}
            })),
        )}),
    );
}

fn render_headers() -> Value {
    json!({
        "X-Relight-Render-Ms": header("Server time, ms.", json!({"type": "number", "minimum": 0}), true),
        "X-Relight-Exposure": header("Shaded 8-bit images: the exposure used, stops.", json!({"type": "number"}), false),
        "X-Relight-Falsecolor-Lux": header("False colour: `low,high`, the lux range of the log scale.", json!({"type": "string"}), false),
        "Cache-Control": header("`no-store`.", json!({"type": "string"}), true),
    })
}

/// The POST paths of one scene.
fn scene_post_paths(paths: &mut Map<String, Value>) {
    let radiosity_ok = json!({
        "description": "Per-patch radiosity in lm/m² (or, with quantity = illuminance, incident illuminance in lux), in patch order.",
        "headers": {
            "X-Relight-Patches": header("Binary answer: the number of patches n.", json!({"type": "integer", "minimum": 0}), false),
            "X-Relight-Layout": header("Binary answer: the layout of the bytes.", json!({"type": "string"}), false),
        },
        "content": {
            "application/json": {"schema": schema_ref("RadiosityResponse")},
            "application/octet-stream": {"schema": binary(
                "With `Accept: application/octet-stream`: n × 3 little-endian f32, [r, g, b] radiosity (lm/m²) or illuminance (lx) of each patch in patch order.")}
        }
    });
    paths.insert(
        "/api/scenes/{id}/radiosity".into(),
        json!({"post": scene_op(
            "radiosity",
            "Per-patch radiosity for a lighting state (group settings, or a per-patch emission in factored mode).",
            Some(body("RadiosityRequest", false, "An empty body is the default lighting state.",
                json!({"lights": {"ceiling": 0.5}, "surfaces": true}))),
            vec![],
            with(post_errors(), radiosity_ok),
        )}),
    );
    paths.insert(
        "/api/scenes/{id}/illuminance".into(),
        json!({"post": scene_op(
            "illuminance",
            "Illuminance per surface (avg, min, max, uniformity), at points (direct light of the luminaires plus light gathered from the solved patches, with occlusion), and on calculation grids (Eavg, Emin, Emax, U0, Emin/Emax), with the luminaires' lumens and watts.",
            Some(body("IlluminanceRequest", false, "An empty body gives every surface in the default lighting state.",
                json!({"lights": {"ceiling": {"intensity": 0.8, "color": [1.0, 0.9, 0.8]}}, "surfaces": ["floor"]}))),
            vec![],
            with(post_errors(), json_ok("Illuminance answers in lux.", schema_ref("IlluminanceResponse"))),
        )}),
    );
    paths.insert(
        "/api/scenes/{id}/batch".into(),
        json!({"post": scene_op(
            "batch",
            "Up to 1000 lighting states in one request, each with surface illuminance statistics and the power balance.",
            Some(body("BatchRequest", true, "The lighting states and what to report.",
                json!({"states": [{"lights": {"ceiling": 0.25}}, {"lights": {"ceiling": 1}}], "surfaces": ["floor"]}))),
            vec![],
            with(post_errors(), json_ok("One result per state, in request order.", schema_ref("BatchResponse"))),
        )}),
    );
    paths.insert(
        "/api/scenes/{id}/optimize".into(),
        json!({"post": scene_op(
            "optimize",
            "Dimming levels (0..1 per free group, modelled colours) that meet grid targets with the least emitted flux: a linear program over the precomputed grid responses. 422 explains unreachable targets.",
            Some(body("OptimizeRequest", true, "Targets per grid, the free groups and the state of the others.",
                json!({"targets": [{"grid": "desk", "eavg_min": 500, "u0_min": 0.6}]}))),
            vec![],
            with(post_errors(), json_ok("The levels, flux, power and achieved statistics.", schema_ref("OptimizeResponse"))),
        )}),
    );
    paths.insert(
        "/api/scenes/{id}/render".into(),
        json!({"post": scene_op(
            "render",
            "A relit image from a camera preset or a full camera.",
            Some(body("RenderRequest", false, "An empty body is a 512×512 PNG from the first camera preset in the default lighting state.",
                json!({"camera": "front", "width": 256, "height": 256, "lights": {"ceiling": 0.5}, "format": "png"}))),
            vec![],
            with(post_errors(), json!({
                "description": "The encoded image, in the requested format.",
                "headers": render_headers(),
                "content": {
                    "image/png": {"schema": binary("PNG, 8-bit RGB.")},
                    "image/jpeg": {"schema": binary("JPEG, 8-bit RGB.")},
                    "image/x-exr": {"schema": binary("OpenEXR: linear radiance B/π, lm/(m²·sr), 32-bit float RGB.")}
                }
            })),
        )}),
    );
}

/// Shared responses: errors as RFC 9457 problem documents.
fn responses() -> Value {
    let problem = |desc: &str| json!({"description": desc, "content": {"application/problem+json": {"schema": schema_ref("ProblemDetails")}}});
    json!({
        "BadRequest": problem("Malformed JSON, or a request body that could not be read."),
        "BadQuery": problem("A malformed query: an unknown parameter, one given twice, or a value that is not a number where one is expected."),
        "NotFound": problem("Unknown scene."),
        "TooLarge": problem("The body exceeds the size limit (16 MiB by default, --body-limit)."),
        "UnsupportedMediaType": problem("A body whose Content-Type is not JSON (application/json or …/…+json)."),
        "Invalid": problem("Well-formed JSON with invalid content: not an object, a repeated key, unknown fields, unknown light groups, surfaces, grids or cameras, a wrong emission length, NaN, infinite, negative or out-of-range values, a colour that is not three numbers; or a request too large for the memory budget."),
        "Unavailable": {
            "description": "The scene is still baking (with `progress`) or failed to load (with its error); or the server is shedding load, its memory budget is momentarily full, or the request did not finish within the time limit. Retry after the given seconds.",
            "headers": {"Retry-After": header("Seconds to wait before retrying.", json!({"type": "integer", "minimum": 0}), true)},
            "content": {"application/problem+json": {"schema": schema_ref("ProblemDetails")}}
        }
    })
}

/// Input schemas: what the handlers accept. Unknown fields are refused everywhere.
fn request_schemas(s: &mut Map<String, Value>) {
    let num = |lo: f64, hi: f64| json!({"type": "number", "minimum": lo, "maximum": hi});
    let triple = |item: Value, desc: &str| json!({"type": "array", "items": item, "minItems": 3, "maxItems": 3, "description": desc});
    s.insert(
        "Color".into(),
        triple(
            num(0.0, MAX_INTENSITY as f64),
            "Linear RGB colour filter, each channel in [0, 1e6].",
        ),
    );
    s.insert(
        "Position".into(),
        triple(
            num(-MAX_COORDINATE, MAX_COORDINATE),
            "A point, metres; each coordinate within ±1e6.",
        ),
    );
    let mut dir = triple(
        num(-MAX_F32, MAX_F32),
        "A direction (normalised by the server); not all zero.",
    );
    // "Some component is not zero" (spelt without `not`, which generators handle badly).
    dir["contains"] = json!({"anyOf": [{"exclusiveMinimum": 0}, {"exclusiveMaximum": 0}]});
    s.insert("Direction".into(), dir);
    s.insert(
        "LightSetting".into(),
        json!({"oneOf": [
            {"type": "number", "minimum": 0, "maximum": MAX_INTENSITY, "description": "Intensity (dimming factor; 1 = as modelled)."},
            {"type": "object", "additionalProperties": false, "properties": {
                "intensity": {"type": "number", "minimum": 0, "maximum": MAX_INTENSITY},
                "color": schema_ref("Color")}}]}),
    );
    s.insert(
        "Lights".into(),
        json!({"type": "object", "additionalProperties": schema_ref("LightSetting"),
            "description": "Light group id → setting. Groups left out keep their defaults. Unknown groups are a 422."}),
    );
    let exitance = triple(
        num(0.0, MAX_EMISSION),
        "Emitted exitance [r, g, b], lm/m², each in [0, 1e9].",
    );
    s.insert(
        "Emission".into(),
        json!({
            "description": "Factored mode only: per-patch emitted exitance (lm/m²), dense (one [r,g,b] per patch, exactly as many as the scene has patches) or sparse (patch index → [r,g,b]). Replaces the light groups.",
            "oneOf": [
                {"type": "array", "items": exitance},
                {"type": "object", "propertyNames": {"pattern": "^(0|[1-9][0-9]*)$"}, "additionalProperties": exitance}
            ]}),
    );
    // Every lighting request takes `lights` or `emission`, never both.
    let lighting = |mut props: Map<String, Value>, desc: &str| -> Value {
        props.insert("lights".into(), schema_ref("Lights"));
        props.insert("emission".into(), schema_ref("Emission"));
        json!({"type": "object", "additionalProperties": false, "description": desc,
            "properties": props, "not": {"required": ["lights", "emission"]}})
    };
    let names = |desc: &str| json!({"type": "array", "items": {"type": "string"}, "uniqueItems": true, "description": desc});
    s.insert(
        "LightingState".into(),
        lighting(
            Map::new(),
            "Group settings (`lights`) or, in factored mode, a per-patch `emission`; not both.",
        ),
    );
    let mut p = Map::new();
    p.insert("surfaces".into(), json!({"type": "boolean", "default": false, "description": "Also return per-surface area-weighted averages."}));
    p.insert("quantity".into(), json!({"type": "string", "enum": ["radiosity", "illuminance"], "default": "radiosity",
        "description": "radiosity: B, lm/m² leaving each patch; illuminance: H, lux arriving at each patch."}));
    s.insert(
        "RadiosityRequest".into(),
        lighting(p, "A lighting state and what to return."),
    );
    let mut p = Map::new();
    p.insert(
        "surfaces".into(),
        names("Surfaces to report (default: all when no points or grids are asked for)."),
    );
    p.insert("points".into(), json!({"type": "array", "maxItems": MAX_POINTS,
        "description": "Receivers, e.g. [{\"position\": [0.278, 0.1, 0.278], \"normal\": [0, 1, 0]}]. Each point gathers from every patch it sees: thousands of points take seconds.",
        "items": {
        "type": "object", "required": ["position", "normal"], "additionalProperties": false,
        "properties": {"position": schema_ref("Position"), "normal": schema_ref("Direction")}}}));
    p.insert(
        "grids".into(),
        names("Calculation grid ids from scene.toml."),
    );
    s.insert(
        "IlluminanceRequest".into(),
        lighting(p, "A lighting state and where to report illuminance."),
    );
    let mut p = Map::new();
    p.insert("camera".into(), json!({"oneOf": [
        {"type": "string", "description": "Preset id from scene.toml."},
        {"type": "object", "required": ["position", "target", "fov_deg"], "additionalProperties": false,
         "description": "A full camera. The target must differ from the position, and up must not be parallel to the view direction.",
         "properties": {"position": schema_ref("Position"), "target": schema_ref("Position"),
            "up": {"allOf": [schema_ref("Direction")], "default": [0, 1, 0]},
            "fov_deg": {"type": "number", "minimum": MIN_FOV_DEG, "maximum": MAX_FOV_DEG, "description": "Vertical field of view, degrees."}}}],
        "description": "Default: the scene's first preset."}));
    let side = json!({"type": "integer", "minimum": 1, "maximum": MAX_SIDE, "default": 512});
    p.insert("width".into(), side.clone());
    p.insert("height".into(), side);
    p.insert("exposure".into(), schema_ref("Exposure"));
    p.insert(
        "format".into(),
        json!({"type": "string", "enum": ["png", "jpeg", "jpg", "exr"], "default": "png"}),
    );
    p.insert("mode".into(), json!({"type": "string", "enum": ["shaded", "falsecolor"], "default": "shaded",
        "description": "falsecolor maps illuminance (lux) on a log scale, with a legend bar labelled in lux at the right edge; the range is in the X-Relight-Falsecolor-Lux header. It is an 8-bit image: not with format exr."}));
    p.insert(
        "tonemap".into(),
        json!({"type": "string", "enum": ["filmic", "clamp"], "default": "filmic"}),
    );
    p.insert("range".into(), json!({"type": "array", "minItems": 2, "maxItems": 2,
        "items": num(MIN_RANGE_LUX, MAX_RANGE_LUX),
        "description": "False-colour range [low, high] in lux, high ≥ 1.01 × low (default: max/100 to max)."}));
    let mut render = lighting(p, "A lighting state, a camera and the image to make.");
    render["allOf"] = json!([{"not": {"required": ["mode", "format"],
        "properties": {"mode": {"const": "falsecolor"}, "format": {"const": "exr"}}}}]);
    s.insert("RenderRequest".into(), render);
    s.insert("Exposure".into(), json!({
        "description": "Stops (2^exposure scales radiance), within ±40, or \"auto\" (default): log-average luminance to middle grey.",
        "oneOf": [{"type": "number", "minimum": -40, "maximum": 40}, {"type": "string", "const": "auto"}]}));
    s.insert("BatchRequest".into(), json!({
        "type": "object", "required": ["states"], "additionalProperties": false,
        "properties": {
            "states": {"type": "array", "minItems": 1, "maxItems": MAX_BATCH, "items": schema_ref("LightingState")},
            "surfaces": names("Surfaces to report (default: all)."),
            "radiosity": {"type": "boolean", "default": false, "description": "Also return per-patch radiosity for each state."},
            "grids": names("Grid ids: also return grid statistics for each state (light-group states only).")}}));
    s.insert("OptimizeRequest".into(), json!({
        "type": "object", "required": ["targets"], "additionalProperties": false,
        "properties": {
            "targets": {"type": "array", "minItems": 1, "description": "At most one target per grid.", "items": {
                "type": "object", "required": ["grid"], "additionalProperties": false,
                "description": "At least one bound; u0_min needs a positive eavg_min or emin_min as well.",
                "anyOf": [{"required": ["eavg_min"]}, {"required": ["emin_min"]}, {"required": ["u0_min"]}],
                "properties": {
                    "grid": {"type": "string"},
                    "eavg_min": {"type": "number", "minimum": 0, "maximum": 1e6, "description": "lx"},
                    "emin_min": {"type": "number", "minimum": 0, "maximum": 1e6, "description": "lx"},
                    "u0_min": {"type": "number", "minimum": 0, "maximum": 1, "description": "Emin/Eavg"}}}},
            "groups": {"type": "array", "minItems": 1, "uniqueItems": true, "items": {"type": "string"}, "description": "Groups the optimizer may dim (default: all)."},
            "lights": {"allOf": [schema_ref("Lights")], "description": "State of the groups that are not free."}}}));
}

/// Output schemas: what the handlers return.
fn response_schemas(s: &mut Map<String, Value>) {
    let num = || json!({"type": "number"});
    let obj = |required: &[&str], props: Value| json!({"type": "object", "required": required, "additionalProperties": false, "properties": props});
    s.insert(
        "ProblemDetails".into(),
        json!({"type": "object", "required": ["type", "title", "status", "detail"], "additionalProperties": false,
            "description": "RFC 9457 problem document.",
            "properties": {
                "type": {"type": "string", "const": "about:blank"},
                "title": {"type": "string"},
                "status": {"type": "integer", "minimum": 400, "maximum": 599},
                "detail": {"type": "string"},
                "progress": {"type": "number", "minimum": 0, "maximum": 1, "description": "503 while a scene bakes: its progress."}}}),
    );
    s.insert(
        "Rgb".into(),
        json!({"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3}),
    );
    let vec3 = schema_ref("Rgb");
    let count = || json!({"type": "integer", "minimum": 0});
    s.insert(
        "GroupInfo".into(),
        obj(
            &[
                "id",
                "name",
                "intensity",
                "color",
                "emitting_area",
                "lumens",
                "luminaires",
                "watts",
            ],
            json!({
                "id": {"type": "string"}, "name": {"type": "string"},
                "intensity": {"type": "number", "description": "Default intensity."},
                "color": {"allOf": [vec3], "description": "Default colour."},
                "emitting_area": {"type": "number", "description": "m²"},
                "lumens": {"type": "number", "description": "Flux at intensity 1, colour white, lm."},
                "luminaires": count(),
                "watts": {"type": ["number", "null"], "description": "Electrical power of the luminaires at intensity 1, W, when every one gives it."}}),
        ),
    );
    s.insert(
        "SceneSummary".into(),
        obj(
            &["id", "name", "status", "progress"],
            json!({
                "id": {"type": "string"}, "name": {"type": "string"},
                "status": {"type": "string", "enum": ["queued", "baking", "ready", "failed"]},
                "progress": {"type": "number", "minimum": 0, "maximum": 1},
                "patches": {"type": "integer", "minimum": 0, "description": "Ready scenes."},
                "lights": {"type": "array", "items": schema_ref("GroupInfo"), "description": "Ready scenes."},
                "transfer": {"type": "string", "enum": ["factored", "columns"], "description": "Ready scenes."},
                "error": {"type": "string", "description": "Failed scenes."}}),
        ),
    );
    s.insert(
        "Readiness".into(),
        obj(
            &["ready", "scenes"],
            json!({"ready": {"type": "boolean"}, "scenes": {"type": "array", "items": schema_ref("SceneSummary")}}),
        ),
    );
    let range = obj(
        &["start", "end", "count"],
        json!({"start": count(), "end": count(), "count": count()}),
    );
    s.insert("SceneDetails".into(), obj(
        &["id", "name", "status", "patches", "transfer", "units", "bounds", "lights", "cameras", "luminaires", "grids", "surfaces", "bake"],
        json!({
            "id": {"type": "string"}, "name": {"type": "string"},
            "status": {"type": "string", "const": "ready"},
            "patches": count(),
            "transfer": {"type": "string", "enum": ["factored", "columns"]},
            "units": obj(&["length", "source_units", "scale_to_m", "radiosity", "illuminance", "flux"], json!({
                "length": {"type": "string"}, "source_units": {"type": "string"}, "scale_to_m": num(),
                "radiosity": {"type": "string"}, "illuminance": {"type": "string"}, "flux": {"type": "string"}})),
            "bounds": obj(&["min", "max"], json!({"min": vec3, "max": vec3})),
            "lights": {"type": "array", "items": schema_ref("GroupInfo")},
            "cameras": {"type": "array", "items": obj(&["id", "position", "target", "up", "fov_deg"], json!({
                "id": {"type": "string"}, "position": vec3, "target": vec3, "up": vec3, "fov_deg": num()}))},
            "luminaires": {"type": "array", "items": obj(&["id", "group", "position", "aim", "lumens", "watts", "distribution"], json!({
                "id": {"type": "string"}, "group": {"type": "string"}, "position": vec3, "aim": vec3,
                "lumens": num(), "watts": {"type": ["number", "null"]},
                "distribution": {"type": "string", "enum": ["isotropic", "spot", "ies"]}}))},
            "grids": {"type": "array", "items": obj(&["id", "name", "count", "layout", "normal", "points"], json!({
                "id": {"type": "string"}, "name": {"type": "string"}, "count": count(),
                "layout": {"oneOf": [{"type": "array", "items": count(), "minItems": 2, "maxItems": 2}, {"type": "null"}],
                    "description": "[columns, rows] of a work plane (x fastest), or null."},
                "normal": vec3, "points": {"type": "array", "items": vec3}}))},
            "surfaces": {"type": "array", "items": obj(&["id", "index", "area", "patches", "two_sided"], json!({
                "id": {"type": "string"}, "index": count(), "area": num(), "patches": range, "two_sided": {"type": "boolean"}}))},
            "bake": obj(&["seconds", "from_cache", "residual"], json!({
                "seconds": num(), "from_cache": {"type": "boolean"}, "residual": num()}))
        })));
    s.insert(
        "Patches".into(),
        obj(
            &["patches"],
            json!({"patches": {"type": "array", "items": obj(
        &["surface", "area", "centroid", "normal"],
        json!({"surface": {"type": "string"}, "area": num(), "centroid": vec3, "normal": vec3}))}}),
        ),
    );
    s.insert("RadiosityResponse".into(), json!({
        "type": "object", "required": ["scene", "patches", "unit"], "additionalProperties": false,
        "oneOf": [{"required": ["radiosity"]}, {"required": ["illuminance"]}],
        "properties": {
            "scene": {"type": "string"}, "patches": count(),
            "unit": {"type": "string", "enum": ["lm/m2", "lx"]},
            "radiosity": {"type": "array", "items": vec3, "description": "quantity = radiosity: B per patch, lm/m²."},
            "illuminance": {"type": "array", "items": vec3, "description": "quantity = illuminance: H per patch, lx."},
            "surfaces": {"type": "object", "description": "With surfaces = true.", "additionalProperties": obj(
                &["area", "radiosity", "illuminance"],
                json!({"area": num(), "radiosity": vec3, "illuminance": vec3}))}}}));
    s.insert(
        "Lux".into(),
        obj(&["lux", "rgb"], json!({"lux": num(), "rgb": vec3})),
    );
    s.insert(
        "SurfaceIlluminance".into(),
        obj(
            &["area", "avg", "min", "max", "uniformity"],
            json!({
        "area": num(), "avg": schema_ref("Lux"), "min": schema_ref("Lux"), "max": schema_ref("Lux"),
        "uniformity": {"type": "number", "description": "Emin / Eavg"}}),
        ),
    );
    s.insert("GridStats".into(), obj(
        &["name", "unit", "count", "layout", "avg", "min", "max", "u0", "min_max", "values"],
        json!({"name": {"type": "string"}, "unit": {"type": "string", "const": "lx"}, "count": count(),
            "layout": {"oneOf": [{"type": "array", "items": count(), "minItems": 2, "maxItems": 2}, {"type": "null"}],
                "description": "[columns, rows] of a work plane (x fastest), or null."},
            "values": {"type": "array", "items": num()}, "avg": num(), "min": num(), "max": num(),
            "u0": {"type": "number", "description": "Emin/Eavg"}, "min_max": {"type": "number", "description": "Emin/Emax"}})));
    s.insert("LuminairePower".into(), obj(&["luminaire_lumens", "luminaire_watts"], json!({
        "luminaire_lumens": num(),
        "luminaire_watts": {"type": ["number", "null"], "description": "null when some luminaire gives no watts."}})));
    let by_name = |item: Value| json!({"type": "object", "additionalProperties": item});
    s.insert("IlluminanceResponse".into(), obj(&["unit", "points", "surfaces", "grids", "power"], json!({
        "unit": {"type": "string", "const": "lx"},
        "points": {"type": "array", "items": schema_ref("Lux")},
        "surfaces": by_name(schema_ref("SurfaceIlluminance")),
        "grids": by_name(schema_ref("GridStats")),
        "power": {"oneOf": [schema_ref("LuminairePower"), {"type": "null"}],
            "description": "The luminaires' flux and power in this state; null for a per-patch emission with points."}})));
    s.insert("Power".into(), obj(
        &["emitted", "absorbed", "escaped", "emitted_lm", "absorbed_lm", "escaped_lm", "imbalance"],
        json!({"emitted": vec3, "absorbed": vec3, "escaped": vec3, "emitted_lm": num(), "absorbed_lm": num(),
            "escaped_lm": num(), "imbalance": num()})));
    s.insert("BatchResponse".into(), obj(&["unit", "results"], json!({
        "unit": obj(&["illuminance", "radiosity", "power"], json!({
            "illuminance": {"type": "string"}, "radiosity": {"type": "string"}, "power": {"type": "string"}})),
        "results": {"type": "array", "items": obj(&["surfaces", "power"], json!({
            "surfaces": by_name(schema_ref("SurfaceIlluminance")),
            "power": schema_ref("Power"),
            "radiosity": {"type": "array", "items": vec3, "description": "With radiosity = true."},
            "grids": {"allOf": [by_name(schema_ref("GridStats"))], "description": "With grids."}}))}})));
    let bound = || json!({"type": ["number", "null"]});
    s.insert("OptimizeResponse".into(), obj(&["lights", "lumens", "power", "targets", "grids", "solve_ms"], json!({
        "lights": by_name(obj(&["intensity", "color", "free"], json!({
            "intensity": num(), "color": vec3, "free": {"type": "boolean"}}))),
        "lumens": num(),
        "power": schema_ref("LuminairePower"),
        "targets": {"type": "array", "items": obj(&["grid", "eavg_min", "emin_min", "u0_min", "achieved", "met"], json!({
            "grid": {"type": "string"}, "eavg_min": bound(), "emin_min": bound(), "u0_min": bound(),
            "achieved": obj(&["avg", "min", "u0"], json!({"avg": num(), "min": num(), "u0": num()})),
            "met": {"type": "boolean"}}))},
        "grids": by_name(schema_ref("GridStats")),
        "solve_ms": num()})));
}

/// The spec document.
pub fn spec() -> Value {
    let mut paths = Map::new();
    service_paths(&mut paths);
    scene_get_paths(&mut paths);
    scene_post_paths(&mut paths);
    let mut schemas = Map::new();
    request_schemas(&mut schemas);
    response_schemas(&mut schemas);
    json!({
        "openapi": "3.1.0",
        "info": {
            "title": "relight",
            "version": env!("CARGO_PKG_VERSION"),
            "description": "Relights static scenes from a precomputed radiosity transfer. Units: radiosity and exitance in lm/m² (per linear RGB channel), illuminance in lux, flux in lumens, lengths in metres. The luminous value of an RGB triple is Y = 0.2126 R + 0.7152 G + 0.0722 B. Request bodies are JSON objects sent as application/json; repeated keys are refused. Errors are RFC 9457 problem documents."
        },
        "tags": [{"name": "scenes"}, {"name": "service"}],
        "paths": paths,
        "components": {
            "parameters": {"SceneId": {"name": "id", "in": "path", "required": true,
                "description": "Scene id: the scene's folder name, as listed by GET /api/scenes.",
                "schema": {"type": "string"}, "example": "cornell-box"}},
            "responses": responses(),
            "schemas": schemas
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refs<'a>(v: &'a Value, out: &mut Vec<&'a str>) {
        match v {
            Value::Object(m) => {
                for (k, x) in m {
                    match (k.as_str(), x) {
                        ("$ref", Value::String(r)) => out.push(r),
                        _ => refs(x, out),
                    }
                }
            }
            Value::Array(a) => a.iter().for_each(|x| refs(x, out)),
            _ => {}
        }
    }

    #[test]
    fn every_reference_resolves() {
        let s = spec();
        let mut all = vec![];
        refs(&s, &mut all);
        assert!(all.len() > 50);
        for r in all {
            let pointer = r.strip_prefix('#').expect("local reference");
            assert!(s.pointer(pointer).is_some(), "dangling {r}");
        }
    }

    #[test]
    fn scene_operations_document_their_errors() {
        let s = spec();
        let paths = s["paths"].as_object().unwrap();
        let mut posts = 0;
        for (path, item) in paths {
            for (method, op) in item.as_object().unwrap() {
                let codes = op["responses"].as_object().unwrap();
                assert!(codes.contains_key("200"), "{method} {path}");
                if path.starts_with("/api/scenes/{id}") {
                    for c in ["404", "503"] {
                        assert!(codes.contains_key(c), "{method} {path} lacks {c}");
                    }
                }
                if method == "post" {
                    posts += 1;
                    for c in ["400", "413", "415", "422", "503"] {
                        assert!(codes.contains_key(c), "{method} {path} lacks {c}");
                    }
                    let content = op["requestBody"]["content"].as_object().unwrap();
                    assert_eq!(content.keys().collect::<Vec<_>>(), ["application/json"]);
                }
            }
        }
        assert_eq!(posts, 5);
    }
}
