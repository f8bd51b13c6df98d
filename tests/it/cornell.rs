//! The bundled Cornell box against the independent path-traced reference
//! (`tests/data/cornell_reference.json`, a copy of shared/reference/cornell-box/reference.json).

use relight::color::Rgb;
use relight::model::report::surface_averages;

use crate::common;

#[test]
fn cornell_box_matches_the_path_traced_reference() {
    let _gate = common::shared();
    let b = common::cornell_baked();
    assert!(
        b.mesh.len() >= 3000,
        "default meshing has {} patches",
        b.mesh.len()
    );
    let sol = b.transfer.relight(&[Rgb::ONE]);
    let ours = surface_averages(&b.scene, &b.mesh, &sol);
    let reference: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("tests/data/cornell_reference.json"),
        )
        .unwrap(),
    )
    .unwrap();
    let surfaces = reference["states"]["white"]["surfaces"]
        .as_object()
        .unwrap();
    let (mut worst, mut wsum, mut asum) = (0f64, 0f64, 0f64);
    for (name, r) in surfaces {
        if name == "light" {
            continue;
        }
        let ours = &ours[name.as_str()];
        let area = r["area_m2"].as_f64().unwrap();
        assert!(
            (ours.area / area - 1.0).abs() < 1e-6,
            "{name}: area {} vs {area}",
            ours.area
        );
        let mut mean_abs = 0.0;
        for (quantity, got) in [
            ("radiosity_B", ours.radiosity),
            ("irradiance_E", ours.illuminance),
        ] {
            for c in 0..3 {
                let want = r[quantity][c].as_f64().unwrap();
                let rel = (got[c] - want) / want;
                worst = worst.max(rel.abs());
                if quantity == "radiosity_B" {
                    mean_abs += rel.abs() / 3.0;
                }
            }
        }
        wsum += area * mean_abs;
        asum += area;
    }
    let mean = wsum / asum;
    // Measured at 5498 patches (contact lines refined): mean 0.11 %, worst 0.61 % (short
    // block sides). The limits are the targets (0.3 %, 1 %).
    assert!(mean < 0.003, "area-weighted mean |rel. err| {mean:.4}");
    assert!(worst < 0.01, "worst |rel. err| {worst:.4}");
    // The power balance of the reference: the light emits 0.6825 W per channel.
    let p = b.transfer.power(&sol);
    for c in 0..3 {
        assert!((p.emitted[c] - 0.6825).abs() < 1e-4);
        let rel = (p.emitted[c] - p.absorbed[c] - p.escaped[c]) / p.emitted[c];
        assert!(rel.abs() < 1e-4, "imbalance {rel}");
    }
    let absorbed_ref = [0.4630, 0.4775, 0.4997];
    for (got, want) in p.absorbed.iter().zip(absorbed_ref) {
        assert!((got / want - 1.0).abs() < 0.01, "absorbed {:?}", p.absorbed);
    }
}
