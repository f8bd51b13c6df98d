//! The sun's position from a site and a local standard time, after NOAA's "General Solar
//! Position Calculations" (fractional-year series for the equation of time and the
//! declination, Spencer 1971): about 0.1° over the year, ample for daylight.

use super::Site;

/// A local standard time (no daylight saving) at a site.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalTime {
    pub year: i32,
    pub month: u32,
    pub day: u32,
    /// Hours after midnight, fractional (12.5 = 12:30).
    pub hour: f64,
}

fn is_leap(year: i32) -> bool {
    (year % 4 == 0 && year % 100 != 0) || year % 400 == 0
}

fn days_in_month(year: i32, month: u32) -> u32 {
    match month {
        1 | 3 | 5 | 7 | 8 | 10 | 12 => 31,
        4 | 6 | 9 | 11 => 30,
        _ if is_leap(year) => 29,
        _ => 28,
    }
}

impl LocalTime {
    /// A checked date and time.
    pub fn new(year: i32, month: u32, day: u32, hour: f64) -> Result<LocalTime, String> {
        if !(1..=9999).contains(&year) || !(1..=12).contains(&month) {
            return Err(format!("date {year}-{month:02}: no such month"));
        }
        if day < 1 || day > days_in_month(year, month) {
            return Err(format!("date {year}-{month:02}-{day:02}: no such day"));
        }
        if !(0.0..=24.0).contains(&hour) {
            return Err(format!("hour {hour}: use 0 … 24"));
        }
        Ok(LocalTime {
            year,
            month,
            day,
            hour,
        })
    }

    /// Parses `2026-06-21T12:00` or `2026-06-21T12:00:30` (local standard time).
    pub fn parse(s: &str) -> Result<LocalTime, String> {
        let bad = || format!("time '{s}': use YYYY-MM-DDTHH:MM (local standard time)");
        let (date, time) = s.trim().split_once(['T', ' ']).ok_or_else(bad)?;
        let d: Vec<&str> = date.split('-').collect();
        let t: Vec<&str> = time.split(':').collect();
        if d.len() != 3 || !(2..=3).contains(&t.len()) {
            return Err(bad());
        }
        let num = |x: &str| x.parse::<u32>().map_err(|_| bad());
        let (year, month, day) = (
            d[0].parse::<i32>().map_err(|_| bad())?,
            num(d[1])?,
            num(d[2])?,
        );
        let (h, m) = (num(t[0])?, num(t[1])?);
        let sec = match t.get(2) {
            Some(x) => x.parse::<f64>().map_err(|_| bad())?,
            None => 0.0,
        };
        if h > 24 || m > 59 || !(0.0..60.0).contains(&sec) || (h == 24 && (m > 0 || sec > 0.0)) {
            return Err(bad());
        }
        LocalTime::new(year, month, day, h as f64 + m as f64 / 60.0 + sec / 3600.0)
    }

    /// Day of the year, 1 on January 1.
    pub fn day_of_year(&self) -> u32 {
        (1..self.month)
            .map(|m| days_in_month(self.year, m))
            .sum::<u32>()
            + self.day
    }

    fn days_in_year(&self) -> f64 {
        if is_leap(self.year) {
            366.0
        } else {
            365.0
        }
    }
}

/// The fractional year γ, radians, at `t` (hours in local standard time; NOAA uses the
/// clock hour, a difference far below the series' accuracy).
fn fractional_year(t: &LocalTime) -> f64 {
    2.0 * std::f64::consts::PI / t.days_in_year()
        * (t.day_of_year() as f64 - 1.0 + (t.hour - 12.0) / 24.0)
}

/// The equation of time, minutes (true solar time − mean solar time).
pub fn equation_of_time_min(t: &LocalTime) -> f64 {
    let g = fractional_year(t);
    229.18
        * (0.000075 + 0.001868 * g.cos()
            - 0.032077 * g.sin()
            - 0.014615 * (2.0 * g).cos()
            - 0.040849 * (2.0 * g).sin())
}

/// The solar declination, degrees.
pub fn declination_deg(t: &LocalTime) -> f64 {
    let g = fractional_year(t);
    (0.006918 - 0.399912 * g.cos() + 0.070257 * g.sin() - 0.006758 * (2.0 * g).cos()
        + 0.000907 * (2.0 * g).sin()
        - 0.002697 * (3.0 * g).cos()
        + 0.00148 * (3.0 * g).sin())
    .to_degrees()
}

/// The sun's position, degrees: altitude above the horizon (negative at night, without
/// refraction) and azimuth from north, clockwise (90 = east, 180 = south), in [0, 360).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SunPosition {
    pub altitude_deg: f64,
    pub azimuth_deg: f64,
}

