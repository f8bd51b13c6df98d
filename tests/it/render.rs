//! The renderer: known pixel values, no cracks, depth order, false colour, and the Cornell
//! box against the path-traced reference image.

use relight::color::Rgb;
use relight::render::{self, Camera, GroupImages, Shading, ToneMap, ViewBuffer};

use crate::common::{self, *};

fn cam(pos: [f32; 3], target: [f32; 3], fov: f32, w: u32, h: u32) -> Camera {
    Camera {
        position: pos.into(),
        target: target.into(),
        up: glam::Vec3::Y,
        fov_deg: fov,
        width: w,
        height: h,
    }
}

#[test]
fn constant_radiosity_renders_its_exact_value_without_cracks() {
    let _gate = common::shared();
    // A finely meshed wall, every patch at B = π·0.5 → radiance 0.5 everywhere it covers.
    let obj = quad(
        "wall",
        "grey",
        [[-1., -1., 0.], [1., -1., 0.], [1., 1., 0.], [-1., 1., 0.]],
        [0., 0., -1.],
    );
    let s = write_scene(&obj, GREY_MTL, Some("[mesh]\nmax_edge = 0.1\n"));
    let scene = relight::scene::Scene::load(s.path()).unwrap();
    let mesh = relight::geometry::mesh::Mesh::build(&scene);
    assert!(mesh.len() > 500);
    let shading = Shading::new(&mesh);
    // The wall fills the whole view: 60° fov at distance 1 sees ±0.577.
    let c = cam([0., 0., -1.], [0., 0., 0.], 60.0, 200, 200);
    let view = ViewBuffer::build(&mesh, &shading, &c);
    let b = vec![0.5 * std::f32::consts::PI; 3 * mesh.len()];
    let img = view.gather(&shading.vertex_values(&b), std::f32::consts::FRAC_1_PI);
    for p in &img {
        // Every pixel fully covered: no crack lets the black background through.
        assert!((p[0] - 0.5).abs() < 1e-4, "pixel {p:?}");
    }
    // Tone mapping: 0.5 linear, clamp, is sRGB 187.52 → 188; the gathered image (within
    // 1e-4 of 0.5) stays within that code's rounding.
    let exact = render::tonemap(&[Rgb::splat(0.5)], 0.0, ToneMap::Clamp);
    assert_eq!(exact, [188, 188, 188]);
    let px = render::tonemap(&img, 0.0, ToneMap::Clamp);
    assert!(px.iter().all(|&v| v == 187 || v == 188), "{:?}", &px[..3]);
    // One stop up saturates.
    assert!(render::tonemap(&img, 1.0, ToneMap::Clamp)
        .iter()
        .all(|&v| v == 255));
}

#[test]
fn the_z_buffer_puts_the_near_block_in_front() {
    let _gate = common::shared();
    // A bright near square in front of a dark far wall.
    let obj = quad(
        "far",
        "grey",
        [[-2., -2., 2.], [2., -2., 2.], [2., 2., 2.], [-2., 2., 2.]],
        [0., 0., -1.],
    ) + &quad(
        "near",
        "grey",
        [
            [-0.2, -0.2, 0.5],
            [0.2, -0.2, 0.5],
            [0.2, 0.2, 0.5],
            [-0.2, 0.2, 0.5],
        ],
        [0., 0., -1.],
    );
    let s = write_scene(&obj, GREY_MTL, Some("[mesh]\nmax_edge = 0.5\n"));
    let scene = relight::scene::Scene::load(s.path()).unwrap();
    let mesh = relight::geometry::mesh::Mesh::build(&scene);
    let shading = Shading::new(&mesh);
    let view = ViewBuffer::build(
        &mesh,
        &shading,
        &cam([0., 0., -1.], [0., 0., 0.], 40.0, 64, 64),
    );
    let near = scene.surface_index("near").unwrap() as u32;
    let mut b = vec![0f32; 3 * mesh.len()];
    for (i, p) in mesh.patches.iter().enumerate() {
        let v = if p.surface == near { 10.0 } else { 1.0 };
        b[3 * i..3 * i + 3].copy_from_slice(&[v; 3]);
    }
    let img = view.gather(&shading.vertex_values(&b), 1.0);
    let centre = img[32 * 64 + 32];
    let corner = img[2 * 64 + 2];
    assert!(
        (centre[0] - 10.0).abs() < 1e-3,
        "centre {centre:?}: the near square must win"
    );
    assert!((corner[0] - 1.0).abs() < 1e-3, "corner {corner:?}");
    // And the picking buffer names the near square at the centre.
    assert_eq!(
        mesh.patches[view.center_patch[32 * 64 + 32] as usize].surface,
        near
    );
}

#[test]
fn false_colour_maps_known_values_to_known_colours() {
    let _gate = common::shared();
    // Log scale 1..100 lux: 1 → the first stop, 100 → the last, 10 → the middle.
    let mut img = vec![Rgb::ZERO; 96];
    img[..3].copy_from_slice(&[Rgb::ONE, Rgb::splat(10.0), Rgb::splat(100.0)]);
    let out = render::false_color(&img, 96, 1, 1.0, 100.0);
    // The legend covers the last 4 columns; check the first three pixels.
    assert_eq!(&out[0..3], &render::scale_color(0.0));
    assert_eq!(&out[3..6], &render::scale_color(0.5));
    assert_eq!(&out[6..9], &render::scale_color(1.0));
    assert_eq!(render::scale_color(0.0), [13, 13, 89]);
    assert_eq!(render::scale_color(1.0), [217, 26, 13]);
}

