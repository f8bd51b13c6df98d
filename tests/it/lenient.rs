//! Lenient loading, as the tools people export from expect: `Kd 1 1 1`, missing MTL files,
//! unknown materials, several files on one `mtllib` line and `map_Kd` textures load with a
//! warning; `strict = true` turns each into an error. A path that leaves the scene folder
//! is an error either way.

use relight::scene::Scene;

use crate::common::{self, write_scene};

const TRI: &str = "o floor\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n";
const STRICT: &str = "strict = true\n";

fn load(obj: &str, mtl: &str, toml: Option<&str>) -> Scene {
    let s = write_scene(obj, mtl, toml);
    Scene::load(s.path()).unwrap()
}

fn load_err(obj: &str, mtl: &str, toml: Option<&str>) -> String {
    let s = write_scene(obj, mtl, toml);
    Scene::load(s.path())
        .expect_err("should not load")
        .to_string()
}

fn material<'a>(s: &'a Scene, name: &str) -> &'a relight::scene::Material {
    s.materials.iter().find(|m| m.name == name).unwrap()
}

fn warned(s: &Scene, needles: &[&str]) -> bool {
    s.warnings
        .iter()
        .any(|w| needles.iter().all(|n| w.contains(n)))
}

fn png(path: &std::path::Path, rgba: [u8; 4]) {
    image::RgbaImage::from_pixel(4, 4, image::Rgba(rgba))
        .save(path)
        .unwrap();
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

#[test]
fn kd_of_one_or_more_is_scaled_down_keeping_its_colour() {
    let _gate = common::shared();
    let s = load(TRI, "newmtl grey\nKd 1 1 1\n", None);
    assert_eq!(material(&s, "grey").kd, [0.95; 3]);
    assert!(
        warned(&s, &["scene.mtl:2", "grey", "scaled to 0.95 0.95 0.95"]),
        "{:?}",
        s.warnings
    );
    let s = load(TRI, "newmtl grey\nKd 2 1 0.5\n", None);
    let kd = material(&s, "grey").kd;
    assert!(
        (kd[0] - 0.95).abs() < 1e-6
            && (kd[1] - 0.475).abs() < 1e-6
            && (kd[2] - 0.2375).abs() < 1e-6,
        "{kd:?}"
    );
    // Negative reflectance is not a habit of exporters: always an error.
    let e = load_err(TRI, "newmtl grey\nKd -0.1 0.5 0.5\n", None);
    assert!(e.contains("scene.mtl:2") && e.contains("[0, 1)"), "{e}");
    let e = load_err(TRI, "newmtl grey\nKd 1 1 1\n", Some(STRICT));
    assert!(
        e.contains("scene.mtl:2") && e.contains("strict = true"),
        "{e}"
    );
}

#[test]
fn missing_mtl_files_and_unknown_materials_turn_grey_with_a_warning() {
    let _gate = common::shared();
    let obj = format!(
        "mtllib missing.mtl\n{TRI}o wall\nusemtl brick\nv 0 1 0\nv 1 1 0\nv 0 1 1\nf 4 5 6\n"
    );
    let s = load(&obj, "newmtl grey\nKd 0.3 0.3 0.3\n", None);
    assert_eq!(material(&s, "grey").kd, [0.3; 3]);
    assert_eq!(material(&s, "brick").kd, [0.5; 3]);
    assert!(
        warned(&s, &["mtllib 'missing.mtl' not found"]),
        "{:?}",
        s.warnings
    );
    assert!(
        warned(&s, &["1 material(s) not defined", "'brick' (line 10)"]),
        "{:?}",
        s.warnings
    );
    // [material.NAME] reaches a defaulted material too.
    let s = load(
        &obj,
        "newmtl grey\nKd 0.3 0.3 0.3\n",
        Some("[material.brick]\ntwo_sided = true\n"),
    );
    assert!(material(&s, "brick").two_sided);
    let e = load_err(&obj, "newmtl grey\nKd 0.3 0.3 0.3\n", Some(STRICT));
    assert!(
        e.contains("mtllib 'missing.mtl'") && e.contains("not found"),
        "{e}"
    );
    let strict_unknown = format!("{TRI}o wall\nusemtl brick\nv 0 1 0\nv 1 1 0\nv 0 1 1\nf 4 5 6\n");
    let e = load_err(
        &strict_unknown,
        "newmtl grey\nKd 0.3 0.3 0.3\n",
        Some(STRICT),
    );
    assert!(e.contains("unknown material 'brick'"), "{e}");
    // Leniency never reaches outside the folder.
    for outside in ["../elsewhere.mtl", "/etc/passwd"] {
        let e = load_err(
            &format!("mtllib {outside}\n{TRI}"),
            "newmtl grey\nKd 0.3 0.3 0.3\n",
            None,
        );
        assert!(e.contains("outside the scene folder"), "{outside}: {e}");
    }
}

#[test]
fn one_mtllib_line_may_name_several_files() {
    let _gate = common::shared();
    let s = write_scene(
        &format!(
            "mtllib a.mtl b.mtl\n{TRI}o wall\nusemtl red\nv 0 1 0\nv 1 1 0\nv 0 1 1\nf 4 5 6\n"
        ),
        "newmtl grey\nKd 0.3 0.3 0.3\n",
        None,
    );
    std::fs::write(s.path().join("a.mtl"), "newmtl unused\nKd 0.1 0.1 0.1\n").unwrap();
    std::fs::write(s.path().join("b.mtl"), "newmtl red\nKd 0.6 0.1 0.1\n").unwrap();
    let scene = Scene::load(s.path()).unwrap();
    assert_eq!(material(&scene, "red").kd, [0.6, 0.1, 0.1]);
    assert_eq!(material(&scene, "unused").kd, [0.1; 3]);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    // A file whose name has a space is still one file.
    let s = write_scene(
        &format!("mtllib my materials.mtl\n{TRI}"),
        "newmtl x\nKd 0.2 0.2 0.2\n",
        None,
    );
    std::fs::write(
        s.path().join("my materials.mtl"),
        "newmtl grey\nKd 0.4 0.4 0.4\n",
    )
    .unwrap();
    let scene = Scene::load(s.path()).unwrap();
    assert_eq!(material(&scene, "grey").kd, [0.4; 3]);
}

#[test]
fn map_kd_textures_are_averaged_into_kd() {
    let _gate = common::shared();
    let mtl = "newmtl grey\nKd 0.8 0.8 0.8\nmap_Kd -s 1 1 1 tex/wood.png\nnewmtl bare\nmap_Kd plain.png\n";
    let obj = format!("{TRI}o wall\nusemtl bare\nv 0 1 0\nv 1 1 0\nv 0 1 1\nf 4 5 6\n");
    let s = write_scene(&obj, mtl, None);
    std::fs::create_dir(s.path().join("tex")).unwrap();
    png(&s.path().join("tex/wood.png"), [188, 94, 47, 255]);
    png(&s.path().join("plain.png"), [255, 255, 255, 255]);
    let scene = Scene::load(s.path()).unwrap();
    let kd = material(&scene, "grey").kd;
    for (c, code) in [188u8, 94, 47].into_iter().enumerate() {
        assert!((kd[c] - 0.8 * linear(code)).abs() < 1e-5, "{kd:?}");
    }
    // No Kd: the texture alone; a white texture reaches 1 and is scaled down.
    assert_eq!(material(&scene, "bare").kd, [0.95; 3]);
    assert!(
        warned(&scene, &["'bare'", "scaled to 0.95"]),
        "{:?}",
        scene.warnings
    );
    // The texture is part of the cache key.
    assert!(scene.files.iter().any(|f| f.ends_with("tex/wood.png")));

    // A missing or broken texture leaves Kd alone, with a warning; strict refuses it.
    std::fs::remove_file(s.path().join("tex/wood.png")).unwrap();
    std::fs::write(s.path().join("plain.png"), b"not a png").unwrap();
    let scene = Scene::load(s.path()).unwrap();
    assert_eq!(material(&scene, "grey").kd, [0.8; 3]);
    assert!(
        warned(
            &scene,
            &["map_Kd 'tex/wood.png'", "not in the scene folder"]
        ),
        "{:?}",
        scene.warnings
    );
    assert!(
        warned(&scene, &["map_Kd 'plain.png'", "cannot be read"]),
        "{:?}",
        scene.warnings
    );
    std::fs::write(s.path().join("scene.toml"), STRICT).unwrap();
    let e = Scene::load(s.path()).err().unwrap().to_string();
    assert!(e.contains("map_Kd 'tex/wood.png'"), "{e}");
    // Outside the folder: an error even when lenient.
    std::fs::remove_file(s.path().join("scene.toml")).unwrap();
    std::fs::write(
        s.path().join("scene.mtl"),
        "newmtl grey\nmap_Kd ../secret.png\n",
    )
    .unwrap();
    let e = Scene::load(s.path()).err().unwrap().to_string();
    assert!(e.contains("outside the scene folder"), "{e}");
}

/// Total area and (for every triangle) the upward-facing part of it, m².
fn areas(s: &Scene) -> (f64, f64) {
    s.triangles.iter().fold((0.0, 0.0), |(a, up), t| {
        let n = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]);
        (a + 0.5 * n.length(), up + 0.5 * n.y)
    })
}

