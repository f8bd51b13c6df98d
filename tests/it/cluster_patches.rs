//! Cluster patches: a model's small triangles grouped into patches of about `max_edge`.
//! The furnace (closed form), energy balance, and per-surface agreement with the same
//! model baked at triangle resolution (`[mesh] cluster = false`).

use relight::bake::{load_or_bake, BakeOptions, Baked, CachePolicy};
use relight::color::Rgb;
use relight::geometry::mesh::MAX_CLUSTER_TURN_DEG;
use relight::transport::transfer::TransferMode;

use crate::common::{self, *};

fn bake(dir: &std::path::Path, mode: Option<TransferMode>) -> Baked {
    let opts = BakeOptions {
        mode,
        ..BakeOptions::default()
    };
    load_or_bake(dir, CachePolicy::Off, &opts, &|_, _| {}).expect("bakes")
}

/// OBJ text for a quad tessellated into an `n` × `n` grid of quads (one object, shared
/// vertices), front facing `normal`, as exporters write furniture: many small triangles.
fn fine_quad(name: &str, mat: &str, p: [[f64; 3]; 4], normal: [f64; 3], n: usize) -> String {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let (u, v) = (sub(p[1], p[0]), sub(p[3], p[0]));
    let cross = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    let flip = cross[0] * normal[0] + cross[1] * normal[1] + cross[2] * normal[2] < 0.0;
    let mut s = format!("o {name}\nusemtl {mat}\n");
    for j in 0..=n {
        for i in 0..=n {
            let (a, b) = (i as f64 / n as f64, j as f64 / n as f64);
            let x: Vec<f64> = (0..3).map(|k| p[0][k] + u[k] * a + v[k] * b).collect();
            s += &format!("v {} {} {}\n", x[0], x[1], x[2]);
        }
    }
    let count = ((n + 1) * (n + 1)) as i64;
    let at = |i: usize, j: usize| (j * (n + 1) + i) as i64 - count;
    for j in 0..n {
        for i in 0..n {
            let mut f = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
            if flip {
                f.reverse();
            }
            s += &format!("f {} {} {} {}\n", f[0], f[1], f[2], f[3]);
        }
    }
    s
}

/// The six faces of a box, each an `n` × `n` grid, fronts inward (a room) or outward.
fn fine_box(prefix: &str, mat: &str, lo: [f64; 3], hi: [f64; 3], inward: bool, n: usize) -> String {
    box_quads(lo, hi, inward)
        .iter()
        .map(|(k, p, nn)| fine_quad(&format!("{prefix}{k}"), mat, *p, *nn, n))
        .collect()
}

/// Area-weighted mean radiosity (lm/m², luminous) of each surface.
fn surface_means(b: &Baked, sol: &[f32]) -> Vec<(String, f64, f64)> {
    let col = Rgb::column(sol);
    b.scene
        .surfaces
        .iter()
        .enumerate()
        .map(|(s, surf)| {
            let (mut acc, mut area) = (0.0, 0.0);
            for i in b.mesh.surface_patches[s].clone() {
                let a = b.mesh.patches[i as usize].area;
                area += a;
                acc += a * col[i as usize].luminance() as f64;
            }
            (surf.name.clone(), area, acc / area.max(1e-300))
        })
        .collect()
}

#[test]
fn furnace_holds_with_cluster_patches_in_every_mode() {
    let _gate = common::shared();
    // Every face a 16 × 16 grid (3,072 triangles): E = 10, ρ = 0.5 gives B = 20.
    let obj = fine_box("room", "glow", [0., 0., 0.], [3., 2.5, 2.], true, 16);
    let s = write_scene(
        &obj,
        "newmtl glow\nKd 0.5 0.5 0.5\nKe 10 10 10\n",
        Some("[mesh]\ntarget_patches = 300\n"),
    );
    for mode in [TransferMode::Factored, TransferMode::Hierarchical] {
        let b = bake(s.path(), Some(mode));
        assert_eq!(b.mesh.elements.len(), 6 * 16 * 16 * 2);
        // Clusters of about max_edge: far fewer patches than triangles.
        assert!(
            b.mesh.len() * 8 < b.mesh.elements.len(),
            "{} patches of {} triangles",
            b.mesh.len(),
            b.mesh.elements.len()
        );
        let sol = b.transfer.relight(&[Rgb::ONE]);
        let worst = sol
            .b
            .iter()
            .map(|&x| (x as f64 / 20.0 - 1.0).abs())
            .fold(0.0, f64::max);
        let tol = if mode == TransferMode::Factored {
            0.005
        } else {
            0.01
        };
        assert!(
            worst < tol,
            "{mode:?}: worst patch off E/(1−ρ) by {worst:.4}"
        );
    }
}

