//! Property tests of request parsing: arbitrary JSON shaped like the API's requests (the
//! right field names, wrong and right types, hostile numbers and ids) and arbitrary bytes
//! at every POST endpoint, and arbitrary query strings at `render.png`. No request may
//! panic or answer 5xx; every refusal is a 4xx problem document with a short, precise
//! detail.

use std::sync::{Arc, OnceLock};

use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use http_body_util::BodyExt;
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use relight::server::{router, AppState, ServerConfig};
use serde_json::{Map, Value};
use tower::ServiceExt;

use crate::common;

/// Cases per endpoint.
const CASES: u32 = 256;

fn state() -> Arc<AppState> {
    static STATE: OnceLock<Arc<AppState>> = OnceLock::new();
    STATE
        .get_or_init(|| {
            let cache = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("http-cache");
            let s = AppState::new(ServerConfig {
                scenes: common::scenes_dir(),
                cache,
                ..ServerConfig::default()
            })
            .unwrap();
            common::bake_all(&s);
            s
        })
        .clone()
}

fn runtime() -> &'static tokio::runtime::Runtime {
    static RT: OnceLock<tokio::runtime::Runtime> = OnceLock::new();
    RT.get_or_init(|| tokio::runtime::Runtime::new().unwrap())
}

/// Sends one request; checks the answer's class and, for refusals, its problem document.
fn check(req: Request<Body>, what: &str) -> Result<u16, TestCaseError> {
    let resp = runtime().block_on(router(state()).oneshot(req)).unwrap();
    let status = resp.status();
    let ct = resp
        .headers()
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .unwrap_or("")
        .to_string();
    let body = runtime()
        .block_on(resp.into_body().collect())
        .unwrap()
        .to_bytes();
    prop_assert!(
        !status.is_server_error(),
        "{what}: {status} {}",
        String::from_utf8_lossy(&body)
    );
    if status.is_client_error() && status != StatusCode::METHOD_NOT_ALLOWED {
        prop_assert_eq!(ct.as_str(), "application/problem+json", "{}", what);
        let v: Value = serde_json::from_slice(&body).unwrap_or(Value::Null);
        let detail = v["detail"].as_str().unwrap_or("");
        prop_assert!(!detail.is_empty(), "{what}: no detail");
        prop_assert!(
            detail.len() < 1500,
            "{what}: a {}-byte detail",
            detail.len()
        );
        prop_assert_eq!(v["status"].as_u64(), Some(status.as_u16() as u64));
    }
    Ok(status.as_u16())
}

const KEYS: &[&str] = &[
    "lights",
    "emission",
    "surfaces",
    "points",
    "grids",
    "position",
    "normal",
    "camera",
    "width",
    "height",
    "exposure",
    "format",
    "mode",
    "tonemap",
    "range",
    "states",
    "targets",
    "grid",
    "eavg_min",
    "emin_min",
    "u0_min",
    "groups",
    "quantity",
    "radiosity",
    "intensity",
    "color",
    "fov_deg",
    "target",
    "up",
    "ceiling",
    "lamp",
    "window_row",
    "0",
    "1",
    "+1",
];

const STRINGS: &[&str] = &[
    "ceiling",
    "lamp",
    "window_row",
    "corridor_row",
    "desk",
    "workplane",
    "floor",
    "back_wall",
    "front",
    "auto",
    "png",
    "jpeg",
    "exr",
    "falsecolor",
    "shaded",
    "clamp",
    "illuminance",
    "radiosity",
    "",
    "x",
    "+1",
    "01",
    "\u{0}",
    "ü",
];

fn leaf() -> impl Strategy<Value = Value> {
    prop_oneof![
        Just(Value::Null),
        any::<bool>().prop_map(Value::from),
        (-3i64..5000).prop_map(Value::from),
        prop::sample::select(vec![
            0.0, -0.0, 0.5, 1.0, -1.0, 1e-300, 1e-9, 1e6, 1e7, 1e12, 1e38, 3.5e38, 1e39, 1e300,
            -1e300, 4096.0, 4097.0, 2.5,
        ])
        .prop_map(Value::from),
        any::<f64>()
            .prop_filter("finite", |x| x.is_finite())
            .prop_map(Value::from),
        prop::sample::select(STRINGS.to_vec()).prop_map(Value::from),
    ]
}

