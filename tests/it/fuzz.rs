//! Property tests (bounded fuzzing) of the scene readers: the OBJ line pass and tobj, the
//! MTL reader, `scene.toml`, IES files, and `Scene::load` end to end.
//!
//! Inputs are the bundled scenes' real files mutated at the byte, line and number level,
//! plus random garbage. Properties: no reader ever panics, and every rejection is a
//! `SceneError` whose message starts with the file's name (and whose line, when it has
//! one, lies within the file).
//!
//! The runs are deterministic (fixed seed) so CI is stable; set `RELIGHT_FUZZ_SEED` to
//! explore other inputs and `RELIGHT_FUZZ_SCALE` (a factor, default 1) to run more cases.
//! Each test prints its case count and time.

use std::path::{Path, PathBuf};
use std::time::Instant;

use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestCaseError, TestRunner};
use relight::photometry::parse_ies;
use relight::scene::{parse_mtl_str, parse_obj_str, parse_scene_toml, Scene, SceneError};

use crate::common;

/// Numbers that stress parsers and range checks.
const NUMBERS: &[&str] = &[
    "nan",
    "NaN",
    "inf",
    "-inf",
    "infinity",
    "1e39",
    "-1e39",
    "3.4028236e38",
    "3e38",
    "1e300",
    "-1e300",
    "1e-300",
    "1e-45",
    "0",
    "-0",
    "-1",
    "1",
    "2",
    "0.5",
    "0.99999994",
    "1.0",
    "1e5",
    "1e9",
    "1e18",
    "999999999999",
    "99999999999999999999",
    "-9223372036854775808",
    "9223372036854775807",
    "18446744073709551616",
    "4294967296",
    "2147483648",
    "0x10",
    "1_0",
    "+1",
    ".5",
    "5.",
    "1e",
    "e5",
    "",
    "-",
    "٣",
];

const OBJ_LINES: &[&str] = &[
    "v 0 0 0",
    "v 1 2 3 4",
    "v 1 2 3 0",
    "v 1 2 3 1 1 1",
    "v 1 2 3 1 1",
    "v",
    "vt 0 0",
    "vt 0",
    "vn 0 1 0",
    "f 1 2 3",
    "f -1 -2 -3",
    "f 1/1/1 2/2/2 3/3/3",
    "f 1//1 2//1 3//1",
    "f 1/1/1/1 2 3",
    "f 1 2",
    "f 0 1 2",
    "f 1 2 3 4 5 6 7",
    "f",
    "l 1 2",
    "l 1 2 3",
    "l",
    "p 1",
    "o x",
    "o",
    "g y z",
    "usemtl white",
    "usemtl light",
    "usemtl nosuch",
    "usemtl",
    "mtllib x.mtl",
    "mtllib",
    "s 1",
    "curv 0 1 1 2",
    "# comment",
    "  usemtl white",
    "\tf 1 2 3",
];

const MTL_LINES: &[&str] = &[
    "newmtl a",
    "newmtl white",
    "newmtl",
    "Kd 0.5",
    "Kd 0.5 0.5",
    "Kd 1 1 1",
    "Kd 0.2 0.3 0.4 # comment",
    "Ke 1e9 0 0",
    "Ke 1 1 1",
    "Ke -1",
    "Ke",
    "Ns abc",
    "Ns 10",
    "illum",
    "illum x",
    "map_Kd",
    "map_Kd tex.png",
    "kd 0 0 0",
    "KE 1 1 1",
    "Kd spectral x.spd",
    "Kd xyz 1 1 1",
    "Tf 1 1 1",
    "d 0.5",
    "foo bar",
    "# comment",
];

const TOML_LINES: &[&str] = &[
    "[mesh]",
    "max_edge = 1e-9",
    "max_edge = 0.1",
    "target_patches = 0",
    "target_patches = 100",
    "target_patches = -1",
    "[[lights]]",
    "id = \"x\"",
    "id = \"\"",
    "materials = [\"white\"]",
    "surfaces = [\"nosuch\"]",
    "lumens = 1e300",
    "lumens = 100",
    "intensity = nan",
    "color = [1, 1, inf]",
    "[[luminaires]]",
    "position = [0, 1, 0]",
    "position = [0, 1e300, 0]",
    "aim = [0, 0, 0]",
    "c0 = [0, -1, 0]",
    "distribution = \"spot\"",
    "distribution = \"ies\"",
    "ies = \"downlight.ies\"",
    "ies = \"../x.ies\"",
    "beam_deg = 200",
    "field_deg = 10",
    "cct = 1",
    "watts = -1",
    "efficacy = 0",
    "group = \"g\"",
    "[[grids]]",
    "spacing = 1e-9",
    "spacing = 0.5",
    "min = [0, 0]",
    "max = [1e300, 1]",
    "max = [1, 1]",
    "height = 0.75",
    "points = [[0, 0, 0], [1, 1, 1]]",
    "normal = [0, 0, 0]",
    "scale = 0",
    "scale = 1e-3",
    "units = \"furlong\"",
    "units = \"mm\"",
    "transfer = \"columns\"",
    "[[cameras]]",
    "target = [0, 0, 0]",
    "fov_deg = nan",
    "fov_deg = 60",
    "[surface.x]",
    "[material.white]",
    "two_sided = true",
    "name = \"n\"",
];

