//! Cluster patches: the small triangles of one surface grouped into patches of about
//! `max_edge`, so the lighting resolution follows the designer's setting and not the
//! exporter's tessellation.
//!
//! A triangle may join a cluster when it is *small*, of at most [`SMALL_AREA_SHARE`] ×
//! `max_edge²`, and the model's own: refinement never split it, or it is a piece of a
//! small model triangle. (Longest-edge bisection leaves patches with a longest edge above
//! `max_edge / 2`, which from a well-shaped triangle is more than `max_edge² / 20`; the
//! pieces of a large triangle that contact refinement cut follow a contact line on
//! purpose.) Small triangles are the model's own detail: furniture, fittings, curved trim
//! and the slivers exporters write along long edges, which refinement cuts into pieces
//! (at most `max_edge` long, `max_edge / CONTACT_DIVISOR` where another surface cuts them):
//! on a real apartment model, 24,000 of its 77,000 patches were such pieces, each alone.
//!
//! Clusters grow greedily, in refinement order, from the first small triangle not yet
//! taken, across shared edges. A neighbour joins when it is small, of the same material
//! and light group, faces within [`MAX_CLUSTER_TURN_DEG`] of the seed, and keeps the
//! cluster's bounding box within `max_edge` across (its diagonal). A triangle that another
//! scene triangle cuts (a contact line: a chair leg on the floor, a cushion on a seat)
//! joins only others like it, and within `max_edge / CONTACT_DIVISOR`, so contact
//! refinement keeps its resolution. Every other triangle is a patch of its own.
//!
//! **Invariant:** a cluster never spans two surfaces (it is built per surface), two
//! materials, two light groups, or triangles whose normals differ by more than twice
//! [`MAX_CLUSTER_TURN_DEG`] (each is within it of the seed).

use std::collections::VecDeque;

use glam::DVec3;

use super::refine::Refiner;
use super::CONTACT_DIVISOR;
use crate::scene::Scene;

/// A triangle of at most this share of `max_edge²` (m²) may join a cluster. Longest-edge
/// bisection leaves patches with a longest edge above `max_edge / 2`; from a well-shaped
/// triangle (angles of 30° or more), that is more than `max_edge² / 20`.
pub const SMALL_AREA_SHARE: f64 = 1.0 / 20.0;

/// The largest angle, in degrees, between a clustered triangle's normal and its seed's.
pub const MAX_CLUSTER_TURN_DEG: f64 = 25.0;

/// The patches of one surface as lists of the refiner's live triangles, in the order of
/// their first triangle in `front` (the live triangles in refinement order). Triangles
/// `input..` were made by refinement. A triangle that is not small, or made by
/// refinement from a triangle of the model that is not small, is a list of one, so a
/// surface without small triangles keeps its patches and their order. `cut` says whether another scene triangle cuts a triangle.
pub(super) fn clusters(
    r: &Refiner,
    front: &[usize],
    input: usize,
    scene: &Scene,
    max_edge: f64,
    cut: impl Fn(u32) -> bool,
) -> Vec<Vec<usize>> {
    let small_area = SMALL_AREA_SHARE * max_edge * max_edge;
    let cos_turn = MAX_CLUSTER_TURN_DEG.to_radians().cos();
    // Per live triangle: small, cut, normal, bounds. Indexed by refiner triangle.
    let n = r.tris.len();
    let mut small = vec![false; n];
    let mut info: Vec<Option<Facet>> = vec![None; n];
    let source_small = |t: usize| {
        let [a, b, c] = scene.triangles[r.src[t] as usize].p;
        0.5 * (b - a).cross(c - a).length() <= small_area
    };
    for &t in front.iter().filter(|&&t| t < input || source_small(t)) {
        let c = r.corners(t as u32);
        let nn = (c[1] - c[0]).cross(c[2] - c[0]);
        if 0.5 * nn.length() <= small_area && nn.length() > 0.0 {
            small[t] = true;
            info[t] = Some(Facet {
                normal: nn.normalize(),
                lo: c[0].min(c[1]).min(c[2]),
                hi: c[0].max(c[1]).max(c[2]),
                cut: cut(t as u32),
            });
        }
    }
    let key = |t: usize| {
        let tri = &scene.triangles[r.src[t] as usize];
        (tri.material, tri.group)
    };
    let mut taken = vec![false; n];
    let mut out = Vec::new();
    let mut queue = VecDeque::new();
    for &seed in front {
        if taken[seed] {
            continue;
        }
        taken[seed] = true;
        let Some(s) = info[seed] else {
            out.push(vec![seed]);
            continue;
        };
        let limit = if s.cut {
            max_edge / CONTACT_DIVISOR
        } else {
            max_edge
        };
        let limit2 = limit * limit * (1.0 + 1e-9);
        let (mut lo, mut hi) = (s.lo, s.hi);
        let mut members = vec![seed];
        queue.clear();
        queue.push_back(seed);
        while let Some(t) = queue.pop_front() {
            for u in r.neighbours(t as u32) {
                let u = u as usize;
                if taken[u] || !small[u] {
                    continue;
                }
                let Some(f) = info[u] else { continue };
                if f.cut != s.cut || f.normal.dot(s.normal) < cos_turn || key(u) != key(seed) {
                    continue;
                }
                let (l, h) = (lo.min(f.lo), hi.max(f.hi));
                if (h - l).length_squared() > limit2 {
                    continue;
                }
                (lo, hi) = (l, h);
                taken[u] = true;
                members.push(u);
                queue.push_back(u);
            }
        }
        out.push(members);
    }
    out
}

/// What clustering needs of a small triangle.
#[derive(Clone, Copy)]
struct Facet {
    normal: DVec3,
    lo: DVec3,
    hi: DVec3,
    /// Another scene triangle cuts it (a contact line).
    cut: bool,
}
