//! The EULUMDAT reader, and evaluating the tables it accepts.

use proptest::prelude::*;
use relight::photometry::parse_ldt;

use super::mutate::input;
use super::{check_rejection, run};
use crate::common;

const LDT_LINES: &[&str] = &[
    "0", "1", "2", "3", "4", "5", "24", "15", "37", "5", "-1", "1e9", "85,5", "1200", "LED",
    "4000K", "0.5", "360", "180", "x",
];

/// The EULUMDAT files in `tests/data/photometry`.
fn ldt_seeds() -> Vec<Vec<u8>> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/photometry");
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ldt"))
        .collect();
    files.sort();
    files.iter().map(|f| std::fs::read(f).unwrap()).collect()
}

#[test]
fn ldt_reader_never_panics_and_names_file_and_line() {
    let _gate = common::shared();
    run("ldt", 20_000, input(ldt_seeds(), LDT_LINES), |bytes| {
        let text = String::from_utf8_lossy(&bytes);
        let path = "fuzz/x.ldt";
        match parse_ldt(path, &text, None) {
            Ok(d) => {
                prop_assert!(d
                    .candela
                    .iter()
                    .flatten()
                    .all(|c| c.is_finite() && *c >= 0.0));
                prop_assert!(!d.vertical.is_empty() && !d.horizontal.is_empty());
                for v in [-200.0, 0.0, 45.0, 90.0, 180.0, 400.0] {
                    for h in [-400.0, 0.0, 90.0, 180.0, 270.0, 359.0, 720.0] {
                        prop_assert!(d.candela_at(v, h).is_finite());
                    }
                }
                Ok(true)
            }
            Err(e) => check_rejection(path, &text, &e.into()).map(|_| false),
        }
    });
}
