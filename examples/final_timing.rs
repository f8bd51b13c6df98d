//! Build time of a new `final` view, repeated on one loaded scene so the load and the
//! bake stay out of it: `cargo run --release --example final_timing [SCENE_DIR [WIDTH
//! HEIGHT [RUNS [CACHE_DIR]]]]` (defaults: scenes/office-floor, 1024 × 768, 3 runs, the
//! default cache directory). The scene's first camera; prints each run's seconds and the
//! process's peak memory.
use std::time::Instant;

use relight::bake::{load_or_bake, BakeOptions, CachePolicy};
use relight::model::{Cancel, Model};
use relight::render::final_gather::{patch_locator, FinalSettings};
use relight::render::pipeline::final_images;
use relight::render::{Camera, Shading};

fn main() {
    let arg = |k: usize| std::env::args().nth(k);
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = arg(1).map_or(root.join("scenes/office-floor"), Into::into);
    let num = |k: usize, d: u32| arg(k).and_then(|s| s.parse().ok()).unwrap_or(d);
    let (w, h, runs) = (num(2, 1024), num(3, 768), num(4, 3));
    let cache = arg(5).map_or_else(relight::bake::default_cache_dir, Into::into);
    let policy = CachePolicy::ReadWrite(&cache);
    let b = load_or_bake(&dir, policy, &BakeOptions::default(), &|_, _| {}).unwrap();
    let m = Model::new(b);
    let shading = Shading::new(&m.baked.mesh);
    let patches = patch_locator(&m.baked.mesh, &m.baked.scene.triangles);
    // The benches' RELIGHT_FINAL_* overrides (docs/performance.md).
    let settings = FinalSettings::from_env();
    let cam = Camera::from_def(&m.baked.scene.cameras[0], w, h);
    let times: Vec<f64> = (0..runs)
        .map(|_| {
            let t0 = Instant::now();
            let gi =
                final_images(&m, &shading, &patches, &cam, &settings, &Cancel::default()).unwrap();
            std::hint::black_box(gi);
            t0.elapsed().as_secs_f64()
        })
        .collect();
    println!(
        "{{\"scene\": {:?}, \"width\": {w}, \"height\": {h}, \"build_s\": {times:.2?}, \"peak_mb\": {:.0}}}",
        dir.display(),
        relight::bench::peak_rss_mb()
    );
}
