//! `illuminance` on surfaces, at points and on grids, and `batch` of many states at once.

use axum::http::StatusCode;
use relight::color::Rgb;
use serde_json::{json, Value};

use super::{app, post, ready};
use crate::common;

#[tokio::test]
async fn illuminance_per_surface_and_at_points_matches_the_reference() {
    let _gate = common::shared();
    let reference: Value = serde_json::from_str(
        &std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("tests/data/cornell_reference.json"),
        )
        .unwrap(),
    )
    .unwrap();
    let grid = reference["states"]["white"]["floor_grid_5x5_y1mm"]["points"]
        .as_array()
        .unwrap();
    let points: Vec<Value> = grid
        .iter()
        .map(|p| json!({"position": p["p"], "normal": p["n"]}))
        .collect();
    let body = json!({"surfaces": ["floor", "back_wall"], "points": points});
    let (s, _, v) = post(
        app(),
        "/api/scenes/cornell-box/illuminance",
        body.to_string(),
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let got = v["points"].as_array().unwrap();
    assert_eq!(got.len(), 25);
    let mut worst = 0f64;
    for (g, r) in got.iter().zip(grid) {
        for c in 0..3 {
            let (a, b) = (g["rgb"][c].as_f64().unwrap(), r["E"][c].as_f64().unwrap());
            if b == 0.0 {
                assert!(a < 1e-3, "inside a block: {a}");
            } else {
                worst = worst.max(((a - b) / b).abs());
            }
        }
    }
    eprintln!("floor points: worst relative error {worst:.4}");
    // Measured: 1.24 % at worst (a point in the short block's penumbra), most under 0.5 %.
    assert!(worst < 0.02, "worst point error {worst}");
    // Per surface: avg equals the library's area-weighted mean; min ≤ avg ≤ max.
    let floor = &v["surfaces"]["floor"];
    let r = ready("cornell-box");
    let sol = r.model.baked.transfer.relight(&[Rgb::ONE]);
    let avg =
        &relight::model::report::surface_averages(&r.model.baked.scene, &r.model.baked.mesh, &sol)
            ["floor"];
    assert!((floor["avg"]["rgb"][1].as_f64().unwrap() - avg.illuminance[1]).abs() < 1e-9);
    let (mn, av, mx) = (
        floor["min"]["lux"].as_f64().unwrap(),
        floor["avg"]["lux"].as_f64().unwrap(),
        floor["max"]["lux"].as_f64().unwrap(),
    );
    assert!(mn <= av && av <= mx);
    assert!((floor["uniformity"].as_f64().unwrap() - mn / av).abs() < 1e-12);
    // Errors.
    let (s, _, v) = post(
        app(),
        "/api/scenes/cornell-box/illuminance",
        r#"{"surfaces": ["roof"]}"#,
    )
    .await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(v["detail"]
        .as_str()
        .unwrap()
        .contains("unknown surface 'roof'"));
    let (s, _, v) = post(
        app(),
        "/api/scenes/cornell-box/illuminance",
        r#"{"points": [{"position": [0, 0], "normal": [0, 1, 0]}]}"#,
    )
    .await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(v["detail"].as_str().unwrap().contains("points[0].position"));
}

#[tokio::test]
async fn batch_answers_each_state_like_a_single_request() {
    let _gate = common::shared();
    let states: Vec<Value> = (0..5)
        .map(|k| json!({"lights": {"ceiling": k as f64 * 0.25, "lamp": 1.0 - k as f64 * 0.2}}))
        .collect();
    let body = json!({"states": states, "surfaces": ["desk_top"]});
    let (s, _, v) = post(app(), "/api/scenes/desk-room/batch", body.to_string()).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let results = v["results"].as_array().unwrap();
    assert_eq!(results.len(), 5);
    for (k, res) in results.iter().enumerate() {
        let single = json!({"lights": {"ceiling": k as f64 * 0.25, "lamp": 1.0 - k as f64 * 0.2}, "surfaces": ["desk_top"]});
        let (_, _, one) = post(
            app(),
            "/api/scenes/desk-room/illuminance",
            single.to_string(),
        )
        .await;
        assert_eq!(res["surfaces"]["desk_top"], one["surfaces"]["desk_top"]);
        assert!(res["power"]["emitted_lm"].as_f64().unwrap() >= 0.0);
    }
    let too_many: Vec<Value> = (0..1001).map(|_| json!({})).collect();
    let (s, _, v) = post(
        app(),
        "/api/scenes/desk-room/batch",
        json!({ "states": too_many }).to_string(),
    )
    .await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(v["detail"].as_str().unwrap().contains("1000"));
    let (s, _, v) = post(
        app(),
        "/api/scenes/desk-room/batch",
        r#"{"states": [{"lights": {"x": 1}}]}"#,
    )
    .await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(v["detail"].as_str().unwrap().starts_with("states[0]"));
}

#[tokio::test]
async fn grids_answer_with_statistics_and_luminaire_power() {
    let _gate = common::shared();
    let (s, _, v) = post(
        app(),
        "/api/scenes/office/illuminance",
        r#"{"lights": {"window_row": 0.5}, "grids": ["desk", "workplane"], "surfaces": []}"#,
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let r = ready("office");
    for id in ["desk", "workplane"] {
        let g = &v["grids"][id];
        let values: Vec<f64> = g["values"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert_eq!(
            g["excluded"], 0,
            "no point of the office's grids is inside an object"
        );
        let gr = r.model.grids.iter().find(|x| x.grid.id == id).unwrap();
        assert_eq!(values.len(), gr.len());
        let avg = values.iter().sum::<f64>() / values.len() as f64;
        let min = values.iter().copied().fold(f64::INFINITY, f64::min);
        let max = values.iter().copied().fold(0.0, f64::max);
        assert!((g["avg"].as_f64().unwrap() - avg).abs() < 1e-6 * avg);
        assert!((g["u0"].as_f64().unwrap() - min / avg).abs() < 1e-6);
        assert!((g["min_max"].as_f64().unwrap() - min / max).abs() < 1e-6);
        // Linear in the weights: the half-dimmed window row equals the weighted sum.
        let full = gr.values(&[Rgb::splat(0.5), Rgb::ONE]);
        for (a, b) in values.iter().zip(&full) {
            assert!((a - *b as f64).abs() <= 1e-4 * a.max(1.0));
        }
    }
    // 3 × 2500 lm at half plus 3 × 2500 lm at full (the table integrates to 2495 lm each).
    let lm = v["power"]["luminaire_lumens"].as_f64().unwrap();
    assert!((lm / 11250.0 - 1.0).abs() < 0.005, "{lm}");
    let w = v["power"]["luminaire_watts"].as_f64().unwrap();
    assert!((w / (lm / 113.6) - 1.0).abs() < 1e-6, "{w}");
    // Unknown grids are precise 422s.
    let (s, _, v) = post(
        app(),
        "/api/scenes/office/illuminance",
        r#"{"grids": ["kitchen"]}"#,
    )
    .await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(
        v["detail"].as_str().unwrap().contains("desk, workplane"),
        "{v}"
    );
}
