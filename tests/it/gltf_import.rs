//! glTF 2.0 scenes, built here byte by byte: node transforms and instancing (checked against
//! a closed-form form factor), materials with factors and textures, emission,
//! `KHR_lights_punctual` point and spot lights as luminaires, external and embedded
//! buffers, and hostile files that must be refused with a message rather than a panic.

use std::path::Path;

use relight::scene::Scene;
use serde_json::{json, Value};

use crate::common;

mod exporters;
mod node_trees;
pub(crate) use node_trees::{forest, tree_glb};

/// A glTF document under construction: one binary buffer, its views and accessors.
#[derive(Default)]
pub(crate) struct Doc {
    pub(crate) bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Doc {
    pub(crate) fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()}));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    /// A float VEC3 POSITION accessor.
    pub(crate) fn positions(&mut self, p: &[[f32; 3]]) -> usize {
        let bytes: Vec<u8> = p.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes);
        let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
        for v in p {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        self.accessors.push(
            json!({"bufferView": view, "componentType": 5126, "count": p.len(),
            "type": "VEC3", "min": lo, "max": hi}),
        );
        self.accessors.len() - 1
    }

    /// An unsigned-int index accessor.
    pub(crate) fn indices(&mut self, i: &[u32]) -> usize {
        let bytes: Vec<u8> = i.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessors.push(
            json!({"bufferView": view, "componentType": 5125, "count": i.len(),
            "type": "SCALAR"}),
        );
        self.accessors.len() - 1
    }

    /// The document: `rest` gives meshes, nodes, materials, …; buffers, views and
    /// accessors come from here, the buffer at `uri` (None: the GLB binary chunk).
    pub(crate) fn json(&self, rest: Value, uri: Option<&str>) -> Value {
        let mut doc = json!({
            "asset": {"version": "2.0"},
            "buffers": [{"byteLength": self.bin.len()}],
            "bufferViews": self.views,
            "accessors": self.accessors,
        });
        if let Some(u) = uri {
            doc["buffers"][0]["uri"] = json!(u);
        }
        for (k, v) in rest.as_object().unwrap() {
            doc[k] = v.clone();
        }
        doc
    }

    pub(crate) fn glb(&self, rest: Value) -> Vec<u8> {
        glb(&self.json(rest, None), &self.bin)
    }
}

