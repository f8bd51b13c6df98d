//! Photometric RGB triples and the luminous value of a triple.
//!
//! Every light quantity in relight is a linear RGB triple in photometric units:
//! exitance and radiosity in lm/m², illuminance in lux (= lm/m²), flux in lm.
//! The luminous (photopic) value of a triple is its Rec. 709 / sRGB luminance
//! `Y = 0.2126 R + 0.7152 G + 0.0722 B`, so a "white" triple `[v, v, v]` has `Y = v`.
//!
//! [`Rgb`] holds a triple in `f32`, as stored; [`Rgb64`] in `f64`, for sums over many
//! patches. Both are plain triples with component-wise arithmetic (`a + b`, `a * b`,
//! `a * k`), serialize as a 3-element array, and index by channel (`c[0]` is red).
//! Per-patch columns are stored interleaved (`n × 3` `f32`: r, g, b per patch);
//! [`Rgb::column`] reads one as `&[Rgb]` without copying.

use std::fmt;
use std::iter::Sum;
use std::ops::{Add, AddAssign, Div, Index, IndexMut, Mul, MulAssign, Neg, Sub, SubAssign};

use serde::{Deserialize, Serialize};

/// Rec. 709 luminance weights: the luminous value of an RGB triple.
pub const LUMA: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// A linear RGB triple in `f32`. Its unit depends on the quantity it holds: exitance and
/// radiosity lm/m², illuminance lux, flux lm, radiance cd/m²; reflectances and colour
/// filters are unitless.
#[repr(transparent)]
#[derive(
    Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable, Serialize, Deserialize,
)]
#[serde(transparent)]
pub struct Rgb(pub [f32; 3]);

/// A linear RGB triple in `f64`, for sums over many patches (units as [`Rgb`]).
#[repr(transparent)]
#[derive(Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Rgb64(pub [f64; 3]);

impl Rgb {
    /// Luminous value Y (lm/m² for exitance, lux for illuminance, lm for flux).
    #[inline]
    pub fn luminance(self) -> f32 {
        LUMA[0] * self.0[0] + LUMA[1] * self.0[1] + LUMA[2] * self.0[2]
    }

    /// The triple in `f64`.
    #[inline]
    pub fn to_f64(self) -> Rgb64 {
        Rgb64(self.0.map(f64::from))
    }

    /// An interleaved column (`n × 3` values: r, g, b per patch) as `n` triples, without
    /// copying. Panics when the length is not a multiple of 3.
    #[inline]
    pub fn column(values: &[f32]) -> &[Rgb] {
        bytemuck::cast_slice(values)
    }

    /// [`Rgb::column`], mutable.
    #[inline]
    pub fn column_mut(values: &mut [f32]) -> &mut [Rgb] {
        bytemuck::cast_slice_mut(values)
    }
}

impl Rgb64 {
    /// Luminous value Y (lm/m² for exitance, lux for illuminance, lm for flux).
    #[inline]
    pub fn luminance(self) -> f64 {
        LUMA[0] as f64 * self.0[0] + LUMA[1] as f64 * self.0[1] + LUMA[2] as f64 * self.0[2]
    }

    /// The triple in `f32` (each channel rounded to nearest).
    #[inline]
    pub fn to_f32(self) -> Rgb {
        Rgb(self.0.map(|v| v as f32))
    }
}

