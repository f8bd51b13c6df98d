//! Compares two transfer modes of one scene per light group: every group alone, and mixed
//! states (one group off, another dimmed), per surface of at least 1 m² (mean incident
//! illuminance, lux), with each state's power balance. The dark-room check of
//! docs/accuracy.md: a group alone lights the other rooms only through their openings.
//!
//! `cargo run --release --example compare_groups -- SCENE_DIR [MODE_A] [MODE_B] [MAX_EDGE]`
//! (default modes: factored hierarchical). Prints the worst surfaces of each state and a
//! summary line per state: surfaces past 2 %, the worst, the power imbalance.

use std::path::PathBuf;
use std::time::Instant;

use relight::bake::{load_or_bake, BakeOptions, Baked, CachePolicy};
use relight::color::Rgb;
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
    let cache = std::env::var("COMPARE_CACHE")
        .ok()
        .filter(|_| mode == "factored");
    let policy = match &cache {
        Some(c) => CachePolicy::ReadWrite(std::path::Path::new(c)),
        None => CachePolicy::Off,
    };
    let b = load_or_bake(dir, policy, &opts, &|_, _| {}).expect("bake");
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
    let dir = PathBuf::from(args.get(1).expect("SCENE_DIR"));
    let ma = args.get(2).map_or("factored", |s| s.as_str());
    let mb = args.get(3).map_or("hierarchical", |s| s.as_str());
    let max_edge = args
        .get(4)
        .map(|s| s.parse::<f64>().expect("max_edge in metres"));
    let (a, b) = (bake(&dir, ma, max_edge), bake(&dir, mb, max_edge));
    let g = a.transfer.group_count();
    let ids: Vec<String> = a.scene.lights.iter().map(|l| l.id.clone()).collect();
    let mut states: Vec<(String, Vec<Rgb>)> = Vec::new();
    states.push(("all".into(), vec![Rgb::ONE; g]));
    for k in 0..g {
        let mut w = vec![Rgb::ZERO; g];
        w[k] = Rgb::ONE;
        states.push((format!("{} alone", ids[k]), w));
    }
    if g >= 2 {
        // The first group off, the second at 50 %, the rest on.
        let mut w = vec![Rgb::ONE; g];
        w[0] = Rgb::ZERO;
        w[1] = Rgb::splat(0.5);
        states.push((format!("{} off, {} at 50 %", ids[0], ids[1]), w));
    }
    let mut worst_all = 0f64;
    for (name, w) in &states {
        let (sa, sb) = (a.transfer.relight(w), b.transfer.relight(w));
        let (ra, rb) = (
            surface_averages(&a.scene, &a.mesh, &sa),
            surface_averages(&b.scene, &b.mesh, &sb),
        );
        let mut rows = Vec::new();
        for (s, x) in &ra {
            let Some(y) = rb.get(s) else { continue };
            let (p, q) = (
                x.illuminance.iter().sum::<f64>(),
                y.illuminance.iter().sum::<f64>(),
            );
            if x.area < 1.0 || p <= 0.0 {
                continue;
            }
            rows.push((s.clone(), p / 3.0, q / 3.0, q / p - 1.0));
        }
        rows.sort_by(|x, y| y.3.abs().total_cmp(&x.3.abs()));
        let past = rows.iter().filter(|r| r.3.abs() > 0.02).count();
        let worst = rows.first().map_or(0.0, |r| r.3.abs());
        worst_all = worst_all.max(worst);
        let balance = |t: &relight::transport::transfer::Transfer, s| {
            let p = t.power(s);
            let e: f64 = p.emitted.iter().sum();
            (e - p.absorbed.iter().sum::<f64>() - p.escaped.iter().sum::<f64>()) / e
        };
        println!(
            "{name}: {} surfaces ≥ 1 m², {past} past 2 %, worst {:.2} %; imbalance {ma} {:.2e}, {mb} {:.2e}",
            rows.len(),
            100.0 * worst,
            balance(&a.transfer, &sa),
            balance(&b.transfer, &sb)
        );
        for (s, p, q, d) in rows.iter().take(
            std::env::var("SHOW")
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or(6),
        ) {
            println!(
                "    {s:<20} {p:>10.3} lx {q:>10.3} lx {:>+8.2} %",
                100.0 * d
            );
        }
    }
    println!("worst over every state: {:.2} %", 100.0 * worst_all);
}
