//! Calculation grids that measure what a designer means: points buried in objects are
//! left out of the statistics, and EN 12464-1 areas place their points by the standard.

use relight::bake::{load_or_bake, BakeOptions, CachePolicy};
use relight::color::Rgb;
use relight::model::Model;
use relight::scene::grids::{en12464_spacing, GridKind};

use crate::common::{self, *};

const MTL: &str = "newmtl wall\nKd 0.5 0.5 0.5\nnewmtl wood\nKd 0.4 0.3 0.2\n";

/// A 6 × 3 × 4 m room with a 1 m box standing on the floor, a desk top (a closed slab
/// from 0.70 to 0.75 m, no legs) and one luminaire under the ceiling.
fn room(grids: &str) -> Model {
    let mut obj = box_faces("room", "wall", [0.0, 0.0, 0.0], [6.0, 3.0, 4.0], true);
    obj += &box_faces("box", "wood", [1.0, 0.0, 1.0], [2.0, 0.5, 2.0], false);
    obj += &box_faces("desk", "wood", [3.5, 0.70, 1.5], [5.0, 0.75, 2.5], false);
    let toml = format!(
        r#"
[mesh]
max_edge = 0.5
[[luminaires]]
id = "lamp"
position = [3, 2.9, 2]
lumens = 3000
{grids}"#
    );
    let s = write_scene(&obj, MTL, Some(&toml));
    Model::new(
        load_or_bake(
            s.path(),
            CachePolicy::Off,
            &BakeOptions::default(),
            &|_, _| {},
        )
        .unwrap(),
    )
}

fn answer(m: &Model, id: &str) -> relight::model::query::GridAnswer {
    let gi = m.grids.iter().position(|g| g.grid.id == id).unwrap();
    m.grid_answer(gi, &vec![Rgb::ONE; m.baked.scene.lights.len()])
}

/// The gallery's floor grid and the rooflight's reference plane reported Emin 0 lx and
/// U₀ 0.00: their points under plinths and inside a box counted as measurements.
#[test]
fn points_inside_a_box_and_a_desk_were_measured_as_zero_lux() {
    let _gate = common::shared();
    let grids = r#"
[[grids]]
id = "floor"
min = [0.25, 0.25]
max = [5.75, 3.75]
height = 0.01
[[grids]]
id = "slab"
min = [0.25, 0.25]
max = [5.75, 3.75]
height = 0.72
"#;
    let m = room(grids);
    let inside =
        |p: [f64; 3], lo: [f64; 3], hi: [f64; 3]| (0..3).all(|c| p[c] > lo[c] && p[c] < hi[c]);
    for (id, lo, hi, want) in [
        ("floor", [1.0, 0.0, 1.0], [2.0, 0.5, 2.0], 16),
        ("slab", [3.5, 0.70, 1.5], [5.0, 0.75, 2.5], 24),
    ] {
        let a = answer(&m, id);
        let g = &m.grids.iter().find(|g| g.grid.id == id).unwrap().grid;
        assert_eq!(a.count, 22 * 14);
        assert_eq!(a.excluded, want, "{id}");
        // Exactly the points inside the solid are null.
        for (p, v) in g.points.iter().zip(&a.values) {
            assert_eq!(v.is_none(), inside(*p, lo, hi), "{id} {p:?}");
        }
        let measured: Vec<f64> = a.values.iter().flatten().map(|&v| v as f64).collect();
        let avg = measured.iter().sum::<f64>() / measured.len() as f64;
        let min = measured.iter().copied().fold(f64::INFINITY, f64::min);
        assert!((a.avg - avg).abs() < 1e-6 * avg && (a.min - min).abs() < 1e-9);
        assert!(a.u0.is_some_and(|u| u > 0.1), "{id}: U0 {:?}", a.u0);
    }
    // Floor points under the desk (0.69 m of open space above them) still measure.
    let floor = answer(&m, "floor");
    let g = &m.grids.iter().find(|g| g.grid.id == "floor").unwrap().grid;
    let under = g
        .points
        .iter()
        .position(|p| p[0] > 3.6 && p[0] < 4.9 && p[2] > 1.6 && p[2] < 2.4)
        .unwrap();
    assert!(floor.values[under].unwrap() > 1.0);

    // keep_obstructed = true: the raw grid, the buried points read (almost) nothing.
    let m = room(&grids.replace("height = 0.01", "height = 0.01\nkeep_obstructed = true"));
    let a = answer(&m, "floor");
    assert_eq!(a.excluded, 0);
    assert!(a.values.iter().all(|v| v.is_some()));
    assert!(a.min < 1e-3 * a.avg, "inside the box: {} lx", a.min);
}

