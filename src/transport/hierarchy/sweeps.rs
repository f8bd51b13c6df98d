//! Solving through the links: Jacobi sweeps of pull (area means up the tree), gather
//! (`σ Σ k x` over each node's links) and push (irradiance down to the patches).

use rayon::prelude::*;

use super::Hierarchy;
use crate::color::Rgb;

/// A solve's result, per patch and column (row-major n × C).
pub struct HierarchySolution {
    /// Radiosity, lm/m².
    pub b: Vec<f32>,
    /// Irradiance gathered through the links, lux (direct light not included).
    pub h: Vec<f32>,
    pub sweeps: usize,
    /// Largest relative residual `‖S − (B − ρH)‖∞ / ‖S‖∞` over the columns.
    pub residual: f64,
}

impl Hierarchy {
    /// The irradiance `H = σ K B` (n × c) that the patch radiosities `b` (n × c) give.
    pub fn irradiance(&self, b: &[f32], c: usize) -> Vec<f32> {
        let mut x = vec![0f32; self.nodes() * c];
        x[..self.n * c].copy_from_slice(&b[..self.n * c]);
        self.pull(&mut x, c);
        self.gather(&x, c)
    }

    /// Area means of `c` columns from the leaves up (`x` is nodes × c; leaves filled).
    pub(super) fn pull(&self, x: &mut [f32], c: usize) {
        for (k, ch) in self.children.iter().enumerate() {
            let node = self.n + k;
            let (wa, wb) = (self.area[ch[0] as usize], self.area[ch[1] as usize]);
            let inv = 1.0 / self.area[node].max(f32::MIN_POSITIVE);
            let (lo, hi) = x.split_at_mut(node * c);
            let (a, b) = (ch[0] as usize * c, ch[1] as usize * c);
            for j in 0..c {
                hi[j] = (wa * lo[a + j] + wb * lo[b + j]) * inv;
            }
        }
    }

    /// `σ · Σ_links k · x_s` at every patch, links of ancestors included (push).
    fn gather(&self, x: &[f32], c: usize) -> Vec<f32> {
        let mut g = Vec::new();
        self.gather_into(x, c, &mut g);
        g.truncate(self.n * c);
        g
    }

    /// [`Hierarchy::gather`] into `g` (resized to nodes × c; the patches' rows come
    /// first), so that sweeps reuse one buffer: at a few hundred columns it is hundreds of
    /// MB, and a fresh one per sweep cost as much time in page faults as in arithmetic.
    pub(super) fn gather_into(&self, x: &[f32], c: usize, g: &mut Vec<f32>) {
        g.clear();
        g.resize(self.nodes() * c, 0.0);
        if c == 3 {
            // One RGB column (an emission answer): a loop the compiler keeps in registers.
            let xs = Rgb::column(x);
            let links = &self.links;
            Rgb::column_mut(g)
                .par_iter_mut()
                .enumerate()
                .with_min_len(256)
                .for_each(|(r, acc)| {
                    let range = links.of(r);
                    let mut sum = Rgb::ZERO;
                    for (&s, &k) in links.src[range.clone()].iter().zip(&links.k[range]) {
                        sum += xs[s as usize] * k;
                    }
                    *acc = sum;
                });
            self.push_sigma(g, c);
            return;
        }
        g.par_chunks_mut(c)
            .enumerate()
            .with_min_len(256)
            .for_each(|(r, acc)| {
                let links = &self.links;
                for l in links.of(r) {
                    let (k, s) = (links.k[l], links.src[l] as usize * c);
                    for (o, &v) in acc.iter_mut().zip(&x[s..s + c]) {
                        *o += k * v;
                    }
                }
            });
        self.push_sigma(g, c);
    }

    /// Pushes the irradiance `g` (nodes × c) of every node down to the patches under it
    /// and scales the patches' rows by σ.
    fn push_sigma(&self, g: &mut [f32], c: usize) {
        for k in (0..self.children.len()).rev() {
            let p = (self.n + k) * c;
            for ch in self.children[k] {
                let q = ch as usize * c;
                for j in 0..c {
                    g[q + j] += g[p + j];
                }
            }
        }
        g[..self.n * c]
            .par_chunks_mut(c)
            .zip(&self.sigma)
            .for_each(|(row, &s)| row.iter_mut().for_each(|v| *v *= s));
    }

    /// Solves `B = S + ρ H`, `H = σ K B` for `c` columns of sources `s` (n × c row-major,
    /// lm/m²); column j uses the reflectance channel j % 3. Jacobi sweeps until, in every
    /// column, the largest change is at most `tol` of the largest reflected radiosity ρH
    /// (emitters' own exitance does not set the scale), at most `max_sweeps`.
    pub fn solve(
        &self,
        rho: &[Rgb],
        s: &[f32],
        c: usize,
        tol: f64,
        max_sweeps: usize,
        progress: &(dyn Fn(f64) + Sync),
    ) -> HierarchySolution {
        let n = self.n;
        let mut x = vec![0f32; self.nodes() * c];
        x[..n * c].copy_from_slice(&s[..n * c]);
        let mut sweeps = 0;
        let mut h = Vec::new();
        loop {
            self.pull(&mut x, c);
            self.gather_into(&x, c, &mut h);
            if sweeps >= max_sweeps {
                break;
            }
            sweeps += 1;
            // Per column: the largest change and the largest reflected radiosity ρH.
            let zero = || (vec![0f32; c], vec![0f32; c]);
            let (change, top) = x[..n * c]
                .par_chunks_mut(c)
                .zip(s.par_chunks(c))
                .zip(h.par_chunks(c))
                .zip(rho.par_iter())
                .fold(zero, |(mut ch, mut top), (((b, s), h), r)| {
                    for j in 0..c {
                        let reflected = r[j % 3] * h[j];
                        let v = s[j] + reflected;
                        ch[j] = ch[j].max((v - b[j]).abs());
                        top[j] = top[j].max(reflected.abs());
                        b[j] = v;
                    }
                    (ch, top)
                })
                .reduce(zero, |mut a, b| {
                    for j in 0..c {
                        a.0[j] = a.0[j].max(b.0[j]);
                        a.1[j] = a.1[j].max(b.1[j]);
                    }
                    a
                });
            let converged = change
                .iter()
                .zip(&top)
                .all(|(&ch, &t)| ch as f64 <= tol * t as f64);
            progress((sweeps as f64 / 60.0).min(0.99));
            if converged {
                self.pull(&mut x, c);
                self.gather_into(&x, c, &mut h);
                break;
            }
        }
        x.truncate(n * c);
        h.truncate(n * c);
        let residual = residual(&x, s, &h, rho, c);
        HierarchySolution {
            b: x,
            h,
            sweeps,
            residual,
        }
    }
}

/// Largest relative residual `‖S − (B − ρH)‖∞ / ‖S‖∞` over the columns.
pub(super) fn residual(b: &[f32], s: &[f32], h: &[f32], rho: &[Rgb], c: usize) -> f64 {
    let mut worst = 0f64;
    for j in 0..c {
        let (mut num, mut den) = (0f64, 0f64);
        for (i, rh) in rho.iter().enumerate() {
            let k = i * c + j;
            let r = s[k] as f64 - (b[k] as f64 - rh[j % 3] as f64 * h[k] as f64);
            num = num.max(r.abs());
            den = den.max(s[k].abs() as f64);
        }
        if den > 0.0 {
            worst = worst.max(num / den);
        }
    }
    worst
}
