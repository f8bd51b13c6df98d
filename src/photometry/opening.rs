//! The luminous opening of a luminaire: the part that emits, as its photometric file gives
//! it (IES width/length/height, EULUMDAT luminous-area dimensions), in metres, in the
//! luminaire frame (`aim`, `c0`, `c90 = aim × c0`). A flat opening faces along the aim.
//!
//! Conventions of the two formats:
//! - **IES LM-63** (2002, 2019): length lies along the 0°–180° axis (`c0`), width along
//!   90°–270° (`c90`), height along the aim. All zero is a point; positive width and length
//!   a rectangle (with luminous sides when the height is positive); negative width and
//!   length a disk or ellipse of those diameters (a vertical cylinder with a positive
//!   height); all three negative a sphere or ellipsoid. The remaining combinations
//!   (horizontal cylinders, openings facing sideways) are taken as their bounding box.
//! - **EULUMDAT**: the luminous area's length lies along C90–C270 (`c90`) and its width
//!   along C0–C180 (`c0`); a width of 0 makes it a disk of diameter "length"; the heights
//!   of the luminous area towards C0, C90, C180 and C270 are luminous sides (their largest
//!   is used).

/// A luminous opening, metres.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum LuminousOpening {
    /// No dimensions: a point source.
    #[default]
    Point,
    /// A flat rectangle facing along the aim, with luminous sides `sides` high (0: none).
    Rectangle {
        along_c0: f64,
        along_c90: f64,
        sides: f64,
    },
    /// A flat disk or ellipse (diameters) facing along the aim; with `sides` > 0 a
    /// cylinder whose mantle emits too.
    Disk {
        along_c0: f64,
        along_c90: f64,
        sides: f64,
    },
    /// A sphere or ellipsoid (diameters along c0, c90 and the aim).
    Sphere {
        along_c0: f64,
        along_c90: f64,
        along_aim: f64,
    },
}

impl LuminousOpening {
    /// From an IES file's width, length and height, already in metres.
    pub fn from_ies(width: f64, length: f64, height: f64) -> Result<LuminousOpening, String> {
        if [width, length, height].iter().any(|v| !v.is_finite()) {
            return Err("luminous dimensions must be finite".into());
        }
        let (w, l, h) = (width, length, height);
        Ok(if w == 0.0 && l == 0.0 && h == 0.0 {
            LuminousOpening::Point
        } else if w > 0.0 && l > 0.0 && h >= 0.0 {
            LuminousOpening::Rectangle {
                along_c0: l,
                along_c90: w,
                sides: h,
            }
        } else if w < 0.0 && l < 0.0 && h >= 0.0 {
            LuminousOpening::Disk {
                along_c0: -l,
                along_c90: -w,
                sides: h,
            }
        } else if w < 0.0 && l < 0.0 && h < 0.0 {
            LuminousOpening::Sphere {
                along_c0: -l,
                along_c90: -w,
                along_aim: -h,
            }
        } else {
            LuminousOpening::Rectangle {
                along_c0: l.abs(),
                along_c90: w.abs(),
                sides: h.abs(),
            }
        })
    }

    /// From an EULUMDAT file's luminous-area length and width and its four side heights,
    /// metres.
    pub fn from_ldt(length: f64, width: f64, heights: [f64; 4]) -> LuminousOpening {
        let sides = heights.iter().fold(0.0f64, |m, h| m.max(*h));
        if length <= 0.0 && width <= 0.0 {
            LuminousOpening::Point
        } else if width <= 0.0 {
            LuminousOpening::Disk {
                along_c0: length,
                along_c90: length,
                sides,
            }
        } else {
            LuminousOpening::Rectangle {
                along_c0: width,
                along_c90: length.max(0.0),
                sides,
            }
        }
    }

    /// The extents along c0, c90 and the aim (for a flat opening, the height of its
    /// luminous sides), metres; zeros for a point.
    fn extents(&self) -> [f64; 3] {
        match *self {
            LuminousOpening::Point => [0.0; 3],
            LuminousOpening::Rectangle {
                along_c0,
                along_c90,
                sides,
            }
            | LuminousOpening::Disk {
                along_c0,
                along_c90,
                sides,
            } => [along_c0, along_c90, sides],
            LuminousOpening::Sphere {
                along_c0,
                along_c90,
                along_aim,
            } => [along_c0, along_c90, along_aim],
        }
    }

