//! The MTL file: reflectances, emission, numeric statements and materials defined twice.

use relight::scene::Scene;

use super::{load_err, TRI};
use crate::common::{self, *};

#[test]
fn reflectance_of_one_or_more_is_rejected_when_strict() {
    let _gate = common::shared();
    // (Lenient loads scale it down with a warning: tests/it/lenient.rs.)
    let e = load_err(
        TRI,
        "newmtl grey\nKd 1.0 0.5 0.5\n",
        Some("strict = true\n"),
    );
    assert!(
        e.contains("scene.mtl:2") && e.contains("grey") && e.contains("[0, 1)"),
        "{e}"
    );
}

#[test]
fn obj_without_scene_toml_gets_one_group_per_emissive_material() {
    let _gate = common::shared();
    let obj = format!("{TRI}o lamp\nusemtl glow\nv 0 1 0\nv 0 1 1\nv 1 1 0\nf 4 5 6\n");
    let s = write_scene(
        &obj,
        "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl glow\nKd 0 0 0\nKe 5 5 5\n",
        None,
    );
    let scene = Scene::load(s.path()).unwrap();
    assert_eq!(scene.lights.len(), 1);
    assert_eq!(scene.lights[0].id, "glow");
}

#[test]
fn kd_with_one_value_does_not_panic() {
    let _gate = common::shared();
    // One value means grey (MTL specification); it used to make tobj panic.
    let s = write_scene(TRI, "newmtl grey\nKd 0.5\n", None);
    let scene = Scene::load(s.path()).unwrap();
    assert_eq!(scene.materials[0].kd, [0.5; 3]);
    // Two values, or four, are errors that name the file and line.
    for bad in ["Kd 0.5 0.5", "Kd 0.1 0.2 0.3 0.4", "Kd", "Ke 1 2"] {
        let e = load_err(TRI, &format!("newmtl grey\n{bad}\n"), None);
        assert!(
            e.contains("scene.mtl:2") && e.contains("needs 3 numbers"),
            "{bad}: {e}"
        );
    }
}

#[test]
fn unparsable_mtl_line_is_an_error_not_a_silent_drop() {
    let _gate = common::shared();
    let obj = format!("{TRI}o lamp\nusemtl glow\nv 0 1 0\nv 0 1 1\nv 1 1 0\nf 4 5 6\n");
    // `Ns abc` made tobj drop every material, so emitters vanished. relight reads every
    // numeric statement, used or not: a damaged one is an error naming file and line.
    for (bad, needle) in [
        ("Ns abc", "Ns: 'abc' is not a number"),
        ("illum x", "illum: 'x' is not a number"),
        ("d", "d needs a number"),
        ("Ka 1 nan 1", "Ka: 'nan' is not a number"),
    ] {
        let mtl = format!("newmtl grey\nKd 0.5 0.5 0.5\n{bad}\nnewmtl glow\nKe 5 5 5\n");
        let e = load_err(&obj, &mtl, None);
        assert!(
            e.contains("scene.mtl:3") && e.contains(needle),
            "{bad}: {e}"
        );
    }
    // Well-formed statements it does not use are ignored, and every material is kept.
    let mtl = "newmtl grey\nKd 0.5 0.5 0.5\nNs 10\nillum 2\nd -halo 0.5\nKa spectral a.rfl 1\nmap_Kd\nnewmtl glow\nKe 5 5 5\n";
    let s = write_scene(&obj, mtl, None);
    let scene = Scene::load(s.path()).unwrap();
    assert_eq!(scene.lights.len(), 1, "the emitter must not vanish");
    assert_eq!(scene.lights[0].id, "glow");
    // What relight does use is strict: a bad number names file, line and material.
    for (bad, needle) in [
        ("Ke 5 x 5", "'x' is not a number"),
        ("Ke 5 5 -1", "must be in [0"),
        ("Ke 5 5 1e39", "not a finite 32-bit number"),
        ("Ke 5 5 nan", "not a finite"),
        ("ke 5 5 5", "did you mean 'Ke'"),
        ("Ke spectral a.spd", "only RGB"),
    ] {
        let e = load_err(&obj, &mtl.replace("Ke 5 5 5", bad), None);
        assert!(
            e.contains("scene.mtl:9") && e.contains(needle),
            "{bad}: {e}"
        );
    }
    // Unknown statements are not errors, but they are reported.
    let s = write_scene(&obj, &format!("{mtl}Xyz 1\n"), None);
    let scene = Scene::load(s.path()).unwrap();
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("scene.mtl") && w.contains("'Xyz' on line 10")),
        "{:?}",
        scene.warnings
    );
    // A material defined twice is an error (which one would count?).
    let e = load_err(
        TRI,
        "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl grey\nKd 0.1 0.1 0.1\n",
        None,
    );
    assert!(
        e.contains("scene.mtl:3") && e.contains("defined twice"),
        "{e}"
    );
}
