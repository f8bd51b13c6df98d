//! The daylight metrics, as pure functions of illuminance values (lux): what the annual
//! and the daylight queries report once their matrices and gathers have given the values.
//!
//! - Spatial daylight autonomy sDA300/50 % and annual sunlight exposure ASE1000,250h, after
//!   IES LM-83-12 ("IES Spatial Daylight Autonomy (sDA) and Annual Sunlight Exposure
//!   (ASE)"), over the occupied hours.
//! - Useful daylight illuminance, after Nabil & Mardaljevic ("Useful daylight
//!   illuminance: a new paradigm for assessing daylight in buildings", Lighting Res.
//!   Technol. 37(1), 2005), with the 3000 lx upper edge of the authors' later work (the
//!   first paper used 2000 lx).
//! - EN 17037:2018 ("Daylight in buildings"), the minimum level of daylight provision
//!   through vertical and inclined openings: a target illuminance over half the reference
//!   plane and a minimum target illuminance over 95 % of it, each for at least half the
//!   daylight hours.
//! - Daylight-factor statistics of a grid under the CIE overcast sky.
//!
//! Points left out of a grid's statistics (inside objects) are `None` or `excluded` here,
//! and count nowhere: neither in a numerator nor in a denominator.

use serde::Serialize;

/// sDA: the illuminance a point must reach, lx (at least; LM-83-12's 300 lx).
pub const SDA_LUX: f32 = 300.0;
/// sDA: the share of occupied hours in which a point must reach [`SDA_LUX`] (at least;
/// LM-83-12's 50 %).
pub const SDA_HOURS_FRACTION: f64 = 0.5;
/// ASE: the illuminance of direct sunlight alone that counts an hour, lx (at least;
/// LM-83-12's 1000 lx).
pub const ASE_LUX: f32 = 1000.0;
/// ASE: a point is overexposed with more than this many such occupied hours
/// (LM-83-12's 250 h).
pub const ASE_HOURS: u32 = 250;
/// UDI: below this illuminance an hour "fell short", lx.
pub const UDI_LOW_LUX: f32 = 100.0;
/// UDI: above this illuminance an hour is "exceeded", lx; from [`UDI_LOW_LUX`] up to and
/// including it, it is useful.
pub const UDI_HIGH_LUX: f32 = 3000.0;
/// EN 17037 minimum level: the target illuminance, lx (at least).
pub const EN17037_TARGET_LUX: f32 = 300.0;
/// EN 17037 minimum level: the share of the reference plane that must reach
/// [`EN17037_TARGET_LUX`] in an hour (at least).
pub const EN17037_TARGET_FRACTION: f64 = 0.5;
/// EN 17037 minimum level: the minimum target illuminance, lx (at least).
pub const EN17037_MINIMUM_LUX: f32 = 100.0;
/// EN 17037 minimum level: the share of the reference plane that must reach
/// [`EN17037_MINIMUM_LUX`] in an hour (at least).
pub const EN17037_MINIMUM_FRACTION: f64 = 0.95;
/// EN 17037 minimum level: the share of daylight hours in which both must hold (at least).
pub const EN17037_HOURS_FRACTION: f64 = 0.5;

/// Useful daylight illuminance: the mean share of occupied hours per band, percent.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct Udi {
    pub below_100: f64,
    pub from_100_to_3000: f64,
    pub above_3000: f64,
}

/// EN 17037's minimum-level check.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct En17037 {
    /// Share of daylight hours with at least 300 lx over half the grid, percent.
    pub hours_300_lx_over_50_percent: f64,
    /// Share of daylight hours with at least 100 lx over 95 % of the grid, percent.
    pub hours_100_lx_over_95_percent: f64,
    /// Both shares at least 50 %.
    pub minimum_level_met: bool,
}

/// Daylight factor statistics of a grid, percent.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct DaylightFactors {
    pub avg: f64,
    pub min: f64,
    pub max: f64,
    pub median: f64,
    /// Per point, in grid order; null for points left out of the statistics.
    #[cfg_attr(feature = "server", schema(value_type = Vec<Option<f64>>))]
    pub values: Vec<Option<f32>>,
}

/// `100 · count / of`, percent; 0 when `of` is 0.
pub fn percent(count: usize, of: usize) -> f64 {
    100.0 * count as f64 / of.max(1) as f64
}

/// The UDI band of an hour's illuminance `lux`: 0 below [`UDI_LOW_LUX`], 1 up to and
/// including [`UDI_HIGH_LUX`], 2 above.
pub fn udi_band(lux: f32) -> usize {
    if lux < UDI_LOW_LUX {
        0
    } else if lux <= UDI_HIGH_LUX {
        1
    } else {
        2
    }
}

