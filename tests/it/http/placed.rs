//! Luminaires placed per request over HTTP: the answer equals the library's, and bad input
//! gets a 422 that names the field before any work.

use axum::http::StatusCode;
use relight::color::Rgb;
use relight::model::lighting::Lighting;
use relight::model::placed::{place, LuminairePlacement, Photometry};
use serde_json::{json, Value};

use super::{app, post, ready};
use crate::common;

const IES: &str = include_str!("../../../scenes/office-floor/downlight.ies");

/// A downlight over the desk, inline IES, both groups of the desk room off.
fn over_the_desk() -> Value {
    json!({"id": "task", "position": [1.2, 2.6, 2.4], "ies": IES, "lumens": 1200, "cct": 3000})
}

#[tokio::test]
async fn a_luminaire_placed_over_http_equals_the_library_answer() {
    let _gate = common::shared();
    let body = json!({"lights": {"ceiling": 0, "lamp": 0}, "luminaires": [over_the_desk()],
                      "surfaces": ["desk_top", "floor"]});
    let (s, _, v) = post(app(), "/api/scenes/desk-room/illuminance", body.to_string()).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let got = v["surfaces"]["desk_top"]["avg"]["lux"].as_f64().unwrap();
    // The same state through the library.
    let r = ready("desk-room");
    let m = &r.model;
    let lum = LuminairePlacement {
        id: "task".into(),
        position: Some([1.2, 2.6, 2.4]),
        photometry: Some(Photometry::Ies(IES.into())),
        lumens: Some(1200.0),
        cct: Some(3000.0),
        ..Default::default()
    };
    let placed = place(&m.baked.scene, m.patches(), vec![Rgb::ZERO; 2], &[lum]).unwrap();
    let sol = m.solve(&Lighting::Placed(placed)).unwrap();
    let want = relight::model::report::surface_averages(&m.baked.scene, &m.baked.mesh, &sol)
        ["desk_top"]
        .illuminance_y();
    assert!(want > 50.0, "the desk is lit: {want} lx");
    assert!((got - want).abs() < 1e-6 * want, "{got} against {want}");
    // The groups' light and the luminaire's add up.
    let groups = json!({"surfaces": ["desk_top"]});
    let both = json!({"luminaires": [over_the_desk()], "surfaces": ["desk_top"]});
    let avg = |v: &Value| v["surfaces"]["desk_top"]["avg"]["lux"].as_f64().unwrap();
    let (_, _, g) = post(
        app(),
        "/api/scenes/desk-room/illuminance",
        groups.to_string(),
    )
    .await;
    let (s, _, b) = post(app(), "/api/scenes/desk-room/illuminance", both.to_string()).await;
    assert_eq!(s, StatusCode::OK, "{b}");
    assert!(
        (avg(&b) - avg(&g) - got).abs() < 1e-4 * avg(&b),
        "{} ≠ {} + {got}",
        avg(&b),
        avg(&g)
    );
}

