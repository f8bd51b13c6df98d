//! Luminaires and grids in `scene.toml`, and the IES files luminaires read.

use relight::scene::Scene;

use super::{load_err, TRI};
use crate::common::{self, *};

#[test]
fn bad_luminaires_and_grids_get_precise_errors() {
    let _gate = common::shared();
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
            "names no materials or surfaces, and no luminaire or model light joins it",
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

#[test]
fn ies_values_and_counts_are_bounded() {
    let _gate = common::shared();
    let ies = |header: &str, rest: &str| format!("IESNA:LM-63-2002\nTILT=NONE\n{header}\n{rest}");
    let ok_rest = "1 1 20\n0 45 90\n0\n1000 707.1 0\n";
    let cases = [
        (
            ies("1 1000 1 1000000000 1 1 2 0.1 0.1 0", ok_rest),
            "number of vertical angles = 1000000000",
            3,
        ),
        (
            ies("1 1000 1 2000 2000 1 2 0.1 0.1 0", ok_rest),
            "candela values; the limit is",
            3,
        ),
        (
            ies("1 1000 1e300 3 1 1 2 0.1 0.1 0", ok_rest),
            "candela multiplier",
            3,
        ),
        (
            ies(
                "1 1000 1 3 1 1 2 0.1 0.1 0",
                "1 1 20\n0 45 90\n0\n1e300 707.1 0\n",
            ),
            "candela value",
            7,
        ),
        (
            ies(
                "1 1000 1 3 1 1 2 0.1 0.1 0",
                "1 1 20\n0 45 45\n0\n1000 707.1 0\n",
            ),
            "must increase",
            5,
        ),
        (
            ies("1 1000 1 3.5 1 1 2 0.1 0.1 0", ok_rest),
            "whole number",
            3,
        ),
        (
            ies(
                "1 1000 1 3 1 1 2 0.1 0.1 0",
                "1 1 20\n0 45 90\n0\n1000 -1 0\n",
            ),
            "candela values = -1",
            7,
        ),
        (
            "TILT=INCLUDE\n1\n1e18\n".to_string(),
            "TILT pair count = 1e18",
            3,
        ),
    ];
    for (text, needle, line) in cases {
        let e = relight::photometry::parse_ies("office/x.ies", &text)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with(&format!("office/x.ies:{line}: ")) && e.contains(needle),
            "{needle}: {e}"
        );
    }
    let good = ies("1 1000 1 3 1 1 2 0.1 0.1 0", ok_rest);
    assert!(relight::photometry::parse_ies("x.ies", &good).is_ok());
}
