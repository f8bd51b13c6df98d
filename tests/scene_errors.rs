//! Broken scenes give clear errors that name the file and line or object; none panics.

mod common;

use common::*;
use relight::scene::Scene;

fn load_err(obj: &str, mtl: &str, toml: Option<&str>) -> String {
    let s = write_scene(obj, mtl, toml);
    match Scene::load(s.path()) {
        Ok(_) => panic!("scene should not load"),
        Err(e) => e.to_string(),
    }
}

const TRI: &str = "o floor\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n";

#[test]
fn missing_mtl_names_the_obj_line() {
    let s = write_scene(TRI, GREY_MTL, None);
    let obj = std::fs::read_to_string(s.path().join("scene.obj")).unwrap();
    std::fs::write(
        s.path().join("scene.obj"),
        obj.replace("mtllib scene.mtl", "mtllib nowhere.mtl"),
    )
    .unwrap();
    let e = Scene::load(s.path()).unwrap_err().to_string();
    assert!(
        e.contains("scene.obj:1") && e.contains("nowhere.mtl"),
        "{e}"
    );
}

#[test]
fn nan_coordinates_name_the_line() {
    let e = load_err(
        "o floor\nusemtl grey\nv 0 0 0\nv nan 0 0\nv 0 0 1\nf 1 3 2\n",
        GREY_MTL,
        None,
    );
    // Line 1 is mtllib, so the NaN vertex is on line 5.
    assert!(e.contains("scene.obj:5") && e.contains("nan"), "{e}");
}

#[test]
fn face_index_out_of_range_names_the_line() {
    let e = load_err(
        "o floor\nusemtl grey\nv 0 0 0\nv 1 0 0\nf 1 2 7\n",
        GREY_MTL,
        None,
    );
    assert!(
        e.contains("scene.obj:6") && e.contains("out of range"),
        "{e}"
    );
}

#[test]
fn degenerate_triangles_are_skipped_with_a_warning() {
    let obj = format!("{TRI}o sliver\nusemtl grey\nv 0 1 0\nv 1 1 0\nv 2 1 0\nf 4 5 6\n");
    let s = write_scene(&obj, GREY_MTL, None);
    let scene = Scene::load(s.path()).unwrap();
    assert_eq!(scene.triangles.len(), 1);
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("sliver") && w.contains("degenerate")),
        "{:?}",
        scene.warnings
    );
}

#[test]
fn reflectance_of_one_or_more_is_rejected() {
    let e = load_err(TRI, "newmtl grey\nKd 1.0 0.5 0.5\n", None);
    assert!(
        e.contains("scene.mtl:2") && e.contains("grey") && e.contains("[0, 1)"),
        "{e}"
    );
}

#[test]
fn unknown_material_names_the_line() {
    let e = load_err(
        "o floor\nusemtl chrome\nv 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n",
        GREY_MTL,
        None,
    );
    assert!(e.contains("scene.obj:3") && e.contains("chrome"), "{e}");
}

#[test]
fn unknown_light_reference_names_the_light() {
    let toml = "[[lights]]\nid = \"desk\"\nsurfaces = [\"lampshade\"]\n";
    let e = load_err(TRI, GREY_MTL, Some(toml));
    assert!(
        e.contains("scene.toml") && e.contains("desk") && e.contains("lampshade"),
        "{e}"
    );
}

#[test]
fn empty_scene_is_an_error() {
    let e = load_err("# nothing here\n", GREY_MTL, None);
    assert!(e.contains("no usable triangles"), "{e}");
}

#[test]
fn malformed_scene_toml_names_the_line() {
    let e = load_err(TRI, GREY_MTL, Some("name = \"x\"\n[mesh]\nmax_edg = 0.1\n"));
    assert!(e.contains("scene.toml") && e.contains("max_edg"), "{e}");
}

#[test]
fn folder_without_obj_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let e = Scene::load(dir.path()).unwrap_err().to_string();
    assert!(e.contains("no .obj"), "{e}");
}

#[test]
fn obj_without_scene_toml_gets_one_group_per_emissive_material() {
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
fn millimetre_models_are_scaled_to_metres() {
    let s = write_scene(TRI, GREY_MTL, Some("units = \"mm\"\n"));
    let scene = Scene::load(s.path()).unwrap();
    let max_x = scene.triangles[0].p.iter().map(|p| p.x).fold(0.0, f64::max);
    assert!((max_x - 0.001).abs() < 1e-12, "{max_x}");
}

#[test]
fn bad_luminaires_and_grids_get_precise_errors() {
    let lum = |extra: &str| format!("[[luminaires]]\nid = \"l\"\nposition = [0, 2, 0]\n{extra}\n");
    let cases: Vec<(String, &str)> = vec![
        (lum("lumens = 100\nies = \"missing.ies\""), "missing.ies"),
        (lum(""), "lumens is required"),
        (
            lum("lumens = 100\ndistribution = \"spot\"\nbeam_deg = 60\nfield_deg = 30"),
            "beam_deg",
        ),
        (
            lum("lumens = 100\ndistribution = \"laser\""),
            "distribution 'laser'",
        ),
        (lum("lumens = 100\ncct = 200"), "cct = 200"),
        (lum("lumens = 100\naim = [0, 0, 0]"), "aim"),
        (lum("lumens = -5"), "lumens = -5"),
        (
            lum("lumens = 100\ncolor = [1, 1, 1]\ncct = 3000"),
            "color or cct",
        ),
        (
            "[[grids]]\nid = \"g\"\nspacing = 0.1\n".into(),
            "give either points",
        ),
        (
            "[[grids]]\nid = \"g\"\nmin = [0, 0]\nmax = [100, 100]\nspacing = 0.01\n".into(),
            "the limit is",
        ),
        (
            "[[grids]]\nid = \"g\"\nmin = [1, 0]\nmax = [0, 1]\n".into(),
            "max must exceed min",
        ),
        (
            "[[lights]]\nid = \"empty\"\n".into(),
            "names no materials or surfaces, and no luminaire joins it",
        ),
    ];
    for (toml, needle) in cases {
        let e = load_err(TRI, GREY_MTL, Some(&toml));
        assert!(e.contains(needle), "{toml}\n→ {e}");
    }
    // A broken IES file names the file and what is wrong.
    let s = write_scene(TRI, GREY_MTL, Some(&lum("ies = \"bad.ies\"")));
    std::fs::write(
        s.path().join("bad.ies"),
        "IESNA:LM-63-2002\nTILT=NONE\n1 1000 1 3 1 1\n",
    )
    .unwrap();
    let e = Scene::load(s.path()).unwrap_err().to_string();
    assert!(e.contains("bad.ies") && e.contains("ends before"), "{e}");
}
