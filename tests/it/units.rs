//! Units that make sense: a model whose size is implausible in metres loads with a warning
//! that suggests the `units` (or `scale`) to set, unless `scene.toml` sets either; the
//! scene's bounds, in metres, in `relight info` and `GET /api/scenes/{id}`.

use relight::scene::Scene;

use crate::common::{self, box_faces, write_scene};

const MTL: &str = "newmtl wall\nKd 0.5 0.5 0.5\n";

/// A 6 × 3 × 4 m room, in millimetres.
fn room_mm() -> String {
    box_faces("room", "wall", [0., 0., 0.], [6000., 3000., 4000.], true)
}

fn units_warnings(s: &Scene) -> Vec<&String> {
    s.warnings
        .iter()
        .filter(|w| w.contains("no units or scale"))
        .collect()
}

#[test]
fn a_room_in_millimetres_suggests_units_mm() {
    let _gate = common::shared();
    let t = write_scene(&room_mm(), MTL, None);
    let s = Scene::load(t.path()).unwrap();
    let w = units_warnings(&s);
    assert_eq!(w.len(), 1, "{:?}", s.warnings);
    assert!(
        w[0].contains("scene.obj")
            && w[0].contains("6000 m across")
            && w[0].contains("units = \"mm\"")
            && w[0].contains("then 6 m across"),
        "{}",
        w[0]
    );
    // Read as asked: metres, 6 km wide.
    let (lo, hi) = s.bounds();
    assert_eq!((hi - lo).to_array(), [6000., 3000., 4000.]);
    // strict = true does not make the hint an error: nothing was fixed.
    let t = write_scene(&room_mm(), MTL, Some("strict = true\n"));
    let s = Scene::load(t.path()).unwrap();
    assert_eq!(units_warnings(&s).len(), 1, "{:?}", s.warnings);
}

#[test]
fn units_or_scale_set_silence_the_hint_and_bounds_are_metres() {
    let _gate = common::shared();
    for toml in ["units = \"mm\"\n", "scale = 0.001\n"] {
        let t = write_scene(&room_mm(), MTL, Some(toml));
        let s = Scene::load(t.path()).unwrap();
        assert!(s.warnings.is_empty(), "{toml}: {:?}", s.warnings);
        let (lo, hi) = s.bounds();
        assert!(lo.abs().max_element() < 1e-12, "{toml}: {lo}");
        assert!(
            (hi - glam::DVec3::new(6.0, 3.0, 4.0)).abs().max_element() < 1e-9,
            "{toml}: {hi}"
        );
    }
    // The user chose: even an implausible setting is not second-guessed.
    let t = write_scene(&room_mm(), MTL, Some("units = \"m\"\n"));
    let s = Scene::load(t.path()).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn a_room_converted_to_metres_twice_suggests_a_scale() {
    let _gate = common::shared();
    // A 6 m room divided by 100 once too often: 6 cm.
    let obj = box_faces("room", "wall", [0., 0., 0.], [0.06, 0.03, 0.04], true);
    let t = write_scene(&obj, MTL, None);
    let s = Scene::load(t.path()).unwrap();
    let w = units_warnings(&s);
    assert_eq!(w.len(), 1, "{:?}", s.warnings);
    assert!(
        w[0].contains("only 0.06 m across") && w[0].contains("scale = 100 "),
        "{}",
        w[0]
    );
    // A plausible room in metres gets no hint.
    let obj = box_faces("room", "wall", [0., 0., 0.], [6., 3., 4.], true);
    let s = Scene::load(write_scene(&obj, MTL, None).path()).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn info_prints_bounds_in_metres_and_the_hint() {
    let _gate = common::shared();
    let root = tempfile::tempdir().unwrap();
    for (id, toml) in [("mm-bare", None), ("mm-set", Some("units = \"mm\"\n"))] {
        let d = root.path().join(id);
        std::fs::create_dir(&d).unwrap();
        std::fs::write(
            d.join("room.obj"),
            format!("mtllib room.mtl\n{}", room_mm()),
        )
        .unwrap();
        std::fs::write(d.join("room.mtl"), MTL).unwrap();
        if let Some(t) = toml {
            std::fs::write(d.join("scene.toml"), t).unwrap();
        }
    }
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_relight"))
        .args(["info", "--scenes"])
        .arg(root.path())
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    // A scene's lines: its own, then the indented ones under it.
    let block = |id: &str| -> String {
        let mut lines = text.lines().skip_while(|l| !l.starts_with(id));
        let first = lines
            .next()
            .unwrap_or_else(|| panic!("{id} missing: {text}"));
        let rest: Vec<&str> = lines.take_while(|l| l.starts_with(' ')).collect();
        format!("{first}\n{}", rest.join("\n"))
    };
    let bare = block("mm-bare");
    assert!(
        bare.contains("bounds (m) min [0.000, 0.000, 0.000] max [6000.000, 3000.000, 4000.000]")
            && bare.contains("size 6000.000 x 3000.000 x 4000.000 m")
            && bare.contains("warning:")
            && bare.contains("units = \"mm\""),
        "{text}"
    );
    let set = block("mm-set");
    assert!(
        set.contains("max [6.000, 3.000, 4.000]")
            && set.contains("size 6.000 x 3.000 x 4.000 m")
            && set.contains("units mm (0.001 m)")
            && !set.contains("warning:"),
        "{text}"
    );
}