fn json_value() -> impl Strategy<Value = Value> {
    leaf().prop_recursive(4, 48, 6, |inner| {
        prop_oneof![
            prop::collection::vec(inner.clone(), 0..6).prop_map(Value::Array),
            prop::collection::vec((prop::sample::select(KEYS.to_vec()), inner), 0..6).prop_map(
                |kv| Value::Object(kv.into_iter().map(|(k, v)| (k.to_string(), v)).collect())
            ),
        ]
    })
}

/// A top-level body: an object of API fields, mostly.
fn body() -> impl Strategy<Value = Value> {
    prop_oneof![
        8 => prop::collection::vec((prop::sample::select(KEYS.to_vec()), json_value()), 0..5)
            .prop_map(|kv| {
                let mut m = Map::new();
                for (k, v) in kv {
                    m.insert(k.to_string(), v);
                }
                // Keep renders small: a fuzz case is not a benchmark.
                for k in ["width", "height"] {
                    if m.get(k).and_then(Value::as_f64).is_some_and(|x| x > 128.0 && x <= 4096.0) {
                        m.insert(k.into(), Value::from(64));
                    }
                }
                if !m.contains_key("width") {
                    m.insert("width".into(), Value::from(48));
                }
                Value::Object(m)
            }),
        1 => json_value(),
    ]
}

/// A number: mostly in `lo..hi`, sometimes hostile.
fn num(lo: f64, hi: f64) -> BoxedStrategy<Value> {
    prop_oneof![
        25 => (lo..hi).prop_map(Value::from),
        1 => leaf(),
    ]
    .boxed()
}

fn triple(lo: f64, hi: f64) -> BoxedStrategy<Value> {
    prop_oneof![
        25 => prop::collection::vec(num(lo, hi), 3).prop_map(Value::Array),
        1 => json_value(),
    ]
    .boxed()
}

fn id(valid: &'static [&'static str]) -> BoxedStrategy<Value> {
    prop_oneof![
        20 => prop::sample::select(valid.to_vec()).prop_map(Value::from),
        1 => leaf(),
    ]
    .boxed()
}

fn ids(valid: &'static [&'static str]) -> BoxedStrategy<Value> {
    prop_oneof![
        20 => prop::sample::select(valid.to_vec()).prop_map(|v| Value::Array(vec![Value::from(v)])),
        4 => prop::collection::vec(id(valid), 0..4).prop_map(Value::Array),
        1 => json_value(),
    ]
    .boxed()
}

/// Ids of one scene: light groups, grids, surfaces, cameras.
struct Ids {
    groups: &'static [&'static str],
    grids: &'static [&'static str],
    surfaces: &'static [&'static str],
    cameras: &'static [&'static str],
}

fn ids_of(scene: &str) -> Ids {
    match scene {
        "cornell-box" => Ids {
            groups: &["ceiling"],
            grids: &["nope"],
            surfaces: &["floor", "back_wall", "short_block_top"],
            cameras: &["front"],
        },
        "desk-room" => Ids {
            groups: &["ceiling", "lamp"],
            grids: &["nope"],
            surfaces: &["floor", "desk_top", "lamp_shade"],
            cameras: &["door", "desk"],
        },
        "rooflight" => Ids {
            groups: &["nope"],
            grids: &["floor"],
            surfaces: &["floor", "roof", "counter"],
            cameras: &["entrance", "up"],
        },
        _ => Ids {
            groups: &["window_row", "corridor_row"],
            grids: &["desk", "workplane"],
            surfaces: &["floor", "desk_top", "window_wall"],
            cameras: &["entrance", "desk"],
        },
    }
}

fn lights(groups: &'static [&'static str]) -> BoxedStrategy<Value> {
    let setting = prop_oneof![
        num(0.0, 2.0),
        (num(0.0, 2.0), triple(0.0, 1.0))
            .prop_map(|(i, c)| serde_json::json!({"intensity": i, "color": c})),
        triple(0.0, 1.0).prop_map(|c| serde_json::json!({"color": c})),
        json_value(),
    ];
    prop_oneof![
        8 => prop::collection::vec((id(groups), setting), 0..3)
            .prop_map(|kv| kv.into_iter().map(|(k, v)| (k.as_str().unwrap_or("").to_string(), v)).collect::<Vec<_>>())
            .prop_map(|kv| Value::Object(kv.into_iter().collect())),
        1 => json_value(),
    ]
    .boxed()
}