#[test]
fn faces_naming_undefined_normals_were_refused() {
    // tinyobjloader's smoothing-group-two-squares: `f 1//1 …` with no `vn` in the file.
    let _gate = common::shared();
    let obj = "o floor\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 0 0 1\nf 1//1 3//1 2//1\nf 1/5 3/5 2/5\n";
    let s = load(obj, "newmtl grey\nKd 0.5 0.5 0.5\n", None);
    assert_eq!(s.triangles.len(), 2);
    assert!(
        warned(
            &s,
            &[
                "scene.obj",
                "2 face(s) refer to texture coordinates or normals",
                "line 7"
            ]
        ),
        "{:?}",
        s.warnings
    );
    let e = load_err(obj, "newmtl grey\nKd 0.5 0.5 0.5\n", Some(STRICT));
    assert!(
        e.contains("scene.obj:7") && e.contains("strict = true"),
        "{e}"
    );
    // The vertex index stays strict, and says why.
    let e = load_err("o f\nv 0 0 0\nv 1 0 0\nf 1 2 0\n", "", None);
    assert!(e.contains("scene.obj:5") && e.contains("start at 1"), "{e}");
    let e = load_err("o f\nf 1 2 3\nv 0 0 0\n", "", None);
    assert!(e.contains("no vertex is defined before this line"), "{e}");
}

