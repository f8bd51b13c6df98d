//! The `final` render quality (render/final_gather): exact direct light, a final gather
//! and the emitters in view, against closed forms. The Cornell box against its path-traced
//! reference is a bench (`cargo run --release --example final_quality`): it takes too long
//! for the suite.

use glam::Vec3;
use relight::bake::{load_or_bake, BakeOptions, CachePolicy};
use relight::model::{Cancel, Model};
use relight::render::final_gather::patch_bvh;
use relight::render::pipeline::final_images;
use relight::render::{Camera, GroupImages, Shading};

use crate::common::{self, *};

fn model(dir: &std::path::Path) -> Model {
    let b = load_or_bake(dir, CachePolicy::Off, &BakeOptions::default(), &|_, _| {}).unwrap();
    Model::new(b)
}

fn finals(m: &Model, cam: &Camera) -> GroupImages {
    let shading = Shading::new(&m.baked.mesh);
    let patches = patch_bvh(&m.baked.mesh);
    final_images(m, &shading, &patches, cam, &Cancel::default()).unwrap()
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
    let img = finals(&m, &cam).linear(&[[1.0; 3]]);
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
    let cam = Camera {
        position: Vec3::new(0.0, 5.0, 0.0),
        target: Vec3::ZERO,
        up: Vec3::new(0.0, 0.0, -1.0),
        fov_deg: fov,
        width: w,
        height: h,
    };
    let img = finals(&m, &cam).linear(&[[1.0; 3]]);
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
