//! Random numbers and the sampling patterns made of them, at the bottom of the house:
//! the deterministic generators ([`Rng`], [`XorShift`]), Fisher–Yates shuffles
//! ([`shuffle`]), jittered strata ([`Rng::stratum`]) and uniform points of a triangle
//! ([`sample_triangle`], [`stratified_on_triangle`]).
//!
//! Every stream is seeded by what it samples (a patch pair, a pixel block, a patch), never
//! by a thread or the clock, so bakes and images are the same from run to run and compared
//! byte for byte: a change to any sequence here changes them.

use glam::DVec3;

/// SplitMix64's increment (the golden ratio, 2⁶⁴/φ).
const GOLDEN: u64 = 0x9E37_79B9_7F4A_7C15;

/// SplitMix64's output function: a well-mixed 64-bit hash of `z`.
pub(crate) fn splitmix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The top 53 bits of `x` as a number in [0, 1).
pub(crate) fn unit(x: u64) -> f64 {
    (x >> 11) as f64 / (1u64 << 53) as f64
}

/// A fixed pseudo-random point of the unit square for the integer `key` (SplitMix64 of
/// it, its two halves' bits turned against each other).
pub(crate) fn hashed_point(key: u64) -> (f64, f64) {
    let h = splitmix64(key.wrapping_add(GOLDEN));
    (unit(h), unit(h.rotate_left(32)))
}

/// Small deterministic generator (SplitMix64) for ray sampling, seeded by a pair of
/// indices (a patch pair, a pixel block and a salt, …).
pub(crate) struct Rng(u64);

impl Rng {
    pub(crate) fn new(i: usize, j: usize) -> Rng {
        Rng((i as u64).wrapping_mul(GOLDEN) ^ (j as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F))
    }

    /// The next number, uniform in [0, 1).
    pub(crate) fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(GOLDEN);
        unit(splitmix64(self.0))
    }

    /// A uniform index in 0..n (0 when `n` is 0).
    pub(crate) fn index(&mut self, n: usize) -> usize {
        ((self.next_f64() * n as f64) as usize).min(n.saturating_sub(1))
    }

    /// A uniform point of stratum `i` of `n` equal strata of [0, 1): `(i + ξ) / n`.
    pub(crate) fn stratum(&mut self, i: usize, n: usize) -> f64 {
        (i as f64 + self.next_f64()) / n as f64
    }
}

/// Shuffles `v` in place (Fisher–Yates, from the back), uniformly over its orders.
pub(crate) fn shuffle<T>(v: &mut [T], rng: &mut Rng) {
    for i in (1..v.len()).rev() {
        v.swap(i, rng.index(i + 1));
    }
}

/// A small xorshift generator, seeded per patch so results do not depend on threads (the
/// sky view's rays).
pub(crate) struct XorShift(u64);

impl XorShift {
    pub(crate) fn new(seed: u64) -> XorShift {
        XorShift(seed.wrapping_mul(GOLDEN) | 1)
    }

    /// The next number, uniform in [0, 1).
    pub(crate) fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        unit(self.0)
    }
}

/// A point of triangle `c` from the unit square, uniformly distributed, pulled slightly
/// inside so it never lies on an edge shared with a neighbour.
pub(crate) fn sample_triangle(c: &[DVec3; 3], mut u: f64, mut v: f64) -> DVec3 {
    if u + v > 1.0 {
        u = 1.0 - u;
        v = 1.0 - v;
    }
    let p = c[0] + (c[1] - c[0]) * u + (c[2] - c[0]) * v;
    let g = (c[0] + c[1] + c[2]) / 3.0;
    g + (p - g) * (1.0 - 1e-4)
}

/// A jittered point of each cell of a `side × side` grid over the unit square (rows
/// first), mapped onto triangle `c` ([`sample_triangle`]) and handed to `f` in turn.
pub(crate) fn stratified_on_triangle(
    c: &[DVec3; 3],
    side: usize,
    rng: &mut Rng,
    mut f: impl FnMut(DVec3),
) {
    for a in 0..side {
        for b in 0..side {
            let u = rng.stratum(a, side);
            let v = rng.stratum(b, side);
            f(sample_triangle(c, u, v));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sequences bakes and images are made of: SplitMix64 seeded by a pair, its
    /// indices, a shuffle and the xorshift, pinned to their first values.
    #[test]
    fn sequences_are_pinned() {
        let mut r = Rng::new(3, 7);
        let v: Vec<u64> = (0..3).map(|_| r.next_f64().to_bits()).collect();
        // The sequence written out before the move (transport/formfactor.rs).
        let mut state =
            3u64.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 7u64.wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
        let old: Vec<u64> = (0..3)
            .map(|_| {
                state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
                let mut z = state;
                z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
                z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
                z ^= z >> 31;
                ((z >> 11) as f64 / (1u64 << 53) as f64).to_bits()
            })
            .collect();
        assert_eq!(v, old);
        let mut a = Rng::new(1, 2);
        let mut b = Rng::new(1, 2);
        for n in [1usize, 2, 5, 1000] {
            let i = a.index(n);
            assert!(i < n);
            assert_eq!(i, ((b.next_f64() * n as f64) as usize).min(n - 1));
        }
        assert_eq!(Rng::new(0, 0).index(0), 0);
        let mut s = Rng::new(9, 9);
        let mut v: Vec<usize> = (0..10).collect();
        shuffle(&mut v, &mut s);
        let mut sorted = v.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..10).collect::<Vec<_>>());
        assert_ne!(v, sorted);
        let mut x = XorShift::new(5);
        let u = x.next();
        assert!((0.0..1.0).contains(&u));
    }

    /// A stratum's points stay in it.
    #[test]
    fn strata_stay_in_their_cells() {
        let mut r = Rng::new(4, 4);
        for i in 0..8 {
            let u = r.stratum(i, 8);
            assert!(u >= i as f64 / 8.0 && u < (i + 1) as f64 / 8.0, "{i}: {u}");
        }
    }
}
