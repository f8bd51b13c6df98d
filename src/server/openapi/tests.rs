use std::collections::BTreeSet;

use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use axum::Router;
use http_body_util::BodyExt;
use tower::ServiceExt;

use super::*;
use crate::server::{router, AppState, ServerConfig};

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

#[test]
fn required_headers_are_marked() {
    let s = spec();
    for (path, method, status, name) in REQUIRED_HEADERS {
        let h = &s["paths"][path][method]["responses"][status]["headers"][name];
        assert_eq!(h["required"], true, "{method} {path} {status} {name}");
    }
    let retry = &s["components"]["responses"]["Unavailable"]["headers"]["Retry-After"];
    assert_eq!(retry["required"], true);
}

/// Whether `v` is valid against `schema` of `doc`, for the keywords the document uses;
/// `Err` says where not.
fn validate(doc: &Value, schema: &Value, v: &Value, at: &str) -> Result<(), String> {
    if let Some(r) = schema["$ref"].as_str() {
        let target = doc.pointer(r.strip_prefix('#').unwrap()).unwrap();
        return validate(doc, target, v, at);
    }
    let fail = |why: &str| Err(format!("{at}: {why} ({v})"));
    if let Some(t) = schema.get("type") {
        let types: Vec<&str> = match t {
            Value::Array(a) => a.iter().filter_map(Value::as_str).collect(),
            t => vec![t.as_str().unwrap()],
        };
        let ok = types.iter().any(|t| match *t {
            "null" => v.is_null(),
            "boolean" => v.is_boolean(),
            "integer" => v.is_u64() || v.is_i64(),
            "number" => v.is_number(),
            "string" => v.is_string(),
            "array" => v.is_array(),
            "object" => v.is_object(),
            _ => false,
        });
        if !ok {
            return fail(&format!("not of type {t}"));
        }
    }
    if let Some(e) = schema["enum"].as_array() {
        if !e.contains(v) {
            return fail("not in the enum");
        }
    }
    if let (Some(x), Some(lo)) = (v.as_f64(), schema["minimum"].as_f64()) {
        if x < lo {
            return fail("below the minimum");
        }
    }
    if let (Some(x), Some(hi)) = (v.as_f64(), schema["maximum"].as_f64()) {
        if x > hi {
            return fail("above the maximum");
        }
    }
    for (key, all) in [("oneOf", false), ("anyOf", false), ("allOf", true)] {
        if let Some(list) = schema[key].as_array() {
            let valid = list
                .iter()
                .filter(|s| validate(doc, s, v, at).is_ok())
                .count();
            let ok = match key {
                "oneOf" => valid == 1,
                _ if all => valid == list.len(),
                _ => valid > 0,
            };
            if !ok {
                return fail(&format!("fails {key}"));
            }
        }
    }
    if let (Some(a), Some(n)) = (v.as_array(), schema["minItems"].as_u64()) {
        if (a.len() as u64) < n {
            return fail("too few items");
        }
    }
    if let (Some(a), Some(n)) = (v.as_array(), schema["maxItems"].as_u64()) {
        if a.len() as u64 > n {
            return fail("too many items");
        }
    }
    if let (Some(a), Some(items)) = (v.as_array(), schema.get("items")) {
        for (i, x) in a.iter().enumerate() {
            validate(doc, items, x, &format!("{at}[{i}]"))?;
        }
    }
    if let Some(o) = v.as_object() {
        for r in schema["required"].as_array().into_iter().flatten() {
            if !o.contains_key(r.as_str().unwrap()) {
                return fail(&format!("lacks {r}"));
            }
        }
        let props = schema["properties"].as_object();
        for (k, x) in o {
            match (
                props.and_then(|p| p.get(k)),
                schema.get("additionalProperties"),
            ) {
                (Some(s), _) => validate(doc, s, x, &format!("{at}.{k}"))?,
                (None, Some(Value::Bool(false))) => return fail(&format!("has {k}")),
                (None, Some(s @ Value::Object(_))) => validate(doc, s, x, &format!("{at}.{k}"))?,
                _ => {}
            }
        }
    }
    Ok(())
}

