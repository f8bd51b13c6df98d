//! Broken scenes give clear errors that name the file and line or object; none panics.
//!
//! A module per kind of error; this file holds the helpers. The tests named after a finding
//! are hardening regressions, each named after the finding it guards.

mod files;
mod luminaires;
mod mtl;
mod obj;
mod scene_toml;

use relight::scene::Scene;

use crate::common::{write_scene, TempScene};

fn load_err(obj: &str, mtl: &str, toml: Option<&str>) -> String {
    let s = write_scene(obj, mtl, toml);
    match Scene::load(s.path()) {
        Ok(_) => panic!("scene should not load"),
        Err(e) => e.to_string(),
    }
}

const TRI: &str = "o floor\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n";

/// The scene's id as errors show it (the temporary folder's name).
fn id_of(s: &TempScene) -> String {
    s.path().file_name().unwrap().to_string_lossy().into_owned()
}

/// Asserts that an error names files relative to the scene folder, never absolutely.
fn assert_relative(e: &str, s: &TempScene) {
    let abs = s.path().to_string_lossy().into_owned();
    let canon = std::fs::canonicalize(s.path())
        .unwrap()
        .to_string_lossy()
        .into_owned();
    assert!(
        !e.contains(&abs) && !e.contains(&canon) && !e.contains("/tmp/"),
        "absolute path in: {e}"
    );
}

fn with_obj_line(s: &TempScene, from: &str, to: &str) {
    let p = s.path().join("scene.obj");
    let obj = std::fs::read_to_string(&p).unwrap();
    std::fs::write(&p, obj.replace(from, to)).unwrap();
}
