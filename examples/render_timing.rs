//! Warm per-stage timings of a relit image (medians of 50 runs):
//! `cargo run --release --example render_timing`.
use std::time::Instant;

use relight::bake::{load_or_bake, BakeOptions, CachePolicy};
use relight::model::query::Quantity;
use relight::model::Model;
use relight::render::{self, Camera, Format, GroupImages, Shading, ToneMap, ViewBuffer};

/// Runs `f` 50 times (after 5 warm-ups); per stage, the median of the stage times it
/// returns (ms).
fn medians<const K: usize>(mut f: impl FnMut() -> [f64; K]) -> [f64; K] {
    for _ in 0..5 {
        f();
    }
    let gap = std::env::var("GAP_MS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    let runs: Vec<[f64; K]> = (0..50)
        .map(|_| {
            std::thread::sleep(std::time::Duration::from_millis(gap));
            f()
        })
        .collect();
    std::array::from_fn(|k| {
        let mut v: Vec<f64> = runs.iter().map(|r| r[k]).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    })
}

fn ms(a: Instant, b: Instant) -> f64 {
    (b - a).as_secs_f64() * 1e3
}

fn main() {
    let cache = relight::bake::default_cache_dir();
    for (scene, cam_id, w, h, fmt) in [
        ("scenes/cornell-box", "front", 512, 512, Format::Png),
        ("scenes/cornell-box", "front", 1024, 768, Format::Jpeg),
        ("scenes/desk-room", "door", 1024, 768, Format::Jpeg),
    ] {
        let model = Model::new(
            load_or_bake(
                scene.as_ref(),
                CachePolicy::ReadWrite(&cache),
                &BakeOptions::default(),
                &|_, _| {},
            )
            .unwrap(),
        );
        let b = &model.baked;
        let shading = Shading::new(&b.mesh);
        let cam = Camera::from_def(
            b.scene.cameras.iter().find(|c| c.id == cam_id).unwrap(),
            w,
            h,
        );
        let t = Instant::now();
        let view = ViewBuffer::build(&b.mesh, &shading, &cam);
        let t_view = t.elapsed().as_secs_f64() * 1e3;
        let weights = vec![relight::color::Rgb::new(0.7, 0.6, 0.5); b.scene.lights.len()];
        let mut out = vec![0f32; 3 * b.transfer.n];
        // Any lighting (also per-patch emission): relight, vertex values, gather.
        let m = medians(|| {
            let t0 = Instant::now();
            model.per_patch_groups(&weights, Quantity::Radiosity, &mut out);
            let t1 = Instant::now();
            let vv = shading.vertex_values(&out);
            let t2 = Instant::now();
            let (px, _) =
                view.gather_tonemapped(&vv, std::f32::consts::FRAC_1_PI, None, ToneMap::Filmic);
            let t3 = Instant::now();
            std::hint::black_box(render::encode_8bit(&px, w, h, fmt).unwrap());
            let t4 = Instant::now();
            [ms(t0, t1), ms(t1, t2), ms(t2, t3), ms(t3, t4), ms(t0, t4)]
        });
        println!(
            "{scene} {w}x{h} {fmt:?}: view buffer {t_view:.1} ms ({} KB); gather path: relight {:.3} ms, vertex values {:.2} ms, gather+exposure+tonemap {:.2} ms, encode {:.2} ms, total {:.2} ms",
            view.bytes() / 1024, m[0], m[1], m[2], m[3], m[4]
        );
        // Light-group states: a weighted sum of per-group images instead of the gather.
        let t = Instant::now();
        let gi = GroupImages::radiance(&view, &shading, &b.transfer);
        let groups = b.transfer.group_count();
        let t_gi = t.elapsed().as_secs_f64() * 1e3;
        let m = medians(|| {
            let t0 = Instant::now();
            let (px, _) = gi.tonemapped(&weights, None, ToneMap::Filmic);
            let t1 = Instant::now();
            std::hint::black_box(render::encode_8bit(&px, w, h, fmt).unwrap());
            let t2 = Instant::now();
            [ms(t0, t1), ms(t1, t2), ms(t0, t2)]
        });
        println!(
            "  group-image path ({} groups, {} KB, built in {t_gi:.1} ms, server uses it: {}): sum+exposure+tonemap {:.2} ms, encode {:.2} ms, total {:.2} ms",
            groups, gi.bytes() / 1024, GroupImages::worthwhile(&view, groups), m[0], m[1], m[2]
        );
    }
}
