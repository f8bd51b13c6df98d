//! `POST …/daylight` on the office (a south window at Mannheim): daylight factors on the
//! work plane, the sun placed by local time, electric light added, and the errors.

use axum::http::StatusCode;
use serde_json::json;

use super::{app, post};
use crate::common;

#[tokio::test]
async fn the_office_window_lets_daylight_in() {
    let _gate = common::shared();
    let overcast = json!({"type": "cie_overcast", "horizontal_illuminance": 10000});
    let body = json!({"sky": overcast, "grids": ["workplane"],
        "points": [{"position": [3.0, 0.75, 0.6], "normal": [0, 1, 0]},
                   {"position": [3.0, 0.75, 3.4], "normal": [0, 1, 0]}]});
    let (s, _, v) = post(app(), "/api/scenes/office/daylight", body.to_string()).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let near = v["points"][0]["daylight_factor"].as_f64().unwrap();
    let far = v["points"][1]["daylight_factor"].as_f64().unwrap();
    println!("office daylight factors: {near:.2} % by the window, {far:.2} % at the back");
    assert!(near > 2.0 * far && far > 0.0, "{near} vs {far}");
    assert!((v["points"][0]["lux"].as_f64().unwrap() - 100.0 * near).abs() < 1e-6 * near * 100.0);
    let g = &v["grids"]["workplane"];
    let df = &g["daylight_factor"];
    assert!(df["min"].as_f64().unwrap() <= df["median"].as_f64().unwrap());
    assert!(df["median"].as_f64().unwrap() <= df["max"].as_f64().unwrap());
    assert_eq!(
        df["values"].as_array().unwrap().len(),
        g["illuminance"]["count"].as_u64().unwrap() as usize
    );
    assert_eq!(v["sky"]["type"], "cie_overcast");
    assert!(v["sky"]["sun"].is_null());

    // The same points again, under another sky and with electric light: the gathers are
    // cached, and the electric light adds to the daylight.
    let clear = json!({"type": "cie_clear", "horizontal_illuminance": 15000,
        "direct_normal_illuminance": 70000, "time": "2026-12-21T12:00"});
    let body =
        json!({"sky": clear, "points": [{"position": [3.0, 0.75, 3.4], "normal": [0, 1, 0]}]});
    let (s, _, dark) = post(app(), "/api/scenes/office/daylight", body.to_string()).await;
    assert_eq!(s, StatusCode::OK, "{dark}");
    let sun = &dark["sky"]["sun"];
    // Mannheim at noon CET on the winter solstice: the sun is low in the south.
    let (alt, az) = (
        sun["altitude"].as_f64().unwrap(),
        sun["azimuth"].as_f64().unwrap(),
    );
    assert!(
        (15.0..19.0).contains(&alt) && (170.0..185.0).contains(&az),
        "{alt} {az}"
    );
    assert!(dark["points"][0]["daylight_factor"].is_null());
    let mut lit = body.clone();
    lit["lights"] = json!({"window_row": 1, "corridor_row": 1});
    let (s, _, lit) = post(app(), "/api/scenes/office/daylight", lit.to_string()).await;
    assert_eq!(s, StatusCode::OK, "{lit}");
    let (d, l) = (
        dark["points"][0]["lux"].as_f64().unwrap(),
        lit["points"][0]["lux"].as_f64().unwrap(),
    );
    assert!(l > d + 100.0, "{l} vs {d}");
    // Maintained: the daylight as is plus 0.8 (the office's MF) × the electric light.
    assert!(dark["maintained"].is_null());
    let m = lit["maintained"]["points"][0]["lux"].as_f64().unwrap();
    let want = d + 0.8 * (l - d);
    assert!((m - want).abs() < 1e-4 * want, "{m} vs {want}");
    assert_eq!(lit["maintenance_factors"]["window_row"], 0.8);
}

