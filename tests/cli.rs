//! The command line, run as a user would.

mod common;

use std::process::Command;

use common::*;

fn relight() -> Command {
    Command::new(env!("CARGO_BIN_EXE_relight"))
}

#[test]
fn radiosity_json_on_a_bare_obj_and_mtl_folder() {
    let obj = box_faces("room", "wall", [0., 0., 0.], [2., 2., 2.], true)
        + &quad(
            "lamp",
            "glow",
            [
                [0.8, 1.99, 0.8],
                [1.2, 1.99, 0.8],
                [1.2, 1.99, 1.2],
                [0.8, 1.99, 1.2],
            ],
            [0., -1., 0.],
        );
    let s = write_scene(
        &obj,
        "newmtl wall\nKd 0.5 0.5 0.5\nnewmtl glow\nKd 0 0 0\nKe 100 100 100\n",
        None,
    );
    let cache = tempfile::tempdir().unwrap();
    let out = relight()
        .args([
            "radiosity",
            s.path().to_str().unwrap(),
            "--json",
            "--light",
            "glow=0.5",
            "--cache",
        ])
        .arg(cache.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let floor = &v["surfaces"]["room-y"];
    assert!((floor["area"].as_f64().unwrap() - 4.0).abs() < 1e-6);
    assert!(floor["radiosity"][0].as_f64().unwrap() > 0.0);
    assert!(floor["illuminance"][2].as_f64().unwrap() > 0.0);
    // Half intensity: 0.5 × 100 lm/m² × 0.16 m² = 8 lm emitted, closed room absorbs it.
    let p = &v["power"];
    assert!(
        (p["emitted_lm"].as_f64().unwrap() - 8.0).abs() < 1e-3,
        "{p}"
    );
    assert!(
        (p["absorbed_lm"].as_f64().unwrap() / 8.0 - 1.0).abs() < 0.005,
        "{p}"
    );
}

#[test]
fn bad_input_is_a_clear_error_not_a_panic() {
    let out = relight()
        .args(["radiosity", "/nonexistent/scene"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("error:") && err.contains("/nonexistent/scene"),
        "{err}"
    );
    assert!(!err.contains("panicked"));

    let s = write_scene(
        "o t\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n",
        GREY_MTL,
        None,
    );
    let out = relight()
        .args([
            "radiosity",
            s.path().to_str().unwrap(),
            "--light",
            "nosuch=1",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("unknown light group 'nosuch'"),
        "{err}"
    );
}

#[test]
fn info_lists_the_bundled_scenes() {
    let out = relight()
        .args(["info", "--scenes"])
        .arg(scenes_dir())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success());
    assert!(
        text.contains("cornell-box") && text.contains("desk-room"),
        "{text}"
    );
    assert!(text.contains("ceiling") && text.contains("lamp"));
}