/// One point's counts over the occupied hours.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PointHours {
    /// Hours with at least [`SDA_LUX`] in all.
    pub sda_hours: u32,
    /// Hours with at least [`ASE_LUX`] of direct sunlight alone.
    pub sunlit_hours: u32,
    /// Hours per UDI band ([`udi_band`]).
    pub udi_bands: [u32; 3],
}

impl PointHours {
    /// Counts the occupied hours' `(illuminance in all, direct sunlight alone)`, lx.
    pub fn count(hours: impl IntoIterator<Item = (f32, f32)>) -> PointHours {
        let mut p = PointHours::default();
        for (all, sun) in hours {
            p.sda_hours += u32::from(all >= SDA_LUX);
            p.sunlit_hours += u32::from(sun >= ASE_LUX);
            p.udi_bands[udi_band(all)] += 1;
        }
        p
    }

    /// Whether the point counts towards sDA over `occupied_hours` hours: [`SDA_LUX`] in at
    /// least [`SDA_HOURS_FRACTION`] of them (never without occupied hours).
    pub fn meets_sda(&self, occupied_hours: usize) -> bool {
        occupied_hours > 0 && self.sda_hours as f64 >= SDA_HOURS_FRACTION * occupied_hours as f64
    }

    /// Whether the point counts towards ASE: more than [`ASE_HOURS`] sunlit hours.
    pub fn exceeds_ase(&self) -> bool {
        self.sunlit_hours > ASE_HOURS
    }
}

/// A grid's climate-based metrics over the occupied hours.
#[derive(Debug, Clone)]
pub struct ClimateMetrics {
    /// sDA, percent of the measured points.
    pub sda: f64,
    /// ASE, percent of the measured points.
    pub ase: f64,
    pub udi: Udi,
    /// Points measured (not `None`).
    pub measured: usize,
}

/// sDA, ASE and UDI of a grid from its points' counts over `occupied_hours` hours; `None`
/// for a point left out.
pub fn climate_metrics(points: &[Option<PointHours>], occupied_hours: usize) -> ClimateMetrics {
    let (mut sda, mut ase, mut measured) = (0usize, 0usize, 0usize);
    let mut udi = [0f64; 3];
    for p in points.iter().flatten() {
        measured += 1;
        sda += usize::from(p.meets_sda(occupied_hours));
        ase += usize::from(p.exceeds_ase());
        for (u, &b) in udi.iter_mut().zip(&p.udi_bands) {
            *u += b as f64 / occupied_hours.max(1) as f64;
        }
    }
    let mean = |u: f64| 100.0 * u / measured.max(1) as f64;
    ClimateMetrics {
        sda: percent(sda, measured),
        ase: percent(ase, measured),
        udi: Udi {
            below_100: mean(udi[0]),
            from_100_to_3000: mean(udi[1]),
            above_3000: mean(udi[2]),
        },
        measured,
    }
}

/// Whether at least `fraction` of the values reach `lux`: whether the ⌈fraction · m⌉-th
/// largest of the m values does. `sorted` is ascending and not empty; `fraction` in
/// (0, 1].
pub fn share_reaches(sorted: &[f32], fraction: f64, lux: f32) -> bool {
    let m = sorted.len();
    sorted[m - (fraction * m as f64).ceil() as usize] >= lux
}

/// One daylight hour of EN 17037's minimum level over a grid's measured values (lx, not
/// empty; sorted here): (the target level holds, the minimum target level holds).
pub fn en17037_hour(values: &mut [f32]) -> (bool, bool) {
    values.sort_by(f32::total_cmp);
    (
        share_reaches(values, EN17037_TARGET_FRACTION, EN17037_TARGET_LUX),
        share_reaches(values, EN17037_MINIMUM_FRACTION, EN17037_MINIMUM_LUX),
    )
}

/// EN 17037's minimum-level check from the daylight hours that met the target level and
/// the minimum target level, out of `daylight_hours`.
pub fn en17037(target_hours: usize, minimum_hours: usize, daylight_hours: usize) -> En17037 {
    let target = percent(target_hours, daylight_hours);
    let minimum = percent(minimum_hours, daylight_hours);
    let needed = 100.0 * EN17037_HOURS_FRACTION;
    En17037 {
        hours_300_lx_over_50_percent: target,
        hours_100_lx_over_95_percent: minimum,
        minimum_level_met: target >= needed && minimum >= needed,
    }
}

/// The median of ascending values; 0 for none.
pub fn median(sorted: &[f32]) -> f64 {
    let m = sorted.len();
    if m == 0 {
        0.0
    } else if m % 2 == 1 {
        sorted[m / 2] as f64
    } else {
        0.5 * (sorted[m / 2 - 1] + sorted[m / 2]) as f64
    }
}

