//! Ray throughput of one core on a scene's BVHs, millions of rays per second:
//! - any-hit (`occluded`): segments between random points of random patches, as the form
//!   factors, links and shadow rays trace them, on the scene BVH ([`relight::bench::ray_throughput`]);
//! - nearest hit (`nearest`): cosine-weighted rays from random points of random patches,
//!   as the final gather traces them, on the patch BVH.
//!
//! `cargo run --release --example ray_throughput [SCENE_DIR]` (default
//! `scenes/office-floor`; bakes into the default cache if it is not there yet).

use relight::bake::{default_cache_dir, load_or_bake, BakeOptions, CachePolicy};
use relight::render::final_gather::patch_bvh;

fn main() {
    let dir = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "scenes/office-floor".into());
    let cache = default_cache_dir();
    let opts = BakeOptions::default();
    let baked = load_or_bake(
        std::path::Path::new(&dir),
        CachePolicy::ReadWrite(&cache),
        &opts,
        &|_, _| {},
    )
    .expect("the scene loads");
    let mesh = &baked.mesh;
    let any_hit = relight::bench::ray_throughput(mesh, &baked.bvh, 1_000_000);
    let patches = patch_bvh(mesh);
    let nearest = relight::bench::nearest_throughput(mesh, &patches, 1_000_000);
    println!(
        "{{\"scene\": \"{dir}\", \"patches\": {}, \"any_hit_mrays_per_core\": {any_hit:.2}, \
         \"nearest_mrays_per_core\": {nearest:.2}}}",
        mesh.len()
    );
}
