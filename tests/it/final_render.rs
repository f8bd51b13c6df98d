//! The `final` render quality (render/final_gather): exact direct light, a final gather
//! and the emitters in view, against closed forms and the Cornell box's path-traced
//! reference. `cargo run --release --example final_quality` measures the latter with its
//! build time, and `benches/cornell/compare.py` against a 262,144-spp reference.

use glam::Vec3;
use relight::bake::{load_or_bake, BakeOptions, CachePolicy};
use relight::color::Rgb;
use relight::model::{Cancel, Model};
use relight::render::final_gather::patch_locator;
use relight::render::pipeline::final_images;
use relight::render::{Camera, GroupImages, Shading};

use crate::common::{self, *};

fn model(dir: &std::path::Path) -> Model {
    let b = load_or_bake(dir, CachePolicy::Off, &BakeOptions::default(), &|_, _| {}).unwrap();
    Model::new(b)
}

pub(crate) fn finals(m: &Model, cam: &Camera) -> GroupImages {
    let shading = Shading::new(&m.baked.mesh);
    let patches = patch_locator(&m.baked.mesh, &m.baked.scene.triangles);
    final_images(
        m,
        &shading,
        &patches,
        cam,
        &relight::render::final_gather::FinalSettings::default(),
        &Cancel::default(),
    )
    .unwrap()
}

/// A square `side`² camera `height` above the origin looking straight down, image x along
/// +x and image y along +z.
fn looking_down(height: f32, fov_deg: f32, side: u32) -> Camera {
    Camera {
        position: Vec3::new(0.0, height, 0.0),
        target: Vec3::ZERO,
        up: Vec3::new(0.0, 0.0, -1.0),
        fov_deg,
        width: side,
        height: side,
    }
}

/// Furnace: a closed room whose every surface emits E and reflects ρ has radiosity
/// E/(1 − ρ) everywhere, so every pixel shows E/(π(1 − ρ)): emission, exact direct
/// light, the gather and the filter together must add up to it.
#[test]
fn a_closed_glowing_room_shows_the_analytic_radiance_everywhere() {
    let _gate = common::shared();
    let obj = box_faces("room", "glow", [0., 0., 0.], [2., 2., 2.], true);
    let mtl = "newmtl glow\nKd 0.5 0.5 0.5\nKe 1 1 1\n";
    let toml = "[mesh]\nmax_edge = 0.25\n[[lights]]\nid = \"glow\"\nmaterials = [\"glow\"]\n";
    let s = write_scene(&obj, mtl, Some(toml));
    let m = model(s.path());
    let cam = Camera {
        position: Vec3::new(0.3, 1.2, 0.4),
        target: Vec3::new(1.9, 0.7, 1.6),
        up: Vec3::Y,
        fov_deg: 80.0,
        width: 48,
        height: 36,
    };
    let img = finals(&m, &cam).linear(&[Rgb::ONE]);
    let want = 1.0 / (std::f32::consts::PI * 0.5);
    let worst = img
        .iter()
        .map(|p| (p[1] / want - 1.0).abs())
        .fold(0.0f32, f32::max);
    eprintln!("furnace: worst pixel off by {:.3} %", 100.0 * worst);
    assert!(worst < 0.005, "worst pixel off by {worst}");
}

