//! How much work a `final` image gets: samples, gather rays, shadow rays and filter
//! passes per pixel, and how the gather rays fall with the image size.

/// How much work a `final` image gets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FinalSettings {
    /// Jittered primary samples per pixel side (k² per pixel), for antialiasing.
    pub samples_per_side: u32,
    /// Gather rays per pixel, shared among its samples, for images of up to
    /// [`GATHER_REFERENCE_PIXELS`]; larger ones get fewer per pixel when `scale_gather`
    /// ([`FinalSettings::for_pixels`]).
    pub gather_rays: u32,
    /// Shadow rays per pixel sample for the dominant emitting triangle (fewer for
    /// triangles that give less light, at least 1).
    pub emitter_rays: u32,
    /// Rays per pixel drawn from the specular lobe of a glossy surface, shared among its
    /// samples (0: no glossy reflections nor highlights).
    pub specular_rays: u32,
    /// À-trous passes over the indirect light (0: unfiltered).
    pub filter_passes: u32,
    /// Mixed into every pixel's random sequence: two seeds give two independent images,
    /// whose difference measures the noise (benches).
    pub seed: u32,
    /// Whether images larger than [`GATHER_REFERENCE_PIXELS`] get fewer gather rays per
    /// pixel (false when `RELIGHT_FINAL_GATHER` fixes them, [`FinalSettings::from_env`]).
    pub scale_gather: bool,
}

/// The image size (pixels, 512²) up to which a pixel gets [`FinalSettings::gather_rays`]
/// gather rays. A larger image gets about as many per unit of image area instead
/// (down to a quarter per pixel), and the filter one more pass where that halves them
/// or more, so its indirect light is about as smooth as at this size: the gather's
/// noise is in the scene, not in the pixels, and one more à-trous pass doubles the
/// filter's reach. On the Cornell box at 1024² (12 rays per pixel, 3 passes) the
/// image, box-filtered to 256², is as close to the 262,144-spp path tracing (0.80 %) as
/// the 512² one with 48 rays (0.84 %).
pub const GATHER_REFERENCE_PIXELS: u64 = 512 * 512;

impl FinalSettings {
    /// The settings for an image of `pixels`: fewer gather rays per pixel past
    /// [`GATHER_REFERENCE_PIXELS`] (a whole square grid per camera sample, at least a
    /// quarter of `gather_rays`), with one more filter pass where they are halved or more.
    pub fn for_pixels(&self, pixels: u64) -> FinalSettings {
        if !self.scale_gather || pixels <= GATHER_REFERENCE_PIXELS {
            return *self;
        }
        let full = self.gather_rays as u64;
        let want = (full * GATHER_REFERENCE_PIXELS / pixels).max(full / 4);
        let k2 = (self.samples_per_side.max(1) as u64).pow(2);
        // A whole grid per camera sample.
        let each = (want / k2).max(1) as usize;
        let rays = (super::gather::ray_count(each) as u64 * k2).min(full);
        FinalSettings {
            gather_rays: rays as u32,
            filter_passes: self.filter_passes + u32::from(2 * rays <= full),
            ..*self
        }
    }
}

impl Default for FinalSettings {
    /// The documented work per pixel: 2 × 2 samples, 48 gather rays (fewer past
    /// [`GATHER_REFERENCE_PIXELS`]), 16 emitter and 16 specular rays, 2 filter passes, seed 0.
    fn default() -> Self {
        FinalSettings {
            samples_per_side: 2,
            gather_rays: 48,
            emitter_rays: 16,
            specular_rays: 16,
            filter_passes: 2,
            seed: 0,
            scale_gather: true,
        }
    }
}

impl FinalSettings {
    /// The defaults with the benches' overrides from the environment, read once where a
    /// process starts (`relight serve`, `relight render`, the examples):
    /// `RELIGHT_FINAL_SPS`, `RELIGHT_FINAL_GATHER` (which also fixes the gather rays at
    /// every image size), `RELIGHT_FINAL_EMITTER`, `RELIGHT_FINAL_SPECULAR`,
    /// `RELIGHT_FINAL_FILTER` and `RELIGHT_FINAL_SEED`. A variable that does not parse
    /// keeps its default.
    pub fn from_env() -> FinalSettings {
        Self::from_vars(|k| std::env::var_os(k))
    }

    /// [`Self::from_env`] with the variables looked up by `var`.
    fn from_vars(var: impl Fn(&str) -> Option<std::ffi::OsString>) -> FinalSettings {
        let d = FinalSettings::default();
        let num = |k: &str, d: u32| {
            var(k)
                .and_then(|v| v.into_string().ok())
                .and_then(|v| v.parse().ok())
                .unwrap_or(d)
        };
        FinalSettings {
            scale_gather: var("RELIGHT_FINAL_GATHER").is_none(),
            samples_per_side: num("RELIGHT_FINAL_SPS", d.samples_per_side),
            gather_rays: num("RELIGHT_FINAL_GATHER", d.gather_rays),
            emitter_rays: num("RELIGHT_FINAL_EMITTER", d.emitter_rays),
            specular_rays: num("RELIGHT_FINAL_SPECULAR", d.specular_rays),
            filter_passes: num("RELIGHT_FINAL_FILTER", d.filter_passes),
            seed: num("RELIGHT_FINAL_SEED", d.seed),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Past 512², a pixel gets about as many gather rays per unit of image area as at
    /// 512² (a whole grid per camera sample, at least a quarter of the rays), and the
    /// filter one more pass where they are halved or more; a fixed ray count stays.
    #[test]
    fn gather_rays_per_pixel_fall_with_the_image_size() {
        let base = FinalSettings::default();
        let at = |w: u64, h: u64| {
            let s = base.for_pixels(w * h);
            (s.gather_rays, s.filter_passes)
        };
        assert_eq!(at(512, 512), (48, 2));
        assert_eq!(at(256, 256), (48, 2));
        // 512² · 48 / (800 · 600) = 26.2: 6 per sample, a 2 × 3 grid each (24), which
        // halves them: one more pass.
        assert_eq!(at(800, 600), (24, 3));
        // 16 per pixel: a 2 × 2 grid per sample, one more pass.
        assert_eq!(at(1024, 768), (16, 3));
        // 12: never below a quarter (a 1 × 3 grid per sample).
        assert_eq!(at(1024, 1024), (12, 3));
        let fixed = FinalSettings {
            scale_gather: false,
            ..base
        };
        assert_eq!(fixed.for_pixels(1024 * 1024), fixed);
    }

    /// The environment's overrides: a set `RELIGHT_FINAL_GATHER` fixes the gather rays at
    /// every size, one that does not parse keeps its default, none gives the defaults.
    #[test]
    fn the_environment_overrides_the_defaults() {
        use std::ffi::OsString;
        assert_eq!(FinalSettings::from_vars(|_| None), FinalSettings::default());
        let set = |k: &str| match k {
            "RELIGHT_FINAL_GATHER" => Some(OsString::from("96")),
            "RELIGHT_FINAL_SEED" => Some(OsString::from("7")),
            "RELIGHT_FINAL_SPS" => Some(OsString::from("many")),
            _ => None,
        };
        let s = FinalSettings::from_vars(set);
        assert_eq!(
            s,
            FinalSettings {
                gather_rays: 96,
                seed: 7,
                scale_gather: false,
                ..FinalSettings::default()
            }
        );
    }
}