    /// The largest dimension, metres (0 for a point).
    pub fn largest_dimension(&self) -> f64 {
        self.extents().into_iter().fold(0.0, f64::max)
    }

    /// The luminous area seen from a direction given in the luminaire frame by its
    /// components along (aim, c0, c90) (a unit vector from the luminaire towards the
    /// viewer), m². A flat opening is seen only from its front (`a > 0`); luminous sides
    /// and spheres from everywhere.
    pub fn projected_area(&self, a: f64, c0: f64, c90: f64) -> f64 {
        use std::f64::consts::FRAC_PI_4;
        // x along c0, y along c90, z along the aim (the sides' height when flat).
        let [x, y, z] = self.extents();
        match self {
            LuminousOpening::Point => 0.0,
            LuminousOpening::Rectangle { .. } => {
                x * y * a.max(0.0) + z * (y * c0.abs() + x * c90.abs())
            }
            LuminousOpening::Disk { .. } => {
                // The mantle of an elliptic cylinder seen from the side: its width across
                // the view times its height.
                let across = (c0 * y).hypot(c90 * x) / c0.hypot(c90).max(1e-12);
                FRAC_PI_4 * x * y * a.max(0.0) + z * across * (1.0 - a * a).max(0.0).sqrt()
            }
            LuminousOpening::Sphere { .. } => {
                // An ellipsoid's silhouette: π/4 · √((yz·c0)² + (xz·c90)² + (xy·a)²).
                FRAC_PI_4
                    * ((y * z * c0).powi(2) + (x * z * c90).powi(2) + (x * y * a).powi(2)).sqrt()
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ies_sign_conventions_give_the_lm63_shapes() {
        assert_eq!(
            LuminousOpening::from_ies(0.0, 0.0, 0.0).unwrap(),
            LuminousOpening::Point
        );
        // Width along 90°–270°, length along 0°–180°.
        assert_eq!(
            LuminousOpening::from_ies(0.3, 1.2, 0.0).unwrap(),
            LuminousOpening::Rectangle {
                along_c0: 1.2,
                along_c90: 0.3,
                sides: 0.0
            }
        );
        assert_eq!(
            LuminousOpening::from_ies(-0.2, -0.2, 0.0).unwrap(),
            LuminousOpening::Disk {
                along_c0: 0.2,
                along_c90: 0.2,
                sides: 0.0
            }
        );
        assert!(matches!(
            LuminousOpening::from_ies(-0.1, -0.1, -0.1).unwrap(),
            LuminousOpening::Sphere { .. }
        ));
        assert!(LuminousOpening::from_ies(f64::NAN, 0.0, 0.0).is_err());
    }

    #[test]
    fn projected_areas_of_the_shapes() {
        let r = LuminousOpening::from_ies(0.3, 1.2, 0.0).unwrap();
        // From straight below: the full 0.36 m²; at 60° from the aim: half of it.
        assert!((r.projected_area(1.0, 0.0, 0.0) - 0.36).abs() < 1e-12);
        let (s, c) = 60f64.to_radians().sin_cos();
        assert!((r.projected_area(c, s, 0.0) - 0.18).abs() < 1e-12);
        assert_eq!(r.projected_area(-1.0, 0.0, 0.0), 0.0);
        // A sphere of 0.2 m looks the same from everywhere.
        let sphere = LuminousOpening::from_ies(-0.2, -0.2, -0.2).unwrap();
        let disk = std::f64::consts::FRAC_PI_4 * 0.04;
        assert!((sphere.projected_area(0.0, 1.0, 0.0) - disk).abs() < 1e-12);
        assert!((sphere.projected_area(0.6, 0.0, 0.8) - disk).abs() < 1e-12);
        // A cylinder 0.1 m across and 0.3 m high, seen from the side: 0.03 m² of mantle.
        let cyl = LuminousOpening::from_ies(-0.1, -0.1, 0.3).unwrap();
        assert!((cyl.projected_area(0.0, 1.0, 0.0) - 0.03).abs() < 1e-12);
    }
}