/// A point downlight over a table: the table's shadow on the floor ends where the ray
/// from the light past the table's edge meets the floor, to the pixel.
#[test]
fn a_point_downlights_shadow_edge_lies_on_the_geometric_umbra() {
    let _gate = common::shared();
    let (light_y, table_y, half) = (2.5, 0.75, 0.5);
    let obj = quad(
        "floor",
        "white",
        [[-3., 0., -3.], [3., 0., -3.], [3., 0., 3.], [-3., 0., 3.]],
        [0., 1., 0.],
    ) + &quad(
        "table",
        "black",
        [
            [-half, table_y, -half],
            [half, table_y, -half],
            [half, table_y, half],
            [-half, table_y, half],
        ],
        [0., 1., 0.],
    );
    let mtl = "newmtl white\nKd 0.5 0.5 0.5\nnewmtl black\nKd 0 0 0\n";
    let toml = format!(
        "transfer = \"columns\"\n[mesh]\nmax_edge = 0.5\n[[luminaires]]\nid = \"down\"\n\
         position = [0, {light_y}, 0]\nlumens = 1000\n"
    );
    let s = write_scene(&obj, mtl, Some(&toml));
    let m = model(s.path());
    let (w, h, fov) = (128u32, 128u32, 40.0f32);
    let cam = looking_down(5.0, fov, w);
    let img = finals(&m, &cam).linear(&[Rgb::ONE]);
    // Along the middle row (z = 0), image x runs along +x.
    let row = &img[(h as usize / 2) * w as usize..][..w as usize];
    let lit = row[w as usize - 8][1];
    // The umbra's edge on the floor, and the table's edge, in pixels.
    let tan = (fov as f64 / 2.0).to_radians().tan();
    let to_px = |x: f64, depth: f64| (x / depth / tan + 1.0) * w as f64 / 2.0;
    let px = to_px(half * light_y / (light_y - table_y), 5.0);
    let table_px = to_px(half, 5.0 - table_y);
    // Past the table's edge: the shadowed floor, then the lit floor.
    let edge_px = (table_px.ceil() as usize..w as usize)
        .find(|&x| row[x][1] > 0.5 * lit)
        .unwrap();
    eprintln!("shadow edge at pixel {edge_px}, geometry says {px:.2}");
    assert!(
        (edge_px as f64 + 0.5 - px).abs() <= 1.0,
        "edge at {edge_px}, geometry {px}"
    );
    // Beyond the edge the floor has the inverse-square cosine illuminance, exactly.
    let x = 100usize;
    let fx = ((x as f64 + 0.5) / (w as f64 / 2.0) - 1.0) * tan * 5.0;
    let i = 1000.0 / (4.0 * std::f64::consts::PI);
    let d2 = fx * fx + light_y * light_y;
    let e = i * (light_y / d2.sqrt()) / d2;
    let want = 0.5 * e / std::f64::consts::PI;
    let got = row[x][1] as f64;
    assert!((got / want - 1.0).abs() < 0.01, "{got} vs {want}");
}

