//! Daylight: the site, the sun's position, sky luminance models, the Tregenza sky
//! subdivision and EnergyPlus weather files. The physics daylight queries are built on;
//! nothing here knows about scenes or HTTP.
//!
//! Conventions: the scene's up is +y. Directions in the sky are given by altitude γ above
//! the horizon and azimuth measured from north, clockwise seen from above (90° = east,
//! 180° = south). A [`Site`] says which scene direction is north; east is north × up.
//! Luminance is in cd/m², illuminance in lux, irradiance in W/m².

pub mod epw;
pub mod perez;
pub mod sky_luminance;
pub mod sun;
pub mod tregenza;

use glam::DVec3;

/// Where a scene stands on Earth.
#[derive(Debug, Clone, PartialEq)]
pub struct Site {
    /// Degrees north (negative: south), −90 … 90.
    pub latitude_deg: f64,
    /// Degrees east (negative: west), −180 … 180.
    pub longitude_deg: f64,
    /// Hours east of UTC of the local standard time (no daylight saving), −12 … 14.
    pub timezone_h: f64,
    /// Unit horizontal scene direction of north.
    pub north: DVec3,
    /// Diffuse reflectance of the ground outside the model, [0, 1).
    pub ground_reflectance: f64,
}

impl Site {
    /// A site, checked: `north` is made unit length and must be horizontal.
    pub fn new(
        latitude_deg: f64,
        longitude_deg: f64,
        timezone_h: f64,
        north: DVec3,
        ground_reflectance: f64,
    ) -> Result<Site, String> {
        if !(-90.0..=90.0).contains(&latitude_deg) {
            return Err(format!(
                "latitude {latitude_deg}: use −90 … 90 (degrees north)"
            ));
        }
        if !(-180.0..=180.0).contains(&longitude_deg) {
            return Err(format!(
                "longitude {longitude_deg}: use −180 … 180 (degrees east)"
            ));
        }
        if !(-12.0..=14.0).contains(&timezone_h) {
            return Err(format!(
                "timezone {timezone_h}: use −12 … 14 (hours east of UTC)"
            ));
        }
        if !(0.0..1.0).contains(&ground_reflectance) {
            return Err(format!(
                "ground_reflectance {ground_reflectance}: use [0, 1)"
            ));
        }
        let len = north.length();
        if !len.is_finite() || len == 0.0 || (north.y / len).abs() > 1e-6 {
            return Err(format!(
                "north {north}: give a horizontal direction (y = 0), e.g. [0, 0, -1]"
            ));
        }
        Ok(Site {
            latitude_deg,
            longitude_deg,
            timezone_h,
            north: north / len,
            ground_reflectance,
        })
    }

    /// Unit scene direction of east (north × up).
    pub fn east(&self) -> DVec3 {
        self.north.cross(DVec3::Y)
    }

    /// The scene direction of a sky position (degrees).
    pub fn direction(&self, altitude_deg: f64, azimuth_deg: f64) -> DVec3 {
        let (g, a) = (altitude_deg.to_radians(), azimuth_deg.to_radians());
        (self.north * a.cos() + self.east() * a.sin()) * g.cos() + DVec3::Y * g.sin()
    }

    /// The sky position (altitude, azimuth in [0, 360)), degrees, of a scene direction.
    pub fn sky_position(&self, d: DVec3) -> (f64, f64) {
        let d = d.normalize_or_zero();
        let alt = d.y.clamp(-1.0, 1.0).asin().to_degrees();
        let az = d.dot(self.east()).atan2(d.dot(self.north)).to_degrees();
        (alt, az.rem_euclid(360.0))
    }
}

#[cfg(test)]
mod tests {
    use super::Site;
    use glam::DVec3;

    #[test]
    fn default_north_puts_east_at_plus_x() {
        let s = Site::new(49.52, 8.55, 1.0, DVec3::NEG_Z, 0.2).unwrap();
        assert!(s.east().abs_diff_eq(DVec3::X, 1e-15));
        assert!(s.direction(0.0, 90.0).abs_diff_eq(DVec3::X, 1e-12));
        assert!(s.direction(0.0, 180.0).abs_diff_eq(DVec3::Z, 1e-12));
        assert!(s.direction(90.0, 0.0).abs_diff_eq(DVec3::Y, 1e-12));
        let (alt, az) = s.sky_position(s.direction(35.0, 217.0));
        assert!((alt - 35.0).abs() < 1e-9 && (az - 217.0).abs() < 1e-9);
        assert!(Site::new(91.0, 0.0, 0.0, DVec3::NEG_Z, 0.2).is_err());
        assert!(Site::new(0.0, 0.0, 0.0, DVec3::Y, 0.2).is_err());
        assert!(Site::new(0.0, 0.0, 0.0, DVec3::NEG_Z, 1.0).is_err());
    }
}