/// A GLB container: header, JSON chunk (space-padded), BIN chunk (zero-padded).
pub(crate) fn glb(doc: &Value, bin: &[u8]) -> Vec<u8> {
    let mut js = serde_json::to_vec(doc).unwrap();
    while !js.len().is_multiple_of(4) {
        js.push(b' ');
    }
    let mut b = bin.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let total = 12 + 8 + js.len() + 8 + b.len();
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((js.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(js);
    out.extend((b.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(b);
    out
}

/// A unit square in the xz-plane, corners (0,0,0)–(1,0,1), front facing +y.
fn unit_square(d: &mut Doc) -> (usize, usize) {
    let p = d.positions(&[[0., 0., 0.], [0., 0., 1.], [1., 0., 1.], [1., 0., 0.]]);
    let i = d.indices(&[0, 1, 2, 0, 2, 3]);
    (p, i)
}

fn folder(files: &[(&str, &[u8])]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes) in files {
        std::fs::write(dir.path().join(name), bytes).unwrap();
    }
    dir
}

fn load(dir: &Path) -> Scene {
    Scene::load(dir).unwrap_or_else(|e| panic!("scene should load: {e}"))
}

fn load_err(dir: &Path) -> String {
    Scene::load(dir).expect_err("should not load").to_string()
}

fn warned(s: &Scene, needles: &[&str]) -> bool {
    s.warnings
        .iter()
        .any(|w| needles.iter().all(|n| w.contains(n)))
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * b.abs().max(1e-12)
}

/// Triangle normal (unnormalized, right-handed from the winding) summed over a surface.
fn surface_normal(s: &Scene, name: &str) -> glam::DVec3 {
    let k = s.surface_index(name).unwrap() as u32;
    s.triangles
        .iter()
        .filter(|t| t.surface == k)
        .map(|t| (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]))
        .sum()
}

fn surface_area(s: &Scene, name: &str) -> f64 {
    surface_normal(s, name).length() / 2.0
}

const GREY: &str = r#"{"name": "grey", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0}}"#;

#[test]
fn instanced_squares_facing_each_other_give_the_closed_form_factor() {
    let _gate = common::shared();
    // One mesh, two nodes: the floor as is, the ceiling one metre up and turned over by a
    // half turn about x (quaternion [1, 0, 0, 0]), which also moves z to −z.
    let mut d = Doc::default();
    let (p, i) = unit_square(&mut d);
    let bytes = d.glb(json!({
        "materials": [serde_json::from_str::<Value>(GREY).unwrap()],
        "meshes": [{"name": "square", "primitives": [{"attributes": {"POSITION": p}, "indices": i, "material": 0}]}],
        "nodes": [
            {"name": "floor", "mesh": 0},
            {"name": "lifted", "translation": [0, 1, 1], "children": [2]},
            {"mesh": 0, "rotation": [1, 0, 0, 0]}
        ],
        "scenes": [{"nodes": [0, 1]}],
        "scene": 0
    }));
    let dir = folder(&[("room.glb", &bytes)]);
    let s = load(dir.path());
    // The unnamed node takes its mesh's name.
    let names: Vec<&str> = s.surfaces.iter().map(|x| x.name.as_str()).collect();
    assert_eq!(names, ["floor", "square"], "{names:?}");
    let up = surface_normal(&s, "floor").normalize();
    let down = surface_normal(&s, "square").normalize();
    assert!(up.abs_diff_eq(glam::DVec3::Y, 1e-12), "{up}");
    assert!(down.abs_diff_eq(glam::DVec3::NEG_Y, 1e-12), "{down}");
    let (lo, hi) = s.bounds();
    assert!(lo.abs_diff_eq(glam::DVec3::ZERO, 1e-9) && hi.abs_diff_eq(glam::DVec3::ONE, 1e-9));
    // Parallel unit squares one apart, directly opposed: F = 0.19982 (Howell, C-11).
    let solved = common::form_factors(dir.path());
    let f = solved.surface_factor("floor", "square");
    assert!(close(f, 0.199825, 0.01), "F = {f}");
    let g = solved.surface_factor("square", "floor");
    assert!(close(g, f, 0.01), "reciprocity: {g} vs {f}");
}

#[test]
fn scaled_mirrored_and_nested_transforms_compose_and_keep_fronts() {
    let _gate = common::shared();
    let mut d = Doc::default();
    let (p, i) = unit_square(&mut d);
    let prim = json!({"attributes": {"POSITION": p}, "indices": i});
    let bytes = d.glb(json!({
        "meshes": [{"name": "tile", "primitives": [prim]}],
        "nodes": [
            // scale 2 then a parent's translation: area 4, at x 10..12
            {"name": "parent", "translation": [10, 0, 0], "children": [1]},
            {"name": "tile", "mesh": 0, "scale": [2, 2, 2]},
            // a mirror (negative determinant) must keep the front facing +y
            {"name": "tile", "mesh": 0, "scale": [-1, 1, 1]},
            // a matrix: 90° about z takes +y to −x
            {"name": "wall", "mesh": 0, "matrix": [0, 1, 0, 0,  -1, 0, 0, 0,  0, 0, 1, 0,  0, 0, 0, 1]}
        ],
        "scenes": [{"nodes": [0, 2, 3]}]
    }));
    let dir = folder(&[("m.glb", &bytes)]);
    let s = load(dir.path());
    let names: Vec<&str> = s.surfaces.iter().map(|x| x.name.as_str()).collect();
    assert_eq!(names, ["tile", "tile-2", "wall"]);
    assert!(close(surface_area(&s, "tile"), 4.0, 1e-12));
    let k = s.surface_index("tile").unwrap() as u32;
    let xs = s
        .triangles
        .iter()
        .filter(|t| t.surface == k)
        .flat_map(|t| t.p.map(|p| p.x));
    let (lo, hi) = xs.fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)));
    assert!(
        close(lo, 10.0, 1e-12) && close(hi, 12.0, 1e-12),
        "{lo} {hi}"
    );
    let mirrored = surface_normal(&s, "tile-2").normalize();
    assert!(mirrored.abs_diff_eq(glam::DVec3::Y, 1e-12), "{mirrored}");
    let wall = surface_normal(&s, "wall").normalize();
    assert!(wall.abs_diff_eq(glam::DVec3::NEG_X, 1e-12), "{wall}");
    // No materials in the file: the grey default, as in OBJ scenes.
    let m = &s.materials[s.triangles[0].material as usize];
    assert_eq!(m.kd, [0.5; 3]);
}

