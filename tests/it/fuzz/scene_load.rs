//! `Scene::load` end to end, on disk: the office with one of its files mutated.

use std::path::Path;

use proptest::prelude::*;
use relight::scene::Scene;

use super::ies::IES_LINES;
use super::mtl::MTL_LINES;
use super::mutate::{apply, op};
use super::obj::OBJ_LINES;
use super::scene_toml::TOML_LINES;
use super::{run, scenes};
use crate::common;

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
