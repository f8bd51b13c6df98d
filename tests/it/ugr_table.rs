//! `relight ugr-table`: the CIE 190 standard UGR table against an independent
//! implementation. The reference tables in `tests/data/ugr/*.eulumdat-ugr.json` were
//! written by `eulumdat-ugr` (PyPI, MIT) through `tests/data/ugr/make_reference.py`; this
//! test needs no Python.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::common;

/// Largest difference allowed from the reference, UGR units (the target is 0.5).
const TOLERANCE: f64 = 0.5;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/ugr")
        .join(name)
}

fn relight(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_relight"))
        .arg("ugr-table")
        .args(args)
        .output()
        .unwrap()
}

/// relight's table (`[room][crosswise 5, endwise 5]`) for `file` at `spacing` H.
fn table(file: &Path, spacing: &str) -> (Vec<Vec<f64>>, serde_json::Value) {
    let out = relight(&[
        file.to_str().unwrap(),
        "--format",
        "json",
        "--spacing",
        spacing,
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = v["rooms"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            r["crosswise"]
                .as_array()
                .unwrap()
                .iter()
                .chain(r["endwise"].as_array().unwrap())
                .map(|c| c.as_f64().expect("every standard cell has a value"))
                .collect()
        })
        .collect();
    (rows, v)
}

fn reference(stem: &str, key: &str) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(data(&format!("{stem}.eulumdat-ugr.json"))).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    serde_json::from_value(v[key].clone()).unwrap()
}

/// The largest |relight − reference| over the table, with its room and column.
fn max_difference(ours: &[Vec<f64>], theirs: &[Vec<f64>]) -> (f64, usize, usize) {
    assert_eq!(ours.len(), 19);
    assert_eq!(theirs.len(), 19);
    let mut worst = (0.0, 0, 0);
    for (i, (a, b)) in ours.iter().zip(theirs).enumerate() {
        assert_eq!(a.len(), 10);
        for (j, (x, y)) in a.iter().zip(b).enumerate() {
            if (x - y).abs() > worst.0 {
                worst = ((x - y).abs(), i, j);
            }
        }
    }
    worst
}

#[test]
fn tables_agree_with_eulumdat_ugr() {
    let _gate = common::shared();
    for (file, stem) in [
        ("lambertian-disk.ldt", "lambertian-disk"),
        ("linear-panel.ldt", "linear-panel"),
        // The IES twin of the panel reads into the same distribution.
        ("linear-panel.ies", "linear-panel"),
    ] {
        for (spacing, key) in [("1", "spacing_1"), ("0.25", "spacing_0.25")] {
            let (ours, _) = table(&data(file), spacing);
            let (d, room, col) = max_difference(&ours, &reference(stem, key));
            assert!(
                d <= TOLERANCE,
                "{file} at {spacing} H: room #{room} column #{col} differs by {d:.2}"
            );
        }
    }
}

#[test]
fn the_json_names_its_conditions_and_the_text_is_the_catalogue_layout() {
    let _gate = common::shared();
    let (rows, v) = table(&data("linear-panel.ldt"), "1");
    assert_eq!(v["standard"], "CIE 190:2010");
    assert!((v["lamp_lumens"].as_f64().unwrap() - 3600.0).abs() < 1e-6);
    // LOR 80 %: the file's intensities integrate to 2880 lm.
    let lum = v["luminaire_lumens"].as_f64().unwrap();
    assert!((lum / 2880.0 - 1.0).abs() < 0.01, "{lum}");
    let summand = v["correction_summand"].as_f64().unwrap();
    assert!((summand - 8.0 * 3.6f64.log10()).abs() < 1e-9);
    assert_eq!(v["rooms"][10]["x"], 4.0);
    assert_eq!(v["rooms"][10]["y"], 8.0);
    // The linear panel is narrower across: endwise glares more.
    assert!(rows[10][5] > rows[10][0]);

    let out = relight(&[data("linear-panel.ldt").to_str().unwrap()]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("linear-panel.ldt"), "{text}");
    assert!(text.contains("Viewed crosswise") && text.contains("Viewed endwise"));
    assert!(text.contains("1000 lm"), "{text}");
    // The 4H × 8H row carries the JSON's values, to one decimal.
    let lines: Vec<&str> = text.lines().collect();
    let head = lines.iter().position(|l| l.trim() == "X     Y").unwrap();
    assert_eq!(lines.len(), head + 20, "{text}");
    assert!(
        lines[head + 1].trim_start().starts_with("2H    2H"),
        "{text}"
    );
    let row = lines[head + 11];
    assert!(row.trim_start().starts_with("8H"), "{row}");
    let shown: Vec<&str> = row.split_whitespace().filter(|c| *c != "|").collect();
    assert_eq!(shown[1], format!("{:.1}", rows[10][0]), "{row}");

    let out = relight(&[
        data("linear-panel.ldt").to_str().unwrap(),
        "--format",
        "csv",
        "--lumens",
        "7200",
    ]);
    assert!(out.status.success());
    let csv = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 20, "{csv}");
    assert!(lines[0].starts_with("x_h,y_h,crosswise 70/50/20"));
    // Twice the flux: every cell 8 log10 2 higher.
    let cells: Vec<f64> = lines[11]
        .split(',')
        .skip(2)
        .map(|c| c.parse().unwrap())
        .collect();
    for (c, r) in cells.iter().zip(&rows[10]) {
        assert!((c - r - 8.0 * 2f64.log10()).abs() < 0.006, "{c} vs {r}");
    }
}

#[test]
fn bad_files_are_clear_errors() {
    let _gate = common::shared();
    let dir = tempfile::tempdir().unwrap();
    let garbage = dir.path().join("broken.ldt");
    std::fs::write(&garbage, "not\na\nEULUMDAT file\n").unwrap();
    let point = dir.path().join("point.ies");
    std::fs::write(
        &point,
        "IESNA:LM-63-2002\nTILT=NONE\n1 1000 1 3 1 1 2 0 0 0\n1 1 10\n0 45 90\n0\n300 200 0\n",
    )
    .unwrap();
    let other = dir.path().join("table.txt");
    std::fs::write(&other, "x").unwrap();
    for (path, needle) in [
        (dir.path().join("missing.ldt"), "missing.ldt"),
        (garbage, "broken.ldt:"),
        (point, "luminous area"),
        (other, ".ies"),
    ] {
        let out = relight(&[path.to_str().unwrap()]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{}", path.display());
        assert!(err.contains(needle), "{}: {err}", path.display());
        assert!(!err.contains("panicked"), "{err}");
    }
    let out = relight(&[data("linear-panel.ldt").to_str().unwrap(), "--lumens", "-3"]);
    assert!(!out.status.success());
}
