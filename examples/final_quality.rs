//! The `final` render quality on the Cornell box: build time of a new view, and the image
//! against the path-traced reference in tests/data (512² box-filtered to 256², relative
//! RMSE with the light left out, and with the light and its one-pixel rim left out), and
//! linearity. `cargo run --release --example final_quality [SIDE [OUT.pfm]]` (OUT: the
//! 256² box-filtered image, for shared/tools/compare_cornell.py).
use std::time::Instant;

use relight::bake::{load_or_bake, BakeOptions, CachePolicy};
use relight::color::Rgb;
use relight::model::{Cancel, Model};
use relight::render::final_gather::{patch_locator, FinalSettings};
use relight::render::pipeline::final_images;
use relight::render::{Camera, Shading};

fn main() {
    let side: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(512);
    assert!(side.is_multiple_of(256), "SIDE must be a multiple of 256");
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box");
    let b = load_or_bake(&dir, CachePolicy::Off, &BakeOptions::default(), &|_, _| {}).unwrap();
    let m = Model::new(b);
    let shading = Shading::new(&m.baked.mesh);
    let t0 = Instant::now();
    let patches = patch_locator(&m.baked.mesh, &m.baked.scene.triangles);
    let bvh_ms = t0.elapsed().as_secs_f64() * 1e3;
    // The benches' RELIGHT_FINAL_* overrides (docs/performance.md).
    let settings = FinalSettings::from_env();
    let cam = Camera::from_def(&m.baked.scene.cameras[0], side as u32, side as u32);
    let t0 = Instant::now();
    let gi = final_images(&m, &shading, &patches, &cam, &settings, &Cancel::default()).unwrap();
    let build_s = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let img = gi.linear(&[Rgb::ONE]);
    let relight_ms = t0.elapsed().as_secs_f64() * 1e3;
    // Linearity: two weights add up to their sum.
    let (a, c) = (
        gi.linear(&[Rgb::new(0.3, 0.2, 0.1)]),
        gi.linear(&[Rgb::new(0.7, 0.8, 0.9)]),
    );
    let lin = a
        .iter()
        .zip(&c)
        .zip(&img)
        .flat_map(|((p, q), r)| (0..3).map(move |k| (p[k] + q[k] - r[k]).abs() / r[k].max(1e-3)))
        .fold(0.0f32, f32::max);
    let f = side / 256;
    let mut small = vec![[0f64; 3]; 256 * 256];
    for y in 0..side {
        for x in 0..side {
            for k in 0..3 {
                small[(y / f) * 256 + x / f][k] += img[y * side + x][k] as f64 / (f * f) as f64;
            }
        }
    }
    if let Some(out) = std::env::args().nth(2) {
        write_pfm(std::path::Path::new(&out), &small, 256);
    }
    let reference = read_pfm(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/cornell_ref_white.pfm"),
    );
    let light: Vec<bool> = reference
        .iter()
        .map(|r| r.iter().any(|&v| v > 1.0))
        .collect();
    let rim = |x: usize, y: usize| {
        (y.saturating_sub(1)..=(y + 1).min(255))
            .any(|yy| (x.saturating_sub(1)..=(x + 1).min(255)).any(|xx| light[yy * 256 + xx]))
    };
    let rmse = |skip: &dyn Fn(usize, usize) -> bool| {
        let (mut num, mut den) = (0f64, 0f64);
        for y in 0..256 {
            for x in 0..256 {
                if skip(x, y) {
                    continue;
                }
                let (p, r) = (small[y * 256 + x], reference[y * 256 + x]);
                for k in 0..3 {
                    num += (p[k] - r[k] as f64).powi(2);
                    den += (r[k] as f64).powi(2);
                }
            }
        }
        (num / den).sqrt()
    };
    println!(
        "{{\"side\": {side}, \"patch_locator_ms\": {bvh_ms:.1}, \"build_s\": {build_s:.2}, \
         \"relight_ms\": {relight_ms:.2}, \"rel_rmse_light_out\": {:.4}, \
         \"rel_rmse_light_and_rim_out\": {:.4}, \"linearity\": {lin:.1e}, \"bytes\": {}}}",
        rmse(&|x, y| light[y * 256 + x]),
        rmse(&rim),
        gi.bytes()
    );
}

/// Writes a little-endian PFM (bottom row first, as PFM prescribes) of a top-row-first
/// `side`² image.
fn write_pfm(path: &std::path::Path, img: &[[f64; 3]], side: usize) {
    let mut bytes = format!("PF\n{side} {side}\n-1.0\n").into_bytes();
    for y in (0..side).rev() {
        for p in &img[y * side..(y + 1) * side] {
            for v in p {
                bytes.extend_from_slice(&(*v as f32).to_le_bytes());
            }
        }
    }
    std::fs::write(path, bytes).unwrap();
}

/// A PFM image, top row first.
fn read_pfm(path: &std::path::Path) -> Vec<[f32; 3]> {
    let bytes = std::fs::read(path).unwrap();
    let header_end = bytes
        .iter()
        .enumerate()
        .filter(|(_, &c)| c == b'\n')
        .nth(2)
        .unwrap()
        .0
        + 1;
    let data: Vec<f32> = bytes[header_end..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    let side = ((data.len() / 3) as f64).sqrt() as usize;
    (0..side * side)
        .map(|i| {
            let (y, x) = (i / side, i % side);
            let k = ((side - 1 - y) * side + x) * 3;
            [data[k], data[k + 1], data[k + 2]]
        })
        .collect()
}
