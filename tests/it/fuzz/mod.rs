//! Property tests (bounded fuzzing) of the scene readers: the runner and shared checks.
//!
//! A module per reader: the OBJ line pass and tobj, the MTL reader, `scene.toml`, IES and
//! EULUMDAT files, and `Scene::load` end to end; `mutate` makes the inputs.
//!
//! Inputs are the bundled scenes' real files mutated at the byte, line and number level,
//! plus random garbage. Properties: no reader ever panics, and every rejection is a
//! `SceneError` whose message starts with the file's name (and whose line, when it has
//! one, lies within the file).
//!
//! The runs are deterministic (fixed seed) so CI is stable; set `RELIGHT_FUZZ_SEED` to
//! explore other inputs and `RELIGHT_FUZZ_SCALE` (a factor, default 1) to run more cases.
//! Each test prints its case count and time.

mod gltf;
mod ies;
mod ldt;
mod mtl;
mod mutate;
mod obj;
mod scene_load;
mod scene_toml;

use std::path::PathBuf;
use std::time::Instant;

use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestCaseError, TestRunner};
use relight::scene::SceneError;

use crate::common;

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