fn emission() -> BoxedStrategy<Value> {
    let key = prop_oneof![
        (0usize..5000).prop_map(|i| i.to_string()),
        prop::sample::select(vec!["+1", "01", "-1", "x", "", "99999999999999999999"])
            .prop_map(String::from),
    ];
    prop_oneof![
        8 => prop::collection::vec((key, triple(0.0, 100.0)), 0..4)
            .prop_map(|kv| Value::Object(kv.into_iter().collect())),
        1 => json_value(),
    ]
    .boxed()
}

fn points() -> BoxedStrategy<Value> {
    let point = (triple(-1.0, 6.0), triple(-1.0, 1.0))
        .prop_map(|(p, n)| serde_json::json!({"position": p, "normal": n}));
    prop_oneof![
        8 => prop::collection::vec(prop_oneof![6 => point, 1 => json_value()], 0..4).prop_map(Value::Array),
        1 => json_value(),
    ]
    .boxed()
}

fn camera(cameras: &'static [&'static str]) -> BoxedStrategy<Value> {
    prop_oneof![
        id(cameras),
        (triple(-2.0, 6.0), triple(-2.0, 6.0), triple(-1.0, 1.0), num(1.0, 170.0)).prop_map(
            |(p, t, u, f)| serde_json::json!({"position": p, "target": t, "up": u, "fov_deg": f})
        ),
        json_value(),
    ]
    .boxed()
}

/// The fields an endpoint knows, each with a strategy of mostly plausible values.
/// A sky: a type and a random subset of every sky's fields, in and out of range.
fn sky() -> BoxedStrategy<Value> {
    let opt = |s: BoxedStrategy<Value>| prop::option::weighted(0.5, s);
    let sun = (num(-100.0, 100.0), num(-10.0, 400.0))
        .prop_map(|(a, z)| serde_json::json!({"altitude": a, "azimuth": z}))
        .boxed();
    let time = prop::sample::select(vec![
        "2026-06-21T12:00",
        "2026-02-30T12:00",
        "2026-12-21T08:15",
        "x",
    ])
    .prop_map(Value::from)
    .boxed();
    let valid = prop::sample::select(vec![
        serde_json::json!({"type": "cie_overcast", "horizontal_illuminance": 10000}),
        serde_json::json!({"type": "uniform", "horizontal_illuminance": 5000, "time": "2026-03-01T09:00"}),
        serde_json::json!({"type": "cie_clear", "horizontal_illuminance": 15000,
            "direct_normal_illuminance": 70000, "sun": {"altitude": 35, "azimuth": 190}}),
        serde_json::json!({"type": "perez", "direct_normal_irradiance": 500,
            "diffuse_horizontal_irradiance": 150, "time": "2026-06-21T16:30"}),
    ]);
    let random = (
        id(&["uniform", "cie_overcast", "cie_clear", "perez", "overcast"]),
        opt(num(-10.0, 300_000.0)),
        opt(num(-10.0, 300_000.0)),
        opt(num(-10.0, 2000.0)),
        opt(num(-10.0, 2000.0)),
        opt(sun),
        opt(time),
        opt(num(-100.0, 100.0)),
    )
        .prop_map(|(t, eh, en, dni, dhi, sun, time, dew)| {
            let mut m = Map::new();
            m.insert("type".into(), t);
            for (k, v) in [
                ("horizontal_illuminance", eh),
                ("direct_normal_illuminance", en),
                ("direct_normal_irradiance", dni),
                ("diffuse_horizontal_irradiance", dhi),
                ("sun", sun),
                ("time", time),
                ("dew_point", dew),
            ] {
                if let Some(v) = v {
                    m.insert(k.into(), v);
                }
            }
            Value::Object(m)
        });
    prop_oneof![1 => valid, 1 => random].boxed()
}