/// Two coplanar floors, dark and bright, meet along a line that crosses a pixel column
/// 0.3 of a pixel in: the column's pixels show 0.3 of the dark floor's light and 0.7 of
/// the bright one's, on average over the rows. When a pixel's own 2 × 2 samples decided
/// whether it got more samples, keeping them when they all saw the bright floor (16 % of
/// the time here) and tracing again otherwise, the column read 6.9 % too bright.
#[test]
fn an_edge_pixel_is_not_pulled_towards_the_surface_that_covers_more_of_it() {
    let _gate = common::shared();
    let (w, fov, height, light_y) = (128u32, 40.0f32, 5.0, 2.5);
    let tan = (fov as f64 / 2.0).to_radians().tan();
    // Image column c starts at world x = (c / (w/2) − 1) · tan · height.
    let world_x = |c: f64| (c / (w as f64 / 2.0) - 1.0) * tan * height;
    let (column, share) = (80usize, 0.3);
    let edge = world_x(column as f64 + share);
    let obj = quad(
        "dark",
        "dark",
        [
            [-3., 0., -3.],
            [edge, 0., -3.],
            [edge, 0., 3.],
            [-3., 0., 3.],
        ],
        [0., 1., 0.],
    ) + &quad(
        "bright",
        "bright",
        [[edge, 0., -3.], [3., 0., -3.], [3., 0., 3.], [edge, 0., 3.]],
        [0., 1., 0.],
    );
    let (dark, bright) = (0.1, 0.8);
    let mtl = format!(
        "newmtl dark\nKd {dark} {dark} {dark}\nnewmtl bright\nKd {bright} {bright} {bright}\n"
    );
    let toml = format!(
        "transfer = \"columns\"\n[mesh]\nmax_edge = 0.5\n[[luminaires]]\nid = \"down\"\n\
         position = [0, {light_y}, 0]\nlumens = 1000\n"
    );
    let s = write_scene(&obj, &mtl, Some(&toml));
    let m = model(s.path());
    let cam = looking_down(height as f32, fov, w);
    let img = finals(&m, &cam).linear(&[Rgb::ONE]);
    // The floor's radiance at image point (x, y) for reflectance ρ: ρ I cos θ / (π d²).
    let radiance = |x: f64, y: f64, rho: f64| {
        let (fx, fz) = (world_x(x), world_x(y));
        let d2 = fx * fx + fz * fz + light_y * light_y;
        let i = 1000.0 / (4.0 * std::f64::consts::PI);
        rho * i * (light_y / d2.sqrt()) / d2 / std::f64::consts::PI
    };
    let mean = |c: usize| {
        let rows = 8..w as usize - 8;
        let n = rows.len() as f64;
        let (got, want) = rows.fold((0.0, [0.0; 3]), |(g, wnt), y| {
            let yc = y as f64 + 0.5;
            (
                g + img[y * w as usize + c][1] as f64,
                [
                    wnt[0] + radiance(c as f64 + 0.5, yc, dark),
                    wnt[1] + radiance(c as f64 + 0.5, yc, bright),
                    // The split pixel: each floor's part at its own centre.
                    wnt[2]
                        + share * radiance(c as f64 + share / 2.0, yc, dark)
                        + (1.0 - share) * radiance(c as f64 + (1.0 + share) / 2.0, yc, bright),
                ],
            )
        });
        (got / n, want.map(|v| v / n))
    };
    let (got_dark, want) = mean(column - 4);
    assert!(
        (got_dark / want[0] - 1.0).abs() < 0.01,
        "dark {got_dark} vs {}",
        want[0]
    );
    let (got_bright, want) = mean(column + 4);
    assert!(
        (got_bright / want[1] - 1.0).abs() < 0.01,
        "bright {got_bright} vs {}",
        want[1]
    );
    let (got, want) = mean(column);
    eprintln!(
        "edge column: {got} against {} ({:+.2} %)",
        want[2],
        100.0 * (got / want[2] - 1.0)
    );
    assert!(
        (got / want[2] - 1.0).abs() < 0.02,
        "edge {got} vs {}",
        want[2]
    );
}

