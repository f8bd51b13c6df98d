//! Ray throughput of one core on a scene's BVHs, millions of rays per second:
//! - any-hit (`occluded`): segments between random points of random patches that face each
//!   other, as the form factors, links and shadow rays trace them, on the scene BVH
//!   ([`relight::bench::ray_throughput`]); and between any two such points;
//! - nearest hit: cosine-weighted rays from random points of random patches, as the final
//!   gather traces them (the scene BVH, then the grid corners around the hit, where the
//!   gather reads the radiosity).
//!
//! `cargo run --release --example ray_throughput [SCENE_DIR] [RAYS]` (default
//! `scenes/office-floor`, a million rays). The scene is meshed, not baked.

use relight::bake::scene_bvh;
use relight::bench::Segments;
use relight::geometry::mesh::Mesh;
use relight::render::final_gather::patch_locator;
use relight::scene::Scene;

fn main() {
    let mut args = std::env::args().skip(1);
    let dir = args.next().unwrap_or_else(|| "scenes/office-floor".into());
    let rays: usize = args
        .next()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    let scene = Scene::load(std::path::Path::new(&dir)).expect("the scene loads");
    let mesh = Mesh::build(&scene);
    let t = std::time::Instant::now();
    let bvh = scene_bvh(&scene);
    let scene_build = t.elapsed().as_secs_f64();
    let any_hit = relight::bench::ray_throughput(&mesh, &bvh, rays, Segments::Facing);
    let any_pair = relight::bench::ray_throughput(&mesh, &bvh, rays, Segments::Any);
    let t = std::time::Instant::now();
    let patches = patch_locator(&mesh, &scene.triangles);
    let locator_build = t.elapsed().as_secs_f64();
    let nearest = relight::bench::nearest_throughput(&mesh, &bvh, &patches, rays);
    println!(
        "{{\"scene\": \"{dir}\", \"triangles\": {}, \"patches\": {}, \
         \"scene_bvh_build_s\": {scene_build:.3}, \"patch_locator_build_s\": {locator_build:.3}, \"patch_locator_mb\": {:.1}, \"grid_corners\": {}, \
         \"any_hit_mrays_per_core\": {any_hit:.2}, \"any_hit_any_pair_mrays_per_core\": {any_pair:.2}, \"nearest_mrays_per_core\": {nearest:.2}}}",
        scene.triangles.len(),
        mesh.len(),
        patches.bytes() as f64 / 1e6,
        patches.corner_count()
    );
}
