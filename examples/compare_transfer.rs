//! Compares the transfer modes of one scene per surface, and the Cornell box against its
//! path-traced reference (`tests/data/cornell_reference.json`).
//!
//! `cargo run --release --example compare_transfer -- [SCENE_DIR] [MODE_A] [MODE_B]
//! [MAX_EDGE]` (default: scenes/cornell-box factored hierarchical, the scene's meshing). Prints per surface the mean
//! radiosity (lm/m²) of both modes and their relative difference, the power balance (lm),
//! and for the Cornell box each mode's error against the reference.

use std::path::PathBuf;
use std::time::Instant;

use relight::bake::{load_or_bake, BakeOptions, Baked, CachePolicy};
use relight::model::report::surface_averages;
use relight::scene::TransferChoice;

fn bake(dir: &std::path::Path, mode: &str, max_edge: Option<f64>) -> Baked {
    let choice: TransferChoice =
        serde_json::from_value(serde_json::Value::String(mode.into())).expect("mode");
    let opts = BakeOptions {
        choice: Some(choice),
        max_edge,
        ..Default::default()
    };
    let t = Instant::now();
    let b = load_or_bake(dir, CachePolicy::Off, &opts, &|_, _| {}).expect("bake");
    eprintln!(
        "{mode}: {} patches, baked in {:.2} s ({:?})",
        b.mesh.len(),
        t.elapsed().as_secs_f64(),
        b.transfer.mode
    );
    if let Some(h) = &b.transfer.hierarchy {
        eprintln!("  {:?}", h.stats);
    }
    b
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dir = PathBuf::from(args.get(1).map_or("scenes/cornell-box", |s| s.as_str()));
    let ma = args.get(2).map_or("factored", |s| s.as_str());
    let mb = args.get(3).map_or("hierarchical", |s| s.as_str());
    let max_edge = args
        .get(4)
        .map(|s| s.parse::<f64>().expect("max_edge in metres"));
    let (a, b) = (bake(&dir, ma, max_edge), bake(&dir, mb, max_edge));
    let on = vec![relight::color::Rgb::ONE; a.transfer.group_count()];
    let (sa, sb) = (a.transfer.relight(&on), b.transfer.relight(&on));
    let (ra, rb) = (
        surface_averages(&a.scene, &a.mesh, &sa),
        surface_averages(&b.scene, &b.mesh, &sb),
    );
    let (mut wsum, mut asum, mut worst) = (0.0, 0.0, 0f64);
    println!("{:<24} {:>12} {:>12} {:>9}", "surface", ma, mb, "diff %");
    for (name, x) in &ra {
        let Some(y) = rb.get(name) else { continue };
        let (p, q) = (
            x.radiosity.iter().sum::<f64>(),
            y.radiosity.iter().sum::<f64>(),
        );
        if p <= 0.0 {
            continue;
        }
        let d = q / p - 1.0;
        println!("{name:<24} {p:>12.4} {q:>12.4} {:>9.3}", 100.0 * d);
        wsum += x.area * d.abs();
        asum += x.area;
        worst = worst.max(d.abs());
    }
    println!(
        "area-weighted mean |diff| {:.3} %, worst {:.3} %",
        100.0 * wsum / asum,
        100.0 * worst
    );
    for (m, t, s) in [(ma, &a.transfer, &sa), (mb, &b.transfer, &sb)] {
        let p = t.power(s);
        let e: f64 = p.emitted.iter().sum();
        println!(
            "{m}: emitted {:.4} lm, absorbed {:.4}, escaped {:.4} ({:.3} %), imbalance {:.3} %",
            e,
            p.absorbed.iter().sum::<f64>(),
            p.escaped.iter().sum::<f64>(),
            100.0 * p.escaped.iter().sum::<f64>() / e,
            100.0 * (e - p.absorbed.iter().sum::<f64>() - p.escaped.iter().sum::<f64>()) / e
        );
    }
    if !dir.ends_with("cornell-box") {
        return;
    }
    let reference: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string("tests/data/cornell_reference.json").expect("reference"),
    )
    .expect("json");
    let surfaces = reference["states"]["white"]["surfaces"]
        .as_object()
        .expect("surfaces");
    for (m, baked, sol) in [(ma, &a, &sa), (mb, &b, &sb)] {
        let ours = surface_averages(&baked.scene, &baked.mesh, sol);
        let (mut worst, mut wsum, mut asum, mut wname) = (0f64, 0f64, 0f64, String::new());
        for (name, r) in surfaces {
            if name == "light" {
                continue;
            }
            let o = &ours[name.as_str()];
            let area = r["area_m2"].as_f64().unwrap_or(0.0);
            let mut mean = 0.0;
            let mut signed = [0.0; 3];
            for c in 0..3 {
                let want = r["radiosity_B"][c].as_f64().unwrap_or(f64::NAN);
                let rel = (o.radiosity[c] - want) / want;
                signed[c] = 100.0 * rel;
                mean += rel.abs() / 3.0;
                if rel.abs() > worst {
                    worst = rel.abs();
                    wname = name.clone();
                }
            }
            println!(
                "  {m:<12} {name:<20} {:>7.3} {:>7.3} {:>7.3} %",
                signed[0], signed[1], signed[2]
            );
            wsum += area * mean;
            asum += area;
        }
        println!(
            "{m} vs reference: mean {:.3} %, worst {:.3} % ({wname})",
            100.0 * wsum / asum,
            100.0 * worst
        );
    }
}
