//! Warm per-stage timings of a relit image: `cargo run --release --example render_timing`.
use std::time::Instant;

use relight::bake::{load_or_bake, BakeOptions, CachePolicy};
use relight::render::{self, Camera, Format, Shading, ToneMap, ViewBuffer};

fn main() {
    let cache = relight::bake::default_cache_dir();
    for (scene, cam_id, w, h, fmt) in [
        ("scenes/cornell-box", "front", 512, 512, Format::Png),
        ("scenes/desk-room", "door", 1024, 768, Format::Jpeg),
    ] {
        let b = load_or_bake(
            scene.as_ref(),
            CachePolicy::ReadWrite(&cache),
            &BakeOptions::default(),
            &|_, _| {},
        )
        .unwrap();
        let shading = Shading::new(&b.mesh);
        let cam = Camera::from_def(
            b.scene.cameras.iter().find(|c| c.id == cam_id).unwrap(),
            w,
            h,
        );
        let t = Instant::now();
        let view = ViewBuffer::build(&b.mesh, &shading, &cam);
        let t_view = t.elapsed().as_secs_f64() * 1e3;
        let weights = vec![[0.7f32, 0.6, 0.5]; b.scene.lights.len()];
        let mut best = [f64::INFINITY; 5];
        let mut out = vec![0f32; 3 * b.transfer.n];
        for _ in 0..20 {
            let t0 = Instant::now();
            b.transfer.relight_into(&weights, &mut out);
            let t1 = Instant::now();
            let vv = shading.vertex_values(&out);
            let t2 = Instant::now();
            let (px, _) =
                view.gather_tonemapped(&vv, std::f32::consts::FRAC_1_PI, None, ToneMap::Filmic);
            let t3 = Instant::now();
            let bytes = render::encode_8bit(&px, w, h, fmt).unwrap();
            let t4 = Instant::now();
            std::hint::black_box(bytes);
            let d = [t1 - t0, t2 - t1, t3 - t2, t4 - t3, t4 - t0].map(|d| d.as_secs_f64() * 1e3);
            for k in 0..5 {
                best[k] = best[k].min(d[k]);
            }
        }
        println!(
            "{scene} {w}x{h} {fmt:?}: view buffer {t_view:.1} ms ({} KB); relight {:.3} ms, vertex values {:.2} ms, gather+exposure+tonemap {:.2} ms, encode {:.2} ms, total {:.2} ms",
            view.bytes() / 1024, best[0], best[1], best[2], best[3], best[4]
        );
    }
}
