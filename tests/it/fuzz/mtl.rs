//! The MTL reader.

use proptest::prelude::*;
use relight::scene::parse_mtl_str;

use super::mutate::input;
use super::{check_rejection, run, seeds};
use crate::common;

pub(super) const MTL_LINES: &[&str] = &[
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
