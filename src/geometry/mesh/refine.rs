//! Longest-edge (Rivara) refinement of one surface's triangles: vertices welded by
//! position, T-junctions of the input repaired, then bisection of every triangle's
//! longest edge (with its neighbour across it) until no edge is longer than the limit, or
//! until a predicate no longer asks for it. The mesh stays conforming throughout.

use std::collections::HashMap;

use glam::DVec3;

use crate::scene::Scene;

type EdgeKey = (u32, u32);

pub(super) fn key(a: u32, b: u32) -> EdgeKey {
    if a < b {
        (a, b)
    } else {
        (b, a)
    }
}

/// Longest-edge (Rivara) refinement of one surface's triangles.
pub(super) struct Refiner {
    pub(super) pos: Vec<DVec3>,
    pub(super) tris: Vec<[u32; 3]>,
    pub(super) src: Vec<u32>,
    pub(super) alive: Vec<bool>,
    edges: HashMap<EdgeKey, Vec<u32>>,
    /// Number of alive triangles.
    live: usize,
}

impl Refiner {
    pub(super) fn new(scene: &Scene, tris: &[u32]) -> Refiner {
        let mut weld: HashMap<[u64; 3], u32> = HashMap::new();
        let mut r = Refiner {
            pos: Vec::new(),
            tris: Vec::new(),
            src: Vec::new(),
            alive: Vec::new(),
            edges: HashMap::new(),
            live: 0,
        };
        for &t in tris {
            let tri = &scene.triangles[t as usize];
            let v = tri.p.map(|p| {
                let k = p.to_array().map(|c| (c + 0.0).to_bits());
                *weld.entry(k).or_insert_with(|| {
                    r.pos.push(p);
                    (r.pos.len() - 1) as u32
                })
            });
            if v[0] == v[1] || v[1] == v[2] || v[0] == v[2] {
                continue;
            }
            r.add(v, t);
        }
        r
    }

    fn add(&mut self, v: [u32; 3], src: u32) -> u32 {
        let t = self.tris.len() as u32;
        self.tris.push(v);
        self.src.push(src);
        self.alive.push(true);
        self.live += 1;
        for k in 0..3 {
            self.edges
                .entry(key(v[k], v[(k + 1) % 3]))
                .or_default()
                .push(t);
        }
        t
    }

    fn kill(&mut self, t: u32) {
        self.alive[t as usize] = false;
        self.live -= 1;
        let v = self.tris[t as usize];
        for k in 0..3 {
            let e = key(v[k], v[(k + 1) % 3]);
            if let Some(list) = self.edges.get_mut(&e) {
                list.retain(|&x| x != t);
                if list.is_empty() {
                    self.edges.remove(&e);
                }
            }
        }
    }

    /// Splits triangle `t` at vertex `m`, which lies on its edge starting at corner `k`.
    fn split_at(&mut self, t: u32, k: usize, m: u32) {
        let v = self.tris[t as usize];
        let (a, b, c) = (v[k], v[(k + 1) % 3], v[(k + 2) % 3]);
        let src = self.src[t as usize];
        self.kill(t);
        self.add([a, m, c], src);
        self.add([m, b, c], src);
    }

    fn len2(&self, e: EdgeKey) -> f64 {
        self.pos[e.0 as usize].distance_squared(self.pos[e.1 as usize])
    }

    /// The longest edge of `t`, ties broken by vertex index so the order is total.
    fn longest(&self, t: u32) -> EdgeKey {
        let v = self.tris[t as usize];
        let mut best = key(v[0], v[1]);
        let mut best_l = self.len2(best);
        for k in 1..3 {
            let e = key(v[k], v[(k + 1) % 3]);
            let l = self.len2(e);
            if l > best_l || (l == best_l && e > best) {
                best = e;
                best_l = l;
            }
        }
        best
    }

