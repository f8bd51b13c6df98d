//! `optimize`: the least luminous flux that meets illuminance targets on grids.

use axum::http::StatusCode;

use super::{app, post, ready};
use crate::common;

#[tokio::test]
async fn optimize_finds_the_least_flux_levels_that_meet_the_targets() {
    let _gate = common::shared();
    let body = r#"{"targets": [{"grid": "desk", "eavg_min": 500, "u0_min": 0.6}]}"#;
    let (s, _, v) = post(app(), "/api/scenes/office/optimize", body).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    assert_eq!(v["targets"][0]["met"], true, "{v}");
    let lv = |id: &str| v["lights"][id]["intensity"].as_f64().unwrap();
    let (a, b) = (lv("window_row"), lv("corridor_row"));
    let r = ready("office");
    let desk = r.model.grids.iter().find(|g| g.grid.id == "desk").unwrap();
    let meets = |x: f64, y: f64| {
        let s = desk.stats(&[[x as f32; 3], [y as f32; 3]]);
        s.avg >= 500.0 * (1.0 - 1e-4) && s.u0 >= 0.6 - 1e-4
    };
    assert!(meets(a, b), "levels {a} {b}");
    // Brute force over a 1 % grid of levels: nothing feasible uses less flux (both rows
    // have the same lumens, so flux ∝ a + b).
    let best = (0..=100)
        .flat_map(|i| (0..=100).map(move |j| (i as f64 / 100.0, j as f64 / 100.0)))
        .filter(|&(x, y)| meets(x, y))
        .map(|(x, y)| x + y)
        .fold(f64::INFINITY, f64::min);
    assert!(a + b <= best + 1e-6, "LP {a} + {b} vs brute force {best}");
    // Out of reach: a clear reason with the best achievable value.
    let (s, _, v) = post(
        app(),
        "/api/scenes/office/optimize",
        r#"{"targets": [{"grid": "desk", "eavg_min": 5000}]}"#,
    )
    .await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);
    let d = v["detail"].as_str().unwrap();
    assert!(d.contains("out of reach") && d.contains("100 %"), "{d}");
    // Bad targets are precise 422s.
    for (body, needle) in [
        (r#"{"targets": []}"#, "non-empty"),
        (r#"{"targets": [{"grid": "desk"}]}"#, "sets no bound"),
        (r#"{"targets": [{"grid": "desk", "u0_min": 2}]}"#, "u0_min"),
        (
            r#"{"targets": [{"grid": "desk", "eavg": 5}]}"#,
            "unknown field",
        ),
        (
            r#"{"targets": [{"grid": "desk", "u0_min": 0.9}]}"#,
            "u0_min needs",
        ),
        (
            r#"{"targets": [{"grid": "nope", "eavg_min": 5}]}"#,
            "unknown grid",
        ),
        (
            r#"{"targets": [{"grid": "desk", "eavg_min": 5}], "groups": ["x"]}"#,
            "unknown light group",
        ),
    ] {
        let (s, _, v) = post(app(), "/api/scenes/office/optimize", body).await;
        assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{body}");
        assert!(
            v["detail"].as_str().unwrap().contains(needle),
            "{body}: {v}"
        );
    }
}
