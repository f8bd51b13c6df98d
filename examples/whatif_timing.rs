//! Lighting-design what-if timings (medians): `cargo run --release --example whatif_timing`.
//!
//! - the office bake, cold (form factors, direct light per luminaire, columns);
//! - a grid answer for ~1,000 points per lighting state;
//! - an optimization over 8 light groups.
use std::time::Instant;

use relight::bake::{load_or_bake, BakeOptions, CachePolicy};
use relight::model::optimize::GridTarget;
use relight::model::Model;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let opts = BakeOptions::default();
    let t = Instant::now();
    let office = load_or_bake(
        "scenes/office".as_ref(),
        CachePolicy::Off,
        &opts,
        &|_, _| {},
    )
    .unwrap();
    println!(
        "office cold bake: {:.2} s ({} patches, {} luminaires)",
        t.elapsed().as_secs_f64(),
        office.transfer.n,
        office
            .scene
            .lights
            .iter()
            .map(|g| g.luminaires.len())
            .sum::<usize>()
    );
    let t = Instant::now();
    let office = Model::new(office);
    println!(
        "office grids precomputed: {:.2} s ({} points)",
        t.elapsed().as_secs_f64(),
        office.grids.iter().map(|g| g.len()).sum::<usize>()
    );

    // An 8-group room with a 1,092-point work plane.
    let dir = tempfile::tempdir().unwrap();
    relight::bench::write_group_room(dir.path(), 8, 3000).unwrap();
    let mut toml = std::fs::read_to_string(dir.path().join("scene.toml")).unwrap();
    toml += "\n[[grids]]\nid = \"workplane\"\nmin = [0.5, 0.5]\nmax = [7.5, 5.5]\nheight = 0.75\nspacing = 0.18\n";
    std::fs::write(dir.path().join("scene.toml"), toml).unwrap();
    let room = Model::new(load_or_bake(dir.path(), CachePolicy::Off, &opts, &|_, _| {}).unwrap());
    let g = &room.grids[0];
    let groups = room.baked.scene.lights.len();
    let times: Vec<f64> = (0..200)
        .map(|k| {
            let w: Vec<[f32; 3]> = (0..groups)
                .map(|i| [((k + i) % 10) as f32 / 10.0; 3])
                .collect();
            let t = Instant::now();
            std::hint::black_box(room.grid_answer(0, &w));
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    println!(
        "grid answer ({} points, {groups} groups, statistics included): median {:.3} ms",
        g.len(),
        median(times)
    );
    let full_avg = room.grid_answer(0, &vec![[1.0; 3]; groups]).avg;
    let target = GridTarget {
        grid: 0,
        eavg_min: Some(0.6 * full_avg),
        emin_min: None,
        u0_min: Some(0.5),
    };
    let base = vec![[1.0f32; 3]; groups];
    let free: Vec<usize> = (0..groups).collect();
    let times: Vec<f64> = (0..20)
        .map(|_| {
            let t = Instant::now();
            let answer = room.optimize(&base, &free, &[target]).unwrap();
            std::hint::black_box(answer);
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    println!(
        "optimize ({groups} groups, Eavg ≥ {:.0} lx and U0 ≥ 0.5 over {} points): median {:.2} ms",
        0.6 * full_avg,
        g.len(),
        median(times)
    );
}