#[test]
fn cornell_box_image_matches_the_path_traced_reference() {
    let _gate = common::shared();
    let b = common::cornell_baked();
    let shading = Shading::new(&b.mesh);
    // The reference camera; render at 2× and box-filter to 256² like the reference pixels.
    let c = Camera::from_def(&b.scene.cameras[0], 512, 512);
    let view = ViewBuffer::build(&b.mesh, &shading, &c);
    let sol = b.transfer.relight(&[Rgb::ONE]);
    let img = view.gather(&shading.vertex_values(&sol.b), std::f32::consts::FRAC_1_PI);
    // The fast path for light-group states, a weighted sum of per-group images, gives the
    // same image as the gather, for any RGB weight.
    let gi = GroupImages::radiance(&view, &shading, &b.transfer);
    let wt = [Rgb::new(0.3, 0.6, 0.9)];
    let tinted = view.gather(
        &shading.vertex_values(&b.transfer.relight(&wt).b),
        std::f32::consts::FRAC_1_PI,
    );
    for (p, q) in gi.linear(&wt).iter().zip(&tinted) {
        for ch in 0..3 {
            assert!(
                (p[ch] - q[ch]).abs() <= 1e-5 + 1e-4 * q[ch],
                "{p:?} vs {q:?}"
            );
        }
    }
    let mut small = vec![[0f64; 3]; 256 * 256];
    for y in 0..512 {
        for x in 0..512 {
            for ch in 0..3 {
                small[(y / 2) * 256 + x / 2][ch] += img[y * 512 + x][ch] as f64 / 4.0;
            }
        }
    }
    let reference = common::cornell_reference();
    let (mut num, mut den) = (0f64, 0f64);
    for y in 0..256 {
        for x in 0..256 {
            let r = &reference[y * 256 + x];
            if r.iter().any(|&v| v > 1.0) {
                continue; // the light itself
            }
            for ch in 0..3 {
                let d = small[y * 256 + x][ch] - r[ch] as f64;
                num += d * d;
                den += (r[ch] as f64).powi(2);
            }
        }
    }
    // Per surface: the surface seen at each 256² pixel (its top-left 512² sample).
    let names = &b.scene.surfaces;
    let mut per: Vec<(f64, f64, usize)> = vec![(0.0, 0.0, 0); names.len()];
    for y in 0..256 {
        for x in 0..256 {
            let p = view.center_patch[(2 * y) * 512 + 2 * x];
            let r = &reference[y * 256 + x];
            if p == u32::MAX || r.iter().any(|&v| v > 1.0) {
                continue;
            }
            let e = &mut per[b.mesh.patches[p as usize].surface as usize];
            for ch in 0..3 {
                let d = small[y * 256 + x][ch] - r[ch] as f64;
                e.0 += d * d;
                e.1 += (r[ch] as f64).powi(2);
            }
            e.2 += 1;
        }
    }
    for (s, (n, d, px)) in names.iter().zip(&per) {
        if *px > 0 {
            eprintln!(
                "  {:<14} {px:>6} px  rel. RMSE {:.4}",
                s.name,
                (n / d.max(1e-30)).sqrt()
            );
        }
    }
    let rel_rmse = (num / den).sqrt();
    eprintln!("Cornell image rel. RMSE (all but the light): {rel_rmse:.4}");
    // Measured 0.0338 (the reference's own noise is 0.012); fails if it grows.
    assert!(rel_rmse < 0.04, "rel. RMSE {rel_rmse}");
}

/// The preview mesh's vertices take the full mesh's Gouraud value where they sit: with a
/// per-patch radiosity that is linear in position, every preview vertex reads that linear
/// function at its own position, up to the fine patches' size.
#[test]
fn preview_vertices_read_the_fine_shading_at_their_position() {
    let _gate = common::shared();
    let obj = box_faces("room", "grey", [0., 0., 0.], [4., 3., 5.], true);
    let s = write_scene(&obj, GREY_MTL, None);
    let scene = relight::scene::Scene::load(s.path()).unwrap();
    let fine = relight::geometry::mesh::Mesh::build_with(&scene, 0.12);
    let coarse = relight::geometry::mesh::Mesh::build_with(&scene, 0.5);
    assert!(
        coarse.len() * 8 < fine.len(),
        "{} {}",
        coarse.len(),
        fine.len()
    );
    let (fs, cs) = (Shading::new(&fine), Shading::new(&coarse));
    let f = |p: glam::DVec3| 1.0 + 0.3 * p.x + 0.2 * p.y - 0.1 * p.z;
    let rad: Vec<f32> = fine
        .patches
        .iter()
        .flat_map(|p| [f(p.centroid) as f32; 3])
        .collect();
    let w = render::preview::preview_weights(&fine, &fs, &coarse, &cs);
    assert_eq!(w.len(), cs.len());
    // Positions of the preview's shading vertices, from its triangles' corners.
    let mut pos = vec![glam::DVec3::ZERO; cs.len()];
    for (p, c) in coarse.elements.iter().zip(cs.corners()) {
        for k in 0..3 {
            pos[c[k] as usize] = coarse.vertices[p.v[k] as usize];
        }
    }
    let mut worst = 0f64;
    for (v, list) in w.iter().enumerate() {
        assert!(
            !list.is_empty(),
            "vertex {v} at {:?} found no fine patch",
            pos[v]
        );
        let sum: f32 = list.iter().map(|&(_, x)| x).sum();
        assert!((sum - 1.0).abs() < 1e-5, "weights sum to {sum}");
        let got: f64 = list
            .iter()
            .map(|&(q, x)| x as f64 * rad[3 * q as usize] as f64)
            .sum();
        worst = worst.max((got - f(pos[v])).abs());
    }
    // |∇f| = 0.37 per metre; a fine shading vertex averages patch centroids within one
    // edge (0.12 m) of it.
    assert!(worst < 0.37 * 0.12, "worst {worst}");
    assert!(worst > 0.0);
}