/// Statistics of a grid's daylight factors (percent, in grid order) over the points not
/// `excluded`.
pub fn daylight_factors(values: &[f32], excluded: &[bool]) -> DaylightFactors {
    let mut sorted: Vec<f32> = values
        .iter()
        .zip(excluded)
        .filter(|(_, &x)| !x)
        .map(|(&v, _)| v)
        .collect();
    sorted.sort_by(f32::total_cmp);
    let m = sorted.len();
    DaylightFactors {
        avg: sorted.iter().map(|&v| v as f64).sum::<f64>() / m.max(1) as f64,
        min: sorted.first().copied().unwrap_or(0.0) as f64,
        max: sorted.last().copied().unwrap_or(0.0) as f64,
        median: median(&sorted),
        values: values
            .iter()
            .zip(excluded)
            .map(|(&v, &x)| (!x).then_some(v))
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point's counts with `lit` of `occupied` hours at 300 lx or more, no sun.
    fn lit(hours: u32, occupied: u32) -> PointHours {
        PointHours::count((0..occupied).map(|h| (if h < hours { 300.0 } else { 299.9 }, 0.0)))
    }

    #[test]
    fn point_hours_count_each_threshold_at_its_edge() {
        // (all, sun): 300 counts for sDA and 299.99 does not; 1000 of sun counts for ASE
        // and 999.9 does not; the bands split at 100 (up) and 3000 (down).
        let p = PointHours::count([
            (300.0, 1000.0),
            (299.99, 999.9),
            (99.99, 0.0),
            (100.0, 0.0),
            (3000.0, 0.0),
            (3000.01, 2999.0),
            (1e5, 1e5),
        ]);
        assert_eq!(p.sda_hours, 4);
        assert_eq!(p.sunlit_hours, 3);
        assert_eq!(p.udi_bands, [1, 4, 2]);
    }

    #[test]
    fn udi_bands_are_below_100_up_to_3000_and_above() {
        assert_eq!(udi_band(0.0), 0);
        assert_eq!(udi_band(99.999), 0);
        assert_eq!(udi_band(UDI_LOW_LUX), 1);
        assert_eq!(udi_band(UDI_HIGH_LUX), 1);
        assert_eq!(udi_band(3000.001), 2);
    }

    #[test]
    fn sda_is_the_share_of_points_lit_for_at_least_half_the_occupied_hours() {
        // 10 occupied hours: 5 (exactly half), 10 and 7 count; 4 and 0 do not; the
        // excluded point counts nowhere. 3 of 5 measured points: 60 %.
        let points = [
            Some(lit(5, 10)),
            Some(lit(4, 10)),
            None,
            Some(lit(10, 10)),
            Some(lit(0, 10)),
            Some(lit(7, 10)),
        ];
        let m = climate_metrics(&points, 10);
        assert_eq!(m.measured, 5);
        assert_eq!(m.sda, 60.0);
        // With 11 occupied hours, 5 of them is less than half.
        assert!(!lit(5, 11).meets_sda(11));
        assert!(lit(6, 11).meets_sda(11));
        // Without occupied hours no point meets it, even lit ones.
        assert!(!PointHours::default().meets_sda(0));
        assert_eq!(climate_metrics(&[Some(lit(0, 0))], 0).sda, 0.0);
    }

    #[test]
    fn ase_is_the_share_of_points_with_more_than_250_sunlit_hours() {
        let sunlit =
            |h: u32| PointHours::count((0..300).map(|i| (5e4, if i < h { 1000.0 } else { 999.0 })));
        assert!(!sunlit(250).exceeds_ase());
        assert!(sunlit(251).exceeds_ase());
        // 1 of 4 measured points (the excluded one, however sunny, counts nowhere).
        let points = [
            Some(sunlit(251)),
            Some(sunlit(250)),
            None,
            Some(sunlit(0)),
            Some(sunlit(100)),
        ];
        let m = climate_metrics(&points, 300);
        assert_eq!(m.ase, 25.0);
        // Every hour above 3000 lx and 300 lx: sDA 100 %, UDI all "exceeded".
        assert_eq!(m.sda, 100.0);
        assert_eq!(m.udi.above_3000, 100.0);
    }

    #[test]
    fn udi_is_the_mean_over_points_of_each_bands_share_of_hours() {
        // 10 hours; point a: 2 below, 6 useful, 2 above; point b: all useful; c excluded.
        let a = PointHours::count(
            [
                50.0, 50.0, 200.0, 200.0, 200.0, 200.0, 200.0, 200.0, 5000.0, 5000.0,
            ]
            .map(|v| (v, 0.0)),
        );
        let b = PointHours::count([500f32; 10].map(|v| (v, 0.0)));
        let m = climate_metrics(&[Some(a), None, Some(b)], 10);
        assert_eq!(m.udi.below_100, 10.0);
        assert_eq!(m.udi.from_100_to_3000, 80.0);
        assert_eq!(m.udi.above_3000, 10.0);
    }

    #[test]
    fn a_grid_without_measured_points_scores_zero() {
        let m = climate_metrics(&[None, None], 10);
        assert_eq!(m.measured, 0);
        assert_eq!((m.sda, m.ase), (0.0, 0.0));
        assert_eq!(
            m.udi.below_100 + m.udi.from_100_to_3000 + m.udi.above_3000,
            0.0
        );
    }

    #[test]
    fn a_share_reaches_a_level_when_its_rank_from_the_top_does() {
        let v = [50.0, 100.0, 200.0, 300.0, 400.0];
        // Half of 5 is ⌈2.5⌉ = 3 points: the 3rd largest, 200.
        assert!(share_reaches(&v, 0.5, 200.0));
        assert!(!share_reaches(&v, 0.5, 200.5));
        // 95 % of 5 is all 5: the smallest.
        assert!(share_reaches(&v, 0.95, 50.0));
        assert!(!share_reaches(&v, 0.95, 51.0));
        // 95 % of 20 is 19: every point but the darkest.
        let mut w = [500f32; 20];
        w[0] = 0.0;
        w[1] = 120.0;
        assert!(share_reaches(&w, 0.95, 120.0));
        assert!(!share_reaches(&w, 0.95, 121.0));
    }

    #[test]
    fn en17037_hour_needs_300_lx_on_half_and_100_lx_on_95_percent() {
        // 20 points, unsorted: 10 at 300 lx, 9 at 150, 1 at 50: both hold.
        let mut v: Vec<f32> = (0..20)
            .map(|i| match i % 2 {
                0 => 300.0,
                _ if i == 19 => 50.0,
                _ => 150.0,
            })
            .collect();
        assert_eq!(en17037_hour(&mut v), (true, true));
        assert!(v.windows(2).all(|p| p[0] <= p[1]), "sorted");
        // A second dark point: only 18 of 20 (90 %) reach 100 lx.
        v[1] = 50.0;
        assert_eq!(en17037_hour(&mut v), (true, false));
        // 9 of 20 at 300 lx is less than half.
        let mut v: Vec<f32> = (0..20).map(|i| if i < 9 { 300.0 } else { 299.0 }).collect();
        assert_eq!(en17037_hour(&mut v), (false, true));
    }

    #[test]
    fn en17037_is_met_when_both_levels_hold_half_the_daylight_hours() {
        let e = en17037(50, 50, 100);
        assert_eq!(e.hours_300_lx_over_50_percent, 50.0);
        assert_eq!(e.hours_100_lx_over_95_percent, 50.0);
        assert!(e.minimum_level_met);
        let e = en17037(80, 49, 100);
        assert_eq!(e.hours_100_lx_over_95_percent, 49.0);
        assert!(!e.minimum_level_met);
        let e = en17037(3, 4, 8);
        assert_eq!(
            (
                e.hours_300_lx_over_50_percent,
                e.hours_100_lx_over_95_percent
            ),
            (37.5, 50.0)
        );
        assert!(!e.minimum_level_met);
        // No daylight hours: 0 %, not met.
        let e = en17037(0, 0, 0);
        assert_eq!(e.hours_300_lx_over_50_percent, 0.0);
        assert!(!e.minimum_level_met);
    }

    #[test]
    fn percent_guards_an_empty_whole() {
        assert_eq!(percent(1, 4), 25.0);
        assert_eq!(percent(0, 0), 0.0);
    }

    #[test]
    fn daylight_factor_statistics_leave_out_excluded_points() {
        let values = [8.0, 2.0, 100.0, 6.0, 4.0];
        let excluded = [false, false, true, false, false];
        let df = daylight_factors(&values, &excluded);
        assert_eq!((df.avg, df.min, df.max), (5.0, 2.0, 8.0));
        // An even count: the mean of the middle two, 4 and 6.
        assert_eq!(df.median, 5.0);
        assert_eq!(
            df.values,
            vec![Some(8.0), Some(2.0), None, Some(6.0), Some(4.0)]
        );
        // An odd count: the middle value.
        let df = daylight_factors(&[3.0, 1.0, 2.5], &[false; 3]);
        assert_eq!(df.median, 2.5);
        assert_eq!(df.avg, 6.5 / 3.0);
        // Nothing measured: zeros.
        let df = daylight_factors(&[7.0], &[true]);
        assert_eq!((df.avg, df.min, df.max, df.median), (0.0, 0.0, 0.0, 0.0));
        assert_eq!(df.values, vec![None]);
    }
}
