//! `POST …/annual` on the office with the Mannheim weather file in its folder: metrics
//! within their ranges and consistent with each other, the same answer from the file's
//! text, and the errors (a bad EPW line, a name leaving the folder, bad hours).

use axum::http::StatusCode;
use serde_json::json;

use super::{app, post};
use crate::common;

#[tokio::test]
async fn annual_metrics_for_the_office_work_plane() {
    let _gate = common::shared();
    let body = json!({"weather": "mannheim.epw", "grids": ["workplane", "desk"]});
    let (s, _, v) = post(app(), "/api/scenes/office/annual", body.to_string()).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let w = &v["weather"];
    assert_eq!(w["city"], "Mannheim");
    assert_eq!(w["hours"], 8760);
    // 08:00–18:00 every day: 3,650 hours; the sun is up about half the year's hours.
    assert_eq!(w["occupied_hours"], 3650);
    let day = w["daylight_hours"].as_u64().unwrap();
    assert!((4300..4500).contains(&day), "{day}");
    for id in ["workplane", "desk"] {
        let g = &v["grids"][id];
        let sda = g["sda_300_50"].as_f64().unwrap();
        let ase = g["ase_1000_250"].as_f64().unwrap();
        assert!(
            (0.0..=100.0).contains(&sda) && (0.0..=100.0).contains(&ase),
            "{g}"
        );
        let u = &g["udi"];
        let sum = u["below_100"].as_f64().unwrap()
            + u["from_100_to_3000"].as_f64().unwrap()
            + u["above_3000"].as_f64().unwrap();
        assert!((sum - 100.0).abs() < 1e-6, "{u}");
        let hours: Vec<u64> = g["hours_above_300"]
            .as_array()
            .unwrap()
            .iter()
            .map(|h| h.as_u64().unwrap())
            .collect();
        assert_eq!(hours.len(), g["count"].as_u64().unwrap() as usize);
        assert!(hours.iter().all(|&h| h <= 3650));
        // sDA is the share of points lit to 300 lx for half the occupied hours.
        let share = hours.iter().filter(|&&h| 2 * h >= 3650).count() as f64 / hours.len() as f64;
        assert!((100.0 * share - sda).abs() < 1e-9, "{sda} vs {share}");
        println!(
            "{id}: sDA {sda:.1} %, ASE {ase:.1} %, UDI {u}, EN 17037 {}",
            g["en17037"]
        );
    }
    // A south window in Mannheim: the desk by the window is daylit most of the time.
    assert!(v["grids"]["desk"]["sda_300_50"].as_f64().unwrap() > 50.0);

    // The same weather as text gives the same answer.
    let text = epw_text();
    let body = json!({"weather": text, "grids": ["desk"], "occupied": ["08:00", "18:00"]});
    let (s, _, t) = post(app(), "/api/scenes/office/annual", body.to_string()).await;
    assert_eq!(s, StatusCode::OK, "{t}");
    assert_eq!(t["grids"]["desk"], v["grids"]["desk"]);
}

#[tokio::test]
async fn annual_requests_are_checked() {
    let _gate = common::shared();
    let text = epw_text();
    // Line 20 (the 12th hour) with a broken diffuse radiation.
    let broken: String = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 19 {
                let mut f: Vec<&str> = l.split(',').collect();
                f[15] = "lots";
                f.join(",")
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let cases = [
        ("cornell-box", json!({"weather": "x.epw"}), "no [site]"),
        ("office", json!({"weather": broken}), "line 20"),
        (
            "office",
            json!({"weather": "../office/mannheim.epw"}),
            "name of an .epw file",
        ),
        ("office", json!({"weather": "chicago.epw"}), "no such file"),
        (
            "office",
            json!({"weather": "mannheim.epw", "grids": ["nope"]}),
            "nope",
        ),
        (
            "office",
            json!({"weather": "mannheim.epw", "occupied": ["18:00", "08:00"]}),
            "before",
        ),
        (
            "office",
            json!({"weather": "mannheim.epw", "occupied": ["8h", "18:00"]}),
            "HH:MM",
        ),
        ("office", json!({"grids": ["desk"]}), "weather"),
    ];
    for (scene, body, says) in cases {
        let (s, _, v) = post(
            app(),
            &format!("/api/scenes/{scene}/annual"),
            body.to_string(),
        )
        .await;
        assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{says}: {v}");
        let detail = v["detail"].as_str().unwrap_or_default();
        assert!(detail.contains(says), "{says}: {detail}");
    }
}

/// The Mannheim weather file's text (its header comments are Latin-1).
fn epw_text() -> String {
    let bytes = std::fs::read(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/weather/mannheim.epw"),
    )
    .unwrap();
    String::from_utf8_lossy(&bytes).into_owned()
}
