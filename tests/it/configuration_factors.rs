//! Form factors against closed-form configuration factors (Howell's catalog), reciprocity,
//! row sums in closed rooms, and exact occlusion.

use std::f64::consts::PI;

use crate::common::{self, *};

/// Howell C-11: directly opposed parallel rectangles a × b at distance c.
fn parallel_rectangles(a: f64, b: f64, c: f64) -> f64 {
    let (x, y) = (a / c, b / c);
    let (x2, y2) = (x * x, y * y);
    2.0 / (PI * x * y)
        * ((((1.0 + x2) * (1.0 + y2)) / (1.0 + x2 + y2)).sqrt().ln()
            + x * (1.0 + y2).sqrt() * (x / (1.0 + y2).sqrt()).atan()
            + y * (1.0 + x2).sqrt() * (y / (1.0 + x2).sqrt()).atan()
            - x * x.atan()
            - y * y.atan())
}

/// Howell C-14: rectangles with a common edge of length l at 90°, from the one of width w
/// to the one of height h.
fn perpendicular_rectangles(l: f64, w: f64, h: f64) -> f64 {
    let (hh, ww) = (h / l, w / l);
    let (h2, w2) = (hh * hh, ww * ww);
    let s = (h2 + w2).sqrt();
    let log_term = ((1.0 + w2) * (1.0 + h2) / (1.0 + w2 + h2)).ln()
        + w2 * (w2 * (1.0 + w2 + h2) / ((1.0 + w2) * (w2 + h2))).ln()
        + h2 * (h2 * (1.0 + h2 + w2) / ((1.0 + h2) * (h2 + w2))).ln();
    (1.0 / (PI * ww))
        * (ww * (1.0 / ww).atan() + hh * (1.0 / hh).atan() - s * (1.0 / s).atan() + 0.25 * log_term)
}

/// Coaxial parallel disks of radii r1 → r2 at distance h.
fn coaxial_disks(r1: f64, r2: f64, h: f64) -> f64 {
    let (a, b) = (r1 / h, r2 / h);
    let x = 1.0 + (1.0 + b * b) / (a * a);
    0.5 * (x - (x * x - 4.0 * (b / a).powi(2)).sqrt())
}

fn assert_rel(got: f64, want: f64, tol: f64, what: &str) {
    let rel = (got - want) / want;
    eprintln!("{what}: {got:.6} vs {want:.6} ({rel:+.5})");
    assert!(
        rel.abs() <= tol,
        "{what}: got {got:.6}, closed form {want:.6}, rel. error {rel:+.4}"
    );
}

#[test]
fn closed_forms_are_what_the_literature_says() {
    let _gate = common::shared();
    // Guards the formulas themselves: the unit-cube values quoted in the literature.
    assert!((perpendicular_rectangles(1.0, 1.0, 1.0) - 0.200044).abs() < 1e-6);
    assert!((parallel_rectangles(1.0, 1.0, 1.0) - 0.199825).abs() < 1e-6);
}

#[test]
fn howell_c11_parallel_rectangles() {
    let _gate = common::shared();
    let obj = quad(
        "bottom",
        "grey",
        [[0., 0., 0.], [1., 0., 0.], [1., 0., 2.], [0., 0., 2.]],
        [0., 1., 0.],
    ) + &quad(
        "top",
        "grey",
        [[0., 1., 0.], [1., 1., 0.], [1., 1., 2.], [0., 1., 2.]],
        [0., -1., 0.],
    );
    let s = write_scene(&obj, GREY_MTL, None);
    let sol = form_factors(s.path());
    let want = parallel_rectangles(1.0, 2.0, 1.0);
    assert_rel(
        sol.surface_factor("bottom", "top"),
        want,
        0.01,
        "C-11 bottom→top",
    );
    assert_rel(
        sol.surface_factor("top", "bottom"),
        want,
        0.01,
        "C-11 top→bottom",
    );
}

#[test]
fn howell_c14_perpendicular_rectangles_with_common_edge() {
    let _gate = common::shared();
    // Common edge along z (length 1); horizontal width 1.5, vertical height 0.8.
    let obj = quad(
        "horizontal",
        "grey",
        [[0., 0., 0.], [1.5, 0., 0.], [1.5, 0., 1.], [0., 0., 1.]],
        [0., 1., 0.],
    ) + &quad(
        "vertical",
        "grey",
        [[0., 0., 0.], [0., 0.8, 0.], [0., 0.8, 1.], [0., 0., 1.]],
        [1., 0., 0.],
    );
    let s = write_scene(&obj, GREY_MTL, None);
    let sol = form_factors(s.path());
    let want = perpendicular_rectangles(1.0, 1.5, 0.8);
    assert_rel(
        sol.surface_factor("horizontal", "vertical"),
        want,
        0.01,
        "C-14 h→v",
    );
    // And the other way, by reciprocity of the closed form.
    let want_back = want * 1.5 / 0.8;
    assert_rel(
        sol.surface_factor("vertical", "horizontal"),
        want_back,
        0.01,
        "C-14 v→h",
    );
}