    /// Splits every triangle whose edge passes through another vertex of the surface.
    /// Stops with the live triangle count as soon as it exceeds `limit`.
    pub(super) fn fix_t_junctions(&mut self, limit: usize) -> Result<(), usize> {
        if self.live > limit {
            return Err(self.live);
        }
        // Vertices sorted by x, to find candidates near an edge quickly.
        let mut by_x: Vec<u32> = (0..self.pos.len() as u32).collect();
        by_x.sort_by(|&a, &b| self.pos[a as usize].x.total_cmp(&self.pos[b as usize].x));
        let xs: Vec<f64> = by_x.iter().map(|&v| self.pos[v as usize].x).collect();
        let mut t = 0u32;
        while (t as usize) < self.tris.len() {
            if !self.alive[t as usize] {
                t += 1;
                continue;
            }
            let v = self.tris[t as usize];
            let mut split = None;
            'edges: for k in 0..3 {
                let (a, b) = (v[k], v[(k + 1) % 3]);
                let (pa, pb) = (self.pos[a as usize], self.pos[b as usize]);
                let d = pb - pa;
                let len2 = d.length_squared();
                let tol = 1e-7 * len2.sqrt();
                let (x0, x1) = (pa.x.min(pb.x) - tol, pa.x.max(pb.x) + tol);
                let lo = xs.partition_point(|&x| x < x0);
                for (i, &m) in by_x.iter().enumerate().skip(lo) {
                    if xs[i] > x1 {
                        break;
                    }
                    if m == a || m == b || v.contains(&m) {
                        continue;
                    }
                    let pm = self.pos[m as usize];
                    let s = (pm - pa).dot(d) / len2;
                    if s <= 1e-9 || s >= 1.0 - 1e-9 {
                        continue;
                    }
                    if (pa + d * s).distance(pm) <= tol {
                        split = Some((k, m));
                        break 'edges;
                    }
                }
            }
            match split {
                Some((k, m)) => {
                    self.split_at(t, k, m);
                    if self.live > limit {
                        return Err(self.live);
                    }
                }
                None => t += 1,
            }
        }
        Ok(())
    }

    /// Rivara refinement: bisect longest edges (along the longest-edge propagation path,
    /// so no hanging vertex is ever created) until every edge is at most `h`. Stops with
    /// the live triangle count as soon as it exceeds `limit`.
    pub(super) fn refine(&mut self, h: f64, limit: usize) -> Result<(), usize> {
        self.refine_where(h, limit, |_, _| true)
    }

    /// Rivara refinement of the triangles `wanted` picks (given the refiner and the
    /// triangle), until their edges are at most `h`. Triangles created by a split are
    /// asked again, so the refinement follows whatever `wanted` marks.
    pub(super) fn refine_where(
        &mut self,
        h: f64,
        limit: usize,
        wanted: impl Fn(&Refiner, u32) -> bool,
    ) -> Result<(), usize> {
        let h2 = h * h * (1.0 + 1e-9);
        let mut t = 0u32;
        while (t as usize) < self.tris.len() {
            while self.alive[t as usize] && self.len2(self.longest(t)) > h2 && wanted(self, t) {
                self.bisect_path(t);
                if self.live > limit {
                    return Err(self.live);
                }
            }
            t += 1;
        }
        Ok(())
    }

    /// One step of Rivara bisection for `t`: walks the longest-edge propagation path from
    /// `t` to an edge that is the longest of all its triangles and bisects it.
    fn bisect_path(&mut self, t: u32) {
        let mut cur = t;
        loop {
            let e = self.longest(cur);
            let next = self.edges[&e]
                .iter()
                .copied()
                .find(|&n| n != cur && self.longest(n) != e);
            match next {
                Some(n) => cur = n,
                None => return self.bisect(e),
            }
        }
    }

    /// The live triangles that share an edge with `t`, edge by edge.
    pub(super) fn neighbours(&self, t: u32) -> impl Iterator<Item = u32> + '_ {
        let v = self.tris[t as usize];
        (0..3).flat_map(move |k| {
            self.edges
                .get(&key(v[k], v[(k + 1) % 3]))
                .into_iter()
                .flatten()
                .copied()
                .filter(move |&u| u != t)
        })
    }

    /// The corners of triangle `t`.
    pub(super) fn corners(&self, t: u32) -> [DVec3; 3] {
        self.tris[t as usize].map(|k| self.pos[k as usize])
    }

    /// Splits edge `e` at its midpoint, in every triangle that has it.
    fn bisect(&mut self, e: EdgeKey) {
        let m = self.pos.len() as u32;
        self.pos
            .push(0.5 * (self.pos[e.0 as usize] + self.pos[e.1 as usize]));
        let owners = self.edges[&e].clone();
        for t in owners {
            let v = self.tris[t as usize];
            let k = (0..3)
                .find(|&k| key(v[k], v[(k + 1) % 3]) == e)
                .expect("owner has the edge");
            self.split_at(t, k, m);
        }
    }
}