fn check(name: &str, answer: impl serde::Serialize) {
    let doc = spec();
    let v = serde_json::to_value(answer).unwrap();
    let schema = json!({"$ref": format!("#/components/schemas/{name}")});
    if let Err(e) = validate(&doc, &schema, &v, name) {
        panic!("the schema {name} does not describe the answer: {e}");
    }
}

#[test]
fn the_validator_refuses_what_the_schemas_refuse() {
    let doc = spec();
    let lux = json!({"$ref": "#/components/schemas/Lux"});
    assert!(validate(&doc, &lux, &json!({"lux": 1.0, "rgb": [1, 1, 1]}), "").is_ok());
    for bad in [
        json!({"lux": 1.0}),
        json!({"lux": 1.0, "rgb": [1, 1]}),
        json!({"lux": "1", "rgb": [1, 1, 1]}),
        json!({"lux": 1.0, "rgb": [1, 1, 1], "more": 1}),
    ] {
        assert!(validate(&doc, &lux, &bad, "").is_err(), "{bad}");
    }
    let stats = json!({"$ref": "#/components/schemas/GridStats"});
    let grid = |unit: &str, layout: Value| {
        json!({"name": "g", "unit": unit, "count": 1, "layout": layout, "avg": 1, "min": 1,
               "max": 1, "u0": 1, "min_max": 1, "values": [1]})
    };
    assert!(validate(&doc, &stats, &grid("lx", json!([1, 1])), "").is_ok());
    assert!(validate(&doc, &stats, &grid("lx", Value::Null), "").is_ok());
    assert!(validate(&doc, &stats, &grid("lm", Value::Null), "").is_err());
    assert!(validate(&doc, &stats, &grid("lx", json!([1])), "").is_err());
}

/// Every object an answer reaches lists all its keys.
#[test]
fn answers_are_closed() {
    let s = spec();
    for name in [
        "SceneList",
        "SceneDetails",
        "GroupInfo",
        "BatchResponse",
        "Power",
    ] {
        let schema = &s["components"]["schemas"][name];
        assert_eq!(schema["additionalProperties"], false, "{name}");
    }
    let units = &s["components"]["schemas"]["SceneDetails"]["properties"]["units"];
    assert_eq!(units["additionalProperties"], false);
    // Requests keep their own rules.
    let radiosity = &s["components"]["schemas"]["RadiosityRequest"];
    assert_eq!(radiosity["additionalProperties"], false);
}

/// The model's answer types, with every optional part present and absent.
#[test]
fn answer_schemas_describe_the_model_types() {
    use crate::model::optimize::{Achieved, LevelAnswer, OptimizeAnswer, TargetAnswer};
    use crate::model::query::{GridAnswer, IlluminanceAnswer, LuminairePower};
    use crate::model::report::{Lux, PowerReport, SurfaceIlluminance};
    use crate::transport::transfer::Power;

    let group = crate::model::GroupInfo {
        id: "ceiling".into(),
        name: "Ceiling".into(),
        intensity: 1.0,
        color: [1.0, 0.9, 0.8],
        emitting_area: 0.1,
        lumens: 1000.0,
        luminaires: 0,
        watts: None,
    };
    check("GroupInfo", &group);
    check(
        "GroupInfo",
        crate::model::GroupInfo {
            watts: Some(10.0),
            ..group
        },
    );
    let grid = GridAnswer {
        name: "Desk".into(),
        unit: "lx",
        count: 2,
        layout: Some([2, 1]),
        avg: 1.0,
        min: 0.5,
        max: 1.5,
        u0: 0.5,
        min_max: 0.33,
        values: vec![0.5, 1.5],
    };
    check("GridStats", &grid);
    check(
        "GridStats",
        GridAnswer {
            layout: None,
            ..grid.clone()
        },
    );
    let lux = Lux::new([1.0, 2.0, 3.0]);
    let power = LuminairePower {
        luminaire_lumens: 100.0,
        luminaire_watts: Some(1.0),
    };
    let answer = IlluminanceAnswer {
        unit: "lx",
        points: vec![lux],
        surfaces: [(
            "floor".to_string(),
            SurfaceIlluminance {
                area: 1.0,
                avg: lux,
                min: lux,
                max: lux,
                uniformity: 1.0,
            },
        )]
        .into(),
        grids: [("desk".to_string(), grid.clone())].into(),
        power: Some(power),
    };
    check("IlluminanceResponse", &answer);
    check(
        "IlluminanceResponse",
        IlluminanceAnswer {
            power: None,
            ..answer
        },
    );
    let p = Power {
        emitted: [1.0; 3],
        absorbed: [0.5; 3],
        escaped: [0.5; 3],
    };
    check("Power", PowerReport::new(p));
    let optimized = OptimizeAnswer {
        lights: [(
            "ceiling".to_string(),
            LevelAnswer {
                intensity: 0.5,
                color: [1.0; 3],
                free: true,
            },
        )]
        .into(),
        lumens: 10.0,
        power: LuminairePower {
            luminaire_lumens: 10.0,
            luminaire_watts: None,
        },
        targets: vec![TargetAnswer {
            grid: "desk".into(),
            eavg_min: Some(500.0),
            emin_min: None,
            u0_min: None,
            achieved: Achieved {
                avg: 500.0,
                min: 300.0,
                u0: 0.6,
            },
            met: true,
        }],
        grids: [("desk".to_string(), grid)].into(),
        solve_ms: 1.0,
    };
    check("OptimizeResponse", optimized);
}