fn disk(name: &str, r: f64, y: f64, up: bool, segments: usize) -> String {
    // A fan around a centre vertex, fronts facing +y (up) or −y.
    let mut s = format!("o {name}\nusemtl grey\nv 0 {y} 0\n");
    for k in 0..segments {
        let a = 2.0 * PI * k as f64 / segments as f64;
        s += &format!("v {} {y} {}\n", r * a.cos(), r * a.sin());
    }
    let m = segments as i64;
    for k in 0..m {
        // Centre is at -(m+1); ring vertex k at -(m - k).
        let (c, a, b) = (-(m + 1), -(m - k), -(m - (k + 1) % m));
        // Seen from +y, increasing angle in the x–z plane runs clockwise.
        if up {
            s += &format!("f {c} {b} {a}\n");
        } else {
            s += &format!("f {c} {a} {b}\n");
        }
    }
    s
}

#[test]
fn coaxial_parallel_disks() {
    let _gate = common::shared();
    let m = 96;
    let obj = disk("lower", 0.5, 0.0, true, m) + &disk("upper", 0.8, 0.6, false, m);
    let s = write_scene(&obj, GREY_MTL, Some("[mesh]\ntarget_patches = 1500\n"));
    let sol = form_factors(s.path());
    // Compare with the disks of equal area (the polygons are 96-gons).
    let r_eff = |name: &str| (sol.surface_area(name) / PI).sqrt();
    assert!((r_eff("lower") / 0.5 - 1.0).abs() < 1e-3);
    let want = coaxial_disks(r_eff("lower"), r_eff("upper"), 0.6);
    assert_rel(
        sol.surface_factor("lower", "upper"),
        want,
        0.01,
        "coaxial disks",
    );
}

#[test]
fn reciprocity_holds_pairwise() {
    let _gate = common::shared();
    let obj = box_faces("room", "grey", [0., 0., 0.], [2., 1.5, 1.], true)
        + &box_faces("block", "grey", [0.6, 0.0, 0.3], [1.1, 0.7, 0.6], false);
    let s = write_scene(&obj, GREY_MTL, Some("[mesh]\ntarget_patches = 1500\n"));
    let sol = form_factors(s.path());
    let n = sol.n();
    let mut worst = 0f64;
    let mut pairs = 0usize;
    for i in 0..n {
        for j in i + 1..n {
            let (ai, aj) = (sol.mesh.patches[i].area, sol.mesh.patches[j].area);
            let gij = ai * sol.f[i * n + j] as f64;
            let gji = aj * sol.f[j * n + i] as f64;
            if gij > 0.0 {
                pairs += 1;
                worst = worst.max((gij - gji).abs() / gij);
            }
        }
    }
    assert!(pairs > n * 10, "too few coupled pairs: {pairs}");
    assert!(
        worst < 1e-5,
        "worst |A_i F_ij − A_j F_ji| / A_i F_ij = {worst:e}"
    );
}

#[test]
fn row_sums_are_one_in_a_closed_room_with_an_occluder() {
    let _gate = common::shared();
    // A closed room with a floating box inside: every patch sees only closed geometry.
    let obj = box_faces("room", "grey", [0., 0., 0.], [3., 2.5, 2.], true)
        + &box_faces("box", "grey", [1.0, 0.8, 0.6], [1.8, 1.4, 1.3], false);
    let s = write_scene(&obj, GREY_MTL, None);
    let sol = form_factors(s.path());
    let sums = relight::transport::formfactor::row_sums(&sol.f, sol.n());
    let worst = sums.iter().map(|s| (s - 1.0).abs()).fold(0.0, f64::max);
    let mean = sums.iter().sum::<f64>() / sums.len() as f64;
    assert!(
        worst < 0.005,
        "worst row sum deviates by {worst:.4} (mean {mean:.5})"
    );
    assert!((mean - 1.0).abs() < 1e-3, "mean row sum {mean}");
}

#[test]
fn an_occluder_that_exactly_hides_gives_zero() {
    let _gate = common::shared();
    let plate = |name: &str, y: f64, up: bool| {
        quad(
            name,
            "grey",
            [[0., y, 0.], [1., y, 0.], [1., y, 1.], [0., y, 1.]],
            [0., if up { 1. } else { -1. }, 0.],
        )
    };
    // The occluder halfway between two unit plates, of exactly their size: every segment
    // between the plates crosses it at its midpoint, which lies inside the occluder.
    let obj =
        plate("lower", 0.0, true) + &plate("upper", 2.0, false) + &plate("occluder", 1.0, true);
    let s = write_scene(&obj, GREY_MTL, None);
    let sol = form_factors(s.path());
    assert_eq!(sol.surface_factor("lower", "upper"), 0.0);
    assert_eq!(sol.surface_factor("upper", "lower"), 0.0);
    // Without it the plates see each other as C-11 says.
    let obj = plate("lower", 0.0, true) + &plate("upper", 2.0, false);
    let s = write_scene(&obj, GREY_MTL, None);
    let sol = form_factors(s.path());
    assert_rel(
        sol.surface_factor("lower", "upper"),
        parallel_rectangles(1.0, 1.0, 2.0),
        0.01,
        "unoccluded",
    );
}