/// A PNG of one colour.
fn png(rgba: [u8; 4]) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    image::RgbaImage::from_pixel(4, 4, image::Rgba(rgba))
        .write_to(&mut out, image::ImageFormat::Png)
        .unwrap();
    out.into_inner()
}

/// Linear value of an 8-bit sRGB code.
fn linear(code: u8) -> f32 {
    let v = code as f64 / 255.0;
    (if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }) as f32
}

fn material_scene(materials: Value, doc: &mut Doc, extra: Value) -> Vec<u8> {
    let (p, i) = unit_square(doc);
    let n = materials.as_array().unwrap().len();
    let meshes: Vec<Value> = (0..n)
        .map(|m| json!({"primitives": [{"attributes": {"POSITION": p}, "indices": i, "material": m}]}))
        .collect();
    let nodes: Vec<Value> = (0..n)
        .map(|m| json!({"name": format!("s{m}"), "mesh": m, "translation": [2 * m, 0, 0]}))
        .collect();
    let mut rest = json!({"materials": materials, "meshes": meshes, "nodes": nodes});
    for (k, v) in extra.as_object().unwrap() {
        rest[k] = v.clone();
    }
    doc.glb(rest)
}

fn kd_of(s: &Scene, surface: &str) -> relight::color::Rgb {
    let k = s.surface_index(surface).unwrap() as u32;
    let t = s.triangles.iter().find(|t| t.surface == k).unwrap();
    s.materials[t.material as usize].kd
}

