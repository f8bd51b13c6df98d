use std::collections::{BTreeMap, BTreeSet};

use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use axum::Router;
use http_body_util::BodyExt;
use tower::ServiceExt;

use super::*;
use crate::server::{router, AppState, ServerConfig};

mod contract;
mod real_answers;

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
            let success = match method.as_str() {
                "put" => "202",
                "delete" => "204",
                _ => "200",
            };
            assert!(codes.contains_key(success), "{method} {path}");
            if method == "put" || method == "delete" {
                for c in ["401", "403", "404", "409", "422"] {
                    assert!(codes.contains_key(c), "{method} {path} lacks {c}");
                }
                assert!(op["security"].is_array(), "{method} {path} needs a token");
            }
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
    assert_eq!(posts, 10);
}

#[test]
fn required_headers_are_marked() {
    let s = spec();
    let mut marked = 0;
    for (path, method, names) in REQUIRED_HEADERS {
        for name in *names {
            let path = format!("/api/scenes/{{id}}/{path}");
            let h = &s["paths"][&path][method]["responses"]["200"]["headers"][name];
            assert_eq!(h["required"], true, "{method} {path} {name}");
            marked += 1;
        }
    }
    assert_eq!(marked, 9);
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
               "max": 1, "u0": 1, "min_max": 1, "values": [1, null], "excluded": 1,
               "kind": "task", "spacing": 0.2})
    };
    assert!(validate(&doc, &stats, &grid("lx", json!([1, 1])), "").is_ok());
    assert!(validate(&doc, &stats, &grid("lx", Value::Null), "").is_ok());
    assert!(validate(&doc, &stats, &grid("lm", Value::Null), "").is_err());
    assert!(validate(&doc, &stats, &grid("lx", json!([1])), "").is_err());
    let mut unzoned = grid("lx", Value::Null);
    unzoned["kind"] = Value::Null;
    unzoned["spacing"] = Value::Null;
    assert!(validate(&doc, &stats, &unzoned, "").is_ok());
    unzoned["kind"] = json!("roof");
    assert!(
        validate(&doc, &stats, &unzoned, "").is_err(),
        "an unknown zone"
    );
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
        color: crate::color::Rgb::new(1.0, 0.9, 0.8),
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
        u0: Some(0.5),
        min_max: Some(0.33),
        note: None,
        values: vec![Some(0.5), Some(1.5), None],
        excluded: 1,
        kind: Some(crate::scene::grids::GridKind::Task),
        spacing: Some(0.2),
    };
    check("GridStats", &grid);
    // An unlit grid: no uniformity, and a note that says why.
    check(
        "GridStats",
        &GridAnswer {
            avg: 0.0,
            min: 0.0,
            max: 0.0,
            u0: None,
            min_max: None,
            note: Some(crate::model::grid::UNLIT_NOTE),
            values: vec![Some(0.0), Some(0.0), None],
            ..grid.clone()
        },
    );
    check(
        "GridStats",
        GridAnswer {
            layout: None,
            kind: None,
            spacing: None,
            ..grid.clone()
        },
    );
    let lux = Lux::new(crate::color::Rgb64::new(1.0, 2.0, 3.0));
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
        maintenance_factors: [("ceiling".to_string(), 0.8)].into(),
        maintained: crate::model::query::Maintained {
            points: vec![lux.scaled(0.8)],
            surfaces: BTreeMap::new(),
            grids: [("desk".to_string(), grid.scaled(0.8))].into(),
        },
        compliance: [("desk".to_string(), compliance())].into(),
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
        emitted: crate::color::Rgb64::ONE,
        absorbed: crate::color::Rgb64::splat(0.5),
        escaped: crate::color::Rgb64::splat(0.5),
    };
    check("Power", PowerReport::new(p));
    let optimized = OptimizeAnswer {
        lights: [(
            "ceiling".to_string(),
            LevelAnswer {
                intensity: 0.5,
                color: crate::color::Rgb::ONE,
                free: true,
            },
        )]
        .into(),
        installed: vec![crate::model::optimize::InstalledAnswer {
            id: "c0_0".into(),
            position: [1.0, 2.0, 3.0],
            photometry: "down.ies".into(),
            level: 0.5,
            lumens: 1250.0,
            watts: None,
        }],
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
            ugr_max: Some(19.0),
            achieved: Achieved {
                avg: 500.0,
                min: 300.0,
                u0: Some(0.6),
                ugr: Some(18.5),
            },
            met: true,
        }],
        grids: [("desk".to_string(), grid)].into(),
        solve_ms: 1.0,
    };
    check("OptimizeResponse", optimized);
}

/// A compliance answer with every kind of check: passed, failed and unknown.
fn compliance() -> crate::model::compliance::Compliance {
    use crate::model::compliance::{check, Achieved, ObserverUgr};
    let r = crate::scene::Requirements {
        em: Some(500.0),
        u0: Some(0.6),
        ugr_l: Some(19.0),
        ra: Some(80.0),
    };
    let observer = ObserverUgr {
        eye: [1.0, 1.2, 1.0],
        direction: [1.0, 0.0, 0.0],
        ugr: Some(20.0),
    };
    check(
        &r,
        &Achieved {
            em: Some(520.0),
            u0: None,
            observers: Some(vec![
                observer,
                ObserverUgr {
                    ugr: None,
                    ..observer
                },
            ]),
            ra: Err(vec!["ceiling".into()]),
        },
    )
}