/// The sun at a site at local standard time `t`.
pub fn position(site: &Site, t: &LocalTime) -> SunPosition {
    let offset_min = equation_of_time_min(t) + 4.0 * site.longitude_deg - 60.0 * site.timezone_h;
    let true_solar_min = t.hour * 60.0 + offset_min;
    let hour_angle = (true_solar_min / 4.0 - 180.0).to_radians();
    let (lat, dec) = (
        site.latitude_deg.to_radians(),
        declination_deg(t).to_radians(),
    );
    // The sun's direction in east, north, up coordinates.
    let east = -dec.cos() * hour_angle.sin();
    let north = dec.sin() * lat.cos() - dec.cos() * hour_angle.cos() * lat.sin();
    let up = dec.sin() * lat.sin() + dec.cos() * hour_angle.cos() * lat.cos();
    SunPosition {
        altitude_deg: up.clamp(-1.0, 1.0).asin().to_degrees(),
        azimuth_deg: east.atan2(north).to_degrees().rem_euclid(360.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn mannheim() -> Site {
        Site::new(49.52, 8.55, 1.0, DVec3::NEG_Z, 0.2).unwrap()
    }

    #[test]
    fn declination_and_equation_of_time_match_the_almanac() {
        // Solstices ±23.44°, equinoxes about 0 (the series is good to ~0.1°).
        let dec = |m, d| declination_deg(&LocalTime::new(2026, m, d, 12.0).unwrap());
        assert!((dec(6, 21) - 23.44).abs() < 0.15, "{}", dec(6, 21));
        assert!((dec(12, 21) + 23.44).abs() < 0.15, "{}", dec(12, 21));
        assert!(dec(3, 20).abs() < 0.5 && dec(9, 23).abs() < 0.5);
        // The equation of time peaks near +16.4 min (Nov 3) and −14.2 min (Feb 11).
        let eot = |m, d| equation_of_time_min(&LocalTime::new(2026, m, d, 12.0).unwrap());
        assert!((eot(11, 3) - 16.4).abs() < 0.5, "{}", eot(11, 3));
        assert!((eot(2, 11) + 14.2).abs() < 0.5, "{}", eot(2, 11));
    }

    #[test]
    fn the_sun_culminates_due_south_at_solar_noon() {
        let site = mannheim();
        // Solar noon: 12:00 − (4 min × (lon − 15 × tz)) − equation of time.
        let t0 = LocalTime::new(2026, 6, 21, 12.0).unwrap();
        let noon = 12.0
            - (4.0 * (site.longitude_deg - 15.0 * site.timezone_h) + equation_of_time_min(&t0))
                / 60.0;
        let t = LocalTime::new(2026, 6, 21, noon).unwrap();
        let p = position(&site, &t);
        let want = 90.0 - (site.latitude_deg - declination_deg(&t));
        assert!((p.altitude_deg - want).abs() < 0.01, "{p:?} vs {want}");
        assert!((p.azimuth_deg - 180.0).abs() < 0.2, "{p:?}");
        assert!((p.altitude_deg - 63.9).abs() < 0.2, "{p:?}");
        // Symmetric about solar noon; the morning sun is in the east, the evening in the west.
        let am = position(&site, &LocalTime::new(2026, 6, 21, noon - 3.0).unwrap());
        let pm = position(&site, &LocalTime::new(2026, 6, 21, noon + 3.0).unwrap());
        assert!(
            (am.altitude_deg - pm.altitude_deg).abs() < 0.05,
            "{am:?} {pm:?}"
        );
        assert!(
            (am.azimuth_deg + pm.azimuth_deg - 360.0).abs() < 0.2,
            "{am:?} {pm:?}"
        );
        assert!(am.azimuth_deg > 90.0 && am.azimuth_deg < 180.0);
        // Midnight: below the horizon, north.
        let night = position(
            &site,
            &LocalTime::new(2026, 6, 21, noon - 12.0 + 24.0 * 0.0).unwrap(),
        );
        assert!(night.altitude_deg < 0.0);
        // Equinox noon at the equator: overhead within the declination's accuracy.
        let eq = Site::new(0.0, 0.0, 0.0, DVec3::NEG_Z, 0.2).unwrap();
        let march = LocalTime::new(2026, 3, 20, 12.0).unwrap();
        let t = LocalTime::new(2026, 3, 20, 12.0 - equation_of_time_min(&march) / 60.0).unwrap();
        assert!(position(&eq, &t).altitude_deg > 89.0);
    }

    #[test]
    fn times_parse_strictly() {
        let t = LocalTime::parse("2026-06-21T12:30").unwrap();
        assert_eq!((t.month, t.day, t.hour), (6, 21, 12.5));
        assert_eq!(t.day_of_year(), 172);
        assert_eq!(
            LocalTime::parse("2024-12-31T00:00").unwrap().day_of_year(),
            366
        );
        for bad in [
            "2026-02-29T12:00",
            "2026-13-01T00:00",
            "2026-06-21",
            "2026-06-21T25:00",
            "x",
        ] {
            assert!(LocalTime::parse(bad).is_err(), "{bad}");
        }
    }
}