#[test]
fn base_colour_metallic_textures_and_emission_set_reflectance_and_exitance() {
    let _gate = common::shared();
    let mut d = Doc::default();
    let tex = d.view(&png([200, 100, 50, 255]));
    let bytes = material_scene(
        json!([
            {"name": "paint", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.4, 0.2, 1], "metallicFactor": 0}},
            {"name": "half-metal", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.4, 0.2, 1], "metallicFactor": 0.5}},
            {"name": "metal", "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.9, 0.9, 1]}},
            {"name": "wood", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 1, 1, 1], "metallicFactor": 0, "baseColorTexture": {"index": 0}}},
            {"name": "white", "pbrMetallicRoughness": {"metallicFactor": 0}},
            {"name": "panel", "emissiveFactor": [1, 0.5, 0.25], "pbrMetallicRoughness": {"baseColorFactor": [0.1, 0.1, 0.1, 1], "metallicFactor": 0},
             "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 40}}, "doubleSided": true}
        ]),
        &mut d,
        json!({"images": [{"bufferView": tex, "mimeType": "image/png"}], "textures": [{"source": 0}],
               "extensionsUsed": ["KHR_materials_emissive_strength"]}),
    );
    let dir = folder(&[("m.glb", &bytes)]);
    let s = load(dir.path());
    assert_eq!(kd_of(&s, "s0"), [0.8, 0.4, 0.2]);
    let half = kd_of(&s, "s1");
    assert!(
        half.iter()
            .zip([0.4, 0.2, 0.1])
            .all(|(a, b)| (a - b).abs() < 1e-6),
        "{half:?}"
    );
    // glTF's default metallicFactor is 1: no diffuse reflection, and a warning says why.
    assert_eq!(kd_of(&s, "s2"), [0.0; 3]);
    assert!(
        warned(&s, &["'metal'", "fully metallic"]),
        "{:?}",
        s.warnings
    );
    let wood = kd_of(&s, "s3");
    let want = [0.5 * linear(200), linear(100), linear(50)];
    assert!(
        wood.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-4),
        "{wood:?} vs {want:?}"
    );
    // The specular lobe: F0 = 0.04 (1 − metallic) + base × metallic, α = roughness²
    // (default 1); a fully rough dielectric has none.
    let gloss_of = |surface: &str| {
        let k = s.surface_index(surface).unwrap() as u32;
        let t = s.triangles.iter().find(|t| t.surface == k).unwrap();
        s.materials[t.material as usize].gloss
    };
    assert_eq!(gloss_of("s0"), None);
    let half = gloss_of("s1").unwrap();
    assert!(
        half.f0
            .iter()
            .zip([0.02 + 0.4, 0.02 + 0.2, 0.02 + 0.1])
            .all(|(a, b)| (a - b).abs() < 1e-6)
            && half.alpha == 1.0,
        "{half:?}"
    );
    let metal = gloss_of("s2").unwrap();
    assert!(
        metal.f0.iter().all(|a| (a - 0.9).abs() < 1e-6) && metal.alpha == 1.0,
        "{metal:?}"
    );
    // A base colour of 1 (the default) is scaled to 0.95 with a warning.
    assert_eq!(kd_of(&s, "s4"), [0.95; 3]);
    assert!(
        warned(&s, &["'white'", "scaled to 0.95"]),
        "{:?}",
        s.warnings
    );
    // Emission: luminance emissiveFactor × strength in cd/m², exitance π times that.
    let k = s.surface_index("s5").unwrap() as u32;
    let m = &s.materials[s
        .triangles
        .iter()
        .find(|t| t.surface == k)
        .unwrap()
        .material as usize];
    let pi = std::f32::consts::PI;
    assert!(
        m.ke.iter()
            .zip([40.0 * pi, 20.0 * pi, 10.0 * pi])
            .all(|(a, b)| (a - b).abs() < 1e-3),
        "{:?}",
        m.ke
    );
    assert!(m.two_sided);
    // An emitting material is a light group, as in OBJ scenes.
    assert!(
        s.lights.iter().any(|g| g.id == "panel"),
        "{:?}",
        s.lights.iter().map(|g| &g.id).collect::<Vec<_>>()
    );

    // strict = true: the white material is an error naming it.
    std::fs::write(dir.path().join("scene.toml"), "strict = true\n").unwrap();
    let e = load_err(dir.path());
    assert!(e.contains("'white'") && e.contains("strict = true"), "{e}");
}

/// `KHR_materials_ior` and `KHR_materials_specular` set a dielectric's Fresnel as the
/// extensions define it: F0 = ((ior − 1)/(ior + 1))² × specularColorFactor (at most 1)
/// × specularFactor, F90 = specularFactor; a metal's stays its base colour. An index
/// below 1 is refused with the material's name.
#[test]
fn ior_and_specular_extensions_set_a_dielectrics_fresnel() {
    let _gate = common::shared();
    let mut d = Doc::default();
    let bytes = material_scene(
        json!([
            {"name": "water", "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.3, 0.4, 1], "metallicFactor": 0, "roughnessFactor": 0.2},
             "extensions": {"KHR_materials_ior": {"ior": 1.33}}},
            {"name": "satin", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0, "roughnessFactor": 0.5},
             "extensions": {"KHR_materials_specular": {"specularFactor": 0.5, "specularColorFactor": [1, 0.5, 0.25]}}},
            {"name": "gold", "pbrMetallicRoughness": {"baseColorFactor": [1, 0.8, 0.3, 1], "metallicFactor": 1, "roughnessFactor": 0.3},
             "extensions": {"KHR_materials_specular": {"specularFactor": 0.5}}},
            {"name": "matte", "pbrMetallicRoughness": {"metallicFactor": 0, "roughnessFactor": 0.4},
             "extensions": {"KHR_materials_specular": {"specularFactor": 0}}}
        ]),
        &mut d,
        json!({"extensionsUsed": ["KHR_materials_ior", "KHR_materials_specular"]}),
    );
    let dir = folder(&[("m.glb", &bytes)]);
    let s = load(dir.path());
    let gloss = |surface: &str| {
        let k = s.surface_index(surface).unwrap() as u32;
        let t = s.triangles.iter().find(|t| t.surface == k).unwrap();
        s.materials[t.material as usize].gloss
    };
    let near =
        |a: relight::color::Rgb, b: [f32; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6);
    let water = gloss("s0").unwrap();
    let f = (0.33f32 / 2.33).powi(2);
    assert!(
        near(water.f0, [f; 3]) && near(water.f90, [1.0; 3]),
        "{water:?}"
    );
    assert!((water.alpha - 0.04).abs() < 1e-6, "{water:?}");
    let satin = gloss("s1").unwrap();
    assert!(
        near(satin.f0, [0.02, 0.01, 0.005]) && near(satin.f90, [0.5; 3]),
        "{satin:?}"
    );
    let gold = gloss("s2").unwrap();
    assert!(
        near(gold.f0, [1.0, 0.8, 0.3]) && near(gold.f90, [1.0; 3]),
        "{gold:?}"
    );
    // A dielectric with no specular reflection stays Lambertian.
    assert_eq!(gloss("s3"), None);

    let bytes = material_scene(
        json!([{"name": "odd", "pbrMetallicRoughness": {"metallicFactor": 0},
                "extensions": {"KHR_materials_ior": {"ior": 0.5}}}]),
        &mut Doc::default(),
        json!({"extensionsUsed": ["KHR_materials_ior"]}),
    );
    let dir = folder(&[("m.glb", &bytes)]);
    let e = load_err(dir.path());
    assert!(e.contains("'odd'") && e.contains("ior 0.5"), "{e}");
}

