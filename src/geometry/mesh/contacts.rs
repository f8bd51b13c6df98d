//! Contact refinement: finding the patches that another scene triangle cuts along a line.

use super::*;

/// Contact refinement: a patch that another scene triangle touches or crosses along a
/// line through its interior (a block standing on a floor, a desk against a wall, a column
/// through a ceiling) is refined until its edges are at most `max_edge / CONTACT_DIVISOR`.
/// Such a patch is partly buried or in a contact shadow, and one radiosity value per patch
/// would spread that darkness (or hide it) over the whole patch; the finer patches follow
/// the contact line.
pub const CONTACT_DIVISOR: f64 = 4.0;

/// The scene's triangles in a BVH, to find the ones that cut a patch.
pub(super) struct Contacts<'a> {
    scene: &'a Scene,
    bvh: Bvh,
}

impl<'a> Contacts<'a> {
    pub(super) fn new(scene: &'a Scene) -> Contacts<'a> {
        let tris: Vec<[Vec3A; 3]> = scene
            .triangles
            .iter()
            .map(|t| t.p.map(|p| Vec3A::from(p.as_vec3())))
            .collect();
        Contacts {
            scene,
            bvh: Bvh::new(&tris),
        }
    }

    /// True when some scene triangle cuts the triangle `p` (see [`cuts`]). `found` is
    /// scratch space.
    pub(super) fn cut(&self, p: &[DVec3; 3], found: &mut Vec<u32>) -> bool {
        let lo = p[0].min(p[1]).min(p[2]);
        let hi = p[0].max(p[1]).max(p[2]);
        // The BVH is f32: widen the box by more than its rounding.
        let pad = 1e-5 * (1.0 + lo.abs().max(hi.abs()).max_element());
        found.clear();
        self.bvh.overlapping(
            Vec3A::from((lo - pad).as_vec3()),
            Vec3A::from((hi + pad).as_vec3()),
            found,
        );
        found
            .iter()
            .any(|&q| cuts(p, &self.scene.triangles[q as usize].p))
    }
}

/// True when triangle `q` touches or crosses the interior of triangle `p` along a
/// segment: a contact line. Touching only `p`'s boundary or a single point, and lying in
/// `p`'s plane, do not count.
pub(super) fn cuts(p: &[DVec3; 3], q: &[DVec3; 3]) -> bool {
    let nn = (p[1] - p[0]).cross(p[2] - p[0]);
    let len = nn.length();
    if len == 0.0 {
        return false;
    }
    let n = nn / len;
    let size = p
        .iter()
        .chain(q)
        .flat_map(|a| p.iter().chain(q).map(move |b| a.distance_squared(*b)))
        .fold(0.0, f64::max)
        .sqrt();
    let tol = 1e-6 * size;
    let d = q.map(|x| n.dot(x - p[0]));
    if d.iter().all(|&x| x > tol) || d.iter().all(|&x| x < -tol) || d.iter().all(|x| x.abs() <= tol)
    {
        return false;
    }
    // Where q meets p's plane: its corners on the plane and its edges crossing it.
    let mut pts = [DVec3::ZERO; 6];
    let mut m = 0;
    for k in 0..3 {
        if d[k].abs() <= tol {
            pts[m] = q[k];
            m += 1;
        }
        let (a, b) = (k, (k + 1) % 3);
        if (d[a] > tol && d[b] < -tol) || (d[a] < -tol && d[b] > tol) {
            pts[m] = q[a] + (q[b] - q[a]) * (d[a] / (d[a] - d[b]));
            m += 1;
        }
    }
    let (mut a, mut b, mut far) = (DVec3::ZERO, DVec3::ZERO, 0.0);
    for i in 0..m {
        for j in i + 1..m {
            let l = pts[i].distance_squared(pts[j]);
            if l > far {
                (a, b, far) = (pts[i], pts[j], l);
            }
        }
    }
    if far.sqrt() <= tol {
        return false;
    }
    // Clip the segment a→b to p's interior, shrunk by tol.
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for k in 0..3 {
        let inward = n.cross(p[(k + 1) % 3] - p[k]).normalize();
        let fa = inward.dot(a - p[k]) - tol;
        let fb = inward.dot(b - p[k]) - tol;
        if fa <= 0.0 && fb <= 0.0 {
            return false;
        }
        if fa < 0.0 {
            t0 = t0.max(fa / (fa - fb));
        } else if fb < 0.0 {
            t1 = t1.min(fa / (fa - fb));
        }
    }
    (t1 - t0) * far.sqrt() > tol
}
