//! The IES reader, and evaluating the tables it accepts.

use proptest::prelude::*;
use relight::photometry::parse_ies;

use super::mutate::input;
use super::{check_rejection, run, seeds};
use crate::common;

pub(super) const IES_LINES: &[&str] = &[
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
            Err(e) => check_rejection(path, &text, &e.into()).map(|_| false),
        }
    });
}