#[tokio::test]
async fn daylight_requests_are_checked() {
    let _gate = common::shared();
    let cases = [
        (
            "cornell-box",
            json!({"sky": {"type": "uniform", "horizontal_illuminance": 1}}),
            "no [site]",
        ),
        ("office", json!({}), "sky"),
        ("office", json!({"sky": {"type": "sunny"}}), "sunny"),
        (
            "office",
            json!({"sky": {"type": "uniform", "horizontal_illuminance": 1e9}}),
            "horizontal_illuminance",
        ),
        (
            "office",
            json!({"sky": {"type": "cie_clear", "horizontal_illuminance": 1, "direct_normal_illuminance": 1}}),
            "give the sun",
        ),
        (
            "office",
            json!({"sky": {"type": "perez", "direct_normal_irradiance": 500, "diffuse_horizontal_irradiance": 100, "time": "2026-02-30T12:00"}}),
            "no such day",
        ),
        (
            "office",
            json!({"sky": {"type": "uniform", "horizontal_illuminance": 1, "time": null}}),
            "null",
        ),
        (
            "office",
            json!({"sky": {"type": "uniform", "horizontal_illuminance": 1}, "lights": {"nope": 1}}),
            "nope",
        ),
    ];
    for (scene, body, says) in cases {
        let (s, _, v) = post(
            app(),
            &format!("/api/scenes/{scene}/daylight"),
            body.to_string(),
        )
        .await;
        assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{body}: {v}");
        let detail = v["detail"].as_str().unwrap_or_default();
        assert!(detail.contains(says), "{body}: {detail}");
    }
}

#[tokio::test]
async fn the_rooflight_hall_is_brightest_under_its_rooflight() {
    let _gate = common::shared();
    let body = json!({"sky": {"type": "cie_overcast", "horizontal_illuminance": 10000},
        "grids": ["floor"],
        "points": [{"position": [4.0, 0.85, 4.0], "normal": [0, 1, 0]},
                   {"position": [0.5, 0.85, 0.5], "normal": [0, 1, 0]}]});
    let (s, _, v) = post(app(), "/api/scenes/rooflight/daylight", body.to_string()).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let under = v["points"][0]["daylight_factor"].as_f64().unwrap();
    let corner = v["points"][1]["daylight_factor"].as_f64().unwrap();
    let df = &v["grids"]["floor"]["daylight_factor"];
    println!("rooflight hall: DF {under:.2} % under the rooflight, {corner:.2} % in the north-west corner, grid {df:.2}", df = df["avg"]);
    assert!(under > 3.0 * corner, "{under} vs {corner}");
    assert!((df["max"].as_f64().unwrap() - under).abs() < 0.25 * under);
}

