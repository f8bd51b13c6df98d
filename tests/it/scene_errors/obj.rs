//! The OBJ file: bad coordinates, faces and statements, unknown materials, empty scenes.

use relight::scene::Scene;

use super::{load_err, TRI};
use crate::common::{self, *};

#[test]
fn missing_mtl_names_the_obj_line() {
    let _gate = common::shared();
    let s = write_scene(TRI, GREY_MTL, None);
    let obj = std::fs::read_to_string(s.path().join("scene.obj")).unwrap();
    std::fs::write(
        s.path().join("scene.obj"),
        obj.replace("mtllib scene.mtl", "mtllib nowhere.mtl"),
    )
    .unwrap();
    std::fs::write(s.path().join("scene.toml"), "strict = true\n").unwrap();
    let e = Scene::load(s.path()).unwrap_err().to_string();
    assert!(
        e.contains("scene.obj:1") && e.contains("nowhere.mtl"),
        "{e}"
    );
}

#[test]
fn nan_coordinates_name_the_line() {
    let _gate = common::shared();
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
    let _gate = common::shared();
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
    let _gate = common::shared();
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
fn unknown_material_names_the_line() {
    let _gate = common::shared();
    let e = load_err(
        "o floor\nusemtl chrome\nv 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n",
        GREY_MTL,
        Some("strict = true\n"),
    );
    assert!(e.contains("scene.obj:3") && e.contains("chrome"), "{e}");
}

#[test]
fn empty_scene_is_an_error() {
    let _gate = common::shared();
    let e = load_err("# nothing here\n", GREY_MTL, None);
    assert!(e.contains("no usable triangles"), "{e}");
}

#[test]
fn folder_without_obj_is_an_error() {
    let _gate = common::shared();
    let dir = tempfile::tempdir().unwrap();
    let e = Scene::load(dir.path()).unwrap_err().to_string();
    assert!(e.contains("no .obj"), "{e}");
}

#[test]
fn obj_statements_tobj_would_misread_are_refused() {
    let _gate = common::shared();
    for (line, needle) in [
        ("v 1 2", "vertex needs 3 coordinates"),
        ("v 1 2 3 4 5", "vertex needs 3 coordinates"),
        ("f 1/1/1/1 2 3", "bad face vertex"),
        ("f /1 2 3", "bad face vertex"),
        ("f 1 2 -9223372036854775808", "out of range"),
        (
            "f 1 2 9",
            "vertex index 9 out of range: 3 vertices are defined",
        ),
        ("v 1 2 3 nan", "vertex weight w 'nan' is not a finite"),
        ("f 1 2 99999999999999999999", "bad face index"),
        ("vt x 1", "bad vt value"),
        ("usemtl", "usemtl needs a material name"),
        ("mtllib", "mtllib needs a file name"),
    ] {
        let e = load_err(&format!("{TRI}{line}\n"), GREY_MTL, None);
        assert!(
            e.contains("scene.obj:8") && e.contains(needle),
            "{line}: {e}"
        );
    }
    // Vertex colours: all or none.
    let e = load_err(
        "o floor\nusemtl grey\nv 0 0 0 1 1 1\nv 1 0 0\nv 0 0 1\nf 1 3 2\n",
        GREY_MTL,
        None,
    );
    assert!(e.contains("scene.obj:5") && e.contains("colours"), "{e}");
    // Well-formed extras load: w (a rational weight, not a divisor), colours, vt/vn
    // references, a 2-vertex line, leading blanks before usemtl, usemtl before mtllib.
    let s = write_scene(
        "o floor\n  usemtl grey\nv 0 0 0 2\nv 2 0 0 2\nv 0 0 2 2\nvt 0 0\nvn 0 1 0\n\
         f 1/1/1 3/1/1 2//1\nl 1 2\n",
        GREY_MTL,
        None,
    );
    let scene = Scene::load(s.path()).unwrap();
    assert_eq!(scene.triangles.len(), 1);
    assert_eq!(
        scene.materials[scene.triangles[0].material as usize].name,
        "grey"
    );
    assert!(
        (scene.triangles[0].p[1].z - 2.0).abs() < 1e-12,
        "w is not a divisor"
    );
    let s = write_scene(TRI, GREY_MTL, None);
    let p = s.path().join("scene.obj");
    let obj = std::fs::read_to_string(&p).unwrap();
    std::fs::write(
        &p,
        obj.replace("mtllib scene.mtl\n", "") + "mtllib scene.mtl\n",
    )
    .unwrap();
    let scene = Scene::load(s.path()).unwrap();
    assert_eq!(
        scene.materials[scene.triangles[0].material as usize].name,
        "grey"
    );
}
