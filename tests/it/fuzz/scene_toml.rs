//! The `scene.toml` reader.

use relight::scene::parse_scene_toml;

use super::mutate::input;
use super::{check_rejection, run, seeds};
use crate::common;

pub(super) const TOML_LINES: &[&str] = &[
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
