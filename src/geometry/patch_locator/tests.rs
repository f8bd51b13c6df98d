use super::*;
use crate::geometry::bvh::Bvh;
use crate::geometry::mesh::Mesh;

/// Every grid corner in index order: (triangle, back side, point).
fn grid_corners(loc: &PatchLocator) -> Vec<(u32, bool, DVec3)> {
    loc.grid_sides()
        .flat_map(|(t, back, n)| (0..n).map(move |c| (t, back, loc.grid_corner(t, back, c))))
        .collect()
}
use crate::scene::Scene;

/// On a bundled scene, the patch found through the scene triangles is the one the
/// patch BVH finds, for random rays from random patches, and its distance is the same.
#[test]
fn the_located_patch_is_the_one_a_bvh_over_the_patches_meets() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office");
    let scene = Scene::load(&dir).unwrap();
    let mesh = Mesh::build(&scene);
    let bvh = crate::bake::scene_bvh(&scene);
    let loc = PatchLocator::new(&mesh, &scene.triangles);
    let tris: Vec<[Vec3A; 3]> = (0..mesh.len())
        .map(|j| mesh.element_corners(j).map(|p| Vec3A::from(p.as_vec3())))
        .collect();
    let patches = Bvh::new(&tris);
    let mut rng = crate::sampling::Rng::new(1, 2);
    let (mut same, mut hits, n) = (0, 0, 20_000);
    for _ in 0..n {
        let p = rng.index(mesh.len());
        let c = mesh.element_corners(p);
        let (a, b) = (rng.next_f64(), rng.next_f64());
        let (a, b) = if a + b > 1.0 {
            (1.0 - a, 1.0 - b)
        } else {
            (a, b)
        };
        let x = c[0] + (c[1] - c[0]) * a + (c[2] - c[0]) * b;
        let nrm = mesh.patches[p].normal;
        let d =
            (nrm + DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) - 0.5).normalize();
        if d.dot(nrm) <= 0.01 {
            continue;
        }
        let o = x + nrm * 1e-6 * (1.0 + x.abs().max_element());
        let want = patches.nearest_ranked(
            Vec3A::from(o.as_vec3()),
            Vec3A::from(d.as_vec3()),
            0.0,
            f32::INFINITY,
            |q| {
                if q as usize == p {
                    0
                } else if mesh.patches[q as usize].normal.dot(d) < 0.0 {
                    2
                } else {
                    1
                }
            },
        );
        let got = loc.nearest_weighted(&bvh, PatchRay::leaving(mesh.patches[p].source, o, d));
        assert_eq!(got.is_some(), want.is_some(), "from patch {p} along {d}");
        if let (Some((tg, jg, w)), Some((tw, jw))) = (got, want) {
            hits += 1;
            // The weights put the point where the ray met the patch.
            let c = mesh.element_corners(jg as usize);
            let at = c[0] * w[0] as f64 + c[1] * w[1] as f64 + c[2] * w[2] as f64;
            let x = o + d * tg as f64;
            assert!(
                (at - x).length() < 1e-4 * (1.0 + tg as f64),
                "{at} against {x}"
            );
            assert!((tg - tw).abs() <= 1e-4 * tw.max(1.0), "{tg} against {tw}");
            // On a shared edge either neighbour is right.
            same += usize::from(jg == jw);
        }
    }
    assert!(hits > n / 2, "{hits} hits");
    assert!(
        same as f64 > 0.999 * hits as f64,
        "{same} of {hits} the same patch"
    );
}

/// A bundled scene, its mesh and their patch lookup.
fn bundled(name: &str) -> (Scene, Mesh, PatchLocator) {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    let scene = Scene::load(&dir).unwrap();
    let mesh = Mesh::build(&scene);
    let loc = PatchLocator::new(&mesh, &scene.triangles);
    (scene, mesh, loc)
}

/// The grids' corners are as many as counted and within the bound the memory budget
/// reserves, and the four corners around a point of any patch, weighted bilinearly,
/// put back the point: a field sampled at the corners is read back exactly where it
/// is linear.
#[test]
fn grid_corners_around_a_point_put_it_back_and_stay_within_their_bound() {
    let (scene, mesh, loc) = bundled("office");
    let corners = grid_corners(&loc);
    assert_eq!(corners.len(), loc.corner_count());
    let bound = max_grid_corners(mesh.len(), scene.triangles.len());
    assert!(
        (corners.len() as u64) <= bound && corners.len() < 4 * mesh.len(),
        "{} corners for {} patches (bound {bound})",
        corners.len(),
        mesh.len()
    );
    let mut rng = crate::sampling::Rng::new(5, 6);
    for _ in 0..20_000 {
        let p = rng.index(mesh.len());
        let x = crate::sampling::sample_triangle(
            &mesh.element_corners(p),
            rng.next_f64(),
            rng.next_f64(),
        );
        let tri = mesh.patches[p].source;
        let f = &loc.frames[tri as usize];
        let back = mesh.patches[p].normal.dot(f.normal.as_dvec3()) < 0.0;
        let (c, w) = loc.grid_weights(tri, back, x).unwrap();
        let at: DVec3 = c
            .iter()
            .zip(w)
            .map(|(&c, w)| {
                assert_eq!(corners[c as usize].0, tri);
                assert_eq!(corners[c as usize].1, back);
                corners[c as usize].2 * w as f64
            })
            .sum();
        assert!((at - x).length() < 1e-4, "{at} against {x}");
    }
}

/// A grid corner beside its triangle reads the patch under the triangle's point
/// nearest to it: the weights put the point there (checked against the nearest point
/// found by sampling the triangle densely), so a field read beside a triangle is the
/// one at its edge, and the lookup never searches the empty cells between.
#[test]
fn a_corner_beside_its_triangle_reads_the_triangles_nearest_point() {
    let (scene, mesh, loc) = bundled("cornell-box");
    let (mut beside, mut inside) = (0, 0);
    for (k, (tri, back, x)) in grid_corners(&loc).into_iter().enumerate() {
        if k % 7 != 0 {
            continue;
        }
        let (q, w) = loc.locate_beside(tri, back, x).unwrap();
        let c = mesh.element_corners(q as usize);
        let at = c[0] * w[0] as f64 + c[1] * w[1] as f64 + c[2] * w[2] as f64;
        // The nearest point of the triangle, from a dense barycentric grid.
        let p = scene.triangles[tri as usize].p;
        let n = 400;
        let mut best = (f64::INFINITY, DVec3::ZERO);
        for i in 0..=n {
            for j in 0..=n - i {
                let (a, b) = (i as f64 / n as f64, j as f64 / n as f64);
                let y = p[0] + (p[1] - p[0]) * a + (p[2] - p[0]) * b;
                let d = (y - x).length();
                if d < best.0 {
                    best = (d, y);
                }
            }
        }
        let step = (p[1] - p[0]).length().max((p[2] - p[0]).length()) / n as f64;
        assert!(
            (at - best.1).length() <= 1.5 * step + 1e-5,
            "corner {x} of triangle {tri}: read at {at}, nearest {}",
            best.1
        );
        if best.0 > 2.0 * step {
            beside += 1;
        } else {
            inside += 1;
        }
    }
    assert!(
        beside > 100 && inside > 100,
        "{beside} beside, {inside} inside"
    );
}