/// A room (fine walls) with a fine table and a block standing on the floor, lit by an
/// emitting ceiling panel: clustered and triangle patches agree per surface.
fn furnished(cluster: bool) -> TempScene {
    let mut obj = fine_box("room", "wall", [0., 0., 0.], [4., 2.6, 3.], true, 20);
    obj += &fine_box(
        "table",
        "wood",
        [1.0, 0.7, 1.0],
        [2.2, 0.75, 1.8],
        false,
        12,
    );
    obj += &fine_box("block", "wood", [2.8, 0.0, 0.5], [3.4, 0.9, 1.1], false, 10);
    obj += &quad(
        "panel",
        "lamp",
        [
            [1.5, 2.59, 1.0],
            [2.5, 2.59, 1.0],
            [2.5, 2.59, 2.0],
            [1.5, 2.59, 2.0],
        ],
        [0., -1., 0.],
    );
    let mtl = "newmtl wall\nKd 0.7 0.7 0.7\nnewmtl wood\nKd 0.4 0.3 0.2\n\
               newmtl lamp\nKd 0.5 0.5 0.5\nKe 3000 3000 3000\n";
    write_scene(
        &obj,
        mtl,
        Some(&format!(
            "[mesh]\nmax_edge = 0.8\ncluster = {cluster}\n\n[[lights]]\nid = \"lamp\"\nmaterials = [\"lamp\"]\n"
        )),
    )
}

#[test]
fn cluster_patches_agree_with_triangle_patches_per_surface() {
    let _gate = common::shared();
    let (a, b) = (furnished(true), furnished(false));
    let (ca, cb) = (
        bake(a.path(), Some(TransferMode::Factored)),
        bake(b.path(), Some(TransferMode::Factored)),
    );
    assert_eq!(ca.mesh.elements.len(), cb.mesh.elements.len());
    assert_eq!(cb.mesh.len(), cb.mesh.elements.len());
    assert!(
        ca.mesh.len() * 3 < cb.mesh.len(),
        "{} vs {}",
        ca.mesh.len(),
        cb.mesh.len()
    );
    let w = vec![Rgb::ONE; ca.scene.lights.len()];
    let (sa, sb) = (ca.transfer.relight(&w), cb.transfer.relight(&w));
    let (ma, mb) = (surface_means(&ca, &sa.b), surface_means(&cb, &sb.b));
    let mut worst = (0.0, String::new());
    for ((name, area, x), (_, _, y)) in ma.iter().zip(&mb) {
        if *area < 1.0 || name == "panel" {
            continue;
        }
        let d = (x / y - 1.0).abs();
        if d > worst.0 {
            worst = (d, name.clone());
        }
    }
    assert!(
        worst.0 < 0.01,
        "surface {} differs by {:.4}",
        worst.1,
        worst.0
    );
    // The room is closed: what the panel emits is absorbed, with either patches, within
    // the dense factors' quadrature and visibility noise (measured: 0.68 % with clusters,
    // 0.12 % with triangles).
    for (what, c, sol) in [("clusters", &ca, &sa), ("triangles", &cb, &sb)] {
        let p = c.transfer.power(sol);
        for k in 0..3 {
            let rel = (p.emitted[k] - p.absorbed[k] - p.escaped[k]) / p.emitted[k];
            assert!(rel.abs() < 0.01, "{what}: imbalance {rel}");
        }
    }
}

#[test]
fn clusters_keep_to_one_material_and_one_orientation() {
    let _gate = common::shared();
    // Two materials in one surface's neighbourhood, and a fine cylinder whose facets turn.
    let mut obj = fine_quad(
        "floor",
        "a",
        [[0., 0., 0.], [2., 0., 0.], [2., 0., 2.], [0., 0., 2.]],
        [0., 1., 0.],
        16,
    );
    obj += &fine_quad(
        "floor",
        "b",
        [[2., 0., 0.], [4., 0., 0.], [4., 0., 2.], [2., 0., 2.]],
        [0., 1., 0.],
        16,
    );
    obj += "o drum\nusemtl a\n";
    let k = 48;
    for i in 0..k {
        let t = i as f64 / k as f64 * std::f64::consts::TAU;
        obj += &format!(
            "v {} 0.0 {}\nv {} 0.8 {}\n",
            1.0 + 0.4 * t.cos(),
            1.0 + 0.4 * t.sin(),
            1.0 + 0.4 * t.cos(),
            1.0 + 0.4 * t.sin()
        );
    }
    let base = -(2 * k as i64);
    for i in 0..k as i64 {
        let j = (i + 1) % k as i64;
        let (a0, a1, b0, b1) = (
            base + 2 * i,
            base + 2 * i + 1,
            base + 2 * j,
            base + 2 * j + 1,
        );
        obj += &format!("f {a0} {a1} {b1} {b0}\n");
    }
    let s = write_scene(
        &obj,
        "newmtl a\nKd 0.5 0.5 0.5\nnewmtl b\nKd 0.2 0.2 0.2\n",
        Some("[mesh]\nmax_edge = 1.0\n"),
    );
    let scene = relight::scene::Scene::load(s.path()).unwrap();
    let mesh = relight::geometry::mesh::Mesh::build(&scene);
    let cos = (2.0 * MAX_CLUSTER_TURN_DEG).to_radians().cos() - 1e-9;
    let mut clustered = 0;
    for (i, p) in mesh.patches.iter().enumerate() {
        let facets: Vec<_> = mesh.facets(i).collect();
        clustered += usize::from(facets.len() > 1);
        let area: f64 = facets.iter().map(|f| f.area).sum();
        assert!((area - p.area).abs() < 1e-9 * area.max(1.0));
        let (mut lo, mut hi) = (
            glam::DVec3::splat(f64::INFINITY),
            glam::DVec3::splat(f64::NEG_INFINITY),
        );
        for (e, f) in mesh.elements_of(i).zip(&facets) {
            assert_eq!(mesh.elements[e].patch as usize, i);
            let src = &scene.triangles[mesh.elements[e].source as usize];
            assert_eq!(src.material, p.material, "patch {i} mixes materials");
            assert_eq!(src.surface, p.surface, "patch {i} mixes surfaces");
            for g in &facets {
                assert!(f.normal.dot(g.normal) >= cos, "patch {i} bends too far");
            }
            for c in f.corners {
                lo = lo.min(c);
                hi = hi.max(c);
            }
        }
        assert!(
            (hi - lo).length() <= 1.0 + 1e-9,
            "patch {i} spans {}",
            (hi - lo).length()
        );
    }
    assert!(clustered > 10, "{clustered} cluster patches");
    // The drum's 48 facets turn 7.5° each: at most 7 to a patch, so at least 7 patches.
    let drum = scene.surface_index("drum").unwrap();
    assert!(mesh.surface_patches[drum].len() >= 7);
    // Cluster off: a patch per triangle.
    let t = write_scene(
        &obj,
        "newmtl a\nKd 0.5 0.5 0.5\nnewmtl b\nKd 0.2 0.2 0.2\n",
        Some("[mesh]\nmax_edge = 1.0\ncluster = false\n"),
    );
    let scene = relight::scene::Scene::load(t.path()).unwrap();
    let flat = relight::geometry::mesh::Mesh::build(&scene);
    assert_eq!(flat.len(), flat.elements.len());
    assert_eq!(flat.elements.len(), mesh.elements.len());
}