fn fields(ep: &str, scene: &str) -> Vec<(&'static str, BoxedStrategy<Value>)> {
    let known = ids_of(scene);
    let (groups, grids, surfaces) = (known.groups, known.grids, known.surfaces);
    let mut f: Vec<(&'static str, BoxedStrategy<Value>)> = vec![("lights", lights(groups))];
    match ep {
        "daylight" => {
            f.push(("sky", sky()));
            f.push(("surfaces", ids(surfaces)));
            f.push(("grids", ids(grids)));
            f.push(("points", points()));
        }
        "annual" => {
            f.clear();
            f.push((
                "weather",
                id(&["mannheim.epw", "x.epw", "../office/mannheim.epw", ""]),
            ));
            f.push(("grids", ids(grids)));
            f.push((
                "occupied",
                prop::collection::vec(id(&["08:00", "18:00", "25:00", "7:00", "x"]), 0..3)
                    .prop_map(Value::Array)
                    .boxed(),
            ));
        }
        "radiosity" => {
            f.push(("emission", emission()));
            f.push(("surfaces", any::<bool>().prop_map(Value::from).boxed()));
            f.push(("quantity", id(&["radiosity", "illuminance", "flux"])));
            f.push(("sky", sky()));
        }
        "illuminance" => {
            f.push(("emission", emission()));
            f.push(("surfaces", ids(surfaces)));
            f.push(("grids", ids(grids)));
            f.push(("points", points()));
        }
        "batch" => {
            let state = (lights(groups), emission())
                .prop_map(|(l, e)| serde_json::json!({"lights": l, "emission": e}));
            let state = prop_oneof![3 => lights(groups).prop_map(|l| serde_json::json!({"lights": l})), 1 => state, 1 => json_value()];
            f.push(("states", prop_oneof![8 => prop::collection::vec(state, 0..4).prop_map(Value::Array), 1 => json_value()].boxed()));
            f.push(("surfaces", ids(surfaces)));
            f.push(("grids", ids(grids)));
            f.push(("radiosity", any::<bool>().prop_map(Value::from).boxed()));
        }
        "optimize" => {
            let target = (id(grids), num(0.0, 1000.0), num(0.0, 500.0), num(0.0, 1.0)).prop_map(
                |(g, a, m, u)| serde_json::json!({"grid": g, "eavg_min": a, "emin_min": m, "u0_min": u}),
            );
            f.push(("targets", prop_oneof![8 => prop::collection::vec(target, 0..3).prop_map(Value::Array), 1 => json_value()].boxed()));
            f.push(("groups", ids(groups)));
        }
        _ => {
            f.push(("emission", emission()));
            f.push(("sky", sky()));
            f.push(("camera", camera(known.cameras)));
            f.push(("width", num(1.0, 96.0)));
            f.push(("height", num(1.0, 96.0)));
            f.push((
                "exposure",
                prop_oneof![num(-10.0, 10.0), Just(Value::from("auto"))].boxed(),
            ));
            f.push(("format", id(&["png", "jpeg", "exr", "gif"])));
            f.push(("mode", id(&["shaded", "falsecolor", "x"])));
            f.push(("tonemap", id(&["filmic", "clamp", "x"])));
            f.push((
                "range",
                triple(0.0, 1000.0)
                    .prop_map(|v| match v {
                        Value::Array(mut a) => {
                            a.truncate(2);
                            Value::Array(a)
                        }
                        v => v,
                    })
                    .boxed(),
            ));
        }
    }
    f
}

/// A body for `ep`: a random subset of its fields, sometimes with a stray field.
fn endpoint_body(ep: &'static str, scene: &'static str) -> BoxedStrategy<Value> {
    let fs = fields(ep, scene);
    let n = fs.len();
    let (names, strats): (Vec<&'static str>, Vec<BoxedStrategy<Value>>) = fs.into_iter().unzip();
    (
        prop::collection::vec(prop::bool::weighted(0.4), n),
        strats,
        prop::option::weighted(0.1, (prop::sample::select(KEYS.to_vec()), json_value())),
    )
        .prop_map(move |(use_it, values, stray)| {
            let mut m = Map::new();
            for ((k, v), on) in names.iter().zip(values).zip(use_it) {
                if on {
                    m.insert(k.to_string(), v);
                }
            }
            if let Some((k, v)) = stray {
                m.insert(k.to_string(), v);
            }
            if ep == "render" {
                // Keep renders small: a fuzz case is not a benchmark.
                // Sizes that would render (absent, or 129..=4096) become 48.
                for k in ["width", "height"] {
                    let x = m.get(k).and_then(Value::as_f64);
                    let big = x.is_some_and(|x| x > 128.0 && x <= 4096.0);
                    if big || !m.contains_key(k) {
                        m.insert(k.into(), Value::from(48));
                    }
                }
            }
            Value::Object(m)
        })
        .boxed()
}

fn post(uri: &str, body: Vec<u8>) -> Request<Body> {
    Request::post(uri)
        .header(header::CONTENT_TYPE, "application/json")
        .body(Body::from(body))
        .unwrap()
}

fn run(name: &str, strategy: impl Strategy<Value = Request<Body>>) {
    let mut runner = TestRunner::new(Config {
        cases: CASES,
        failure_persistence: None,
        ..Config::default()
    });
    let seen = std::cell::RefCell::new(std::collections::BTreeMap::new());
    runner
        .run(&strategy, |req| {
            let what = format!("{} {}", req.method(), req.uri());
            let s = check(req, &what)?;
            *seen.borrow_mut().entry(s).or_insert(0) += 1;
            Ok(())
        })
        .unwrap();
    println!("{name}: {CASES} cases, statuses {:?}", seen.borrow());
}

const ENDPOINTS: &[&str] = &[
    "radiosity",
    "illuminance",
    "batch",
    "optimize",
    "render",
    "daylight",
    "annual",
];
const SCENES: &[&str] = &["cornell-box", "desk-room", "office", "rooflight"];

#[test]
fn api_shaped_bodies_get_an_answer_or_a_4xx_problem_never_a_5xx() {
    let _gate = common::shared();
    for ep in ENDPOINTS {
        let strategy = prop::sample::select(SCENES.to_vec()).prop_flat_map(move |scene| {
            endpoint_body(ep, scene).prop_map(move |b| {
                post(
                    &format!("/api/scenes/{scene}/{ep}"),
                    b.to_string().into_bytes(),
                )
            })
        });
        run(&format!("{ep} (API-shaped)"), strategy);
    }
}

#[test]
fn arbitrary_json_bodies_get_an_answer_or_a_4xx_problem_never_a_5xx() {
    let _gate = common::shared();
    for ep in ENDPOINTS {
        let strategy =
            (prop::sample::select(SCENES.to_vec()), body()).prop_map(move |(scene, b)| {
                post(
                    &format!("/api/scenes/{scene}/{ep}"),
                    b.to_string().into_bytes(),
                )
            });
        run(ep, strategy);
    }
}

#[test]
fn arbitrary_bytes_get_400_413_415_or_422() {
    let _gate = common::shared();
    let strategy = (
        prop::sample::select(ENDPOINTS.to_vec()),
        prop::collection::vec(any::<u8>(), 0..256),
        prop::sample::select(vec![
            "application/json",
            "text/plain",
            "",
            "application/x+json",
        ]),
    )
        .prop_map(|(ep, bytes, ct)| {
            let mut r = Request::post(format!("/api/scenes/cornell-box/{ep}"));
            if !ct.is_empty() {
                r = r.header(header::CONTENT_TYPE, ct);
            }
            r.body(Body::from(bytes)).unwrap()
        });
    run("bytes", strategy);
}

#[test]
fn arbitrary_render_png_queries_get_an_image_or_a_4xx_problem() {
    let _gate = common::shared();
    let param = prop_oneof![
        Just("camera".to_string()),
        Just("w".to_string()),
        Just("h".to_string()),
        Just("exposure".to_string()),
        Just("mode".to_string()),
        Just("tonemap".to_string()),
        Just("light.ceiling".to_string()),
        Just("light.nope".to_string()),
        "[a-z.]{1,8}",
    ];
    let value = prop_oneof![
        Just("1".to_string()),
        Just("64".to_string()),
        Just("0".to_string()),
        Just("-1".to_string()),
        Just("1e39".to_string()),
        Just("NaN".to_string()),
        Just("inf".to_string()),
        Just("0.5,0.5,0.5".to_string()),
        Just("1,2".to_string()),
        Just("front".to_string()),
        Just("falsecolor".to_string()),
        Just("auto".to_string()),
        "[ -~]{0,12}",
    ];
    let strategy = prop::collection::vec((param, value), 0..5).prop_map(|kv| {
        let mut q: Vec<String> = kv
            .iter()
            .map(|(k, v)| {
                // Keep images small.
                let v = match (k.as_str(), v.parse::<f64>()) {
                    ("w" | "h", Ok(x)) if x > 128.0 && x <= 4096.0 => "64".to_string(),
                    _ => v.clone(),
                };
                format!("{}={}", urlencode(k), urlencode(&v))
            })
            .collect();
        q.push("w=40".into());
        Request::get(format!(
            "/api/scenes/cornell-box/render.png?{}",
            q.join("&")
        ))
        .body(Body::empty())
        .unwrap()
    });
    run("render.png", strategy);
}

fn urlencode(s: &str) -> String {
    s.bytes()
        .map(|b| match b {
            b'a'..=b'z' | b'A'..=b'Z' | b'0'..=b'9' | b'.' | b'-' | b'_' => (b as char).to_string(),
            _ => format!("%{b:02X}"),
        })
        .collect()
}