/// A `final` render of a state with a placed luminaire over HTTP is the library's image
/// of that state ([`relight::render::pipeline::final_state_image`]), to the pixel.
#[tokio::test]
async fn a_final_render_with_a_placed_luminaire_is_the_librarys_image() {
    use relight::render::final_gather::FinalSettings;
    use relight::render::pipeline::final_state_image;
    use relight::render::{Camera, Shading};
    let _gate = common::shared();
    let body = json!({"lights": {"ceiling": 0, "lamp": 0}, "luminaires": [over_the_desk()],
        "camera": "door", "width": 40, "height": 30, "quality": "final", "format": "exr"});
    let (s, _, bytes) = super::send(
        app(),
        axum::http::Request::post("/api/scenes/desk-room/render")
            .header(axum::http::header::CONTENT_TYPE, "application/json")
            .body(axum::body::Body::from(body.to_string()))
            .unwrap(),
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{}", String::from_utf8_lossy(&bytes));
    let got = image::load_from_memory(&bytes).unwrap().to_rgb32f();
    let r = ready("desk-room");
    let m = &r.model;
    let lum = LuminairePlacement {
        id: "task".into(),
        position: Some([1.2, 2.6, 2.4]),
        photometry: Some(Photometry::Ies(IES.into())),
        lumens: Some(1200.0),
        cct: Some(3000.0),
        ..Default::default()
    };
    let placed = place(&m.baked.scene, m.patches(), vec![Rgb::ZERO; 2], &[lum]).unwrap();
    let door = m
        .baked
        .scene
        .cameras
        .iter()
        .find(|c| c.id == "door")
        .unwrap();
    let cam = Camera::from_def(door, 40, 30);
    let shading = Shading::new(&m.baked.mesh);
    let patches =
        relight::render::final_gather::patch_locator(&m.baked.mesh, &m.baked.scene.triangles);
    let settings = FinalSettings::default();
    let want = final_state_image(
        m,
        &shading,
        &patches,
        &cam,
        &Lighting::Placed(placed),
        &settings,
        &Default::default(),
    )
    .unwrap()
    .linear(&[Rgb::ONE]);
    let peak = want.iter().map(|p| p.0[1]).fold(0f32, f32::max);
    assert!(peak > 0.0);
    let worst = got
        .pixels()
        .zip(&want)
        .map(|(a, b)| (a.0[1] - b.0[1]).abs() / peak)
        .fold(0f32, f32::max);
    assert!(worst < 1e-3, "worst pixel off by {worst} of the peak");
}

/// `/glare` takes placed luminaires: a new one glares by its photometry and opening, in
/// no group; a columns scene refuses them.
#[tokio::test]
async fn glare_rates_a_luminaire_placed_per_request() {
    let _gate = common::shared();
    let body = json!({"lights": {"ceiling": 0, "lamp": 0}, "luminaires": [over_the_desk()],
        "observers": [{"eye": [3.5, 1.2, 2.4], "direction": [-1, 0, 0]}]});
    let (s, _, v) = post(app(), "/api/scenes/desk-room/glare", body.to_string()).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let o = &v["observers"][0];
    let t = &o["luminaires"][0];
    assert_eq!(
        (t["luminaire"].as_str(), t["group"].as_str()),
        (Some("task"), Some("")),
        "{o}"
    );
    // 0.2 × 0.2 m opening 2.3 m ahead, 1.4 m up: seen at γ = 58.7° from its axis.
    let (dx, dy) = (2.3f64, 1.4f64);
    let area = 0.04 * (dy / dx.hypot(dy));
    assert!(
        (t["projected_area"].as_f64().unwrap() / area - 1.0).abs() < 1e-3,
        "{t}"
    );
    assert!(o["ugr"].as_f64().is_some(), "{o}");
    let (s, _, v) = post(app(), "/api/scenes/office/glare", body.to_string()).await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{v}");
    assert!(v["detail"].as_str().unwrap().contains("columns"), "{v}");
}

#[tokio::test]
async fn placed_luminaires_with_bad_input_get_a_422_naming_the_field() {
    let _gate = common::shared();
    let with = |l: Value| json!({"luminaires": [l]}).to_string();
    let mut bad_ies = over_the_desk();
    bad_ies["ies"] = json!(IES.replace("TILT=NONE\n1 2500", "TILT=NONE\n1 lots"));
    let mut huge = over_the_desk();
    huge["ies"] = json!(format!("{IES}{}", " ".repeat(1 << 20)));
    let many: Vec<Value> = (0..1001)
        .map(|i| json!({"id": format!("l{i}"), "position": [1, 2, 1], "lumens": 10}))
        .collect();
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "outside the bounds",
            with(json!({"id": "x", "position": [9, 2, 1], "lumens": 100})),
            "outside the scene's bounds",
        ),
        (
            "photometry that does not parse",
            with(bad_ies),
            "luminaires[0].ies:8: 'lots' is not a number",
        ),
        ("inline photometry over 1 MB", with(huge), "at most 1048576"),
        (
            "too many",
            json!({ "luminaires": many }).to_string(),
            "at most 1000 per request",
        ),
        (
            "a photometric file the scene does not have",
            with(json!({"id": "x", "position": [1, 2, 1], "photometry": "missing.ies"})),
            "photometry 'missing.ies'",
        ),
        (
            "a photometric file outside the scene folder",
            with(
                json!({"id": "x", "position": [1, 2, 1], "photometry": "../office/downlight.ies"}),
            ),
            "photometry '../office/downlight.ies'",
        ),
        (
            "an unknown group",
            with(json!({"id": "x", "position": [1, 2, 1], "lumens": 100, "group": "sun"})),
            "group 'sun' is not a light group",
        ),
        (
            "removing what the scene does not have",
            with(json!({"id": "x", "remove": true})),
            "cannot be removed",
        ),
        (
            "a new luminaire without a position",
            with(json!({"id": "x", "lumens": 100})),
            "needs a position",
        ),
        (
            "negative lumens",
            with(json!({"id": "x", "position": [1, 2, 1], "lumens": -5})),
            "lumens = -5",
        ),
        (
            "an isotropic one without lumens",
            with(json!({"id": "x", "position": [1, 2, 1]})),
            "lumens is required",
        ),
        (
            "with an emission",
            json!({"emission": {"0": [1, 1, 1]}, "luminaires": [over_the_desk()]}).to_string(),
            "not with 'emission'",
        ),
    ];
    for (what, body, says) in cases {
        let (s, _, v) = post(app(), "/api/scenes/desk-room/illuminance", body).await;
        assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{what}: {v}");
        let detail = v["detail"].as_str().unwrap_or_default();
        assert!(detail.contains(says), "{what}: {detail}");
        assert!(
            detail.contains("luminaires"),
            "{what} names the field: {detail}"
        );
    }
    // An infinite coordinate does not parse as a number.
    let (s, _, v) = post(
        app(),
        "/api/scenes/desk-room/radiosity",
        r#"{"luminaires": [{"id": "x", "position": [1e999, 2, 1], "lumens": 100}]}"#,
    )
    .await;
    assert!(s.is_client_error(), "{s}: {v}");
    // The columns transfer answers light groups only.
    let (s, _, v) = post(
        app(),
        "/api/scenes/office/radiosity",
        with(json!({"id": "x", "position": [1, 2, 1], "lumens": 100})),
    )
    .await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{v}");
    assert!(
        v["detail"].as_str().unwrap().contains("columns transfer"),
        "{v}"
    );
}
