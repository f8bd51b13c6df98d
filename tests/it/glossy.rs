//! Glossy highlights in `final` images (render/final_gather/specular): glTF materials with
//! a roughness below 1 or a metallic part reflect specularly at the camera's bounce. The
//! truths here are closed forms written out independently of the library: a mirror's
//! Schlick reflectance of an emitting wall, and glTF's specular BRDF (in the form the
//! glTF specification gives it) under a point light, a uniform sky and the sun.

use glam::{DVec3, Vec3};
use relight::bake::{load_or_bake, BakeOptions, CachePolicy};
use relight::color::Rgb;
use relight::model::Model;
use relight::render::final_gather::patch_locator;
use relight::render::{Camera, GroupImages, Shading};
use serde_json::json;

use crate::common;
use crate::gltf_import::Doc;

/// A quad as two triangles (corners in order, front by the right-hand rule).
fn quad(d: &mut Doc, c: [[f32; 3]; 4]) -> (usize, usize) {
    (d.positions(&c), d.indices(&[0, 1, 2, 0, 2, 3]))
}

/// A 10 m square floor at y = 0, facing up.
const FLOOR: [[f32; 3]; 4] = [[-5., 0., -5.], [-5., 0., 5.], [5., 0., 5.], [5., 0., -5.]];

/// Loads and bakes the GLB `glb` with `toml` as its scene.toml.
fn model(glb: &[u8], toml: &str) -> Model {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.glb"), glb).unwrap();
    std::fs::write(dir.path().join("scene.toml"), toml).unwrap();
    let opts = BakeOptions::default();
    Model::new(load_or_bake(dir.path(), CachePolicy::Off, &opts, &|_, _| {}).unwrap())
}

/// Bakes the GLB `glb` (with `toml` as its scene.toml) and builds its `final` images.
fn finals(glb: &[u8], toml: &str, cam: &Camera) -> GroupImages {
    crate::final_render::finals(&model(glb, toml), cam)
}

/// A square camera `height` above the origin looking straight down at the floor, image
/// x along +x and image y along +z.
struct Above {
    side: usize,
    fov_deg: f64,
    height: f64,
}

impl Above {
    fn camera(&self) -> Camera {
        Camera {
            position: Vec3::new(0.0, self.height as f32, 0.0),
            target: Vec3::ZERO,
            up: Vec3::new(0.0, 0.0, -1.0),
            fov_deg: self.fov_deg as f32,
            width: self.side as u32,
            height: self.side as u32,
        }
    }

    fn eye(&self) -> DVec3 {
        DVec3::new(0.0, self.height, 0.0)
    }

    /// The floor coordinate (x, or z) seen at image coordinate `k` (pixel k spans k..k + 1).
    fn at(&self, k: f64) -> f64 {
        let tan = (self.fov_deg / 2.0).to_radians().tan();
        (k / (self.side as f64 / 2.0) - 1.0) * tan * self.height
    }

    /// The mean of `f` over the floor that pixel (x, y) sees (8 × 8 points), as its
    /// jittered samples see it.
    fn pixel_mean(&self, x: usize, y: usize, f: impl Fn(DVec3) -> f64) -> f64 {
        let point = |i: usize| {
            let (fx, fz) = ((i % 8) as f64 + 0.5, (i / 8) as f64 + 0.5);
            DVec3::new(
                self.at(x as f64 + fx / 8.0),
                0.0,
                self.at(y as f64 + fz / 8.0),
            )
        };
        (0..64).map(|i| f(point(i))).sum::<f64>() / 64.0
    }
}

/// Schlick's Fresnel, as glTF writes it.
fn schlick(f0: f64, cos: f64) -> f64 {
    f0 + (1.0 - f0) * (1.0 - cos).powi(5)
}