/// A square area light over a square occluder: along the floor, the penumbra follows the
/// visible part of the light's configuration factor (the light minus the occluder's
/// shadow volume, both rectangles in the light's plane), within 2 % of the unoccluded
/// light.
#[test]
fn an_area_lights_penumbra_follows_the_visible_configuration_factor() {
    let _gate = common::shared();
    // Light: 1 m square, 2 m up, facing down. Occluder: 0.6 m square, 1 m up, black.
    let (light_y, light_half, occ_y, occ_half) = (2.0, 0.5, 1.0, 0.3);
    let square = |name: &str, mat: &str, y: f64, h: f64, up: f64| {
        quad(
            name,
            mat,
            [[-h, y, -h], [h, y, -h], [h, y, h], [-h, y, h]],
            [0., up, 0.],
        )
    };
    let obj = square("floor", "white", 0.0, 3.0, 1.0)
        + &square("plate", "black", occ_y, occ_half, 1.0)
        + &square("lamp", "lamp", light_y, light_half, -1.0);
    let exitance = 1000.0;
    let mtl = format!(
        "newmtl white\nKd 0.5 0.5 0.5\nnewmtl black\nKd 0 0 0\n\
         newmtl lamp\nKd 0 0 0\nKe {exitance} {exitance} {exitance}\n"
    );
    let toml = "transfer = \"columns\"\n[mesh]\nmax_edge = 0.5\n[[lights]]\nid = \"lamp\"\n\
                materials = [\"lamp\"]\n";
    let s = write_scene(&obj, &mtl, Some(toml));
    let m = model(s.path());
    let (w, h, fov, cam_y) = (160u32, 160u32, 36.0f32, 5.0);
    let cam = looking_down(cam_y as f32, fov, w);
    let img = finals(&m, &cam).linear(&[Rgb::ONE]);
    let tan = (fov as f64 / 2.0).to_radians().tan();
    let to_floor = |px: f64| (px / (w as f64 / 2.0) - 1.0) * tan * cam_y;
    // The radiance of a floor point (x, z): ρ/π × M × the visible factor. Seen from
    // (x, z), the occluder covers the light's plane in the square scaled by
    // light_y / occ_y about the point (coordinates relative to the point's foot).
    let s = light_y / occ_y;
    let visible = |x: f64, z: f64| {
        let light = [
            -light_half - x,
            light_half - x,
            -light_half - z,
            light_half - z,
        ];
        let shade = [
            s * (-occ_half - x),
            s * (occ_half - x),
            s * (-occ_half - z),
            s * (occ_half - z),
        ];
        let cut = [
            light[0].max(shade[0]),
            light[1].min(shade[1]),
            light[2].max(shade[2]),
            light[3].min(shade[3]),
        ];
        let full = rect_factor(
            (x, z),
            (-light_half, light_half),
            (-light_half, light_half),
            light_y,
        );
        let hidden = if cut[0] < cut[1] && cut[2] < cut[3] {
            rect_factor((0.0, 0.0), (cut[0], cut[1]), (cut[2], cut[3]), light_y)
        } else {
            0.0
        };
        (full - hidden, full)
    };
    let k = 0.5 / std::f64::consts::PI * exitance;
    // The 32 rows around the middle, summed per column (each pixel against its own
    // analytic value: the sum only averages the shadow rays' noise); columns from just
    // past the plate's silhouette to the fully lit floor.
    let rows = (h / 2 - 16)..(h / 2 + 16);
    let first = ((occ_half * cam_y / (cam_y - occ_y) / cam_y / tan + 1.0) * w as f64 / 2.0).ceil()
        as u32
        + 1;
    let mut worst: f64 = 0.0;
    let mut penumbra = 0;
    for x in first..w {
        let (mut got, mut want, mut full) = (0.0, 0.0, 0.0);
        for y in rows.clone() {
            let (fx, fz) = (to_floor(x as f64 + 0.5), to_floor(y as f64 + 0.5));
            let (v, f) = visible(fx, fz);
            got += img[(y * w + x) as usize][1] as f64;
            want += k * v;
            full += k * f;
        }
        if want < 0.98 * full {
            penumbra += 1;
        }
        worst = worst.max((got - want).abs() / full);
    }
    eprintln!(
        "penumbra: {penumbra} columns, worst off by {:.2} % of the unoccluded light",
        100.0 * worst
    );
    assert!(
        penumbra > 20,
        "the test must cross the penumbra ({penumbra} columns)"
    );
    assert!(worst < 0.02, "worst column off by {:.2} %", 100.0 * worst);
}

/// An emissive panel's edge across a column of pixels, 65 % of each covered: every pixel of
/// the column shows 65 % of the panel's luminance. Each pixel's four samples all met the
/// panel about one time in five (0.65⁴), and such pixels were drawn fully lit: only pixels
/// whose samples disagreed, or that none of their samples met beside one that did,
/// measured their coverage. On the office floor's panels that made up 95 % of the
/// squared difference from the path tracer.
#[test]
fn an_emitters_edge_pixel_whose_samples_all_met_it_was_drawn_fully_lit() {
    let _gate = common::shared();
    // The panel faces the camera 2 m away; the view spans x, y in −1 … 1 m at the panel,
    // 32 pixels across (image x runs along −x), and the panel ends 65 % into column 10.
    let side = 32usize;
    let edge = 1.0 - 2.0 * (10.0 + 0.65) / side as f64;
    let obj = quad(
        "panel",
        "glow",
        [
            [edge, -1.5, 0.0],
            [edge, 1.5, 0.0],
            [1.5, 1.5, 0.0],
            [1.5, -1.5, 0.0],
        ],
        [0., 0., -1.],
    );
    let toml = "[mesh]\nmax_edge = 0.5\n[[lights]]\nid = \"glow\"\nmaterials = [\"glow\"]\n";
    let s = write_scene(&obj, "newmtl glow\nKd 0 0 0\nKe 1 1 1\n", Some(toml));
    let m = model(s.path());
    let cam = Camera {
        position: Vec3::new(0.0, 0.0, -2.0),
        target: Vec3::ZERO,
        up: Vec3::Y,
        fov_deg: (2.0 * 0.5f32.atan()).to_degrees(),
        width: side as u32,
        height: side as u32,
    };
    let img = finals(&m, &cam).linear(&[Rgb::ONE]);
    let lum = std::f32::consts::FRAC_1_PI;
    for y in 0..side {
        for (x, want) in [(9, 1.0), (10, 0.65), (11, 0.0)] {
            let got = img[y * side + x][1] / lum;
            assert!(
                (got - want).abs() < 0.02,
                "pixel ({x}, {y}) shows {got} of the panel's luminance, not {want}"
            );
        }
    }
}

