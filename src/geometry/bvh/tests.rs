use super::lanes::*;
use super::*;

fn quad(y: f32, id_base: usize) -> Vec<[Vec3A; 3]> {
    let _ = id_base;
    let a = Vec3A::new(-1.0, y, -1.0);
    let b = Vec3A::new(1.0, y, -1.0);
    let c = Vec3A::new(1.0, y, 1.0);
    let d = Vec3A::new(-1.0, y, 1.0);
    vec![[a, b, c], [a, c, d]]
}

#[test]
fn blocks_and_skips() {
    let mut tris = quad(0.0, 0);
    tris.extend(quad(1.0, 2));
    // Many small far triangles so the tree has depth.
    for k in 0..200 {
        let x = 10.0 + k as f32;
        tris.push([
            Vec3A::new(x, 0.0, 0.0),
            Vec3A::new(x + 0.5, 0.0, 0.0),
            Vec3A::new(x, 0.5, 0.0),
        ]);
    }
    let bvh = Bvh::new(&tris);
    let from = Vec3A::new(0.1, -1.0, 0.2);
    let to = Vec3A::new(0.0, 2.0, 0.0);
    assert!(bvh.occluded(from, to, [u32::MAX; 2]));
    // Endpoint on the lower quad: that quad is skipped, the upper one still blocks.
    let on_floor = Vec3A::new(0.3, 0.0, 0.3);
    assert!(bvh.occluded(on_floor, to, [0, 1]));
    // Between the two quads nothing blocks.
    assert!(!bvh.occluded(on_floor, Vec3A::new(-0.2, 0.9, 0.1), [0, 1]));
    // A segment lying in the plane of the lower quad (grazing) is not blocked by it.
    assert!(!bvh.occluded(
        Vec3A::new(-0.5, 0.0, 0.5),
        Vec3A::new(0.5, 0.0, -0.5),
        [u32::MAX; 2]
    ));
    let (t, id) = bvh
        .nearest(from, Vec3A::new(0.0, 1.0, 0.0), 0.0, 10.0)
        .unwrap();
    assert!((t - 1.0).abs() < 1e-5 && id < 2);
}

/// The nearest hit of the ordered walk (nearer child first, boxes past the current
/// hit skipped) is the nearest of all the triangles, by brute force.
#[test]
fn nearest_is_the_brute_force_nearest() {
    let mut r = lcg(7);
    let tris = soup(&mut r, 3000);
    let bvh = Bvh::new(&tris);
    let mut hits = 0;
    for _ in 0..3000 {
        let o = Vec3A::new(r(), r(), r()) * 10.0;
        let d = Vec3A::new(r() - 0.5, r() - 0.5, r() - 0.5).normalize();
        let brute = tris
            .iter()
            .enumerate()
            .filter_map(|(i, t)| hit_t(t, o, d, 0.0, f32::INFINITY).map(|t| (t, i as u32)))
            .min_by(|a, b| a.0.total_cmp(&b.0));
        let got = bvh.nearest(o, d, 0.0, f32::INFINITY);
        // The same distance on the same triangle (or one of its stacked copies).
        assert_eq!(
            got.map(|g| g.0),
            brute.map(|b| b.0),
            "ray from {o} along {d}"
        );
        if let (Some(g), Some(b)) = (got, brute) {
            assert_eq!(tris[g.1 as usize], tris[b.1 as usize]);
        }
        hits += usize::from(got.is_some());
    }
    // Most rays meet something, so the check is not vacuous.
    assert!(hits > 1500, "{hits} hits");
}