/// A polished metal floor (F0 0.5, roughness 0) before a black wall that glows at
/// 10 cd/m²: where the camera sees the wall in the floor, a pixel shows the wall's
/// luminance times the Fresnel reflectance at the viewing angle, and nothing else (no
/// surface reflects diffusely). The metal is black in the radiosity solution: before the
/// specular lobe, this pixel was 0.
#[test]
fn a_mirror_floor_shows_a_glowing_wall_at_its_fresnel_reflectance() {
    let _gate = common::shared();
    let mut d = Doc::default();
    let floor = quad(&mut d, FLOOR);
    let wall = quad(
        &mut d,
        [[-5., 0., -5.], [5., 0., -5.], [5., 5., -5.], [-5., 5., -5.]],
    );
    let mesh = |(p, i): (usize, usize), m: usize| json!({"primitives": [{"attributes": {"POSITION": p}, "indices": i, "material": m}]});
    let glb = d.glb(json!({
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "materials": [
            {"name": "mirror", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 1, "roughnessFactor": 0}},
            {"name": "glow", "emissiveFactor": [1, 1, 1], "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0},
             "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 10}}}
        ],
        "meshes": [mesh(floor, 0), mesh(wall, 1)],
        "nodes": [{"name": "floor", "mesh": 0}, {"name": "wall", "mesh": 1}]
    }));
    let cam = Camera {
        position: Vec3::new(0.0, 1.0, 4.0),
        target: Vec3::ZERO,
        up: Vec3::Y,
        fov_deg: 8.0,
        width: 24,
        height: 24,
    };
    let img = finals(&glb, "[mesh]\nmax_edge = 1.0\n", &cam).linear(&[Rgb::ONE]);
    // The centre of the image sees the floor at the origin, 1 m below and 4 m ahead.
    let cos = 1.0 / 17f64.sqrt();
    let want = 10.0 * schlick(0.5, cos);
    for (x, y) in [(11, 11), (12, 11), (11, 12), (12, 12)] {
        let got = img[y * 24 + x][1] as f64;
        eprintln!("mirror pixel ({x}, {y}): {got:.4} cd/m², closed form {want:.4}");
        assert!((got / want - 1.0).abs() < 0.01, "{got} vs {want}");
    }
}

/// glTF's specular BRDF, `F · V · D`, with the height-correlated visibility term as the
/// glTF specification writes it (α = roughness²).
fn gltf_specular(f0: f64, alpha: f64, n: DVec3, v: DVec3, l: DVec3) -> f64 {
    let h = (v + l).normalize();
    let (nl, nv, nh, vh) = (n.dot(l), n.dot(v), n.dot(h), v.dot(h));
    let a2 = alpha * alpha;
    let vis =
        0.5 / (nl * (nv * nv * (1.0 - a2) + a2).sqrt() + nv * (nl * nl * (1.0 - a2) + a2).sqrt());
    let dd = nh * nh * (a2 - 1.0) + 1.0;
    let dist = a2 / (std::f64::consts::PI * dd * dd);
    schlick(f0, vh) * vis * dist
}

/// A black glossy floor (a dielectric, F0 0.04, roughness 0.5) under a 100 cd point
/// light: seen from above, every pixel shows the light's highlight, `BRDF × I cos θ / d²`,
/// as glTF's BRDF gives it (the floor reflects nothing diffusely).
#[test]
fn a_glossy_floor_shows_a_point_lights_highlight_as_gltf_defines_it() {
    let _gate = common::shared();
    let mut d = Doc::default();
    let (p, i) = quad(&mut d, FLOOR);
    let light = DVec3::new(0.6, 2.0, 0.0);
    let glb = d.glb(json!({
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "bulb", "type": "point", "intensity": 100}
        ]}},
        "materials": [
            {"name": "lacquer", "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0, "roughnessFactor": 0.5}}
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": p}, "indices": i, "material": 0}]}],
        "nodes": [
            {"name": "floor", "mesh": 0},
            {"name": "bulb", "translation": light.as_vec3().to_array(), "extensions": {"KHR_lights_punctual": {"light": 0}}}
        ]
    }));
    let view = Above {
        side: 64,
        fov_deg: 40.0,
        height: 5.0,
    };
    let (side, eye) = (view.side, view.eye());
    let img = finals(&glb, "[mesh]\nmax_edge = 1.0\n", &view.camera()).linear(&[Rgb::ONE]);
    let radiance = |p: DVec3| {
        let (v, to) = ((eye - p).normalize(), light - p);
        let l = to.normalize();
        gltf_specular(0.04, 0.25, DVec3::Y, v, l) * 100.0 * l.y / to.length_squared()
    };
    // Blocks of 4 × 2 pixels (each pixel's 4 jittered samples spread the values by
    // about 1 % on the highlight's flanks).
    let row = side / 2 + 5;
    let (mut checked, mut worst) = (0, 0f64);
    for x0 in (0..side - 4).step_by(4) {
        // Skip the pixels that see the light's own opening, between the eye and the floor.
        let shadow = light.x * view.height / (view.height - light.y);
        if (view.at(x0 as f64 + 2.0) - shadow).abs() < 0.6 {
            continue;
        }
        let block = || (x0..x0 + 4).flat_map(|x| [(x, row), (x, row + 1)]);
        let got: f64 = block().map(|(x, y)| img[y * side + x][1] as f64).sum();
        let want: f64 = block().map(|(x, y)| view.pixel_mean(x, y, radiance)).sum();
        assert!(
            (got / want - 1.0).abs() < 0.01,
            "pixels {x0}..{} of rows {row}, {}: {got} vs {want} cd/m²",
            x0 + 4,
            row + 1
        );
        checked += 1;
        worst = worst.max((got / want - 1.0).abs());
    }
    eprintln!(
        "highlight: {checked} blocks of 4 × 2 pixels, worst off by {:.2} %",
        100.0 * worst
    );
    assert!(checked >= 10, "{checked} runs checked");
}