#[tokio::test]
async fn renders_and_per_patch_answers_take_the_same_sky() {
    let _gate = common::shared();
    let sky = json!({"type": "cie_clear", "horizontal_illuminance": 15000,
        "direct_normal_illuminance": 70000, "time": "2026-06-21T13:00"});
    // A render with the sky: a PNG, its exposure chosen for daylight.
    let (s, h, _) = post(
        app(),
        "/api/scenes/rooflight/render",
        json!({"camera": "entrance", "width": 96, "height": 64, "sky": sky}).to_string(),
    )
    .await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(h["content-type"], "image/png");
    // At final quality the daylight gets its own traced image (the sky gathered per
    // pixel): at the same exposure, about as bright as the patches' image.
    let mut means = Vec::new();
    for quality in ["fast", "final"] {
        let body = json!({"camera": "entrance", "width": 48, "height": 32, "sky": sky,
            "exposure": -12, "quality": quality});
        let req = axum::http::Request::post("/api/scenes/rooflight/render")
            .header(axum::http::header::CONTENT_TYPE, "application/json")
            .body(axum::body::Body::from(body.to_string()))
            .unwrap();
        let (s, _, png) = super::send(app(), req).await;
        assert_eq!(s, StatusCode::OK, "{quality}");
        let img = image::load_from_memory(&png).unwrap().to_rgb8();
        let sum: f64 = img.pixels().map(|p| p.0[1] as f64).sum();
        means.push(sum / (48.0 * 32.0));
    }
    eprintln!("rooflight under a clear sky, mean green value, fast and final: {means:?}");
    assert!(means[1] > 20.0, "the final image is dark: {means:?}");
    assert!(
        (means[1] / means[0] - 1.0).abs() < 0.15,
        "fast and final differ: {means:?}"
    );
    // Per-patch illuminance under the sky agrees with /daylight's surface statistics.
    let overcast = json!({"type": "cie_overcast", "horizontal_illuminance": 10000});
    let (s, _, r) = post(
        app(),
        "/api/scenes/rooflight/radiosity",
        json!({"sky": overcast, "quantity": "illuminance", "surfaces": true}).to_string(),
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{r}");
    let (s, _, d) = post(
        app(),
        "/api/scenes/rooflight/daylight",
        json!({"sky": overcast, "surfaces": ["floor"]}).to_string(),
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{d}");
    let via_radiosity = r["surfaces"]["floor"]["illuminance"][1].as_f64().unwrap();
    let via_daylight = d["surfaces"]["floor"]["avg"]["rgb"][1].as_f64().unwrap();
    assert!(
        (via_radiosity - via_daylight).abs() < 1e-4 * via_daylight,
        "{via_radiosity} vs {via_daylight}"
    );
    // Refused: a sky on a scene without a site, and a sky with a per-patch emission.
    for (uri, body, says) in [
        (
            "/api/scenes/cornell-box/render",
            json!({"sky": overcast}),
            "no [site]",
        ),
        (
            "/api/scenes/cornell-box/radiosity",
            json!({"sky": overcast}),
            "no [site]",
        ),
        (
            "/api/scenes/office/render",
            json!({"sky": overcast, "emission": {"0": [1, 1, 1]}}),
            "emission",
        ),
    ] {
        let (s, _, v) = post(app(), uri, body.to_string()).await;
        assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{uri}: {v}");
        assert!(
            v["detail"].as_str().unwrap_or_default().contains(says),
            "{uri}: {v}"
        );
    }
}

/// Under a clear sky the rooflight's reference plane reported Emin 0 and U₀ 0.00: the
/// points inside the box on the floor counted. Now they are null and counted apart, and
/// every bundled scene's grids have U₀ > 0 under their default lighting.
#[tokio::test]
async fn grid_points_inside_objects_dragged_uniformity_to_zero() {
    let _gate = common::shared();
    let clear = json!({"type": "cie_clear", "horizontal_illuminance": 15000,
        "direct_normal_illuminance": 70000, "sun": {"altitude": 40, "azimuth": 180}});
    let body = json!({"sky": clear, "grids": ["floor"]});
    let (s, _, v) = post(app(), "/api/scenes/rooflight/daylight", body.to_string()).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let g = &v["grids"]["floor"]["illuminance"];
    let values = g["values"].as_array().unwrap();
    let nulls = values.iter().filter(|v| v.is_null()).count();
    assert!(
        nulls > 0 && nulls == g["excluded"].as_u64().unwrap() as usize,
        "{g}"
    );
    assert!(g["u0"].as_f64().unwrap() > 0.05, "{g}");
    let min = values
        .iter()
        .filter_map(|v| v.as_f64())
        .fold(f64::INFINITY, f64::min);
    assert!((g["min"].as_f64().unwrap() - min).abs() < 1e-6 * min.max(1.0));

    for scene in ["cornell-box", "desk-room", "gallery", "office"] {
        let (s, d) = super::get(app(), &format!("/api/scenes/{scene}")).await;
        assert_eq!(s, StatusCode::OK);
        let ids: Vec<String> = d["grids"]
            .as_array()
            .unwrap()
            .iter()
            .map(|g| g["id"].as_str().unwrap().to_string())
            .collect();
        if ids.is_empty() {
            continue;
        }
        let body = json!({"grids": ids});
        let (s, _, v) = post(
            app(),
            &format!("/api/scenes/{scene}/illuminance"),
            body.to_string(),
        )
        .await;
        assert_eq!(s, StatusCode::OK, "{v}");
        for id in &ids {
            let g = &v["grids"][id];
            assert!(g["u0"].as_f64().unwrap() > 0.05, "{scene}/{id}: {g}");
            assert!(g["excluded"].is_u64(), "{scene}/{id}");
        }
    }
}
