//! The dark-room pass: links checked again against each light column's own brightness.
//!
//! Refinement ([`super::refine`]) bounds a link's factor error by ε / (1 + glow), where the
//! glow is the source's brightness over the scene's mean radiosity with every group on.
//! That bound is absolute: a link may be off by about ε × the mean radiosity in lux. A
//! lit room gathers hundreds of times that, so the error is a fraction of a percent there.
//! A room whose own group is off and that is lit by another group only through a door
//! gathers some 0.1–0.3 % of the lit rooms' illuminance, and the same bound is then a
//! percent error per link (measured on the three-room scene of `benches/doors`: the rooms
//! one and two openings away from the only lit room read up to 11 % low).
//!
//! So after the links are assembled, the scene is solved once per light column (the
//! groups), and every link r ← s whose bound exceeds what its receiver needs is refined
//! again. In column g, with M_g the column's area-mean radiosity (lm/m²), the receiver's
//! importance is its leaves' area-mean incident illuminance `E_r` (lux, direct light
//! included) and the source's its brightest leaf's radiosity `B_s`, both over `M_g`. A
//! link's factor error must then stay below
//!
//! `t(r, s) = ε · min_g max(E_r / M_g, FLOOR) / (B_s / M_g)`
//!
//! in every column where the source is lit: its error in lux, spread × B_s, is at most ε
//! of what the receiver itself gathers. In a lit room t is above the first pass's bound
//! (those links stay as they are); from a lit room into a dark one it is far below it, so
//! the links through openings are refined down towards the patches, with more visibility
//! rays each ([`super::refine`] scales the rays with F / t). [`FLOOR`] keeps surfaces that
//! a column does not reach at all from refining every link that touches them.
//!
//! The pass sees every link the first pass made, the ones it judged wholly hidden
//! included (kept as zero links until assembly). It runs only with per-group accuracy
//! (scene.toml `per_group_accuracy`): on office-floor a quarter of the links need it,
//! which costs several times the first pass (docs/accuracy.md).
//!
//! The area mean, not the dimmest leaf, measures a receiver: with the dimmest leaf, a
//! cluster reaching into a corner held every link to the corner's level, for 5 % more
//! work and no measurable gain on the three-room scene.

use rayon::prelude::*;

use super::tree::Tree;
use super::Hierarchy;
use crate::color::Rgb;
use crate::geometry::bvh::Bvh;
use crate::transport::formfactor::FormFactorOptions;

/// Tolerance and most sweeps of the dark-room pass's solve: it only ranks the patches'
/// brightness, so it stops well before the transfer's own solve.
const DARK_PASS_TOL: f64 = 1e-5;
const DARK_PASS_SWEEPS: usize = 200;

/// What the dark-room pass ([`self`]) reads besides the links: the scene's BVH
/// and form-factor options (to refine), and the light columns the transfer solves.
pub struct DarkRoomPass<'a> {
    pub bvh: &'a Bvh,
    pub ff: FormFactorOptions,
    /// Per patch, the reflectance.
    pub rho: &'a [Rgb],
    /// Per light column (each group at intensity 1; daylight), its source `E + ρD`
    /// (lm/m², n × 3 interleaved).
    pub sources: Vec<Vec<f32>>,
    /// Per light column, its direct illuminance (lux, n × 3); None without.
    pub direct: Vec<Option<Vec<f32>>>,
}

/// Receivers dimmer than this fraction of a column's mean radiosity are held to it: an
/// error of ε × FLOOR × the mean per link. On the three-room scene of `benches/doors`
/// the room behind a door and a window gathers about 1e-2 of group a's mean radiosity
/// (the mean over the whole scene, most of it dark).
pub const FLOOR: f32 = 1e-3;

/// Per node of the cluster tree and light column: how bright the node is as a receiver
/// (its leaves' area-mean incident illuminance) and as a source (its brightest leaf's
/// radiosity), over the column's area-mean radiosity.
pub struct Importance {
    cols: usize,
    rcv: Vec<f32>,
    src: Vec<f32>,
}

