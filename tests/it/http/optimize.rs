//! `optimize`: the least luminous flux that meets illuminance targets on grids.

use axum::http::StatusCode;
use relight::color::Rgb;

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
        let s = desk.stats(&[Rgb::splat(x as f32), Rgb::splat(y as f32)]);
        s.avg >= 500.0 * (1.0 - 1e-4) && s.u0.is_some_and(|u| u >= 0.6 - 1e-4)
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

#[tokio::test]
async fn a_ugr_ceiling_is_honoured_at_the_least_flux_or_refused_with_the_reason() {
    let _gate = common::shared();
    let r = ready("office");
    let m = &r.model;
    let gi = m.grids.iter().position(|g| g.grid.id == "desk").unwrap();
    let desk = &m.grids[gi];
    let observers = relight::model::compliance::task_observers(&desk.grid);
    let cancel = relight::model::Cancel::default();
    let worst_ugr = |x: f64, y: f64| {
        m.glare(
            &observers,
            &relight::model::Lighting::Groups(vec![Rgb::splat(x as f32), Rgb::splat(y as f32)]),
            &cancel,
        )
        .unwrap()
        .iter()
        .filter_map(|o| o.ugr)
        .fold(f64::NEG_INFINITY, f64::max)
    };
    let ask = |ceiling: f64| {
        format!(r#"{{"targets": [{{"grid": "desk", "eavg_min": 300, "ugr_max": {ceiling}}}]}}"#)
    };
    // Without a ceiling the cheapest levels for 300 lx glare at some UGR; ask for 0.5 less.
    let (s, _, free) = post(
        app(),
        "/api/scenes/office/optimize",
        r#"{"targets": [{"grid": "desk", "eavg_min": 300}]}"#,
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{free}");
    let lv = |v: &serde_json::Value, id: &str| v["lights"][id]["intensity"].as_f64().unwrap();
    let u_free = worst_ugr(lv(&free, "window_row"), lv(&free, "corridor_row"));
    let ceiling = ((u_free - 0.5) * 100.0).round() / 100.0;
    let (s, _, v) = post(app(), "/api/scenes/office/optimize", ask(ceiling)).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let (a, b) = (lv(&v, "window_row"), lv(&v, "corridor_row"));
    let t = &v["targets"][0];
    assert_eq!(t["met"], true, "{v}");
    assert_eq!(t["ugr_max"].as_f64(), Some(ceiling));
    // The answer's UGR is the rating at its levels, within the ceiling.
    let u = worst_ugr(a, b);
    assert!((t["achieved"]["ugr"].as_f64().unwrap() - u).abs() < 1e-9);
    assert!(u <= ceiling + 1e-3, "UGR {u} over {ceiling}");
    assert!(
        desk.stats(&[Rgb::splat(a as f32), Rgb::splat(b as f32)])
            .avg
            >= 300.0 * (1.0 - 1e-4)
    );
    // Brute force over a 1 % grid of levels: nothing that meets both uses less flux (the
    // rows have the same lumens, so flux ∝ a + b); the ceiling costs flux.
    let meets = |x: f64, y: f64| {
        desk.stats(&[Rgb::splat(x as f32), Rgb::splat(y as f32)])
            .avg
            >= 300.0
            && worst_ugr(x, y) <= ceiling
    };
    let best = (0..=100)
        .flat_map(|i| (0..=100).map(move |j| (i as f64 / 100.0, j as f64 / 100.0)))
        .filter(|&(x, y)| meets(x, y))
        .map(|(x, y)| x + y)
        .fold(f64::INFINITY, f64::min);
    assert!(best.is_finite(), "the brute force found no feasible levels");
    assert!(a + b <= best + 1e-4, "{a} + {b} vs brute force {best}");
    let free_flux = lv(&free, "window_row") + lv(&free, "corridor_row");
    assert!(
        a + b >= free_flux - 1e-6,
        "{a} + {b} vs {free_flux} without the ceiling"
    );

    // A ceiling no level can honour with 300 lx: refused, saying which.
    let (s, _, v) = post(app(), "/api/scenes/office/optimize", ask(8.0)).await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{v}");
    let d = v["detail"].as_str().unwrap();
    assert!(d.contains("not together with UGR ≤ 8 at desk"), "{d}");
    // A ceiling alone, or out of range: 422 naming the field.
    for (body, says) in [
        (
            r#"{"targets": [{"grid": "desk", "ugr_max": 19}]}"#,
            "ugr_max needs a positive eavg_min",
        ),
        (
            r#"{"targets": [{"grid": "desk", "eavg_min": 300, "ugr_max": 50}]}"#,
            "targets[0].ugr_max = 50",
        ),
    ] {
        let (s, _, v) = post(app(), "/api/scenes/office/optimize", body).await;
        assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{v}");
        assert!(v["detail"].as_str().unwrap().contains(says), "{v}");
    }
}

/// Candidates are checked before any work: too many pairs, a position outside the scene,
/// a file the scene lacks, and a columns scene each get a 422 naming what is wrong.
#[tokio::test]
async fn optimize_candidates_with_bad_input_get_a_422() {
    let _gate = common::shared();
    let target = r#""targets": [{"grid": "desk", "eavg_min": 300}]"#;
    let many: Vec<String> = (0..101)
        .map(|i| format!("[{}, 2.9, 1]", 0.01 * i as f64))
        .collect();
    let cases = [
        (
            "office",
            format!(
                r#"{{{target}, "candidates": {{"positions": [{}], "photometry": ["a.ies", "b.ies"]}}}}"#,
                many.join(",")
            ),
            "at most 200 pairs",
        ),
        (
            "office",
            format!(
                r#"{{{target}, "candidates": {{"positions": [[1, 2.9, 1]], "photometry": ["downlight.ies"]}}}}"#
            ),
            "columns",
        ),
        (
            "desk-room",
            format!(
                r#"{{{target}, "candidates": {{"positions": [[1, 9, 1]], "photometry": ["x.ies"]}}}}"#
            ),
            "candidates.positions[0]",
        ),
        (
            "desk-room",
            format!(
                r#"{{{target}, "candidates": {{"positions": [[1, 2.5, 1]], "photometry": ["missing.ies"]}}}}"#
            ),
            "missing.ies",
        ),
    ];
    for (scene, body, needle) in cases {
        let (s, _, v) = post(app(), &format!("/api/scenes/{scene}/optimize"), body).await;
        assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{v}");
        assert!(
            v["detail"].as_str().unwrap().contains(needle),
            "{needle}: {v}"
        );
    }
}
