//! The OBJ reader (the line pass and tobj).

use proptest::prelude::*;
use relight::scene::parse_obj_str;

use super::mutate::input;
use super::{check_rejection, run, seeds};
use crate::common;

pub(super) const OBJ_LINES: &[&str] = &[
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
                        prop_assert!(p.positions.iter().all(
                            |&c| (c as f64 * scale).abs() <= relight::input_limits::MAX_COORD_M
                        ));
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