impl Importance {
    /// From a solve: per patch and column (row-major n × `cols`) the radiosity `b`
    /// (lm/m²) and the incident illuminance `e` (lux, direct light included), channel
    /// means. Columns with no light get no say.
    pub fn new(tree: &Tree, b: &[f32], e: &[f32], cols: usize) -> Importance {
        let n = tree.n;
        let nodes = tree.nodes();
        let mut mean = vec![0f64; cols];
        let mut area = 0f64;
        for i in 0..n {
            let a = tree.area[i];
            area += a;
            for (m, &v) in mean.iter_mut().zip(&b[i * cols..(i + 1) * cols]) {
                *m += a * v as f64;
            }
        }
        let inv: Vec<f32> = mean
            .iter()
            .map(|&m| {
                let m = m / area.max(1e-300);
                if m > 0.0 {
                    (1.0 / m) as f32
                } else {
                    0.0
                }
            })
            .collect();
        let mut rcv = vec![0f32; nodes * cols];
        let mut src = vec![0f32; nodes * cols];
        rcv[..n * cols]
            .par_chunks_mut(cols)
            .zip(src[..n * cols].par_chunks_mut(cols))
            .enumerate()
            .for_each(|(i, (r, s))| {
                for g in 0..cols {
                    r[g] = e[i * cols + g].max(0.0) * inv[g];
                    s[g] = b[i * cols + g].max(0.0) * inv[g];
                }
            });
        for (k, ch) in tree.children.iter().enumerate() {
            let p = (n + k) * cols;
            let (a, c) = (ch[0] as usize * cols, ch[1] as usize * cols);
            let (wa, wc) = (tree.area[ch[0] as usize], tree.area[ch[1] as usize]);
            let w = 1.0 / (wa + wc).max(1e-300);
            for g in 0..cols {
                let mean = (wa * rcv[a + g] as f64 + wc * rcv[c + g] as f64) * w;
                rcv[p + g] = mean as f32;
                src[p + g] = src[a + g].max(src[c + g]);
            }
        }
        Importance { cols, rcv, src }
    }

    /// Each light column's brightness per node of `tree` from a solve over the links
    /// `h`; None without columns.
    pub fn solve(tree: &Tree, h: &Hierarchy, pass: &DarkRoomPass<'_>) -> Option<Importance> {
        let g = pass.sources.len();
        let n = tree.n;
        if g == 0 || pass.rho.len() != n || pass.sources.iter().any(|s| s.len() != 3 * n) {
            return None;
        }
        let c = 3 * g;
        let mut src = vec![0f32; n * c];
        for (gi, col) in pass.sources.iter().enumerate() {
            for (i, v) in col.chunks_exact(3).enumerate() {
                src[i * c + 3 * gi..i * c + 3 * gi + 3].copy_from_slice(v);
            }
        }
        let sol = h.solve(pass.rho, &src, c, DARK_PASS_TOL, DARK_PASS_SWEEPS, &|_| {});
        drop(src);
        let mean3 = |x: &[f32]| (x[0] + x[1] + x[2]) / 3.0;
        let mut b = vec![0f32; n * g];
        let mut e = vec![0f32; n * g];
        for i in 0..n {
            for gi in 0..g {
                let k = i * c + 3 * gi;
                let d = pass
                    .direct
                    .get(gi)
                    .and_then(|d| d.as_deref())
                    .and_then(|d| d.get(3 * i..3 * i + 3))
                    .map_or(0.0, mean3);
                b[i * g + gi] = mean3(&sol.b[k..k + 3]);
                e[i * g + gi] = mean3(&sol.h[k..k + 3]) + d;
            }
        }
        Some(Importance::new(tree, &b, &e, g))
    }

    /// The largest factor error the link r ← s may have: `t(r, s)` of the module doc for
    /// the refinement tolerance `eps`; infinite when no column lights the source.
    pub fn threshold(&self, r: u32, s: u32, eps: f64) -> f64 {
        let c = self.cols;
        let (rr, ss) = (
            &self.rcv[r as usize * c..(r as usize + 1) * c],
            &self.src[s as usize * c..(s as usize + 1) * c],
        );
        let mut t = f64::INFINITY;
        for (&e, &b) in rr.iter().zip(ss) {
            if b > 0.0 {
                t = t.min(eps * e.max(FLOOR) as f64 / b as f64);
            }
        }
        t
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        4 * (self.rcv.capacity() + self.src.capacity()) as u64
    }
}