/// A small room with every kind of thing an answer lists: an emissive light group and a
/// luminaire group (one luminaire with watts, one without), a two-sided surface, a work
/// plane and a list of points, a camera. Patches of 2 m: a few dozen.
fn small_room(dir: &std::path::Path) {
    fn quad(name: &str, mat: &str, p: [[f64; 3]; 4]) -> String {
        let mut s = format!("o {name}\nusemtl {mat}\n");
        for v in p {
            s += &format!("v {} {} {}\n", v[0], v[1], v[2]);
        }
        s + "f -4 -3 -2 -1\n"
    }
    // Corners counter-clockwise seen from the front (inside the room).
    let (x, y, z) = (4.0, 3.0, 4.0);
    let obj = [
        quad(
            "floor",
            "white",
            [[0., 0., 0.], [0., 0., z], [x, 0., z], [x, 0., 0.]],
        ),
        quad(
            "ceiling",
            "white",
            [[0., y, 0.], [x, y, 0.], [x, y, z], [0., y, z]],
        ),
        quad(
            "west",
            "white",
            [[0., 0., 0.], [0., y, 0.], [0., y, z], [0., 0., z]],
        ),
        quad(
            "east",
            "white",
            [[x, 0., 0.], [x, 0., z], [x, y, z], [x, y, 0.]],
        ),
        quad(
            "north",
            "white",
            [[0., 0., 0.], [x, 0., 0.], [x, y, 0.], [0., y, 0.]],
        ),
        quad(
            "south",
            "white",
            [[0., 0., z], [0., y, z], [x, y, z], [x, 0., z]],
        ),
        quad(
            "panel",
            "light",
            [
                [1.5, 2.9, 1.5],
                [2.5, 2.9, 1.5],
                [2.5, 2.9, 2.5],
                [1.5, 2.9, 2.5],
            ],
        ),
        quad(
            "shelf",
            "white",
            [
                [0.5, 1., 0.5],
                [0.5, 1., 1.5],
                [1.5, 1., 1.5],
                [1.5, 1., 0.5],
            ],
        ),
    ]
    .concat();
    let mtl = "newmtl white\nKd 0.7 0.7 0.7\nnewmtl light\nKd 0 0 0\nKe 10 10 10\n";
    let toml = r#"
name = "Small room"
units = "m"
transfer = "factored"
[mesh]
max_edge = 2.0
[surface.shelf]
two_sided = true
[[lights]]
id = "panel"
name = "Ceiling panel"
surfaces = ["panel"]
[[lights]]
id = "lamps"
name = "Lamps"
intensity = 0.9
color = [1.0, 0.9, 0.8]
[[luminaires]]
id = "bulb"
group = "lamps"
position = [3, 2, 3]
lumens = 800
watts = 8
[[luminaires]]
id = "spot"
group = "lamps"
position = [1, 2.5, 3]
distribution = "spot"
beam_deg = 30
field_deg = 60
lumens = 500
[[grids]]
id = "desk"
name = "Desk"
min = [0.5, 0.5]
max = [3.5, 3.5]
height = 0.75
spacing = 1.0
[[grids]]
id = "probes"
points = [[2, 0.5, 2], [3, 0.5, 1]]
[[cameras]]
id = "door"
position = [3.5, 1.6, 0.5]
target = [2, 1, 2]
fov_deg = 60
"#;
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join("scene.obj"), format!("mtllib scene.mtl\n{obj}")).unwrap();
    std::fs::write(dir.join("scene.mtl"), mtl).unwrap();
    std::fs::write(dir.join("scene.toml"), toml).unwrap();
}

