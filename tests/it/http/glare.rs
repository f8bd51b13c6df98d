//! `glare`: the CIE 117 UGR at observers over HTTP.

use axum::http::StatusCode;

use super::{app, post};
use crate::common;

#[tokio::test]
async fn glare_rates_observers_in_the_office_and_refuses_bad_observers() {
    let _gate = common::shared();
    let body = r#"{"observers": [{"position": [0.5, 0, 2.0], "direction": [1, 0, 0]},
                                 {"eye": [0.5, 1.2, 2.0], "direction": [-1, 0, 0]}]}"#;
    let (s, _, v) = post(app(), "/api/scenes/office/glare", body).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let o = &v["observers"][0];
    // Seated: the eye 1.2 m above the position.
    assert_eq!(o["eye"][1].as_f64().unwrap(), 1.2);
    let lb = o["background_luminance"].as_f64().unwrap();
    assert!((lb - o["indirect_illuminance"].as_f64().unwrap() / std::f64::consts::PI).abs() < 1e-9);
    let terms = o["luminaires"].as_array().unwrap();
    let left = o["left_out"].as_array().unwrap();
    assert_eq!(terms.len() + left.len(), 6, "{o}");
    assert!(!terms.is_empty(), "{o}");
    // Each term is L² ω / p², and the rating is 8 log₁₀(0.25 / L_b · Σ).
    let mut sum = 0.0;
    for t in terms {
        let f = |k: &str| t[k].as_f64().unwrap();
        let term = f("luminance").powi(2) * f("solid_angle") / f("position_index").powi(2);
        assert!((f("term") / term - 1.0).abs() < 1e-9, "{t}");
        assert!(
            (f("solid_angle") - f("projected_area") / f("distance").powi(2)).abs() < 1e-12,
            "{t}"
        );
        sum += term;
    }
    let ugr = o["ugr"].as_f64().unwrap();
    assert!((ugr - 8.0 * (0.25 / lb * sum).log10()).abs() < 1e-9);
    assert!((5.0..35.0).contains(&ugr), "UGR {ugr}");
    // Looking at the window wall (x = 0) from the same place: the downlights are behind.
    let back = &v["observers"][1];
    assert!(back["ugr"].is_null(), "{back}");
    assert_eq!(back["left_out"].as_array().unwrap().len(), 6);
    // Dimmed to half, the luminaires' terms fall 4-fold and the background 2-fold: UGR
    // falls by 8 log₁₀ 2.
    let dim = r#"{"lights": {"window_row": 0.5, "corridor_row": 0.5},
                  "observers": [{"position": [0.5, 0, 2.0], "direction": [1, 0, 0]}]}"#;
    let (s, _, d) = post(app(), "/api/scenes/office/glare", dim).await;
    assert_eq!(s, StatusCode::OK, "{d}");
    let fall = ugr - d["observers"][0]["ugr"].as_f64().unwrap();
    assert!((fall - 8.0 * 2f64.log10()).abs() < 1e-6, "{fall}");
    // Bad observers are precise 422s.
    for (body, needle) in [
        (r#"{"observers": []}"#, "observers"),
        (r#"{"observers": [{"direction": [1, 0, 0]}]}"#, "needs eye"),
        (
            r#"{"observers": [{"eye": [0, 1, 0], "position": [0, 0, 0], "direction": [1, 0, 0]}]}"#,
            "not both",
        ),
        (
            r#"{"observers": [{"eye": [0, 1, 0], "direction": [0, 0, 0]}]}"#,
            "direction",
        ),
        (
            r#"{"observers": [{"position": [0, 0, 0], "height": -1, "direction": [1, 0, 0]}]}"#,
            "height",
        ),
        (
            r#"{"observers": [{"eye": [0, 1, 0], "direction": [1, 0, 0]}], "lights": {"nope": 1}}"#,
            "unknown light group",
        ),
    ] {
        let (s, _, v) = post(app(), "/api/scenes/office/glare", body).await;
        assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{body}: {v}");
        let d = v["detail"].as_str().unwrap();
        assert!(d.contains(needle), "{body}: {d}");
    }
}