#[test]
fn punctual_lights_become_luminaires_grouped_by_definition() {
    let _gate = common::shared();
    let mut d = Doc::default();
    let (p, i) = unit_square(&mut d);
    let (inner, outer) = (0.3f64, 0.6f64);
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let bytes = d.glb(json!({
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "Down Light", "type": "point", "intensity": 100, "color": [1, 1, 1]},
            {"name": "spot", "type": "spot", "intensity": 50, "spot": {"innerConeAngle": inner, "outerConeAngle": outer}},
            {"type": "directional", "intensity": 3}
        ]}},
        "meshes": [{"primitives": [{"attributes": {"POSITION": p}, "indices": i}]}],
        "nodes": [
            {"name": "floor", "mesh": 0, "scale": [4, 1, 4]},
            {"name": "a", "translation": [1, 2, 1], "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "b", "translation": [3, 2, 3], "extensions": {"KHR_lights_punctual": {"light": 0}}},
            // a spot aims down its node's −z: turned a quarter about x, it aims down −y
            {"name": "s", "translation": [2, 3, 2], "rotation": [-h, 0, 0, h],
             "extensions": {"KHR_lights_punctual": {"light": 1}}},
            {"name": "sun", "extensions": {"KHR_lights_punctual": {"light": 2}}}
        ]
    }));
    let dir = folder(&[("lit.glb", &bytes)]);
    let s = load(dir.path());
    let ids: Vec<&str> = s.lights.iter().map(|g| g.id.as_str()).collect();
    assert_eq!(ids, ["down-light", "spot"]);
    let down = &s.lights[0];
    assert_eq!(down.luminaires.len(), 2);
    let pi = std::f64::consts::PI;
    for (l, at) in down.luminaires.iter().zip([[1., 2., 1.], [3., 2., 3.]]) {
        assert!(close(l.lumens, 400.0 * pi, 1e-9), "{}", l.lumens);
        assert!(l.position.abs_diff_eq(glam::DVec3::from(at), 1e-9));
        assert!(close(
            l.intensity(glam::DVec3::new(0.3, -1.0, 0.2).normalize()),
            100.0,
            1e-9
        ));
        // Illuminance straight below, 2 m down: 100 cd / 4 m² = 25 lx.
        assert!(close(
            l.illuminance(glam::DVec3::new(at[0], 0.0, at[2]), glam::DVec3::Y),
            25.0,
            1e-9
        ));
    }
    let spot = &s.lights[1].luminaires[0];
    assert!(
        spot.aim.abs_diff_eq(glam::DVec3::NEG_Y, 1e-6),
        "{}",
        spot.aim
    );
    // Flux of the extension's falloff (smoothstep-free: t² between the cones), integrated
    // here by quadrature, independently of the library.
    let (ci, co) = (inner.cos(), outer.cos());
    let steps = 200_000;
    let mut flux = 0.0;
    for k in 0..steps {
        let th = (k as f64 + 0.5) / steps as f64 * outer;
        let c = th.cos();
        let t = ((c - co) / (ci - co)).clamp(0.0, 1.0);
        flux += 50.0 * t * t * 2.0 * pi * th.sin() * outer / steps as f64;
    }
    assert!(close(spot.lumens, flux, 1e-4), "{} vs {flux}", spot.lumens);
    assert!(close(spot.intensity(glam::DVec3::NEG_Y), 50.0, 1e-9));
    assert_eq!(
        spot.intensity(glam::DVec3::new(1.0, -1.0, 0.0).normalize()),
        0.0
    );
    assert!(
        warned(&s, &["1 directional light(s) skipped"]),
        "{:?}",
        s.warnings
    );

    // `[[lights]]` names a model light's group and sets its defaults.
    std::fs::write(
        dir.path().join("scene.toml"),
        "[[lights]]\nid = \"spot\"\nname = \"Reading spot\"\nintensity = 0.4\n",
    )
    .unwrap();
    let s = load(dir.path());
    let g = s.lights.iter().find(|g| g.id == "spot").unwrap();
    assert_eq!(
        (g.name.as_str(), g.intensity, g.luminaires.len()),
        ("Reading spot", 0.4, 1)
    );
}