fn lcg(seed: u64) -> impl FnMut() -> f32 {
    let mut seed = seed;
    move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// Random triangles in a 10 m cube, some large, and a stack of 40 copies of one
/// triangle (centroids on one point: the build must still bound its leaves).
fn soup(r: &mut impl FnMut() -> f32, n: usize) -> Vec<[Vec3A; 3]> {
    let mut tris = Vec::new();
    for k in 0..n {
        let c = Vec3A::new(r(), r(), r()) * 10.0;
        let size = if k % 50 == 0 { 8.0 } else { 1.5 };
        let mut e = || Vec3A::new(r() - 0.5, r() - 0.5, r() - 0.5) * size;
        tris.push([c, c + e(), c + e()]);
    }
    let t = tris[0];
    tris.extend(std::iter::repeat_n(t, 40));
    tris
}

/// The lane-by-lane triangle test on one triangle: the brute-force reference.
fn hit_t(t: &[Vec3A; 3], o: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> Option<f32> {
    let mut block = Tri4::default();
    block.set(0, t);
    let ray = LaneRay::new(o, d);
    hit_lane(&block, 0, &ray, tmin, tmax)
}

/// Occlusion and every crossing of a segment agree with testing every triangle, on a
/// tree of several levels of 8-wide nodes.
#[test]
fn occlusion_and_crossings_are_the_brute_force_ones() {
    let mut r = lcg(11);
    let tris = soup(&mut r, 3000);
    let bvh = Bvh::new(&tris);
    assert!(bvh.nodes.len() > 50, "{} wide nodes", bvh.nodes.len());
    let (mut blocked, mut crossings) = (0, 0);
    for _ in 0..3000 {
        let a = Vec3A::new(r(), r(), r()) * 12.0 - 1.0;
        let b = Vec3A::new(r(), r(), r()) * 12.0 - 1.0;
        let d = b - a;
        let mut brute: Vec<u32> = (0..tris.len() as u32)
            .filter(|&i| hit_t(&tris[i as usize], a, d, 1e-5, 1.0 - 1e-5).is_some())
            .collect();
        let skip = [brute.first().copied().unwrap_or(u32::MAX), u32::MAX];
        let brute_blocked = brute.iter().any(|&i| i != skip[0]);
        assert_eq!(bvh.occluded(a, b, skip), brute_blocked, "{a} → {b}");
        let mut got = Vec::new();
        bvh.each_hit(a, b, |id, _| got.push(id));
        got.sort_unstable();
        brute.sort_unstable();
        assert_eq!(got, brute, "{a} → {b}");
        blocked += usize::from(brute_blocked);
        crossings += brute.len();
    }
    assert!(blocked > 500 && blocked < 2900, "{blocked} blocked");
    assert!(crossings > 3000, "{crossings} crossings");
}

/// Every triangle whose box overlaps a query box is reported once, and no other.
#[test]
fn overlapping_is_the_brute_force_overlap() {
    let mut r = lcg(5);
    let tris = soup(&mut r, 2000);
    let bvh = Bvh::new(&tris);
    for _ in 0..300 {
        let c = Vec3A::new(r(), r(), r()) * 10.0;
        let h = Vec3A::new(r(), r(), r()) * 1.5;
        let (lo, hi) = (c - h, c + h);
        let mut got = Vec::new();
        bvh.overlapping(lo, hi, &mut got);
        got.sort_unstable();
        let brute: Vec<u32> = (0..tris.len() as u32)
            .filter(|&i| {
                let t = tris[i as usize];
                let (tl, th) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
                tl.cmple(hi).all() && lo.cmple(th).all()
            })
            .collect();
        assert_eq!(got, brute);
    }
}

/// The vector box test and the lane-by-lane one agree on every lane, rays parallel to
/// an axis and through box faces included.
#[test]
fn the_vector_box_test_is_the_lane_by_lane_one() {
    let mut r = lcg(9);
    let mut node = Wide {
        lo: [[0.0; WIDTH]; 3],
        hi: [[0.0; WIDTH]; 3],
        child: [0; WIDTH],
        lanes: 7,
    };
    let mut met = 0;
    for k in 0..20_000 {
        for lane in 0..WIDTH {
            for a in 0..3 {
                let (x, y) = ((r() * 4.0).round() - 2.0, (r() * 4.0).round() - 2.0);
                node.lo[a][lane] = x.min(y);
                node.hi[a][lane] = x.max(y);
            }
        }
        let o = Vec3A::new((r() * 4.0).round() - 2.0, r() * 4.0 - 2.0, r() - 0.5);
        let mut d = Vec3A::new(r() - 0.5, r() - 0.5, r() - 0.5);
        if k % 3 == 0 {
            d.x = 0.0;
        }
        let ray = LaneRay::new(o, d);
        let (m1, t1) = enter8(&node, &ray, 0.0, 3.0);
        let (m2, t2) = enter8_lanes(&node, &ray, 0.0, 3.0);
        assert_eq!(m1, m2, "{o} {d}");
        for lane in 0..WIDTH {
            if m1 & (1 << lane) != 0 {
                assert_eq!(t1[lane], t2[lane]);
            }
        }
        assert_eq!(m1 >> 7, 0, "an unused lane is never entered");
        met += m1.count_ones();
    }
    assert!(met > 10_000, "{met} boxes met");
}

/// The vector triangle test and the lane-by-lane one agree on every lane.
#[test]
fn the_vector_triangle_test_is_the_lane_by_lane_one() {
    let mut r = lcg(13);
    let mut met = 0;
    for _ in 0..20_000 {
        let mut block = Tri4::default();
        for lane in 0..4 {
            let c = Vec3A::new(r(), r(), r()) * 2.0 - 1.0;
            let mut e = || Vec3A::new(r() - 0.5, r() - 0.5, r() - 0.5) * 2.0;
            block.set(lane, &[c, c + e(), c + e()]);
        }
        // From a random point toward a point near the first triangle's first corner.
        let o = Vec3A::new(r(), r(), r()) * 4.0 - 2.0;
        let aim = block.corners(0)[0] + Vec3A::new(r(), r(), r()) * 0.5;
        let ray = LaneRay::new(o, aim - o);
        let (mask, t) = hit4(&block, &ray, 0.0, 4.0);
        for (lane, &t) in t.iter().enumerate() {
            let one = hit_lane(&block, lane, &ray, 0.0, 4.0);
            assert_eq!(mask & (1 << lane) != 0, one.is_some());
            if let Some(one) = one {
                assert_eq!(t, one);
                met += 1;
            }
        }
    }
    assert!(met > 2_000, "{met} triangles met");
}
