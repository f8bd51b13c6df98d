//! `scene.toml`: syntax, light references, units, out-of-range numbers, scene-wide counts.

use relight::input_limits as limits;
use relight::scene::Scene;

use super::{load_err, TRI};
use crate::common::{self, *};

#[test]
fn unknown_light_reference_names_the_light() {
    let _gate = common::shared();
    let toml = "[[lights]]\nid = \"desk\"\nsurfaces = [\"lampshade\"]\n";
    let e = load_err(TRI, GREY_MTL, Some(toml));
    assert!(
        e.contains("scene.toml") && e.contains("desk") && e.contains("lampshade"),
        "{e}"
    );
}

#[test]
fn malformed_scene_toml_names_the_line() {
    let _gate = common::shared();
    let e = load_err(TRI, GREY_MTL, Some("name = \"x\"\n[mesh]\nmax_edg = 0.1\n"));
    assert!(e.contains("scene.toml") && e.contains("max_edg"), "{e}");
}

#[test]
fn millimetre_models_are_scaled_to_metres() {
    let _gate = common::shared();
    let s = write_scene(TRI, GREY_MTL, Some("units = \"mm\"\n"));
    let scene = Scene::load(s.path()).unwrap();
    let max_x = scene.triangles[0].p.iter().map(|p| p.x).fold(0.0, f64::max);
    assert!((max_x - 0.001).abs() < 1e-12, "{max_x}");
}

#[test]
fn huge_numbers_are_refused_not_turned_into_null() {
    let _gate = common::shared();
    // OBJ coordinates: finite in f32 and within ±1e5 m after scaling.
    for (v, needle) in [
        ("v 3e38 0 0", "within ±1e5 m"),
        ("v 1e39 0 0", "not a finite 32-bit number"),
        ("v 1e5 0 0.5e6", "within ±1e5 m"),
    ] {
        let e = load_err(
            &format!("o floor\nusemtl grey\n{v}\nv 1 0 0\nv 0 0 1\nf 1 3 2\n"),
            GREY_MTL,
            None,
        );
        assert!(e.contains("scene.obj:4") && e.contains(needle), "{v}: {e}");
    }
    // ... which also depends on the unit scale.
    let e = load_err(
        "o floor\nusemtl grey\nv 2e5 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n",
        GREY_MTL,
        Some("scale = 1.0\n"),
    );
    assert!(e.contains("scene.obj:4"), "{e}");
    let s = write_scene(
        "o floor\nusemtl grey\nv 2e5 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n",
        GREY_MTL,
        Some("units = \"mm\"\n"),
    );
    assert!(Scene::load(s.path()).is_ok(), "200 m in mm is fine");

    let lum = |extra: &str| format!("[[luminaires]]\nid = \"l\"\nposition = [0, 2, 0]\n{extra}\n");
    let cases: Vec<(String, &str)> = vec![
        (
            "[[lights]]\nid = \"a\"\nmaterials = [\"grey\"]\nlumens = 1e300\n".into(),
            "lumens = 1e300",
        ),
        (
            "[[lights]]\nid = \"a\"\nmaterials = [\"grey\"]\nintensity = 1e30\n".into(),
            "intensity",
        ),
        (
            "[[lights]]\nid = \"a\"\nmaterials = [\"grey\"]\ncolor = [1, inf, 1]\n".into(),
            "color",
        ),
        (lum("lumens = 1e300"), "lumens = 1e300"),
        (lum("lumens = nan"), "lumens = NaN"),
        (lum("lumens = 10\nwatts = 1e300"), "watts = 1e300"),
        (lum("lumens = 10\nefficacy = 1e9"), "efficacy"),
        (lum("lumens = 10\ncct = inf"), "cct = inf"),
        (
            lum("lumens = 10\ndistribution = \"spot\"\nbeam_deg = nan"),
            "beam_deg",
        ),
        (
            "[[luminaires]]\nid = \"l\"\nposition = [0, 3e38, 0]\nlumens = 1\n".into(),
            "outside ±1e5 m",
        ),
        (
            "[[cameras]]\nid = \"c\"\nposition = [0, 1e300, 0]\ntarget = [0, 0, 0]\nfov_deg = 60\n"
                .into(),
            "camera 'c'",
        ),
        (
            "[[grids]]\nid = \"g\"\nmin = [0, 0]\nmax = [1, 1]\nspacing = 1e-9\n".into(),
            "spacing = 1e-9",
        ),
        (
            "[[grids]]\nid = \"g\"\nmin = [-1e300, 0]\nmax = [1e300, 1]\n".into(),
            "outside ±1e5 m",
        ),
        (
            "[[grids]]\nid = \"g\"\nmin = [0, 0]\nmax = [1, 1]\nheight = nan\n".into(),
            "height",
        ),
        (
            "[[grids]]\nid = \"g\"\npoints = [[0, 1e300, 0]]\n".into(),
            "points",
        ),
        ("scale = 1e300\n".into(), "scale = 1e300"),
        ("scale = 0\n".into(), "scale = 0"),
        ("[mesh]\nmax_edge = 1e-9\n".into(), "max_edge = 1e-9"),
        ("[mesh]\nmax_edge = inf\n".into(), "max_edge = inf"),
        (
            "[mesh]\ntarget_patches = 1000000000\n".into(),
            "target_patches = 1000000000",
        ),
        ("[mesh]\ntarget_patches = 0\n".into(), "target_patches = 0"),
    ];
    for (toml, needle) in cases {
        let e = load_err(TRI, GREY_MTL, Some(&toml));
        assert!(
            e.contains("scene.toml") && e.contains(needle),
            "{toml}\n→ {e}"
        );
    }
}

#[test]
fn scene_wide_counts_are_bounded() {
    let _gate = common::shared();
    // Luminaires: each adds shadow rays to every patch and grid point.
    let mut toml = String::new();
    for i in 0..=limits::MAX_LUMINAIRES {
        toml += &format!("[[luminaires]]\nid = \"l{i}\"\nposition = [0, 2, 0]\nlumens = 1\n");
    }
    let e = load_err(TRI, GREY_MTL, Some(&toml));
    assert!(
        e.contains("1001 [[luminaires]] entries; the limit is 1000"),
        "{e}"
    );
    // Grid points over all grids.
    let grid = |i: usize| {
        format!("[[grids]]\nid = \"g{i}\"\nmin = [0, 0]\nmax = [14, 14]\nspacing = 0.1\n")
    };
    let e = load_err(TRI, GREY_MTL, Some(&(0..3).map(grid).collect::<String>()));
    assert!(e.contains("points in all; the limit is 50000"), "{e}");
    // Light groups: one per unclaimed emissive material counts too.
    let mut mtl = String::from(GREY_MTL);
    let mut obj = String::from(TRI);
    for i in 0..=limits::MAX_LIGHT_GROUPS {
        mtl += &format!("newmtl e{i}\nKe 1 1 1\n");
        obj += &format!("o lamp{i}\nusemtl e{i}\nf 1 3 2\n");
    }
    let e = load_err(&obj, &mtl, None);
    assert!(
        e.contains("1001 light groups") && e.contains("the limit is 1000"),
        "{e}"
    );
}