#[test]
fn gltf_with_external_and_data_uri_buffers_loads_and_paths_stay_in_the_folder() {
    let _gate = common::shared();
    let mut d = Doc::default();
    let (p, i) = unit_square(&mut d);
    let rest = json!({
        "meshes": [{"primitives": [{"attributes": {"POSITION": p, "_TEMPERATURE": p}, "indices": i}, {"attributes": {"POSITION": p}, "mode": 1}]}],
        "nodes": [{"name": "floor", "mesh": 0}]
    });
    // A .gltf beside its .bin (with a percent-encoded space in the URI).
    let gltf = serde_json::to_vec(&d.json(rest.clone(), Some("my%20data.bin"))).unwrap();
    let dir = folder(&[("scene.gltf", &gltf), ("my data.bin", &d.bin)]);
    let s = load(dir.path());
    assert_eq!(s.triangles.len(), 2);
    assert!(close(surface_area(&s, "floor"), 1.0, 1e-12));
    assert!(
        warned(&s, &["1 primitive(s) of points or lines skipped"]),
        "{:?}",
        s.warnings
    );
    assert!(
        s.files.iter().any(|f| f.ends_with("my data.bin")),
        "{:?}",
        s.files
    );

    // The same buffer as a data URI.
    use base64::Engine as _;
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&d.bin)
    );
    let gltf = serde_json::to_vec(&d.json(rest.clone(), Some(&uri))).unwrap();
    let dir = folder(&[("scene.gltf", &gltf)]);
    assert_eq!(load(dir.path()).triangles.len(), 2);

    // A buffer outside the folder, or missing, is an error even in a lenient load.
    let outside = tempfile::tempdir().unwrap();
    std::fs::write(outside.path().join("x.bin"), &d.bin).unwrap();
    let sub = outside.path().join("scene");
    std::fs::create_dir(&sub).unwrap();
    let gltf = serde_json::to_vec(&d.json(rest.clone(), Some("../x.bin"))).unwrap();
    std::fs::write(sub.join("scene.gltf"), gltf).unwrap();
    let e = load_err(&sub);
    assert!(e.contains("buffers[0]") && e.contains("outside"), "{e}");
    let gltf = serde_json::to_vec(&d.json(rest, Some("gone.bin"))).unwrap();
    let dir = folder(&[("scene.gltf", &gltf)]);
    let e = load_err(dir.path());
    assert!(e.contains("gone.bin"), "{e}");
}