/// Constructors, component-wise helpers and arithmetic shared by [`Rgb`] and [`Rgb64`].
macro_rules! triple {
    ($T:ident, $f:ty) => {
        impl $T {
            /// Black (or no light, or a zero weight).
            pub const ZERO: $T = $T([0.0; 3]);
            /// White of value 1.
            pub const ONE: $T = $T([1.0; 3]);

            #[inline]
            pub const fn new(r: $f, g: $f, b: $f) -> $T {
                $T([r, g, b])
            }

            /// The grey `[v, v, v]` (luminance `v`).
            #[inline]
            pub const fn splat(v: $f) -> $T {
                $T([v; 3])
            }

            /// `f` applied to each channel.
            #[inline]
            pub fn map(self, f: impl FnMut($f) -> $f) -> $T {
                $T(self.0.map(f))
            }

            /// `f` applied channel by channel to `self` and `other`.
            #[inline]
            pub fn zip_map(self, other: $T, mut f: impl FnMut($f, $f) -> $f) -> $T {
                $T(std::array::from_fn(|c| f(self.0[c], other.0[c])))
            }

            /// The largest channel.
            #[inline]
            pub fn max_component(self) -> $f {
                self.0[0].max(self.0[1]).max(self.0[2])
            }

            /// The smallest channel.
            #[inline]
            pub fn min_component(self) -> $f {
                self.0[0].min(self.0[1]).min(self.0[2])
            }

            /// Whether every channel is finite.
            #[inline]
            pub fn is_finite(self) -> bool {
                self.0.iter().all(|v| v.is_finite())
            }

            /// The channels, red first.
            #[inline]
            pub fn iter(&self) -> std::slice::Iter<'_, $f> {
                self.0.iter()
            }
        }

        /// Written as the array (`[0.5, 0.5, 0.5]`), as messages have always shown it.
        impl fmt::Debug for $T {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                fmt::Debug::fmt(&self.0, f)
            }
        }

        impl From<[$f; 3]> for $T {
            #[inline]
            fn from(c: [$f; 3]) -> $T {
                $T(c)
            }
        }

        impl From<$T> for [$f; 3] {
            #[inline]
            fn from(c: $T) -> [$f; 3] {
                c.0
            }
        }

        impl PartialEq<[$f; 3]> for $T {
            #[inline]
            fn eq(&self, other: &[$f; 3]) -> bool {
                self.0 == *other
            }
        }

        impl Index<usize> for $T {
            type Output = $f;
            #[inline]
            fn index(&self, c: usize) -> &$f {
                &self.0[c]
            }
        }

        impl IndexMut<usize> for $T {
            #[inline]
            fn index_mut(&mut self, c: usize) -> &mut $f {
                &mut self.0[c]
            }
        }

        impl Add for $T {
            type Output = $T;
            #[inline]
            fn add(self, o: $T) -> $T {
                self.zip_map(o, |a, b| a + b)
            }
        }

        impl Sub for $T {
            type Output = $T;
            #[inline]
            fn sub(self, o: $T) -> $T {
                self.zip_map(o, |a, b| a - b)
            }
        }

        /// Component-wise product (a reflectance times an illuminance, a weight times a
        /// column).
        impl Mul for $T {
            type Output = $T;
            #[inline]
            fn mul(self, o: $T) -> $T {
                self.zip_map(o, |a, b| a * b)
            }
        }

        impl Mul<$f> for $T {
            type Output = $T;
            #[inline]
            fn mul(self, k: $f) -> $T {
                self.map(|a| a * k)
            }
        }

        impl Mul<$T> for $f {
            type Output = $T;
            #[inline]
            fn mul(self, c: $T) -> $T {
                c.map(|a| self * a)
            }
        }

        impl Div<$f> for $T {
            type Output = $T;
            #[inline]
            fn div(self, k: $f) -> $T {
                self.map(|a| a / k)
            }
        }

        impl Neg for $T {
            type Output = $T;
            #[inline]
            fn neg(self) -> $T {
                self.map(|a| -a)
            }
        }

        impl AddAssign for $T {
            #[inline]
            fn add_assign(&mut self, o: $T) {
                *self = *self + o;
            }
        }

        impl SubAssign for $T {
            #[inline]
            fn sub_assign(&mut self, o: $T) {
                *self = *self - o;
            }
        }

        impl MulAssign for $T {
            #[inline]
            fn mul_assign(&mut self, o: $T) {
                *self = *self * o;
            }
        }

        impl MulAssign<$f> for $T {
            #[inline]
            fn mul_assign(&mut self, k: $f) {
                *self = *self * k;
            }
        }

        impl Sum for $T {
            fn sum<I: Iterator<Item = $T>>(iter: I) -> $T {
                iter.fold($T::ZERO, |a, b| a + b)
            }
        }

        impl<'a> Sum<&'a $T> for $T {
            fn sum<I: Iterator<Item = &'a $T>>(iter: I) -> $T {
                iter.fold($T::ZERO, |a, b| a + *b)
            }
        }
    };
}

