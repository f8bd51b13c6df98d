//! The pinhole camera an image is seen through, and its checks.

use glam::Vec3;

use super::raster::MAX_SIDE;
use crate::scene::CameraDef;

/// A pinhole camera. `fov_deg` is the vertical field of view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    pub fov_deg: f32,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    pub fn from_def(c: &CameraDef, width: u32, height: u32) -> Camera {
        let v = |a: [f64; 3]| Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
        Camera {
            position: v(c.position),
            target: v(c.target),
            up: v(c.up),
            fov_deg: c.fov_deg as f32,
            width,
            height,
        }
    }

    /// Checks the numbers; the message names the problem.
    pub fn validate(&self) -> Result<(), String> {
        if self.width == 0 || self.height == 0 || self.width > MAX_SIDE || self.height > MAX_SIDE {
            return Err(format!(
                "image size {}×{}: width and height must be 1 to {MAX_SIDE}",
                self.width, self.height
            ));
        }
        let finite = [self.position, self.target, self.up]
            .iter()
            .all(|v| v.is_finite());
        if !finite {
            return Err("camera position, target and up must be finite".into());
        }
        if !(self.fov_deg > 0.5 && self.fov_deg < 179.0) {
            return Err(format!("fov_deg {} must be in (0.5, 179)", self.fov_deg));
        }
        let f = self.target - self.position;
        if f.length() < 1e-6 {
            return Err("camera target must differ from its position".into());
        }
        if f.normalize().cross(self.up.normalize_or_zero()).length() < 1e-4 {
            return Err("camera up must not be parallel to the view direction".into());
        }
        Ok(())
    }

    /// A key for view-buffer caches.
    pub fn key(&self) -> [u32; 12] {
        let b = |x: f32| x.to_bits();
        [
            b(self.position.x),
            b(self.position.y),
            b(self.position.z),
            b(self.target.x),
            b(self.target.y),
            b(self.target.z),
            b(self.up.x),
            b(self.up.y),
            b(self.up.z),
            b(self.fov_deg),
            self.width,
            self.height,
        ]
    }
}