/// EN 12464-1 areas: the standard's spacing, the task's immediate surrounding band and the
/// background area without its 0.5 m band along the walls.
#[test]
fn en12464_areas_place_their_points_by_the_standard() {
    let _gate = common::shared();
    let m = room(
        r#"
[[grids]]
id = "task"
kind = "task"
min = [3.5, 1.5]
max = [5.0, 2.5]
height = 0.76
[[grids]]
id = "room"
kind = "background"
min = [0, 0]
max = [6, 4]
[[grids]]
id = "corner"
kind = "task"
area = [[0.2, 2.4], [1.4, 2.4], [1.4, 3.8], [0.8, 3.8], [0.8, 3.0], [0.2, 3.0]]
surrounding = 0
"#,
    );
    let grid = |id: &str| &m.grids.iter().find(|g| g.grid.id == id).unwrap().grid;
    // Task 1.5 × 1.0 m: d = 1.5 m, p = 0.2·5^log10(1.5) = 0.2654 m, 6 cells of 0.25 m; the
    // 1 m side 4 cells.
    let t = grid("task");
    assert_eq!(
        (t.kind, t.layout, t.points.len()),
        (Some(GridKind::Task), Some([6, 4]), 24)
    );
    assert!((t.spacing.unwrap() - 0.25).abs() < 1e-12);
    assert!((t.points[0][0] - 3.625).abs() < 1e-12 && (t.points[0][2] - 1.625).abs() < 1e-12);
    assert!((t.points[0][1] - 0.76).abs() < 1e-12);
    // Its immediate surrounding: a band 0.5 m wide around it, no point inside the task.
    let s = grid("task-surrounding");
    assert_eq!(s.kind, Some(GridKind::Surrounding));
    assert!(s.spacing.unwrap() <= en12464_spacing(2.5) + 1e-12);
    assert!(s.points.len() >= 20, "{}", s.points.len());
    for p in &s.points {
        let in_task = p[0] > 3.5 && p[0] < 5.0 && p[2] > 1.5 && p[2] < 2.5;
        let in_band = p[0] > 3.0 && p[0] < 5.5 && p[2] > 1.0 && p[2] < 3.0;
        assert!(!in_task && in_band, "{p:?}");
    }
    // Background 6 × 4 m less 0.5 m along the walls: 5 × 3 m, d = 5 m, p = 0.616 m, 9 cells
    // of 0.556 m; the 3 m side 6 cells.
    let b = grid("room");
    assert_eq!(
        (b.kind, b.layout, b.points.len()),
        (Some(GridKind::Background), Some([9, 6]), 54)
    );
    assert!(b
        .points
        .iter()
        .all(|p| p[0] > 0.5 && p[0] < 5.5 && p[2] > 0.5 && p[2] < 3.5));
    // An L-shaped task area: only cells whose centre lies inside; no surrounding asked for.
    let c = grid("corner");
    assert!(c.layout.is_none() && !m.grids.iter().any(|g| g.grid.id == "corner-surrounding"));
    assert!(
        c.points.iter().all(|p| !(p[0] < 0.8 && p[2] > 3.0)),
        "the notch has no points"
    );
    assert!(c.points.len() > 10);
    // Answers carry the zone, the spacing and the statistics per area.
    let a = answer(&m, "task-surrounding");
    assert_eq!(a.kind, Some(GridKind::Surrounding));
    assert!(a.avg > 0.0 && a.u0.is_some_and(|u| u > 0.0 && u <= 1.0));
}

#[test]
fn en12464_area_mistakes_are_named() {
    let _gate = common::shared();
    let obj = box_faces("room", "wall", [0.0, 0.0, 0.0], [6.0, 3.0, 4.0], true);
    for (grid, says) in [
        (
            "kind = \"task\"\npoints = [[1, 1, 1]]",
            "a kind needs an area",
        ),
        (
            "kind = \"background\"\nmin = [0, 0]\nmax = [0.8, 4]",
            "narrower than twice",
        ),
        (
            "min = [0, 0]\nmax = [1, 1]\nsurrounding = 1",
            "surrounding is for kind",
        ),
        ("area = [[0, 0], [1, 1]]", "3 to 1000"),
        (
            "kind = \"roof\"\nmin = [0, 0]\nmax = [1, 1]",
            "unknown variant",
        ),
    ] {
        let toml = format!("[[grids]]\nid = \"g\"\n{grid}\n");
        let s = write_scene(&obj, MTL, Some(&toml));
        let e = relight::scene::Scene::load(s.path())
            .unwrap_err()
            .to_string();
        assert!(e.contains(says), "{grid}: {e}");
    }
}