const IES_LINES: &[&str] = &[
    "TILT=NONE",
    "TILT=INCLUDE",
    "TILT=file.tlt",
    "IESNA:LM-63-2002",
    "[TEST] x",
    "1 1000 1 3 1 1 2 0.1 0.1 0",
    "1 -1 1 3 2 2 2 0 0 0",
    "1 1 20",
    "0 45 90",
    "-90 0 90",
    "0",
    "1000 707.1 0",
    "1e9",
    "-1",
    "1,2,3",
];

/// One mutation of a text file.
#[derive(Debug, Clone)]
enum Op {
    FlipByte(usize, u8),
    InsertBytes(usize, Vec<u8>),
    DeleteRange(usize, usize),
    Number(usize, usize),
    DuplicateLine(usize),
    DeleteLine(usize),
    SwapLines(usize, usize),
    InsertLine(usize, usize),
    Truncate(usize),
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(p, m)| Op::FlipByte(p, m)),
        (any::<usize>(), proptest::collection::vec(any::<u8>(), 1..8))
            .prop_map(|(p, b)| Op::InsertBytes(p, b)),
        (any::<usize>(), 1usize..16).prop_map(|(p, n)| Op::DeleteRange(p, n)),
        (any::<usize>(), any::<usize>()).prop_map(|(k, v)| Op::Number(k, v)),
        (any::<usize>(), any::<usize>()).prop_map(|(k, v)| Op::Number(k, v)),
        (any::<usize>(), any::<usize>()).prop_map(|(k, v)| Op::Number(k, v)),
        any::<usize>().prop_map(Op::DuplicateLine),
        any::<usize>().prop_map(Op::DeleteLine),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Op::SwapLines(a, b)),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Op::InsertLine(a, b)),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Op::InsertLine(a, b)),
        any::<usize>().prop_map(Op::Truncate),
    ]
}

/// Byte ranges of number-like tokens (digits with signs, dots and exponents).
fn number_spans(b: &[u8]) -> Vec<(usize, usize)> {
    let is_num = |c: u8| c.is_ascii_digit() || matches!(c, b'.' | b'-' | b'+' | b'e' | b'E');
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if is_num(b[i]) {
            let s = i;
            while i < b.len() && is_num(b[i]) {
                i += 1;
            }
            if b[s..i].iter().any(u8::is_ascii_digit) {
                out.push((s, i));
            }
        } else {
            i += 1;
        }
    }
    out
}

fn apply(mut b: Vec<u8>, ops: &[Op], lines: &[&str]) -> Vec<u8> {
    for op in ops {
        match op {
            Op::FlipByte(p, m) if !b.is_empty() => {
                let k = p % b.len();
                b[k] ^= m.max(&1);
            }
            Op::InsertBytes(p, bytes) => {
                let k = p % (b.len() + 1);
                b.splice(k..k, bytes.iter().copied());
            }
            Op::DeleteRange(p, n) if !b.is_empty() => {
                let k = p % b.len();
                let e = (k + n).min(b.len());
                b.drain(k..e);
            }
            Op::Number(k, v) => {
                let spans = number_spans(&b);
                if !spans.is_empty() {
                    let (s, e) = spans[k % spans.len()];
                    b.splice(s..e, NUMBERS[v % NUMBERS.len()].bytes());
                }
            }
            Op::DuplicateLine(k)
            | Op::DeleteLine(k)
            | Op::SwapLines(k, _)
            | Op::InsertLine(k, _) => {
                let mut ls: Vec<Vec<u8>> = b.split(|&c| c == b'\n').map(<[u8]>::to_vec).collect();
                let i = k % ls.len();
                match op {
                    Op::DuplicateLine(_) => {
                        let l = ls[i].clone();
                        ls.insert(i, l);
                    }
                    Op::DeleteLine(_) => {
                        ls.remove(i);
                    }
                    Op::SwapLines(_, j) => {
                        let j = j % ls.len();
                        ls.swap(i, j);
                    }
                    Op::InsertLine(_, w) => {
                        ls.insert(i, lines[w % lines.len()].as_bytes().to_vec())
                    }
                    _ => {}
                }
                b = ls.join(&b'\n');
            }
            Op::Truncate(p) if !b.is_empty() => {
                let k = p % b.len();
                b.truncate(k);
            }
            _ => {}
        }
    }
    b
}

