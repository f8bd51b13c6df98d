//! `relight bench`'s measures.

use relight::bake::scene_bvh;
use relight::bench::{ray_throughput, Segments};
use relight::geometry::mesh::Mesh;
use relight::scene::Scene;

use crate::common::{self, *};

/// The shadow-ray benchmark traces the segments relight traces, between points that face
/// each other: a glowing floor next to a plain one (both facing up) has none, so it
/// measures nothing, though its pairs of any points are measured; a closed room's facing
/// walls have plenty.
#[test]
fn coplanar_floors_give_the_shadow_ray_benchmark_no_facing_segments() {
    let _gate = common::shared();
    let mtl = "newmtl white\nKd 0.5 0.5 0.5\nnewmtl glow\nKd 0.5 0.5 0.5\nKe 10 10 10\n";
    let up = [0.0, 1.0, 0.0];
    let floors = [
        quad(
            "floor",
            "white",
            [[0., 0., 0.], [1., 0., 0.], [1., 0., 1.], [0., 0., 1.]],
            up,
        ),
        quad(
            "tile",
            "glow",
            [[1., 0., 0.], [2., 0., 0.], [2., 0., 1.], [1., 0., 1.]],
            up,
        ),
    ]
    .concat();
    let room = box_faces("room", "glow", [0., 0., 0.], [3., 2.5, 2.], true);
    let rates = |obj: &str, which| {
        let s = write_scene(obj, mtl, None);
        let scene = Scene::load(s.path()).expect("the scene loads");
        ray_throughput(&Mesh::build(&scene), &scene_bvh(&scene), 2_000, which)
    };
    assert_eq!(rates(&floors, Segments::Facing), 0.0);
    assert!(rates(&floors, Segments::Any) > 0.0);
    assert!(rates(&room, Segments::Facing) > 0.0);
}