/// glTF's specular albedo towards `v`: the BRDF × cos θ integrated over the hemisphere
/// on a midpoint grid of polar angle and azimuth.
fn gltf_albedo(f0: f64, alpha: f64, v: DVec3) -> f64 {
    let (nt, np) = (400, 400);
    let (half, tau) = (std::f64::consts::FRAC_PI_2, std::f64::consts::TAU);
    let mut sum = 0.0;
    for i in 0..nt {
        let theta = (i as f64 + 0.5) / nt as f64 * half;
        for j in 0..np {
            let phi = (j as f64 + 0.5) / np as f64 * tau;
            let l = DVec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            let dw = theta.sin() * (half / nt as f64) * (tau / np as f64);
            sum += gltf_specular(f0, alpha, DVec3::Y, v, l) * theta.cos() * dw;
        }
    }
    sum
}

/// Under a sky, a black glossy floor (F0 0.04, roughness 0.3) in the open reflects the
/// sky and the sun: under a uniform sky of luminance L every pixel shows L × the lobe's
/// albedo towards the camera, and with the sun straight overhead the pixels below the
/// camera show glTF's BRDF × the sun's illuminance.
#[test]
fn a_glossy_floor_reflects_the_sky_and_the_sun() {
    let _gate = common::shared();
    let mut d = Doc::default();
    let (p, i) = quad(&mut d, FLOOR);
    let glb = d.glb(json!({
        "materials": [
            {"name": "lacquer", "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0, "roughnessFactor": 0.3}}
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": p}, "indices": i, "material": 0}]}],
        "nodes": [{"name": "floor", "mesh": 0}]
    }));
    let m = model(
        &glb,
        "[site]\nlatitude = 49.5\nlongitude = 8.5\ntimezone = 1\n[mesh]\nmax_edge = 1.0\n",
    );
    let above = Above {
        side: 32,
        fov_deg: 40.0,
        height: 3.0,
    };
    let (side, cam) = (above.side, above.camera());
    let shading = Shading::new(&m.baked.mesh);
    let patches = patch_locator(&m.baked.mesh, &m.baked.scene.triangles);
    let image = |sky| crate::daylight::final_sky_image(&m, &shading, &patches, &cam, sky);
    let view = |p: DVec3| (above.eye() - p).normalize();
    // A uniform sky of 10,000 lx on the horizontal: L = 10,000/π cd/m².
    let uniform = image(json!({"type": "uniform", "horizontal_illuminance": 10000}));
    let l_sky = 10_000.0 / std::f64::consts::PI;
    let mut worst = 0f64;
    for (x, y) in [(16, 16), (4, 20), (28, 6), (10, 30)] {
        let v = view(DVec3::new(
            above.at(x as f64 + 0.5),
            0.0,
            above.at(y as f64 + 0.5),
        ));
        let want = l_sky * gltf_albedo(0.04, 0.09, v);
        let got = uniform[y * side + x][1] as f64;
        assert!(
            (got / want - 1.0).abs() < 0.01,
            "pixel ({x}, {y}): {got} vs {want} cd/m²"
        );
        worst = worst.max((got / want - 1.0).abs());
    }
    eprintln!(
        "uniform sky in a glossy floor: worst pixel off by {:.2} %",
        100.0 * worst
    );
    // The sun overhead at 50,000 lx (a clear sky of 1 lx beside it).
    let sunny = image(json!({"type": "cie_clear", "horizontal_illuminance": 1,
        "direct_normal_illuminance": 50000, "sun": {"altitude": 90, "azimuth": 180}}));
    // Blocks of 6 × 6 pixels (each pixel's four jittered samples spread its value).
    let mut worst = 0f64;
    for (x0, y0) in [(10, 10), (16, 10), (10, 16), (16, 16), (4, 13)] {
        let (mut got, mut want) = (0.0, 0.0);
        for (x, y) in (0..36).map(|k| (x0 + k % 6, y0 + k / 6)) {
            got += sunny[y * side + x][1] as f64;
            want += above.pixel_mean(x, y, |p| {
                gltf_specular(0.04, 0.09, DVec3::Y, view(p), DVec3::Y) * 50_000.0
            });
        }
        assert!(
            (got / want - 1.0).abs() < 0.01,
            "pixels from ({x0}, {y0}): {got} vs {want} cd/m²"
        );
        worst = worst.max((got / want - 1.0).abs());
    }
    eprintln!(
        "the sun in a glossy floor: worst block off by {:.2} %",
        100.0 * worst
    );
}