#[test]
fn polylines_and_faces_of_two_vertices_were_refused() {
    let _gate = common::shared();
    let obj = format!("{TRI}l 1 2 3\nf 1 2\n");
    let s = load(&obj, "newmtl grey\nKd 0.5 0.5 0.5\n", None);
    assert_eq!(s.triangles.len(), 1);
    assert!(
        warned(
            &s,
            &["1 face(s) of fewer than 3 vertices skipped", "line 9"]
        ),
        "{:?}",
        s.warnings
    );
    assert!(warned(&s, &["'l' on line 8"]), "{:?}", s.warnings);
    let e = load_err(&obj, "newmtl grey\nKd 0.5 0.5 0.5\n", Some(STRICT));
    assert!(e.contains("scene.obj:9") && e.contains("at least 3"), "{e}");
}

#[test]
fn vertex_weights_were_taken_as_homogeneous_divisors() {
    // tinyobjloader's cube-vertex-w-component: `v x y z w` with w the rational weight.
    let _gate = common::shared();
    let obj = "o floor\nusemtl grey\nv 0 0 0 0.1\nv 2 0 0 0.2\nv 0 0 2 0.5\nf 1 3 2\n";
    let s = load(obj, "newmtl grey\nKd 0.5 0.5 0.5\n", None);
    let (a, up) = areas(&s);
    assert!(
        (a - 2.0).abs() < 1e-9 && (up - 2.0).abs() < 1e-9,
        "{a} {up}"
    );
}