triple!(Rgb, f32);
triple!(Rgb64, f64);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_has_its_own_luminance() {
        assert!((Rgb::splat(3.0).luminance() - 3.0).abs() < 1e-6);
        assert!((Rgb::new(1.0, 0.0, 0.0).luminance() - 0.2126).abs() < 1e-7);
        assert!((Rgb::new(0.0, 1.0, 0.0).luminance() - 0.7152).abs() < 1e-7);
        assert!((Rgb64::splat(250.0).luminance() - 250.0).abs() < 1e-9);
        // 500 lux of a warm white: 0.2126·600 + 0.7152·500 + 0.0722·300.
        let e = Rgb64::new(600.0, 500.0, 300.0);
        assert!((e.luminance() - 506.82).abs() < 1e-4);
    }

    #[test]
    fn arithmetic_is_channel_by_channel() {
        let rho = Rgb::new(0.8, 0.5, 0.2);
        let h = Rgb::new(100.0, 200.0, 400.0);
        assert_eq!(rho * h, Rgb::new(80.0, 100.0, 80.0));
        assert_eq!(h + h, h * 2.0);
        assert_eq!(2.0 * h, h * 2.0);
        assert_eq!(h - h, Rgb::ZERO);
        assert_eq!(h / 4.0, Rgb::new(25.0, 50.0, 100.0));
        assert_eq!(-Rgb::ONE, Rgb::splat(-1.0));
        let mut b = Rgb::new(1.0, 2.0, 3.0);
        b += Rgb::ONE;
        b *= 2.0;
        b *= Rgb::new(1.0, 0.5, 0.0);
        b -= Rgb::new(1.0, 1.0, 1.0);
        assert_eq!(b, [3.0, 2.0, -1.0]);
        assert_eq!(b[0], 3.0);
        b[2] = 7.0;
        assert_eq!(b.max_component(), 7.0);
        assert_eq!(b.min_component(), 2.0);
        assert_eq!(Rgb::new(1.0, 2.0, 3.0).map(|v| v * v), [1.0, 4.0, 9.0]);
        let total: Rgb = [Rgb::ONE, Rgb::splat(2.0), Rgb::new(0.0, 0.0, 1.0)]
            .iter()
            .sum();
        assert_eq!(total, [3.0, 3.0, 4.0]);
        assert!(Rgb::ONE.is_finite());
        assert!(!Rgb::new(1.0, f32::NAN, 0.0).is_finite());
        assert!(!Rgb::new(1.0, 0.0, f32::INFINITY).is_finite());
    }

    #[test]
    fn f64_conversions_round_trip() {
        let c = Rgb::new(0.1, 0.2, 0.3);
        assert_eq!(c.to_f64(), [0.1f32 as f64, 0.2f32 as f64, 0.3f32 as f64]);
        assert_eq!(c.to_f64().to_f32(), c);
        assert_eq!(<[f32; 3]>::from(c), [0.1, 0.2, 0.3]);
        assert_eq!(Rgb::from([0.1, 0.2, 0.3]), c);
    }

    #[test]
    fn an_interleaved_column_reads_as_triples() {
        // Two patches: (10, 20, 30) and (1, 2, 3) lm/m².
        let mut b = vec![10.0f32, 20.0, 30.0, 1.0, 2.0, 3.0];
        let rgb = Rgb::column(&b);
        assert_eq!(rgb, [Rgb::new(10.0, 20.0, 30.0), Rgb::new(1.0, 2.0, 3.0)]);
        assert!((rgb[1].luminance() - (0.2126 + 1.4304 + 0.2166)).abs() < 1e-6);
        Rgb::column_mut(&mut b)[1] *= 2.0;
        assert_eq!(b, [10.0, 20.0, 30.0, 2.0, 4.0, 6.0]);
    }

    #[test]
    fn serializes_as_a_plain_array() {
        let c = Rgb::new(1.0, 0.5, 0.25);
        assert_eq!(serde_json::to_string(&c).unwrap(), "[1.0,0.5,0.25]");
        assert_eq!(
            serde_json::to_string(&[1.0f32, 0.5, 0.25]).unwrap(),
            "[1.0,0.5,0.25]"
        );
        let back: Rgb = serde_json::from_str("[1, 0.5, 0.25]").unwrap();
        assert_eq!(back, c);
        assert!(serde_json::from_str::<Rgb>("[1, 2]").is_err());
        assert_eq!(
            serde_json::to_string(&Rgb64::new(2.0, 3.0, 4.5)).unwrap(),
            "[2.0,3.0,4.5]"
        );
        assert_eq!(format!("{c:?}"), format!("{:?}", [1.0f32, 0.5, 0.25]));
    }
}
