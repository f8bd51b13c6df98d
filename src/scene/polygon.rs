//! Triangulating a planar polygon: its projection onto its own plane, a convexity test,
//! and ear clipping for the non-convex ones (an L-shaped floor, a U-shaped wall).

/// The polygon in 2D, projected along the dominant axis of its Newell normal and oriented
/// so that it winds counter-clockwise (positive area). None when it has no area.
pub(crate) fn project(pts: &[[f32; 3]]) -> Option<Vec<[f64; 2]>> {
    let n = pts.len();
    let mut nrm = [0f64; 3];
    for i in 0..n {
        let (a, b) = (pts[i].map(f64::from), pts[(i + 1) % n].map(f64::from));
        nrm[0] += (a[1] - b[1]) * (a[2] + b[2]);
        nrm[1] += (a[2] - b[2]) * (a[0] + b[0]);
        nrm[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
    let abs = nrm.map(f64::abs);
    let axis = if abs[0] >= abs[1] && abs[0] >= abs[2] {
        0
    } else if abs[1] >= abs[2] {
        1
    } else {
        2
    };
    if !(abs[axis].is_finite() && abs[axis] > 0.0) {
        return None;
    }
    // The two other axes, in the cyclic order that keeps the winding seen from +normal.
    let (u, v) = [(1, 2), (2, 0), (0, 1)][axis];
    let flip = nrm[axis] < 0.0;
    Some(
        pts.iter()
            .map(|p| {
                let (x, y) = (p[u] as f64, p[v] as f64);
                if flip {
                    [y, x]
                } else {
                    [x, y]
                }
            })
            .collect(),
    )
}

/// Twice the signed area of triangle abc (positive when counter-clockwise).
fn cross(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Whether a counter-clockwise polygon turns left (or goes straight) at every vertex.
pub(crate) fn is_convex(p: &[[f64; 2]]) -> bool {
    let n = p.len();
    (0..n).all(|i| cross(p[i], p[(i + 1) % n], p[(i + 2) % n]) >= 0.0)
}

/// Whether `x` lies in the closed counter-clockwise triangle abc.
fn inside(x: [f64; 2], a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> bool {
    cross(a, b, x) >= 0.0 && cross(b, c, x) >= 0.0 && cross(c, a, x) >= 0.0
}

/// Ear clipping of a simple counter-clockwise polygon: n − 2 triangles of its vertex
/// indices (fewer when a vertex lies on the line of its neighbours), each
/// counter-clockwise. None when some step finds no ear (a self-intersecting
/// polygon) or when the work would exceed `budget` vertex tests (an ear test costs one per
/// remaining vertex; a simple polygon needs about n² in all); the tests made are taken
/// from `budget`.
pub(crate) fn ear_clip(p: &[[f64; 2]], budget: &mut u64) -> Option<Vec<[usize; 3]>> {
    let mut rest: Vec<usize> = (0..p.len()).collect();
    let mut tris = Vec::with_capacity(p.len().saturating_sub(2));
    let mut i = 0;
    let mut misses = 0;
    // After a whole round without an ear: drop a vertex that lies on the line of its
    // neighbours (a T-junction point on an edge), which adds no area.
    let mut relaxed = false;
    while rest.len() > 3 {
        let m = rest.len();
        let (ia, ib, ic) = (rest[(i + m - 1) % m], rest[i % m], rest[(i + 1) % m]);
        let (a, b, c) = (p[ia], p[ib], p[ic]);
        *budget = budget.checked_sub(m as u64)?;
        let turn = cross(a, b, c);
        let ear = turn > 0.0
            && rest.iter().all(|&k| {
                // A vertex equal to a corner (a polygon touching itself) does not block it.
                k == ia
                    || k == ib
                    || k == ic
                    || p[k] == a
                    || p[k] == b
                    || p[k] == c
                    || !inside(p[k], a, b, c)
            });
        if ear || (relaxed && turn == 0.0) {
            if ear {
                tris.push([ia, ib, ic]);
            }
            rest.remove(i % m);
            misses = 0;
            relaxed = false;
            i %= rest.len();
        } else {
            misses += 1;
            if misses > m {
                if relaxed {
                    return None;
                }
                relaxed = true;
                misses = 0;
            }
            i = (i + 1) % m;
        }
    }
    tris.push([rest[0], rest[1], rest[2]]);
    Some(tris)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(p: &[[f64; 2]], tris: &[[usize; 3]]) -> f64 {
        tris.iter()
            .map(|t| 0.5 * cross(p[t[0]], p[t[1]], p[t[2]]))
            .sum()
    }

    #[test]
    fn an_l_shaped_floor_is_clipped_to_its_own_area() {
        // An L: 3 × 1 plus 1 × 2, area 5, its reflex corner at (1, 1); the first vertex
        // does not see the whole L.
        let l = [[3., 0.], [3., 1.], [1., 1.], [1., 3.], [0., 3.], [0., 0.]];
        assert!(!is_convex(&l));
        let tris = ear_clip(&l, &mut 1000).unwrap();
        assert_eq!(tris.len(), 4);
        assert!((area(&l, &tris) - 5.0).abs() < 1e-12);
        for t in &tris {
            assert!(
                cross(l[t[0]], l[t[1]], l[t[2]]) > 0.0,
                "{t:?} winds backwards"
            );
        }
        // A fan from vertex 0 folds over the notch: its triangles cover more than 5.
        let fan: Vec<[usize; 3]> = (1..5).map(|i| [0, i, i + 1]).collect();
        let fan_abs: f64 = fan
            .iter()
            .map(|t| 0.5 * cross(l[t[0]], l[t[1]], l[t[2]]).abs())
            .sum();
        assert!(fan_abs > 5.5, "{fan_abs}");
    }

    #[test]
    fn collinear_vertices_do_not_stop_the_clipping() {
        // The L with an extra vertex in the middle of its long outer edges.
        let l = [
            [3., 0.],
            [3., 1.],
            [1., 1.],
            [1., 3.],
            [0., 3.],
            [0., 1.5],
            [0., 0.],
            [1.5, 0.],
        ];
        let tris = ear_clip(&l, &mut 10_000).unwrap();
        assert!((area(&l, &tris) - 5.0).abs() < 1e-12);
        assert!(tris.iter().all(|t| cross(l[t[0]], l[t[1]], l[t[2]]) > 0.0));
    }

    #[test]
    fn projection_keeps_the_winding_seen_from_the_normal() {
        // A square in the xz plane wound counter-clockwise seen from -y (normal -y).
        let sq = [[0., 0., 0.], [1., 0., 0.], [1., 0., -1.], [0., 0., -1.]];
        let f = project(&sq).unwrap();
        assert!(area(&f, &[[0, 1, 2], [0, 2, 3]]) > 0.0);
        let rev: Vec<[f32; 3]> = sq.iter().rev().copied().collect();
        let f = project(&rev).unwrap();
        assert!(area(&f, &[[0, 1, 2], [0, 2, 3]]) > 0.0);
        assert!(project(&[[0., 0., 0.], [1., 1., 1.], [2., 2., 2.]]).is_none());
    }

    #[test]
    fn a_self_intersecting_bow_tie_finds_no_complete_clipping_or_stays_bounded() {
        let bow = [[0., 0.], [2., 2.], [2., 0.], [1., 3.], [0., 2.]];
        // Whatever it returns, it returns: n − 2 triangles or None, never a hang.
        if let Some(t) = ear_clip(&bow, &mut 1000) {
            assert_eq!(t.len(), 3);
        }
        // Out of budget: None, having spent no more than it had.
        let l = [[3., 0.], [3., 1.], [1., 1.], [1., 3.], [0., 3.], [0., 0.]];
        let mut budget = 10;
        assert!(ear_clip(&l, &mut budget).is_none());
        assert!(budget < 6);
    }
}