/// The Cornell box's `final` image at 512², box-filtered to 256², against the path-traced
/// reference in tests/data (4,096 spp, whose own noise is 1.2 %): relative RMSE with the
/// light left out, under white light and under a warm tint. One emitter, so the image is
/// linear in its colour per channel and the warm reference is the white one tinted.
/// Measured 1.46 % and 1.44 % when written.
#[test]
fn cornell_final_image_is_within_1_5_percent_of_the_path_traced_reference() {
    let _gate = common::shared();
    let m = common::cornell_model();
    let cam = Camera::from_def(&m.baked.scene.cameras[0], 512, 512);
    let gi = finals(m, &cam);
    let reference = common::cornell_reference();
    for tint in [Rgb::ONE, Rgb::new(1.0, 0.75, 0.5)] {
        let img = gi.linear(&[tint]);
        let (mut num, mut den) = (0f64, 0f64);
        for (i, r) in reference.iter().enumerate() {
            if r.iter().any(|&v| v > 1.0) {
                continue; // the light itself
            }
            let (y, x) = (i / 256, i % 256);
            for k in 0..3 {
                let p: f64 = [(0, 0), (0, 1), (1, 0), (1, 1)]
                    .iter()
                    .map(|(dy, dx)| f64::from(img[(2 * y + dy) * 512 + 2 * x + dx].0[k]) / 4.0)
                    .sum();
                let r = f64::from(r[k] * tint.0[k]);
                num += (p - r).powi(2);
                den += r * r;
            }
        }
        let e = (num / den).sqrt();
        eprintln!("tint {tint:?}: rel. RMSE {e:.4}");
        assert!(e < 0.015, "tint {tint:?}: rel. RMSE {e:.4}");
    }
}

/// Linearity: on a scene of two light groups, final(w₁) + final(w₂) = final(w₁ + w₂) to
/// 1e-5 relative, for RGB weights of both groups, and each group lights the view.
#[test]
fn final_images_add_up_over_lighting_states() {
    let _gate = common::shared();
    let m = model(&common::scenes_dir().join("desk-room"));
    let cam = Camera::from_def(&m.baked.scene.cameras[0], 96, 72);
    let gi = finals(&m, &cam);
    let w1 = [Rgb::new(0.3, 0.5, 0.7), Rgb::new(0.2, 0.0, 0.1)];
    let w2 = [Rgb::new(0.6, 0.1, 0.2), Rgb::new(0.9, 1.1, 0.4)];
    let sum: Vec<Rgb> = w1
        .iter()
        .zip(&w2)
        .map(|(a, b)| Rgb::new(a.0[0] + b.0[0], a.0[1] + b.0[1], a.0[2] + b.0[2]))
        .collect();
    let (a, b, c) = (gi.linear(&w1), gi.linear(&w2), gi.linear(&sum));
    let peak = c.iter().flat_map(|p| p.0).fold(0.0f32, f32::max);
    assert!(peak > 0.0);
    let worst = a
        .iter()
        .zip(&b)
        .zip(&c)
        .flat_map(|((p, q), r)| {
            (0..3).map(move |k| (p.0[k] + q.0[k] - r.0[k]).abs() / r.0[k].max(1e-3 * peak))
        })
        .fold(0.0f32, f32::max);
    assert!(worst <= 1e-5, "worst relative difference {worst:e}");
    for g in 0..2 {
        let mut w = [Rgb::new(0.0, 0.0, 0.0); 2];
        w[g] = Rgb::ONE;
        let lit = gi
            .linear(&w)
            .iter()
            .filter(|p| p.0[1] > 1e-3 * peak)
            .count();
        assert!(lit > 96 * 72 / 4, "group {g} lights {lit} pixels");
    }
}

