//! Glazing: panes that let daylight through, scaled by their transmittance.
//!
//! A surface or material with `transmittance` in `scene.toml` is glazing. It is not meshed
//! into patches (it neither reflects nor emits) and it does not block light between
//! patches. Only the rays of daylight cross it: the sky's and the ground's light and the
//! sun's beam that reach a patch, a point or a pixel through it are multiplied by its
//! transmittance (straight through, no diffusion; two panes multiply).

use glam::{DVec3, Vec3A};

use super::bvh::Bvh;

/// Hits closer than this along a segment (as a share of its length) are one crossing.
const SAME_CROSSING: f32 = 1e-6;

/// The glazing triangles of a scene and each one's transmittance.
pub struct Glazing {
    bvh: Bvh,
    t: Vec<f32>,
}

impl Glazing {
    /// Panes given as corner triples with their transmittances (0..1).
    pub fn new(tris: &[[Vec3A; 3]], t: Vec<f32>) -> Glazing {
        debug_assert_eq!(tris.len(), t.len());
        Glazing {
            bvh: Bvh::new(tris),
            t,
        }
    }

    /// No glazing.
    pub fn none() -> Glazing {
        Glazing::new(&[], Vec::new())
    }

    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The share of light that passes along the segment `from → to`: the product of the
    /// transmittances of the panes it crosses (1 when it crosses none). Crossings at the
    /// same place (through an edge two triangles of a pane share) count once.
    pub fn transmittance(&self, from: DVec3, to: DVec3) -> f64 {
        if self.t.is_empty() {
            return 1.0;
        }
        let mut hits: Vec<(f32, f32)> = Vec::new();
        self.bvh.each_hit(
            Vec3A::from(from.as_vec3()),
            Vec3A::from(to.as_vec3()),
            |id, at| hits.push((at, self.t[id as usize])),
        );
        hits.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut f = 1.0f64;
        let mut last = f32::NEG_INFINITY;
        for (at, t) in hits {
            if at - last > SAME_CROSSING {
                f *= t as f64;
            }
            last = at;
        }
        f
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pane(y: f32) -> [Vec3A; 3] {
        [
            Vec3A::new(-1.0, y, -1.0),
            Vec3A::new(1.0, y, -1.0),
            Vec3A::new(0.0, y, 2.0),
        ]
    }

    #[test]
    fn panes_a_segment_crosses_multiply() {
        let g = Glazing::new(&[pane(1.0), pane(2.0)], vec![0.7, 0.5]);
        let up = |h: f64| g.transmittance(DVec3::ZERO, DVec3::new(0.0, h, 0.0));
        assert_eq!(up(0.5), 1.0);
        assert!((up(1.5) - 0.7).abs() < 1e-6);
        assert!((up(3.0) - 0.35).abs() < 1e-6);
        // Through the edge the two triangles of a square pane share: one crossing.
        let sq = [
            [
                Vec3A::new(0.0, 1.0, 0.0),
                Vec3A::new(1.0, 1.0, 0.0),
                Vec3A::new(1.0, 1.0, 1.0),
            ],
            [
                Vec3A::new(0.0, 1.0, 0.0),
                Vec3A::new(1.0, 1.0, 1.0),
                Vec3A::new(0.0, 1.0, 1.0),
            ],
        ];
        let g2 = Glazing::new(&sq, vec![0.7, 0.7]);
        let t = g2.transmittance(DVec3::new(0.5, 0.0, 0.5), DVec3::new(0.5, 2.0, 0.5));
        assert!((t - 0.7).abs() < 1e-6, "{t}");
        // Beside the panes.
        assert_eq!(
            g.transmittance(DVec3::new(5.0, 0.0, 0.0), DVec3::new(5.0, 3.0, 0.0)),
            1.0
        );
        assert_eq!(Glazing::none().transmittance(DVec3::ZERO, DVec3::Y), 1.0);
    }
}