#[test]
fn a_real_furnished_apartment_meshes_at_the_lighting_resolution() {
    let _gate = common::shared();
    // benches/apartment: a SketchUp export of 177,934 triangles, every material two-sided,
    // in one meshopt-compressed mesh. A patch per triangle side gave 359,846 patches.
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/apartment/apartment");
    let scene = relight::scene::Scene::load(&dir).unwrap();
    assert_eq!(scene.surfaces.len(), 67);
    let mesh = relight::geometry::mesh::Mesh::build(&scene);
    // The target (#48): at most 60,000 patches at the default settings.
    assert!(mesh.len() <= 60_000, "{} patches", mesh.len());
    assert!(
        mesh.elements.len() >= 2 * 177_000,
        "{} triangles",
        mesh.elements.len()
    );
    let area: f64 = mesh.patches.iter().map(|p| p.area).sum();
    let tri: f64 = (0..mesh.elements.len()).map(|e| mesh.facet(e).area).sum();
    assert!((area / tri - 1.0).abs() < 1e-9, "{area} vs {tri}");
}

/// Regression: the closure rays counted a hit on the back of a two-sided surface as light
/// leaving the scene, so in hierarchical mode every patch that sees such a back was scaled
/// down (σ < 1). A closed furnace room with a two-sided plate in it: every patch, both
/// sides of the plate included, must read E / (1 − ρ).
#[test]
fn closure_counts_the_back_of_a_two_sided_surface_as_a_surface() {
    let _gate = common::shared();
    let mut obj = fine_box("room", "glow", [0., 0., 0.], [3., 2.5, 2.], true, 8);
    // A horizontal plate at 1.2 m, front up: the floor below sees its back.
    obj += &quad(
        "plate",
        "glow",
        [
            [0.5, 1.2, 0.4],
            [2.5, 1.2, 0.4],
            [2.5, 1.2, 1.6],
            [0.5, 1.2, 1.6],
        ],
        [0., 1., 0.],
    );
    let s = write_scene(
        &obj,
        "newmtl glow\nKd 0.5 0.5 0.5\nKe 10 10 10\n",
        Some("[mesh]\ntarget_patches = 600\n\n[surface.plate]\ntwo_sided = true\n"),
    );
    let b = bake(s.path(), Some(TransferMode::Hierarchical));
    let plate = b
        .scene
        .surfaces
        .iter()
        .position(|x| x.name == "plate")
        .unwrap();
    let r = b.mesh.surface_patches[plate].clone();
    assert!(
        b.mesh.patches[r.start as usize..r.end as usize]
            .iter()
            .any(|p| p.normal.y < -0.9),
        "the plate has a patch on its back"
    );
    let sol = b.transfer.relight(&[Rgb::ONE]);
    let (worst, at) = sol
        .b
        .iter()
        .enumerate()
        .map(|(i, &x)| ((x as f64 / 20.0 - 1.0).abs(), i))
        .fold((0.0, 0), |a, b| if b.0 > a.0 { b } else { a });
    assert!(
        worst < 0.01,
        "patch {at} ({}) off E/(1−ρ) by {worst:.4}",
        b.scene.surfaces[b.mesh.patches[at].surface as usize].name
    );
}