/// Furnace with a per-patch emission vector: a closed room of ρ = 0.5 whose every patch is
/// given emission E for the request (nothing emits in the scene) shows E/(π(1 − ρ)) in
/// every pixel of its `final` image, the emission reaching the gather and the camera
/// through the patches, not through emitting triangles.
#[test]
fn a_final_image_of_an_emission_vector_shows_the_furnaces_radiance() {
    use relight::model::lighting::Lighting;
    use relight::render::final_gather::FinalSettings;
    use relight::render::pipeline::final_state_image;
    let _gate = common::shared();
    let obj = box_faces("room", "grey", [0., 0., 0.], [2., 2., 2.], true);
    let s = write_scene(
        &obj,
        "newmtl grey\nKd 0.5 0.5 0.5\n",
        Some("[mesh]\nmax_edge = 0.25\n"),
    );
    let m = model(s.path());
    let cam = Camera {
        position: Vec3::new(0.3, 1.2, 0.4),
        target: Vec3::new(1.9, 0.7, 1.6),
        up: Vec3::Y,
        fov_deg: 80.0,
        width: 48,
        height: 36,
    };
    let shading = Shading::new(&m.baked.mesh);
    let patches = patch_locator(&m.baked.mesh, &m.baked.scene.triangles);
    let emission = Lighting::Emission(vec![1.0; 3 * m.patches()]);
    let settings = FinalSettings::default();
    let img = final_state_image(
        &m,
        &shading,
        &patches,
        &cam,
        &emission,
        &settings,
        &Cancel::default(),
    )
    .unwrap()
    .linear(&[Rgb::ONE]);
    let want = 1.0 / (std::f32::consts::PI * 0.5);
    let worst = img
        .iter()
        .map(|p| (p[1] / want - 1.0).abs())
        .fold(0.0f32, f32::max);
    eprintln!(
        "emission furnace: worst pixel off by {:.3} %",
        100.0 * worst
    );
    assert!(worst < 0.005, "worst pixel off by {worst}");
}

/// A light group's emission given as a per-patch emission vector renders in `final` as
/// the group does: the same light, within 1 % RMSE of the group's image, though its
/// emitters reach the gather through the patches instead of exact triangle emitters.
#[test]
fn a_final_image_of_a_groups_emission_vector_matches_the_groups_image() {
    use relight::model::lighting::Lighting;
    use relight::render::final_gather::FinalSettings;
    use relight::render::pipeline::final_state_image;
    let _gate = common::shared();
    let m = model(&common::scenes_dir().join("desk-room"));
    let cam = Camera::from_def(&m.baked.scene.cameras[0], 96, 72);
    let group = finals(&m, &cam).linear(&[Rgb::ONE, Rgb::ZERO]);
    let shading = Shading::new(&m.baked.mesh);
    let patches = patch_locator(&m.baked.mesh, &m.baked.scene.triangles);
    let e = m.baked.transfer.groups[0].e.clone();
    let settings = FinalSettings::default();
    let img = final_state_image(
        &m,
        &shading,
        &patches,
        &cam,
        &Lighting::Emission(e),
        &settings,
        &Cancel::default(),
    )
    .unwrap()
    .linear(&[Rgb::ONE]);
    let e = common::relative_rmse(&img, &group);
    eprintln!("group as emission: relative RMSE {:.3} %", 100.0 * e);
    assert!(e < 0.01, "relative RMSE {e:.4}");
}
