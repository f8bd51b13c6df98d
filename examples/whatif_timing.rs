//! Lighting-design what-if timings (medians): `cargo run --release --example whatif_timing`.
//!
//! - the office bake, cold (form factors, direct light per luminaire, columns, grids);
//! - a grid answer for ~1,000 points per lighting state;
//! - an optimization over 8 light groups.
//!
//! `cargo run --release --example whatif_timing -- office-floor [CACHE_DIR]` times the
//! same questions on `scenes/office-floor` (177k patches, hierarchical), loaded from
//! `CACHE_DIR` (default `target/tmp/office-floor-cache`; baked there first if missing):
//! grid answers, illuminance at points, surface statistics and an optimization.
//!
//! `cargo run --release --example whatif_timing -- daylight` times daylight on the office
//! (server-side work, without HTTP): 25 points under a new sky once their gathers are
//! cached, the 960-point work plane per new sky, a clear sky with the sun, and `/annual`
//! for a 1,000-point grid (a 40 × 25 grid added to a copy of the office) over the year of
//! Mannheim weather in its folder.
use std::path::PathBuf;
use std::time::Instant;

use glam::DVec3;

use relight::bake::{load_or_bake, BakeOptions, CachePolicy};
use relight::color::Rgb;
use relight::model::optimize::GridTarget;
use relight::model::Model;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some("office-floor") {
        let cache = args.get(2).map_or(
            PathBuf::from("target/tmp/office-floor-cache"),
            PathBuf::from,
        );
        return office_floor(&cache);
    }
    if args.get(1).map(String::as_str) == Some("daylight") {
        return daylight();
    }
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
    let office = Model::new(office);
    println!(
        "office grids (baked): {} points",
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
            let w: Vec<Rgb> = (0..groups)
                .map(|i| Rgb::splat(((k + i) % 10) as f32 / 10.0))
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
    let full_avg = room.grid_answer(0, &vec![Rgb::ONE; groups]).avg;
    let target = GridTarget {
        grid: 0,
        eavg_min: Some(0.6 * full_avg),
        emin_min: None,
        u0_min: Some(0.5),
        ugr_max: None,
    };
    let base = vec![Rgb::ONE; groups];
    let free: Vec<usize> = (0..groups).collect();
    let times: Vec<f64> = (0..20)
        .map(|_| {
            let t = Instant::now();
            let answer = room.optimize(&base, &[], &free, &[target]).unwrap();
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

/// Median milliseconds of `runs` calls of `f`.
fn time_ms(runs: usize, mut f: impl FnMut(usize)) -> f64 {
    median(
        (0..runs)
            .map(|k| {
                let t = Instant::now();
                f(k);
                t.elapsed().as_secs_f64() * 1e3
            })
            .collect(),
    )
}

fn office_floor(cache: &std::path::Path) {
    let t = Instant::now();
    let baked = load_or_bake(
        "scenes/office-floor".as_ref(),
        CachePolicy::ReadWrite(cache),
        &BakeOptions::default(),
        &|_, _| {},
    )
    .unwrap();
    println!(
        "office-floor: {} patches, {} groups, loaded in {:.2} s (from cache: {})",
        baked.transfer.n,
        baked.scene.lights.len(),
        t.elapsed().as_secs_f64(),
        baked.stats.from_cache
    );
    let m = Model::new(baked);
    let groups = m.baked.scene.lights.len();
    let state = |k: usize| -> Vec<Rgb> {
        (0..groups)
            .map(|i| Rgb::splat(((k + i) % 10) as f32 / 10.0 + 0.1))
            .collect()
    };
    let all: Vec<usize> = (0..m.grids.len()).collect();
    let points: usize = m.grids.iter().map(|g| g.len()).sum();
    let ms = time_ms(200, |k| {
        std::hint::black_box(m.grid_answers(&all, &state(k)));
    });
    println!(
        "grid answers: all {} grids, {points} points: median {ms:.3} ms",
        all.len()
    );
    for (gi, g) in m.grids.iter().enumerate() {
        let ms = time_ms(200, |k| {
            std::hint::black_box(m.grid_answer(gi, &state(k)));
        });
        println!(
            "grid answer {}: {} points: median {ms:.3} ms",
            g.grid.id,
            g.len()
        );
    }
    let mut b = vec![0f32; 3 * m.patches()];
    let mut h = vec![0f32; 3 * m.patches()];
    let ms = time_ms(50, |k| {
        m.per_patch_groups(
            &state(k),
            relight::model::query::Quantity::Radiosity,
            &mut b,
        );
    });
    println!("per-patch radiosity for a new state: median {ms:.3} ms");
    let surfaces: Vec<usize> = (0..m.baked.scene.surfaces.len()).collect();
    let ms = time_ms(50, |k| {
        m.per_patch_groups(
            &state(k),
            relight::model::query::Quantity::Illuminance,
            &mut h,
        );
        std::hint::black_box(m.surface_stats(&surfaces, &h));
    });
    println!(
        "illuminance statistics of all {} surfaces for a new state: median {ms:.3} ms",
        surfaces.len()
    );
    let w = state(0);
    m.per_patch_groups(&w, relight::model::query::Quantity::Radiosity, &mut b);
    let g = &m.grids[0].grid;
    let n = DVec3::from_array(g.normal);
    let ms = time_ms(10, |k| {
        let x = DVec3::from_array(g.points[k % g.points.len()]);
        std::hint::black_box(m.point_illuminance(&b, Some(&w), x, n));
    });
    println!(
        "illuminance at one point (gather over every patch, with occlusion): median {ms:.1} ms"
    );
    let full: Vec<f64> = (0..m.grids.len())
        .map(|gi| m.grid_answer(gi, &vec![Rgb::ONE; groups]).avg)
        .collect();
    let targets: Vec<GridTarget> = full
        .iter()
        .enumerate()
        .map(|(gi, &avg)| GridTarget {
            grid: gi,
            eavg_min: Some(0.6 * avg),
            emin_min: None,
            u0_min: Some(0.4),
            ugr_max: None,
        })
        .collect();
    let base = vec![Rgb::ONE; groups];
    let free: Vec<usize> = (0..groups).collect();
    let ms = time_ms(10, |_| {
        std::hint::black_box(m.optimize(&base, &[], &free, &targets).unwrap());
    });
    println!(
        "optimize: {groups} groups, Eavg ≥ 60 % of full and U0 ≥ 0.4 on {} grids ({points} points): median {ms:.2} ms",
        targets.len()
    );
}

fn daylight() {
    use relight::model::annual::AnnualQuery;
    use relight::model::query::IlluminanceQuery;
    use relight::model::sky_state::SkySpec;
    use relight::model::Cancel;
    // A copy of the office with a 1,000-point grid beside its own.
    let dir = tempfile::tempdir().unwrap();
    for e in std::fs::read_dir("scenes/office").unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), dir.path().join(e.file_name())).unwrap();
    }
    let toml = dir.path().join("scene.toml");
    let mut text = std::fs::read_to_string(&toml).unwrap();
    text += "\n[[grids]]\nid = \"g1000\"\nmin = [0.5, 0.4]\nmax = [5.5, 3.525]\nheight = 0.75\nspacing = 0.125\n";
    std::fs::write(&toml, text).unwrap();
    let t = Instant::now();
    let baked = load_or_bake(
        dir.path(),
        CachePolicy::Off,
        &BakeOptions::default(),
        &|_, _| {},
    )
    .unwrap();
    println!(
        "office with its sky: {} patches, baked in {:.1} s",
        baked.transfer.n,
        t.elapsed().as_secs_f64()
    );
    let m = Model::new(baked);
    let site = m.site().unwrap().clone();
    let cancel = Cancel::default();
    let sky = |k: usize, kind: &str| -> relight::model::sky_state::SkyState {
        let h = 5000.0 + 500.0 * (k % 20) as f64;
        let v = match kind {
            "clear, new sun position" => serde_json::json!({"type": "cie_clear",
                "horizontal_illuminance": h, "direct_normal_illuminance": 60000,
                "sun": {"altitude": 20 + k % 40, "azimuth": 120 + 3 * (k % 40)}}),
            "clear, same sun position" => serde_json::json!({"type": "cie_clear",
                "horizontal_illuminance": h, "direct_normal_illuminance": 40000 + 1000 * (k % 20),
                "sun": {"altitude": 35, "azimuth": 190}}),
            _ => serde_json::json!({"type": kind, "horizontal_illuminance": h}),
        };
        serde_json::from_value::<SkySpec>(v)
            .unwrap()
            .resolve(&site)
            .unwrap()
    };
    let points: Vec<(DVec3, DVec3)> = (0..25)
        .map(|i| {
            (
                DVec3::new(1.0 + (i % 5) as f64, 0.75, 0.6 + 0.6 * (i / 5) as f64),
                DVec3::Y,
            )
        })
        .collect();
    let q = IlluminanceQuery {
        surfaces: vec![],
        points,
        ..Default::default()
    };
    let t = Instant::now();
    m.daylight(&sky(0, "cie_overcast"), None, &q, &cancel)
        .unwrap();
    println!(
        "25 points, first sky (gathers and sky views traced): {:.1} ms",
        t.elapsed().as_secs_f64() * 1e3
    );
    for kind in [
        "cie_overcast",
        "uniform",
        "clear, new sun position",
        "clear, same sun position",
    ] {
        let ms = time_ms(50, |k| {
            std::hint::black_box(m.daylight(&sky(k + 1, kind), None, &q, &cancel).unwrap());
        });
        println!("25 points, a new {kind} sky (gathers cached): median {ms:.2} ms");
    }
    let wp = m
        .grids
        .iter()
        .position(|g| g.grid.id == "workplane")
        .unwrap();
    let qg = IlluminanceQuery {
        surfaces: vec![],
        grids: vec![wp],
        ..Default::default()
    };
    let t = Instant::now();
    m.daylight(&sky(0, "cie_overcast"), None, &qg, &cancel)
        .unwrap();
    println!(
        "work plane ({} points), first sky: {:.0} ms",
        m.grids[wp].len(),
        t.elapsed().as_secs_f64() * 1e3
    );
    let ms = time_ms(20, |k| {
        std::hint::black_box(
            m.daylight(&sky(k + 1, "cie_overcast"), None, &qg, &cancel)
                .unwrap(),
        );
    });
    println!("work plane, a new overcast sky: median {ms:.2} ms");
    let g1000 = m.grids.iter().position(|g| g.grid.id == "g1000").unwrap();
    let weather =
        relight::daylight::epw::parse_bytes(&std::fs::read("scenes/office/mannheim.epw").unwrap())
            .unwrap();
    let aq = AnnualQuery {
        weather: std::sync::Arc::new(weather),
        grids: vec![g1000],
        occupied: (8.0, 18.0),
    };
    for run in ["first", "again"] {
        let t = Instant::now();
        let a = m.annual(&aq, &cancel).unwrap();
        println!(
            "annual, {} points × {} hours, {run}: {:.2} s (sDA300/50 {:.1} %)",
            m.grids[g1000].len(),
            a.weather.hours,
            t.elapsed().as_secs_f64(),
            a.grids["g1000"].sda_300_50
        );
    }
}