#[test]
fn hostile_gltf_files_are_refused_with_a_message() {
    let _gate = common::shared();
    let bad = |f: &dyn Fn(&mut Value, &mut Doc), needle: &str| {
        let mut d = Doc::default();
        let (p, i) = unit_square(&mut d);
        let mut doc = d.json(
            json!({"meshes": [{"primitives": [{"attributes": {"POSITION": p}, "indices": i}]}],
                   "nodes": [{"name": "floor", "mesh": 0}]}),
            None,
        );
        f(&mut doc, &mut d);
        let dir = folder(&[("x.glb", &glb(&doc, &d.bin))]);
        let e = load_err(dir.path());
        assert!(
            e.contains("x.glb") && e.contains(needle),
            "wanted '{needle}' in: {e}"
        );
    };
    // An accessor reading past its view.
    bad(
        &|doc, _| doc["accessors"][0]["count"] = json!(1000),
        "POSITION",
    );
    bad(
        &|doc, _| doc["accessors"][0]["byteOffset"] = json!(4),
        "POSITION",
    );
    // A view past its buffer.
    bad(
        &|doc, _| doc["bufferViews"][1]["byteOffset"] = json!(1 << 20),
        "",
    );
    // Indices beyond the vertices.
    bad(
        &|doc, d| {
            let i = d.indices(&[0, 1, 7]);
            doc["bufferViews"] = json!(d.views);
            doc["accessors"] = json!(d.accessors);
            doc["buffers"][0]["byteLength"] = json!(d.bin.len());
            doc["meshes"][0]["primitives"][0]["indices"] = json!(i);
        },
        "index 7 out of range",
    );
    // 32-bit integer positions (not among KHR_mesh_quantization's types), float indices.
    bad(
        &|doc, _| doc["accessors"][0]["componentType"] = json!(5125),
        "POSITION of type U32 is not read",
    );
    bad(
        &|doc, _| doc["accessors"][1]["componentType"] = json!(5126),
        "indices",
    );
    // A node cycle, shared subtrees: refused by the tree check (see `node_trees`).
    bad(
        &|doc, _| doc["nodes"][0]["children"] = json!([0]),
        "nodes[0] is its own child",
    );
    bad(
        &|doc, _| {
            let mut nodes: Vec<Value> = (0..40)
                .map(|k| json!({"children": [k + 1, k + 1]}))
                .collect();
            nodes.push(json!({"name": "leaf"}));
            nodes.push(json!({"name": "floor", "mesh": 0}));
            doc["nodes"] = json!(nodes);
            doc["scenes"] = json!([{"nodes": [41, 0]}]);
        },
        "nodes[1] appears twice in the children of nodes[0]",
    );
    // A chain deeper than the depth limit.
    bad(
        &|doc, _| {
            let mut nodes: Vec<Value> = (0..300).map(|k| json!({"children": [k + 1]})).collect();
            nodes.push(json!({"name": "floor", "mesh": 0}));
            doc["nodes"] = json!(nodes);
            doc["scenes"] = json!([{"nodes": [0]}]);
        },
        "nodes[256]: the node tree is deeper than 256 levels",
    );
    // A transform that is not finite, a vertex a long way off.
    bad(
        &|doc, _| doc["nodes"][0]["scale"] = json!([1e300, 1, 1]),
        "",
    );
    bad(
        &|doc, _| doc["nodes"][0]["translation"] = json!([1e9, 0, 0]),
        "beyond",
    );
    // Broken spot cones, negative intensity.
    bad(
        &|doc, _| {
            doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [
                {"type": "spot", "intensity": 1, "spot": {"innerConeAngle": 0.8, "outerConeAngle": 0.5}}]}});
            doc["nodes"][0]["extensions"] = json!({"KHR_lights_punctual": {"light": 0}});
        },
        "cone",
    );
    bad(
        &|doc, _| {
            doc["extensions"] =
                json!({"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": -5}]}});
            doc["nodes"][0]["extensions"] = json!({"KHR_lights_punctual": {"light": 0}});
        },
        "intensity",
    );
    // Not glTF at all, a truncated GLB, an unknown glTF version.
    for bytes in [b"hello world".to_vec(), {
        let mut d = Doc::default();
        unit_square(&mut d);
        let mut g = d.glb(json!({}));
        g.truncate(g.len() - 10);
        g
    }] {
        let dir = folder(&[("x.glb", &bytes)]);
        let e = load_err(dir.path());
        assert!(e.contains("x.glb"), "{e}");
    }
    bad(
        &|doc, _| doc["asset"]["version"] = json!("3.0"),
        "version 3.0",
    );
    bad(
        &|doc, _| {
            doc["extensionsUsed"] = json!(["KHR_draco_mesh_compression"]);
            doc["extensionsRequired"] = json!(["KHR_draco_mesh_compression"]);
        },
        "requires the extension KHR_draco_mesh_compression",
    );
}