/// A mutated seed, or random lines from the format's vocabulary, or random bytes.
fn input(seeds: Vec<Vec<u8>>, lines: &'static [&'static str]) -> impl Strategy<Value = Vec<u8>> {
    let n = seeds.len();
    prop_oneof![
        6 => (0..n, proptest::collection::vec(op(), 1..6))
            .prop_map(move |(i, ops)| apply(seeds[i].clone(), &ops, lines)),
        2 => proptest::collection::vec((0..lines.len(), 0..NUMBERS.len(), any::<bool>()), 0..40)
            .prop_map(move |ls| {
                ls.iter()
                    .map(|&(l, n, sub)| {
                        if sub {
                            String::from_utf8_lossy(&apply(
                                lines[l].as_bytes().to_vec(),
                                &[Op::Number(n, n)],
                                lines,
                            ))
                            .into_owned()
                        } else {
                            lines[l].to_string()
                        }
                    })
                    .collect::<Vec<_>>()
                    .join("\n")
                    .into_bytes()
            }),
        1 => proptest::collection::vec(any::<u8>(), 0..400),
    ]
}

fn scenes() -> PathBuf {
    common::scenes_dir()
}

/// Every bundled scene file with this extension (and, for TOML, name).
fn seeds(ext: &str) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    let mut dirs: Vec<_> = std::fs::read_dir(scenes())
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    dirs.sort();
    for d in dirs {
        let mut files: Vec<_> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == ext))
            .collect();
        files.sort();
        for f in files {
            out.push(std::fs::read(f).unwrap());
        }
    }
    assert!(!out.is_empty(), "no .{ext} seeds");
    out
}

