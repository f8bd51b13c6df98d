//! Building a [`PatchLocator`]: each scene triangle's frame in its plane, the mesh's
//! elements sorted onto the triangles' sides, and per side a grid of cells over them.

use glam::{DVec3, Vec3A};

use super::{Frame, PatchLocator, Side, CELLS_PER_PATCH, MAX_CELLS_PER_PATCH};
use crate::geometry::mesh::Mesh;
use crate::scene::Triangle;

/// The mesh's elements per (scene triangle, side), with their corners in the triangle's
/// plane and the sides' areas.
struct ElementSides {
    /// Element ids per side (`2 × triangle + back`).
    ids: Vec<Vec<u32>>,
    /// Per element, its corners' plane coordinates (see [`PatchLocator::uv`]).
    uv: Vec<[f32; 6]>,
    /// Per side, the area of its elements, m².
    areas: Vec<f64>,
}

impl ElementSides {
    fn new(mesh: &Mesh, frames: &[Frame]) -> ElementSides {
        let mut ids: Vec<Vec<u32>> = vec![Vec::new(); 2 * frames.len()];
        let mut uv = vec![[0f32; 6]; mesh.elements.len()];
        let mut areas = vec![0f64; 2 * frames.len()];
        for (j, uvj) in uv.iter_mut().enumerate() {
            let p = mesh.facet(j);
            let s = p.source as usize;
            let Some(f) = frames.get(s) else { continue };
            let back = p.normal.dot(f.normal.as_dvec3()) < 0.0;
            ids[2 * s + usize::from(back)].push(j as u32);
            areas[2 * s + usize::from(back)] += p.area;
            for (k, c) in p.corners.iter().enumerate() {
                let (u, v) = f.coords(*c);
                uvj[2 * k] = u as f32;
                uvj[2 * k + 1] = v as f32;
            }
        }
        ElementSides { ids, uv, areas }
    }
}

/// The sides' grids as they are built: cells, their runs of element ids, and corners.
#[derive(Default)]
struct Grids {
    cell_start: Vec<u32>,
    entries: Vec<u32>,
    corners: u32,
}

impl Grids {
    /// Adds the grid of one side over its elements `ids` (of total area `area`, m²): square
    /// cells about the size of the mean element, within the cap.
    fn add_side(&mut self, ids: &[u32], uv: &[[f32; 6]], area: f64) -> Side {
        let bbox = |c: &[f32; 6]| {
            (
                [c[0].min(c[2]).min(c[4]), c[1].min(c[3]).min(c[5])],
                [c[0].max(c[2]).max(c[4]), c[1].max(c[3]).max(c[5])],
            )
        };
        let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        for &j in ids {
            let (l, h) = bbox(&uv[j as usize]);
            for a in 0..2 {
                lo[a] = lo[a].min(l[a]);
                hi[a] = hi[a].max(h[a]);
            }
        }
        let (w, h) = (
            ((hi[0] - lo[0]) as f64).max(0.0),
            ((hi[1] - lo[1]) as f64).max(0.0),
        );
        let n = ids.len() as f64;
        let mut cell = (area / (CELLS_PER_PATCH * n)).sqrt();
        let most = (MAX_CELLS_PER_PATCH as f64 * n).max(1.0);
        if cell.is_nan() || cell <= 0.0 || (w / cell + 1.0) * (h / cell + 1.0) > most {
            // Cells of (w + c)(h + c)/c² ≤ most: c from the quadratic.
            let (a, b, c) = (most - 1.0, -(w + h), -w * h);
            cell = (-b + (b * b - 4.0 * a * c).max(0.0).sqrt()) / (2.0 * a).max(1e-30);
        }
        let per_m = if cell > 0.0 { (1.0 / cell) as f32 } else { 0.0 };
        let count = |len: f64| ((len * per_m as f64).floor() as u32 + 1).max(1);
        let side = Side {
            cells: [count(w), count(h)],
            lo,
            per_m,
            first_cell: self.cell_start.len() as u32,
            first_corner: self.corners,
            patch_size: (area / n).sqrt() as f32,
        };
        self.corners += (side.cells[0] + 1) * (side.cells[1] + 1);
        let (gx, gy) = (side.cells[0] as usize, side.cells[1] as usize);
        let mut cells: Vec<Vec<u32>> = vec![Vec::new(); gx * gy];
        let base = side.first_cell as usize;
        for &j in ids {
            let (l, h) = bbox(&uv[j as usize]);
            let (c0, c1) = (side.cell(l[0], l[1]) - base, side.cell(h[0], h[1]) - base);
            for y in c0 / gx..=c1 / gx {
                for x in c0 % gx..=c1 % gx {
                    cells[y * gx + x].push(j);
                }
            }
        }
        for cell in cells {
            self.cell_start.push(self.entries.len() as u32);
            self.entries.extend(cell);
        }
        side
    }
}

impl PatchLocator {
    /// Indexes `mesh`'s elements by the scene triangle each was cut from (`triangles`, the
    /// scene's, as in [`crate::geometry::mesh::Element::source`]).
    pub fn new(mesh: &Mesh, triangles: &[Triangle]) -> PatchLocator {
        let mut frames: Vec<Frame> = triangles.iter().map(|t| frame(&t.p)).collect();
        let sides = ElementSides::new(mesh, &frames);
        let mut grids = Grids::default();
        for (s, f) in frames.iter_mut().enumerate() {
            for (k, side) in f.sides.iter_mut().enumerate() {
                let ids = &sides.ids[2 * s + k];
                if !ids.is_empty() {
                    *side = grids.add_side(ids, &sides.uv, sides.areas[2 * s + k]);
                }
            }
        }
        grids.cell_start.push(grids.entries.len() as u32);
        PatchLocator {
            frames,
            cell_start: grids.cell_start,
            entries: grids.entries,
            uv: sides.uv,
            patch_of: mesh.elements.iter().map(|e| e.patch).collect(),
            corners: grids.corners,
        }
    }
}

/// A triangle's frame in its plane (no sides yet). A degenerate triangle gets a zero frame:
/// every point maps to its first corner.
fn frame(p: &[DVec3; 3]) -> Frame {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let normal = e1.cross(e2);
    let axes = match (e1.try_normalize(), normal.try_normalize()) {
        (Some(x), Some(n)) => [x, n.cross(x)],
        _ => [DVec3::ZERO; 2],
    };
    Frame {
        origin: p[0],
        axes,
        normal: Vec3A::from(normal.as_vec3()),
        corners: [e1.dot(axes[0]), e2.dot(axes[0]), e2.dot(axes[1])],
        sides: [Side::default(); 2],
    }
}