/// Sends requests to a router and checks every answer against what the document says of
/// its operation, status and content type.
struct Client {
    app: Router,
    doc: Value,
    /// (path, method, status) of the JSON answers checked.
    checked: BTreeSet<(String, String, u16)>,
}

impl Client {
    /// `path` is the operation's path in the document; `uri` the request's.
    async fn send(
        &mut self,
        method: &str,
        path: &str,
        uri: &str,
        body: Option<Value>,
    ) -> (StatusCode, Value) {
        let req = Request::builder()
            .method(method.to_uppercase().as_str())
            .uri(uri);
        let req = match body {
            Some(b) => req
                .header(header::CONTENT_TYPE, "application/json")
                .body(Body::from(b.to_string())),
            None => req.body(Body::empty()),
        };
        let resp = self.app.clone().oneshot(req.unwrap()).await.unwrap();
        let status = resp.status();
        let ctype = resp.headers()[header::CONTENT_TYPE]
            .to_str()
            .unwrap()
            .to_string();
        let bytes = resp.into_body().collect().await.unwrap().to_bytes();
        let what = format!("{method} {uri} → {status} {ctype}");
        let op = &self.doc["paths"][path][method];
        assert!(op.is_object(), "{what}: no such operation");
        let mut answer = &op["responses"][status.as_str()];
        if let Some(r) = answer["$ref"].as_str() {
            answer = self.doc.pointer(r.strip_prefix('#').unwrap()).unwrap();
        }
        let media = ctype.split(';').next().unwrap().trim();
        let content = &answer["content"][media];
        assert!(content.is_object(), "{what}: undocumented answer");
        if !media.ends_with("json") {
            return (status, Value::Null);
        }
        let v: Value = serde_json::from_slice(&bytes).unwrap();
        if let Err(e) = validate(&self.doc, &content["schema"], &v, "answer") {
            panic!("{what}: the document does not describe the answer: {e}");
        }
        self.checked
            .insert((path.to_string(), method.to_string(), status.as_u16()));
        (status, v)
    }
}