fn seed() -> u64 {
    std::env::var("RELIGHT_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0x5EED_2026)
}

fn runner(cases: u32) -> TestRunner {
    let scale: f64 = std::env::var("RELIGHT_FUZZ_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0);
    TestRunner::new(Config {
        cases: ((cases as f64 * scale).round() as u32).max(1),
        failure_persistence: None,
        rng_seed: RngSeed::Fixed(seed()),
        max_shrink_iters: 2000,
        ..Config::default()
    })
}

/// The line of an error, for the variants that have one.
fn line_of(e: &SceneError) -> Option<usize> {
    match e {
        SceneError::Syntax { line, .. }
        | SceneError::Reference { line, .. }
        | SceneError::UnknownMaterial { line, .. }
        | SceneError::BadMaterial { line, .. } => Some(*line),
        _ => None,
    }
}

/// A rejection must name the file first and, when it has a line, a line of the file.
fn check_rejection(path: &str, text: &str, e: &SceneError) -> Result<(), TestCaseError> {
    let m = e.to_string();
    prop_assert!(m.starts_with(path), "message does not name {path}: {m}");
    if let Some(line) = line_of(e) {
        let lines = text.lines().count().max(1);
        prop_assert!(
            line >= 1 && line <= lines + 1,
            "line {line} outside 1..={lines}: {m}"
        );
        prop_assert!(m.starts_with(&format!("{path}:{line}: ")), "{m}");
    }
    Ok(())
}

/// Runs `cases` cases of `strategy` through `test` (which says whether the input was
/// accepted), printing the counts and time.
fn run<S: Strategy>(
    name: &str,
    cases: u32,
    strategy: S,
    test: impl Fn(S::Value) -> Result<bool, TestCaseError>,
) {
    use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};
    let mut r = runner(cases);
    let n = r.config().cases;
    let accepted = AtomicUsize::new(0);
    let total = AtomicUsize::new(0);
    let t0 = Instant::now();
    let result = r.run(&strategy, |v| {
        let ok = test(v)?;
        total.fetch_add(1, Relaxed);
        accepted.fetch_add(usize::from(ok), Relaxed);
        Ok(())
    });
    println!(
        "fuzz {name}: {n} cases ({} accepted, {} rejected) in {:.2} s (seed {})",
        accepted.load(Relaxed),
        total.load(Relaxed) - accepted.load(Relaxed),
        t0.elapsed().as_secs_f64(),
        seed()
    );
    if let Err(e) = result {
        panic!("{name}: {e}");
    }
}

#[test]
fn obj_reader_never_panics_and_names_file_and_line() {
    let _gate = common::shared();
    let materials: Vec<String> = ["white", "red", "green", "light", "wall", "floor", "lamp"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    run(
        "obj (line pass + tobj)",
        20_000,
        (
            input(seeds("obj"), OBJ_LINES),
            prop_oneof![Just(1.0), Just(0.001), Just(1e-6)],
        ),
        |(bytes, scale)| {
            let text = String::from_utf8_lossy(&bytes);
            let path = "fuzz/scene.obj";
            match parse_obj_str(path, &text, scale, &materials) {
                Ok((_, parts)) => {
                    for p in parts {
                        prop_assert!(p.positions.iter().all(|c| c.is_finite()));
                        prop_assert!(p
                            .positions
                            .iter()
                            .all(|&c| (c as f64 * scale).abs() <= relight::limits::MAX_COORD_M));
                        prop_assert!(p
                            .indices
                            .iter()
                            .all(|&k| (k as usize) < p.positions.len() / 3));
                    }
                    Ok(true)
                }
                Err(e) => check_rejection(path, &text, &e).map(|_| false),
            }
        },
    );
}

#[test]
fn mtl_reader_never_panics_and_names_file_and_line() {
    let _gate = common::shared();
    run("mtl", 20_000, input(seeds("mtl"), MTL_LINES), |bytes| {
        let text = String::from_utf8_lossy(&bytes);
        let path = "fuzz/scene.mtl";
        match parse_mtl_str(path, &text) {
            Ok(lib) => {
                for m in lib.materials {
                    prop_assert!(m.kd.iter().all(|&x| (0.0..1.0).contains(&x)), "{m:?}");
                    prop_assert!(m.ke.iter().all(|&x| x.is_finite() && x >= 0.0), "{m:?}");
                    prop_assert!(!m.name.is_empty());
                }
                Ok(true)
            }
            Err(e) => check_rejection(path, &text, &e).map(|_| false),
        }
    });
}

#[test]
fn scene_toml_reader_never_panics_and_names_the_file() {
    let _gate = common::shared();
    run(
        "scene.toml",
        20_000,
        input(seeds("toml"), TOML_LINES),
        |bytes| {
            let text = String::from_utf8_lossy(&bytes);
            let path = "fuzz/scene.toml";
            match parse_scene_toml(path, &text) {
                Ok(_) => Ok(true),
                Err(e) => check_rejection(path, &text, &e).map(|_| false),
            }
        },
    );
}

#[test]
fn ies_reader_never_panics_and_names_file_and_line() {
    let _gate = common::shared();
    run("ies", 20_000, input(seeds("ies"), IES_LINES), |bytes| {
        let text = String::from_utf8_lossy(&bytes);
        let path = "fuzz/x.ies";
        match parse_ies(path, &text) {
            Ok(d) => {
                prop_assert!(d
                    .candela
                    .iter()
                    .flatten()
                    .all(|c| c.is_finite() && *c >= 0.0));
                prop_assert!(!d.vertical.is_empty() && !d.horizontal.is_empty());
                // Evaluating the table anywhere must not panic either.
                for v in [-200.0, -90.0, 0.0, 45.0, 90.0, 180.0, 400.0] {
                    for h in [-400.0, -90.0, 0.0, 90.0, 180.0, 270.0, 359.0, 720.0] {
                        prop_assert!(d.candela_at(v, h).is_finite());
                    }
                }
                Ok(true)
            }
            Err(e) => check_rejection(path, &text, &e).map(|_| false),
        }
    });
}

/// Copies a bundled scene into a fresh folder, replacing one file's bytes.
fn scene_with(src: &Path, replace: &str, bytes: &[u8]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for e in std::fs::read_dir(src).unwrap() {
        let p = e.unwrap().path();
        std::fs::copy(&p, dir.path().join(p.file_name().unwrap())).unwrap();
    }
    std::fs::write(dir.path().join(replace), bytes).unwrap();
    dir
}

#[test]
fn scene_load_never_panics_and_names_the_scene() {
    let _gate = common::shared();
    // End to end, on disk: the office (OBJ, MTL, scene.toml with luminaires and grids, IES).
    let office = scenes().join("office");
    let files = ["office.obj", "office.mtl", "scene.toml", "downlight.ies"];
    let vocab: [&'static [&'static str]; 4] = [OBJ_LINES, MTL_LINES, TOML_LINES, IES_LINES];
    let seeds: Vec<Vec<u8>> = files
        .iter()
        .map(|f| std::fs::read(office.join(f)).unwrap())
        .collect();
    run(
        "Scene::load (office, one file mutated)",
        400,
        (0..4usize, proptest::collection::vec(op(), 1..5)),
        |(k, ops)| {
            let bytes = apply(seeds[k].clone(), &ops, vocab[k]);
            let dir = scene_with(&office, files[k], &bytes);
            let id = dir
                .path()
                .file_name()
                .unwrap()
                .to_string_lossy()
                .into_owned();
            match Scene::load(dir.path()) {
                Ok(_) => Ok(true),
                Err(e) => {
                    let m = e.to_string();
                    prop_assert!(
                        m.starts_with(&format!("{id}/")) || m.starts_with(&format!("{id}:")),
                        "{m}"
                    );
                    prop_assert!(!m.contains("/tmp"), "absolute path: {m}");
                    Ok(false)
                }
            }
        },
    );
}