#[test]
fn non_convex_faces_were_fanned_over_their_notch() {
    // An L-shaped floor (area 5 m²) as one polygon, starting at a vertex that does not see
    // the whole L: a fan from it folds triangles over the notch (tinyobjloader's
    // issue-319-002 gave 56 % extra area that way).
    let _gate = common::shared();
    let obj = "o floor\nusemtl grey\nv 3 0 0\nv 3 0 -1\nv 1 0 -1\nv 1 0 -3\nv 0 0 -3\nv 0 0 0\n\
               f 1 2 3 4 5 6\n";
    let s = load(obj, "newmtl grey\nKd 0.5 0.5 0.5\n", None);
    assert_eq!(s.triangles.len(), 4);
    let (a, up) = areas(&s);
    assert!((a - 5.0).abs() < 1e-9, "area {a}");
    // Every triangle keeps the polygon's winding: the floor faces up.
    assert!((up - 5.0).abs() < 1e-9, "upward area {up}");
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn mtllib_names_with_escaped_spaces_were_split_apart() {
    // tinyobjloader's issue46: `mtllib a.mtl my\ file.mtl`.
    let _gate = common::shared();
    let s = write_scene(
        &format!("mtllib missing.mtl my\\ materials.mtl\n{TRI}"),
        "newmtl x\nKd 0.2 0.2 0.2\n",
        None,
    );
    std::fs::write(
        s.path().join("my materials.mtl"),
        "newmtl grey\nKd 0.4 0.4 0.4\n",
    )
    .unwrap();
    let scene = Scene::load(s.path()).unwrap();
    assert_eq!(material(&scene, "grey").kd, [0.4; 3]);
    assert_eq!(scene.warnings.len(), 1, "{:?}", scene.warnings);
    assert!(warned(&scene, &["mtllib 'missing.mtl' not found"]));
}

#[test]
fn map_kd_file_names_with_spaces_lost_their_first_word() {
    // tinyobjloader's texture-filename-with-whitespace: `map_Kd texture 01.png`.
    let _gate = common::shared();
    let mtl = "newmtl grey\nKd 0.5 0.5 0.5\nmap_Kd -clamp on -s 1 1 texture 01.png\n";
    let s = write_scene(TRI, mtl, None);
    png(&s.path().join("texture 01.png"), [255, 0, 0, 255]);
    let scene = Scene::load(s.path()).unwrap();
    assert_eq!(material(&scene, "grey").kd, [0.5, 0.0, 0.0]);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
}

#[test]
fn a_key_given_twice_in_a_material_was_refused() {
    // Exporters repeat keys (`Kd` twice in 'mesh29_SG'); tobj, Assimp and Blender take the
    // last. relight does too, with a warning naming the file, line, material and key.
    let _gate = common::shared();
    let mtl = "newmtl grey\nKd 0.1 0.1 0.1\nKe 0 0 0\nKd 0.6 0.5 0.4\nKe 0 0 0\n";
    let s = load(TRI, mtl, None);
    assert_eq!(material(&s, "grey").kd, [0.6, 0.5, 0.4]);
    assert!(
        warned(
            &s,
            &[
                "scene.mtl:4",
                "material 'grey'",
                "Kd is given twice",
                "first on line 2"
            ]
        ),
        "{:?}",
        s.warnings
    );
    assert!(
        warned(&s, &["scene.mtl:5", "material 'grey'", "Ke is given twice"]),
        "{:?}",
        s.warnings
    );
    // The last value counts also for emission, and a scaled first Kd does not linger.
    let obj = format!("{TRI}o lamp\nusemtl glow\nv 0 1 0\nv 0 1 1\nv 1 1 0\nf 4 5 6\n");
    let mtl = "newmtl grey\nKd 1 1 1\nKd 0.2 0.2 0.2\nnewmtl glow\nKe 5 5 5\nKe 7 7 7\n";
    let s = load(&obj, mtl, None);
    assert_eq!(material(&s, "grey").kd, [0.2; 3]);
    assert_eq!(material(&s, "glow").ke, [7.0; 3]);
    // A bad repeated value is still an error at its own line.
    let e = load_err(TRI, "newmtl grey\nKd 0.5 0.5 0.5\nKd -1 0 0\n", None);
    assert!(e.contains("scene.mtl:3") && e.contains("[0, 1)"), "{e}");
    // strict = true refuses the repeat, naming the line, the material and the key.
    let e = load_err(
        TRI,
        "newmtl grey\nKd 0.1 0.1 0.1\nKd 0.6 0.5 0.4\n",
        Some(STRICT),
    );
    assert!(
        e.contains("scene.mtl:3")
            && e.contains("'grey'")
            && e.contains("Kd is given twice (first on line 2")
            && e.contains("strict = true"),
        "{e}"
    );
    // map_Kd too: the last texture is the one averaged in.
    let mtl = "newmtl grey\nKd 0.5 0.5 0.5\nmap_Kd red.png\nmap_Kd green.png\n";
    let s = write_scene(TRI, mtl, None);
    png(&s.path().join("red.png"), [255, 0, 0, 255]);
    png(&s.path().join("green.png"), [0, 255, 0, 255]);
    let scene = Scene::load(s.path()).unwrap();
    assert_eq!(material(&scene, "grey").kd, [0.0, 0.5, 0.0]);
    assert!(
        warned(&scene, &["scene.mtl:4", "'grey'", "map_Kd is given twice"]),
        "{:?}",
        scene.warnings
    );
    std::fs::write(s.path().join("scene.toml"), STRICT).unwrap();
    let e = Scene::load(s.path()).expect_err("strict").to_string();
    assert!(
        e.contains("scene.mtl:4") && e.contains("map_Kd is given twice"),
        "{e}"
    );
    // Keys of different materials are no repeat.
    let s = load(
        TRI,
        "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl other\nKd 0.2 0.2 0.2\n",
        None,
    );
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}