#[test]
fn one_model_per_folder() {
    let _gate = common::shared();
    let mut d = Doc::default();
    unit_square(&mut d);
    let g = d.glb(json!({}));
    let dir = folder(&[("a.glb", &g), ("b.obj", b"v 0 0 0\n")]);
    let e = load_err(dir.path());
    assert!(e.contains("a.glb") && e.contains("b.obj"), "{e}");
}

/// A closed unit box of grey walls facing in, with an emissive panel under the ceiling: one
/// square mesh instanced by seven nodes.
pub(crate) fn box_glb() -> Vec<u8> {
    let mut d = Doc::default();
    let (p, i) = unit_square(&mut d);
    let h = std::f64::consts::FRAC_1_SQRT_2;
    d.glb(json!({
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "materials": [
            serde_json::from_str::<Value>(GREY).unwrap(),
            {"name": "panel", "emissiveFactor": [1, 1, 1], "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]},
             "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 100}}}
        ],
        "meshes": [
            {"name": "wall", "primitives": [{"attributes": {"POSITION": p}, "indices": i, "material": 0}]},
            {"name": "panel", "primitives": [{"attributes": {"POSITION": p}, "indices": i, "material": 1}]}
        ],
        "nodes": [
            {"name": "floor", "mesh": 0},
            {"name": "ceiling", "mesh": 0, "translation": [0, 1, 1], "rotation": [1, 0, 0, 0]},
            {"name": "west", "mesh": 0, "translation": [0, 1, 0], "rotation": [0, 0, -h, h]},
            {"name": "east", "mesh": 0, "translation": [1, 0, 0], "rotation": [0, 0, h, h]},
            {"name": "north", "mesh": 0, "translation": [0, 1, 0], "rotation": [h, 0, 0, h]},
            {"name": "south", "mesh": 0, "translation": [0, 0, 1], "rotation": [-h, 0, 0, h]},
            {"name": "panel", "mesh": 1, "translation": [0.35, 0.99, 0.65], "rotation": [1, 0, 0, 0], "scale": [0.3, 0.3, 0.3]}
        ]
    }))
}

#[test]
fn a_closed_box_of_instanced_walls_faces_inward_and_is_closed() {
    let _gate = common::shared();
    let dir = folder(&[("box.glb", &box_glb())]);
    let s = load(dir.path());
    let c = glam::DVec3::splat(0.5);
    for name in ["floor", "ceiling", "west", "east", "north", "south"] {
        assert!(
            close(surface_area(&s, name), 1.0, 1e-6),
            "{name}: {}",
            surface_area(&s, name)
        );
        // Each wall faces the centre of the box.
        let k = s.surface_index(name).unwrap() as u32;
        let t = s.triangles.iter().find(|t| t.surface == k).unwrap();
        let n = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]);
        assert!(n.dot(c - t.p[0]) > 0.0, "{name} faces out: {:?} n {n}", t.p);
    }
    // Closed: the rows of the form-factor matrix of the walls sum to 1.
    let solved = common::form_factors(dir.path());
    let mut total = 0.0;
    for name in [
        "floor", "ceiling", "west", "east", "north", "south", "panel",
    ] {
        total += solved.surface_factor("floor", name);
    }
    assert!(close(total, 1.0, 0.01), "floor row sums to {total}");
}
