//! The OpenAPI 3 description of the API, served at `/api/openapi.json`.

use serde_json::{json, Value};

fn problem(desc: &str) -> Value {
    json!({"description": desc, "content": {"application/problem+json": {"schema": {"$ref": "#/components/schemas/Problem"}}}})
}

fn scene_id() -> Value {
    json!({"name": "id", "in": "path", "required": true, "description": "Scene id: the scene's folder name.", "schema": {"type": "string"}})
}

fn errors() -> Value {
    json!({
        "400": problem("Malformed JSON."),
        "404": problem("Unknown scene."),
        "413": problem("Body over the size limit."),
        "415": problem("Content type is not JSON."),
        "422": problem("Invalid content: unknown light group or surface, wrong emission length, NaN, infinite, negative or too large values, a colour that is not three numbers."),
        "503": problem("The scene is still baking (with `progress`) or failed to load (with its error).")
    })
}

/// The spec document.
pub fn spec() -> Value {
    let mut radiosity_resp = errors();
    radiosity_resp["200"] = json!({
        "description": "Per-patch radiosity in lm/m² (or, with quantity = illuminance, incident illuminance in lux), in patch order.",
        "content": {
            "application/json": {"schema": {"$ref": "#/components/schemas/RadiosityResponse"}},
            "application/octet-stream": {"schema": {"type": "string", "format": "binary",
                "description": "n × 3 little-endian f32: [r, g, b] radiosity (lm/m²) or illuminance (lx) of each patch in patch order. Header X-Relight-Patches gives n."}}
        }
    });
    let mut illum_resp = errors();
    illum_resp["200"] = json!({"description": "Illuminance answers in lux.",
        "content": {"application/json": {"schema": {"$ref": "#/components/schemas/IlluminanceResponse"}}}});
    let mut batch_resp = errors();
    batch_resp["200"] = json!({"description": "One result per state, in request order.",
        "content": {"application/json": {"schema": {"type": "object", "properties": {
            "results": {"type": "array", "items": {"type": "object", "properties": {
                "surfaces": {"type": "object", "additionalProperties": {"$ref": "#/components/schemas/SurfaceIlluminance"}},
                "power": {"$ref": "#/components/schemas/Power"},
                "radiosity": {"type": "array", "items": {"$ref": "#/components/schemas/Rgb"}}}}}}}}}});
    let mut render_resp = errors();
    render_resp["200"] = json!({"description": "The encoded image. Headers: X-Relight-Render-Ms (server time), X-Relight-Exposure (stops used), X-Relight-Falsecolor-Lux (low,high of the log scale).",
        "content": {"image/png": {}, "image/jpeg": {}, "image/x-exr": {"description": "Linear radiance B/π, lm/(m²·sr), 32-bit float RGB."}}});
    json!({
        "openapi": "3.0.3",
        "info": {
            "title": "relight",
            "version": env!("CARGO_PKG_VERSION"),
            "description": "Relights static scenes from a precomputed radiosity transfer. Units: radiosity and exitance in lm/m² (per linear RGB channel), illuminance in lux, flux in lumens, lengths in metres. The luminous value of an RGB triple is Y = 0.2126 R + 0.7152 G + 0.0722 B. Errors are RFC 9457 problem documents."
        },
        "paths": {
            "/healthz": {"get": {"summary": "Liveness: 200 while the process is up.", "responses": {"200": {"description": "ok", "content": {"text/plain": {}}}}}},
            "/readyz": {"get": {"summary": "Readiness: 200 once every scene is ready or failed, else 503 with progress.",
                "responses": {"200": {"description": "All scenes settled.", "content": {"application/json": {}}}, "503": {"description": "Some scene is still baking.", "content": {"application/json": {}}}}}},
            "/metrics": {"get": {"summary": "Prometheus metrics: requests and latency per route, bake times.", "responses": {"200": {"description": "Text exposition format.", "content": {"text/plain": {}}}}}},
            "/api/scenes": {"get": {"summary": "All scenes with status (queued, baking with progress 0..1, ready, failed with error), patch count and light groups.",
                "responses": {"200": {"description": "Scene list.", "content": {"application/json": {"schema": {"type": "object", "properties": {"scenes": {"type": "array", "items": {"$ref": "#/components/schemas/SceneSummary"}}}}}}}}}},
            "/api/scenes/{id}": {"get": {"summary": "Light groups, cameras, surfaces (with patch ranges), bounds, units and transfer mode of a scene.",
                "parameters": [scene_id()], "responses": {"200": {"description": "Scene details.", "content": {"application/json": {}}}, "404": problem("Unknown scene."), "503": problem("Baking or failed.")}}},
            "/api/scenes/{id}/patches": {"get": {"summary": "Per patch: surface, area (m²), centroid and normal (m).",
                "parameters": [scene_id()],
                "responses": {"200": {"description": "Patches in patch order.", "content": {
                    "application/json": {},
                    "application/octet-stream": {"schema": {"type": "string", "format": "binary",
                        "description": "32 bytes per patch, little-endian: u32 surface index, f32 area, f32×3 centroid, f32×3 unit normal."}}}},
                    "404": problem("Unknown scene."), "503": problem("Baking or failed.")}}},
            "/api/scenes/{id}/mesh": {"get": {"summary": "The shading mesh for client-side drawing: vertices, triangles (one per patch), surface per triangle, and per-vertex patch weights (vertex colour = Σ weight · B[patch]).",
                "parameters": [scene_id()],
                "responses": {"200": {"description": "One binary buffer.", "content": {
                    "application/octet-stream": {"schema": {"type": "string", "format": "binary",
                        "description": "Little-endian: \"RLMESH01\"; u32 nv, nt, nw; f32 position[nv][3] (m); u32 triangle[nt][3] (counter-clockwise from the lit side); u32 surface[nt]; u32 start[nv+1]; u32 patch[nw]; f32 weight[nw]."}}}},
                    "404": problem("Unknown scene."), "503": problem("Baking or failed.")}}},
            "/api/scenes/{id}/radiosity": {"post": {"summary": "Per-patch radiosity for a lighting state (group settings, or a per-patch emission in factored mode).",
                "parameters": [scene_id()],
                "requestBody": {"required": false, "content": {"application/json": {"schema": {"$ref": "#/components/schemas/RadiosityRequest"}}}},
                "responses": radiosity_resp}},
            "/api/scenes/{id}/illuminance": {"post": {"summary": "Illuminance per surface (avg, min, max, uniformity), at points (direct light of the luminaires plus light gathered from the solved patches, with occlusion), and on calculation grids (Eavg, Emin, Emax, U0, Emin/Emax), with the luminaires' lumens and watts.",
                "parameters": [scene_id()],
                "requestBody": {"required": false, "content": {"application/json": {"schema": {"$ref": "#/components/schemas/IlluminanceRequest"}}}},
                "responses": illum_resp}},
            "/api/scenes/{id}/render": {"post": {"summary": "A relit image from a camera preset or a full camera.",
                "parameters": [scene_id()],
                "requestBody": {"required": false, "content": {"application/json": {"schema": {"$ref": "#/components/schemas/RenderRequest"}}}},
                "responses": render_resp.clone()}},
            "/api/scenes/{id}/render.png": {"get": {"summary": "A relit PNG for quick use from a browser or curl, e.g. ?camera=front&w=512&h=512&light.ceiling=0.5 (light.ID=r,g,b for a colour; exposure=auto|stops; mode=shaded|falsecolor; tonemap=filmic|clamp).",
                "parameters": [scene_id(),
                    {"name": "camera", "in": "query", "schema": {"type": "string"}},
                    {"name": "w", "in": "query", "schema": {"type": "integer", "maximum": 4096}},
                    {"name": "h", "in": "query", "schema": {"type": "integer", "maximum": 4096}},
                    {"name": "exposure", "in": "query", "schema": {"type": "string"}},
                    {"name": "mode", "in": "query", "schema": {"type": "string", "enum": ["shaded", "falsecolor"]}}],
                "responses": render_resp}},
            "/api/scenes/{id}/batch": {"post": {"summary": "Up to 1000 lighting states in one request, each with surface illuminance statistics and the power balance.",
                "parameters": [scene_id()],
                "requestBody": {"required": true, "content": {"application/json": {"schema": {"type": "object", "required": ["states"], "properties": {
                    "states": {"type": "array", "maxItems": 1000, "items": {"$ref": "#/components/schemas/LightingState"}},
                    "surfaces": {"type": "array", "items": {"type": "string"}, "description": "Surfaces to report (default: all)."},
                    "radiosity": {"type": "boolean", "description": "Also return per-patch radiosity for each state."},
                    "grids": {"type": "array", "items": {"type": "string"}, "description": "Grid ids: also return grid statistics for each state (light-group states only)."}}}}}},
                "responses": batch_resp}},
            "/api/scenes/{id}/optimize": {"post": {"summary": "Dimming levels (0..1 per free group, modelled colours) that meet grid targets with the least emitted flux: a linear program over the precomputed grid responses. 422 explains unreachable targets.",
                "parameters": [scene_id()],
                "requestBody": {"required": true, "content": {"application/json": {"schema": {"type": "object", "required": ["targets"], "properties": {
                    "targets": {"type": "array", "minItems": 1, "items": {"type": "object", "required": ["grid"], "additionalProperties": false, "properties": {
                        "grid": {"type": "string"}, "eavg_min": {"type": "number", "description": "lx"}, "emin_min": {"type": "number", "description": "lx"}, "u0_min": {"type": "number", "minimum": 0, "maximum": 1, "description": "Emin/Eavg"}}}},
                    "groups": {"type": "array", "items": {"type": "string"}, "description": "Groups the optimizer may dim (default: all)."},
                    "lights": {"type": "object", "additionalProperties": {"$ref": "#/components/schemas/LightSetting"}, "description": "State of the groups that are not free."}}}}}},
                "responses": {"200": {"description": "Levels as a lights object (intensity, color, free), total lumens, luminaire power (lm, W), per target the achieved avg/min/u0 and met, grid statistics, solve_ms.", "content": {"application/json": {}}},
                    "404": problem("Unknown scene."), "422": problem("Invalid targets, or targets out of reach (with the reason)."), "503": problem("Baking or failed.")}}}
        },
        "components": {"schemas": {
            "Rgb": {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3},
            "Problem": {"type": "object", "properties": {"type": {"type": "string"}, "title": {"type": "string"}, "status": {"type": "integer"}, "detail": {"type": "string"}, "progress": {"type": "number"}}},
            "LightSetting": {"oneOf": [
                {"type": "number", "minimum": 0, "description": "Intensity (dimming factor; 1 = as modelled)."},
                {"type": "object", "additionalProperties": false, "properties": {"intensity": {"type": "number", "minimum": 0}, "color": {"$ref": "#/components/schemas/Rgb"}}}]},
            "LightingState": {"type": "object", "additionalProperties": false, "properties": {
                "lights": {"type": "object", "additionalProperties": {"$ref": "#/components/schemas/LightSetting"}, "description": "Group id → setting. Groups left out keep their defaults."},
                "emission": {"description": "Factored mode only: per-patch emitted exitance (lm/m²), dense (one [r,g,b] per patch) or sparse (patch index → [r,g,b]). Replaces the light groups.",
                    "oneOf": [{"type": "array", "items": {"$ref": "#/components/schemas/Rgb"}}, {"type": "object", "additionalProperties": {"$ref": "#/components/schemas/Rgb"}}]}}},
            "RadiosityRequest": {"allOf": [{"$ref": "#/components/schemas/LightingState"}, {"type": "object", "properties": {"surfaces": {"type": "boolean", "description": "Also return per-surface area-weighted averages."},
                "quantity": {"type": "string", "enum": ["radiosity", "illuminance"], "default": "radiosity", "description": "radiosity: B, lm/m² leaving each patch; illuminance: H, lux arriving at each patch."}}}]},
            "RadiosityResponse": {"type": "object", "properties": {"scene": {"type": "string"}, "patches": {"type": "integer"}, "unit": {"type": "string"},
                "radiosity": {"type": "array", "items": {"$ref": "#/components/schemas/Rgb"}},
                "surfaces": {"type": "object", "additionalProperties": {"type": "object", "properties": {"area": {"type": "number"}, "radiosity": {"$ref": "#/components/schemas/Rgb"}, "illuminance": {"$ref": "#/components/schemas/Rgb"}}}}}},
            "IlluminanceRequest": {"allOf": [{"$ref": "#/components/schemas/LightingState"}, {"type": "object", "properties": {
                "surfaces": {"type": "array", "items": {"type": "string"}},
                "points": {"type": "array", "maxItems": 10000, "items": {"type": "object", "required": ["position", "normal"], "properties": {"position": {"$ref": "#/components/schemas/Rgb"}, "normal": {"$ref": "#/components/schemas/Rgb"}}}},
                "grids": {"type": "array", "items": {"type": "string"}, "description": "Calculation grid ids from scene.toml."}}}]},
            "RenderRequest": {"allOf": [{"$ref": "#/components/schemas/LightingState"}, {"type": "object", "properties": {
                "camera": {"oneOf": [{"type": "string", "description": "Preset id from scene.toml."},
                    {"type": "object", "required": ["position", "target", "fov_deg"], "properties": {"position": {"$ref": "#/components/schemas/Rgb"}, "target": {"$ref": "#/components/schemas/Rgb"}, "up": {"$ref": "#/components/schemas/Rgb"}, "fov_deg": {"type": "number", "description": "Vertical field of view."}}}]},
                "width": {"type": "integer", "minimum": 1, "maximum": 4096, "default": 512},
                "height": {"type": "integer", "minimum": 1, "maximum": 4096, "default": 512},
                "exposure": {"description": "Stops (2^exposure scales radiance), or \"auto\" (default): log-average luminance to middle grey.", "oneOf": [{"type": "number"}, {"type": "string", "enum": ["auto"]}]},
                "format": {"type": "string", "enum": ["png", "jpeg", "exr"], "default": "png"},
                "mode": {"type": "string", "enum": ["shaded", "falsecolor"], "default": "shaded", "description": "falsecolor maps illuminance (lux) on a log scale, with a legend bar labelled in lux at the right edge; the range is in the X-Relight-Falsecolor-Lux header."},
                "tonemap": {"type": "string", "enum": ["filmic", "clamp"], "default": "filmic"},
                "range": {"type": "array", "items": {"type": "number"}, "minItems": 2, "maxItems": 2, "description": "False-colour range in lux (default: max/100 to max)."}}}]},
            "Lux": {"type": "object", "properties": {"lux": {"type": "number"}, "rgb": {"$ref": "#/components/schemas/Rgb"}}},
            "SurfaceIlluminance": {"type": "object", "properties": {"area": {"type": "number"}, "avg": {"$ref": "#/components/schemas/Lux"}, "min": {"$ref": "#/components/schemas/Lux"}, "max": {"$ref": "#/components/schemas/Lux"}, "uniformity": {"type": "number", "description": "Emin / Eavg"}}},
            "IlluminanceResponse": {"type": "object", "properties": {"points": {"type": "array", "items": {"$ref": "#/components/schemas/Lux"}},
                "surfaces": {"type": "object", "additionalProperties": {"$ref": "#/components/schemas/SurfaceIlluminance"}},
                "grids": {"type": "object", "additionalProperties": {"$ref": "#/components/schemas/GridStats"}},
                "power": {"type": "object", "properties": {"luminaire_lumens": {"type": "number"}, "luminaire_watts": {"type": "number", "nullable": true}}}}},
            "GridStats": {"type": "object", "description": "Illuminance on a grid, lux.", "properties": {"name": {"type": "string"}, "count": {"type": "integer"}, "layout": {"type": "array", "items": {"type": "integer"}, "description": "[columns, rows] of a work plane (x fastest)."},
                "values": {"type": "array", "items": {"type": "number"}}, "avg": {"type": "number"}, "min": {"type": "number"}, "max": {"type": "number"}, "u0": {"type": "number", "description": "Emin/Eavg"}, "min_max": {"type": "number", "description": "Emin/Emax"}}},
            "Power": {"type": "object", "description": "Lumens per channel and luminous totals.", "properties": {"emitted": {"$ref": "#/components/schemas/Rgb"}, "absorbed": {"$ref": "#/components/schemas/Rgb"}, "escaped": {"$ref": "#/components/schemas/Rgb"}, "emitted_lm": {"type": "number"}, "absorbed_lm": {"type": "number"}, "escaped_lm": {"type": "number"}, "imbalance": {"type": "number"}}},
            "SceneSummary": {"type": "object", "properties": {"id": {"type": "string"}, "name": {"type": "string"}, "status": {"type": "string", "enum": ["queued", "baking", "ready", "failed"]}, "progress": {"type": "number"}, "patches": {"type": "integer"}, "error": {"type": "string"}, "lights": {"type": "array", "items": {"type": "object"}}}}
        }}
    })
}
