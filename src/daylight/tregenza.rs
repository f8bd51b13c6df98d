//! The Tregenza sky subdivision (145 patches) and Reinhart's finer subdivisions (MF:n), as
//! Radiance's daylight-coefficient tools use them.
//!
//! Bands of 12° of altitude from the horizon up hold 30, 30, 24, 24, 18, 12 and 6 patches;
//! a polar cap covers 84°–90°. MF:n splits every band into n bands and every band patch
//! into n along azimuth; the cap stays one patch (144 n² + 1 sky patches). Patches are
//! numbered band by band from the horizon up; within a band they start centred on north
//! and go clockwise (through east), like Radiance's `reinhart.cal`. Patch 0 is the ground,
//! so sky patch k has index k (1-based) in [`Subdivision::patches`].

use std::f64::consts::{FRAC_PI_2, PI};

const TREGENZA_BANDS: [usize; 7] = [30, 30, 24, 24, 18, 12, 6];

/// One sky patch: altitude and azimuth bounds (radians; azimuth from north, clockwise,
/// centred on `azimuth`, so a patch may straddle north), its centre and solid angle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Patch {
    pub altitude: (f64, f64),
    /// Centre azimuth.
    pub azimuth: f64,
    /// Width in azimuth (2π for the cap).
    pub width: f64,
    /// Solid angle, sr.
    pub solid_angle: f64,
}

impl Patch {
    /// The centre (altitude, azimuth), radians; the cap's centre is the zenith.
    pub fn centre(&self) -> (f64, f64) {
        if self.width >= 2.0 * PI {
            return (FRAC_PI_2, 0.0);
        }
        (0.5 * (self.altitude.0 + self.altitude.1), self.azimuth)
    }
}

/// A subdivision of the sky hemisphere into patches (plus the ground, index 0).
#[derive(Debug, Clone)]
pub struct Subdivision {
    /// The ground (index 0) and the sky patches.
    pub patches: Vec<Patch>,
    /// Per band: first patch index and count (the cap is the last band).
    bands: Vec<(usize, usize, f64, f64)>,
}

impl Subdivision {
    /// Tregenza's 145 patches (MF:1).
    pub fn tregenza() -> Subdivision {
        Subdivision::reinhart(1)
    }

    /// Reinhart MF:`n`, n in 1 … 8.
    pub fn reinhart(n: usize) -> Subdivision {
        let n = n.clamp(1, 8);
        let band_h = (12f64 / n as f64).to_radians();
        let ground = Patch {
            altitude: (-FRAC_PI_2, 0.0),
            azimuth: 0.0,
            width: 2.0 * PI,
            solid_angle: 2.0 * PI,
        };
        let mut patches = vec![ground];
        let mut bands = Vec::new();
        for (b, &count) in TREGENZA_BANDS.iter().enumerate() {
            for k in 0..n {
                let lo = (b * n + k) as f64 * band_h;
                let hi = lo + band_h;
                let m = count * n;
                let width = 2.0 * PI / m as f64;
                bands.push((patches.len(), m, lo, hi));
                for j in 0..m {
                    patches.push(Patch {
                        altitude: (lo, hi),
                        azimuth: j as f64 * width,
                        width,
                        solid_angle: width * (hi.sin() - lo.sin()),
                    });
                }
            }
        }
        let lo = 84f64.to_radians();
        bands.push((patches.len(), 1, lo, FRAC_PI_2));
        patches.push(Patch {
            altitude: (lo, FRAC_PI_2),
            azimuth: 0.0,
            width: 2.0 * PI,
            solid_angle: 2.0 * PI * (1.0 - lo.sin()),
        });
        Subdivision { patches, bands }
    }

    /// The patch a direction (altitude, azimuth in radians) falls in: 0 for the ground.
    pub fn patch_of(&self, altitude: f64, azimuth: f64) -> usize {
        if altitude < 0.0 {
            return 0;
        }
        let band = self
            .bands
            .iter()
            .find(|&&(_, _, lo, hi)| altitude >= lo && altitude < hi)
            .or(self.bands.last());
        let Some(&(first, count, _, _)) = band else {
            return 0;
        };
        let width = 2.0 * PI / count as f64;
        // Patches are centred on multiples of their width.
        let j = ((azimuth.rem_euclid(2.0 * PI) + 0.5 * width) / width).floor() as usize % count;
        first + j
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tregenza_and_reinhart_patch_counts_areas_and_lookup() {
        for (n, count) in [(1, 145), (2, 577), (4, 2305)] {
            let s = Subdivision::reinhart(n);
            assert_eq!(s.patches.len() - 1, count, "MF:{n}");
            let sky: f64 = s.patches[1..].iter().map(|p| p.solid_angle).sum();
            assert!((sky - 2.0 * PI).abs() < 1e-12, "MF:{n}: {sky}");
            for (i, p) in s.patches.iter().enumerate().skip(1) {
                let (a, z) = p.centre();
                assert_eq!(s.patch_of(a, z), i, "MF:{n} patch {i}");
            }
        }
        let t = Subdivision::tregenza();
        // Patch 1 is centred on north at the horizon band; patch 2 is the next one east.
        assert_eq!(t.patch_of(0.1, 0.0), 1);
        assert_eq!(t.patch_of(0.1, -0.01), 1);
        assert_eq!(t.patch_of(0.1, 12f64.to_radians()), 2);
        assert_eq!(t.patch_of(-0.1, 1.0), 0);
        assert_eq!(t.patch_of(FRAC_PI_2, 0.0), 145);
    }
}