/// Real answers of every operation, through the router, against the document: the
/// schemas derived from the answer types must describe what those types serialize to,
/// with each optional part present and absent.
#[tokio::test]
async fn real_answers_match_the_document() {
    let root = tempfile::tempdir().unwrap();
    let scenes = root.path().join("scenes");
    small_room(&scenes.join("room"));
    // A scene that fails to load.
    std::fs::create_dir_all(scenes.join("broken")).unwrap();
    std::fs::write(scenes.join("broken/scene.obj"), "v 0 0 0\nf 1 2 3\n").unwrap();
    let config = ServerConfig {
        scenes,
        cache: root.path().join("cache"),
        ..ServerConfig::default()
    };
    let state = AppState::new(config).unwrap();
    let mut c = Client {
        app: router(state.clone()),
        doc: spec(),
        checked: BTreeSet::new(),
    };
    // Queued.
    let (s, v) = c.send("get", "/readyz", "/readyz", None).await;
    assert_eq!(
        (s, &v["ready"]),
        (StatusCode::SERVICE_UNAVAILABLE, &json!(false))
    );
    c.send("get", "/api/scenes", "/api/scenes", None).await;
    let (s, _) = c
        .send("get", "/api/scenes/{id}", "/api/scenes/room", None)
        .await;
    assert_eq!(s, StatusCode::SERVICE_UNAVAILABLE);
    tokio::task::spawn_blocking({
        let state = state.clone();
        move || state.bake_all()
    })
    .await
    .unwrap();
    let (s, v) = c.send("get", "/readyz", "/readyz", None).await;
    assert_eq!(s, StatusCode::OK);
    let statuses: Vec<&Value> = v["scenes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| &s["status"])
        .collect();
    assert_eq!(statuses, ["failed", "ready"], "{v}");
    c.send("get", "/api/scenes", "/api/scenes", None).await;
    let (s, _) = c
        .send("get", "/api/scenes/{id}", "/api/scenes/broken", None)
        .await;
    assert_eq!(s, StatusCode::SERVICE_UNAVAILABLE);
    let (s, _) = c
        .send("get", "/api/scenes/{id}", "/api/scenes/atlantis", None)
        .await;
    assert_eq!(s, StatusCode::NOT_FOUND);

    let (s, v) = c
        .send("get", "/api/scenes/{id}", "/api/scenes/room", None)
        .await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(v["luminaires"].as_array().unwrap().len(), 2);
    assert_eq!(v["grids"][0]["layout"], json!([3, 3]), "{}", v["grids"]);
    assert!(v["grids"][1]["layout"].is_null());
    assert!(v["lights"][1]["watts"].is_null());
    let surfaces = v["surfaces"].as_array().unwrap();
    assert!(surfaces.iter().any(|s| s["two_sided"] == true));
    c.send(
        "get",
        "/api/scenes/{id}/patches",
        "/api/scenes/room/patches",
        None,
    )
    .await;

    let radiosity = "/api/scenes/{id}/radiosity";
    let uri = "/api/scenes/room/radiosity";
    c.send("post", radiosity, uri, Some(json!({}))).await;
    let (_, v) = c
        .send(
            "post",
            radiosity,
            uri,
            Some(json!({"quantity": "illuminance", "surfaces": true})),
        )
        .await;
    assert!(v["surfaces"].is_object() && v["illuminance"].is_array());
    let emission = json!({"emission": {"0": [1, 1, 1]}, "surfaces": true});
    c.send("post", radiosity, uri, Some(emission)).await;
    let (s, _) = c
        .send("post", radiosity, uri, Some(json!({"lights": {"nope": 1}})))
        .await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);

    let illuminance = "/api/scenes/{id}/illuminance";
    let uri = "/api/scenes/room/illuminance";
    let (_, v) = c
        .send(
            "post",
            illuminance,
            uri,
            Some(json!({"grids": ["desk", "probes"]})),
        )
        .await;
    assert!(v["power"].is_object());
    let points = json!([{"position": [2, 1, 2], "normal": [0, 1, 0]}]);
    let (_, v) = c
        .send(
            "post",
            illuminance,
            uri,
            Some(json!({"emission": {"0": [1, 1, 1]}, "points": points})),
        )
        .await;
    assert!(
        v["power"].is_null() && v["points"].as_array().unwrap().len() == 1,
        "{v}"
    );

    let batch = json!({"states": [{}, {"lights": {"lamps": 0.5}}], "surfaces": ["floor"], "radiosity": true, "grids": ["desk"]});
    let (_, v) = c
        .send(
            "post",
            "/api/scenes/{id}/batch",
            "/api/scenes/room/batch",
            Some(batch),
        )
        .await;
    assert!(v["results"][1]["radiosity"].is_array() && v["results"][1]["grids"].is_object());
    let batch = json!({"states": [{"emission": {"0": [1, 1, 1]}}]});
    let (_, v) = c
        .send(
            "post",
            "/api/scenes/{id}/batch",
            "/api/scenes/room/batch",
            Some(batch),
        )
        .await;
    let plain = v["results"][0].as_object().unwrap();
    assert!(
        !plain.contains_key("radiosity") && !plain.contains_key("grids"),
        "{v}"
    );

    let targets = json!({"targets": [{"grid": "desk", "eavg_min": 1.0, "u0_min": 0.1}]});
    c.send(
        "post",
        "/api/scenes/{id}/optimize",
        "/api/scenes/room/optimize",
        Some(targets),
    )
    .await;

    // Every operation's JSON answer was checked.
    for (path, item) in c.doc["paths"].as_object().unwrap() {
        for (method, op) in item.as_object().unwrap() {
            let json_ok = op["responses"]["200"]["content"]
                .as_object()
                .is_some_and(|m| m.contains_key("application/json"));
            let key = (path.clone(), method.clone(), 200);
            if json_ok && path != "/api/openapi.json" {
                assert!(
                    c.checked.contains(&key),
                    "{method} {path}: no answer checked"
                );
            }
        }
    }
}
