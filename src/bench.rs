//! `relight bench`: the engine's performance figures, measured in this process.
//!
//! One case per process (the CLI spawns itself per case) so that the peak resident memory
//! read from `/proc/self/status` (VmHWM) belongs to that case alone.

use std::path::Path;
use std::time::Instant;

use glam::Vec3A;
use serde::Serialize;

use crate::bake::{load_or_bake, BakeOptions, CachePolicy};
use crate::color::Rgb;
use crate::geometry::bvh::Bvh;
use crate::geometry::mesh::Mesh;
use crate::geometry::patch_locator::PatchRay;
use crate::sampling::{sample_triangle, Rng};
use crate::transport::transfer::TransferMode;

/// Figures of one bench case.
#[derive(Debug, Serialize)]
pub struct BenchResult {
    pub case: String,
    pub patches: usize,
    pub groups: usize,
    pub mode: TransferMode,
    pub form_factor_s: f64,
    /// Factorization plus columns (factored), or the Jacobi columns (columns mode).
    pub solve_s: f64,
    pub cold_bake_s: f64,
    pub cached_load_s: f64,
    pub cache_mb: f64,
    /// Median time of one relight (radiosity of all patches for all groups), microseconds.
    pub relight_us: f64,
    /// Median time of one solve of an arbitrary emission vector (exact in factored mode,
    /// sweeps in hierarchical mode; none in columns mode), ms.
    pub solve_emission_ms: Option<f64>,
    pub peak_rss_mb: f64,
    /// Bytes the loaded transfer holds (what a read-only replica keeps), MB.
    pub transfer_mb: f64,
    /// Hierarchical mode: links, and links per patch.
    pub links: Option<u64>,
    pub links_per_patch: Option<f64>,
    /// Shadow-ray throughput of one core on this scene's BVH: occlusion tests between
    /// random points of random patches that face each other (as the form factors, links
    /// and shadow rays trace them), millions per second.
    pub mrays_per_core: f64,
}

/// Which segments [`ray_throughput`] tests.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Segments {
    /// Between points that face each other: the segment leaves the front of both
    /// patches. These are the segments relight traces: form factors and links join
    /// patches each in front of the other, and shadow rays leave the lit side of a
    /// surface toward an emitter's front.
    Facing,
    /// Between any two points. On office-floor only 49 % of these face each other; 15 %
    /// lie in the plane of one of their patches (floor to floor, say) and the rest leave
    /// or reach a patch from behind, which relight never traces.
    Any,
}

/// Random pairs [`ray_throughput`] draws per segment asked for, at most: a scene where
/// fewer than a quarter of the pairs face each other (office-floor: 49 %) is measured on
/// fewer segments, and one with none measures nothing (0).
const DRAWS_PER_SEGMENT: usize = 4;

/// Occlusion tests per second on one thread, millions: segments between uniformly
/// random points of uniformly random patches (all of them, or only the facing ones),
/// each test skipping its two triangles.
pub fn ray_throughput(mesh: &Mesh, bvh: &Bvh, rays: usize, which: Segments) -> f64 {
    if mesh.len() < 2 {
        return 0.0;
    }
    let mut rng = Rng::new(1, 2);
    let mut pairs = Vec::with_capacity(rays);
    for _ in 0..rays.saturating_mul(DRAWS_PER_SEGMENT) {
        if pairs.len() == rays {
            break;
        }
        let (x, i) = random_patch_point(mesh, &mut rng);
        let (y, j) = random_patch_point(mesh, &mut rng);
        let d = y - x;
        let facing = d.dot(mesh.patches[i].normal) > 0.0 && d.dot(mesh.patches[j].normal) < 0.0;
        if which == Segments::Facing && !facing {
            continue;
        }
        pairs.push((
            (Vec3A::from(x.as_vec3()), mesh.patches[i].source),
            (Vec3A::from(y.as_vec3()), mesh.patches[j].source),
        ));
    }
    if pairs.is_empty() {
        return 0.0;
    }
    per_second(&pairs, |((a, sa), (b, sb))| {
        bvh.occluded(*a, *b, [*sa, *sb])
    })
}

/// Nearest-hit queries per second on one thread, millions: cosine-weighted rays from
/// uniformly random points of uniformly random patches, as the final gather traces them:
/// on `bvh`, the scene BVH, then the four corners around the hit in the side's grid
/// of `patches` ([`crate::render::final_gather::patch_locator`]), where the gather reads
/// the radiosity.
pub fn nearest_throughput(
    mesh: &Mesh,
    bvh: &Bvh,
    patches: &crate::geometry::patch_locator::PatchLocator,
    rays: usize,
) -> f64 {
    if mesh.is_empty() {
        return 0.0;
    }
    let mut rng = Rng::new(3, 4);
    let queries: Vec<PatchRay> = (0..rays)
        .map(|_| {
            let (x, i) = random_patch_point(mesh, &mut rng);
            let nrm = mesh.patches[i].normal;
            let (t, b) = crate::geometry::frame(nrm);
            let (u1, u2): (f64, f64) = (rng.next_f64(), rng.next_f64());
            let (r, phi) = (u1.sqrt(), std::f64::consts::TAU * u2);
            let d = t * (r * phi.cos()) + b * (r * phi.sin()) + nrm * (1.0 - u1).sqrt();
            let o = x + nrm * 1e-6 * (1.0 + x.abs().max_element());
            PatchRay::leaving(mesh.patches[i].source, o, d)
        })
        .collect();
    per_second(&queries, |&ray| {
        patches
            .nearest_side(bvh, ray)
            .and_then(|(t, tri, back)| patches.grid_weights(tri, back, ray.at(t)))
            .is_some()
    })
}

/// A uniformly random point of a uniformly random patch (m), and the patch's index.
fn random_patch_point(mesh: &Mesh, rng: &mut Rng) -> (glam::DVec3, usize) {
    let i = rng.index(mesh.len());
    let (f, u) = mesh.pick_facet(i, rng.next_f64());
    let x = sample_triangle(&f.corners, u, rng.next_f64());
    (x, i)
}

/// Passes over the queries in [`per_second`]; the fastest counts, as the others were
/// slowed by something else on the machine.
const PASSES: usize = 3;

/// Millions of `query` calls per second over `queries`, on this thread: the fastest of
/// [`PASSES`] passes.
fn per_second<Q>(queries: &[Q], query: impl Fn(&Q) -> bool) -> f64 {
    let best = (0..PASSES)
        .map(|_| {
            let t = Instant::now();
            let yes = queries.iter().filter(|q| query(q)).count();
            std::hint::black_box(yes);
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min);
    queries.len() as f64 / best / 1e6
}

/// Peak resident set size of this process, MB (Linux; 0 elsewhere).
pub fn peak_rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(0.0, |kb| kb / 1024.0)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Bakes `dir` cold, reloads it from a fresh cache, and times relighting.
pub fn run_case(case: &str, dir: &Path, opts: &BakeOptions) -> anyhow::Result<BenchResult> {
    let cache = tempfile::tempdir()?;
    let t0 = Instant::now();
    let baked = load_or_bake(dir, CachePolicy::ReadWrite(cache.path()), opts, &|_, _| {})?;
    let cold = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let again = load_or_bake(dir, CachePolicy::ReadWrite(cache.path()), opts, &|_, _| {})?;
    let cached = t1.elapsed().as_secs_f64();
    anyhow::ensure!(
        again.stats.from_cache,
        "second load did not come from the cache"
    );
    drop(again);

    let t = &baked.transfer;
    let g = t.group_count();
    let mut out = vec![0f32; 3 * t.n];
    let mut samples = Vec::new();
    for k in 0..2000 {
        // A different state every call, so nothing is hoisted out of the loop.
        let w: Vec<Rgb> = (0..g)
            .map(|i| Rgb::new(0.5 + ((k + i) % 7) as f32 * 0.1, 0.8, 0.3))
            .collect();
        let s = Instant::now();
        t.relight_into(&w, &mut out);
        samples.push(s.elapsed().as_secs_f64() * 1e6);
        std::hint::black_box(&out);
    }
    let solvable = t.factored.is_some() || t.hierarchy.is_some();
    let solve_emission_ms = solvable.then(|| {
        let e: Vec<f32> = (0..3 * t.n).map(|i| (i % 5) as f32).collect();
        median(
            (0..5)
                .map(|_| {
                    let s = Instant::now();
                    std::hint::black_box(t.solve(&e));
                    s.elapsed().as_secs_f64() * 1e3
                })
                .collect(),
        )
    });
    Ok(BenchResult {
        case: case.into(),
        patches: t.n,
        groups: g,
        mode: t.mode,
        form_factor_s: baked.stats.form_factor_s,
        solve_s: baked.stats.solve_s,
        cold_bake_s: cold,
        cached_load_s: cached,
        cache_mb: baked.stats.cache_bytes as f64 / 1e6,
        relight_us: median(samples),
        solve_emission_ms,
        peak_rss_mb: peak_rss_mb(),
        transfer_mb: t.bytes() as f64 / 1e6,
        links: t.hierarchy.as_ref().map(|h| h.stats.links),
        links_per_patch: t
            .hierarchy
            .as_ref()
            .map(|h| h.stats.links as f64 / h.n.max(1) as f64),
        mrays_per_core: ray_throughput(&baked.mesh, &baked.bvh, 1_000_000, Segments::Facing),
    })
}

/// Writes a room with `groups` ceiling panels, each its own light group, into `dir`.
pub fn write_group_room(dir: &Path, groups: usize, target_patches: usize) -> std::io::Result<()> {
    let (w, h, d) = (8.0f64, 3.0f64, 6.0f64);
    let mut obj = String::from("mtllib room.mtl\n");
    let mut vi = 1;
    let mut quad = |obj: &mut String, name: &str, mat: &str, p: [[f64; 3]; 4]| {
        *obj += &format!("o {name}\nusemtl {mat}\n");
        for v in p {
            *obj += &format!("v {} {} {}\n", v[0], v[1], v[2]);
        }
        *obj += &format!("f {} {} {} {}\n", vi, vi + 1, vi + 2, vi + 3);
        vi += 4;
    };
    // Inward-facing room (counter-clockwise seen from inside).
    quad(
        &mut obj,
        "floor",
        "floor",
        [[0., 0., 0.], [0., 0., d], [w, 0., d], [w, 0., 0.]],
    );
    quad(
        &mut obj,
        "ceiling",
        "white",
        [[0., h, 0.], [w, h, 0.], [w, h, d], [0., h, d]],
    );
    quad(
        &mut obj,
        "wall_w",
        "wall",
        [[0., 0., 0.], [0., h, 0.], [0., h, d], [0., 0., d]],
    );
    quad(
        &mut obj,
        "wall_e",
        "wall",
        [[w, 0., 0.], [w, 0., d], [w, h, d], [w, h, 0.]],
    );
    quad(
        &mut obj,
        "wall_s",
        "wall",
        [[0., 0., 0.], [w, 0., 0.], [w, h, 0.], [0., h, 0.]],
    );
    quad(
        &mut obj,
        "wall_n",
        "wall",
        [[0., 0., d], [0., h, d], [w, h, d], [w, 0., d]],
    );
    let mut toml = format!("name = \"{groups}-group room\"\ntransfer = \"columns\"\n[mesh]\ntarget_patches = {target_patches}\n");
    let per_row = groups.div_ceil(2).max(1);
    for g in 0..groups {
        let (row, col) = (g / per_row, g % per_row);
        let x0 = (col as f64 + 0.3) * w / per_row as f64;
        let z0 = (row as f64 + 0.35) * d / 2.0;
        let y = h - 0.02;
        quad(
            &mut obj,
            &format!("panel{g}"),
            "panel",
            [
                [x0, y, z0],
                [x0 + 0.6, y, z0],
                [x0 + 0.6, y, z0 + 0.6],
                [x0, y, z0 + 0.6],
            ],
        );
        toml += &format!("[[lights]]\nid = \"g{g}\"\nsurfaces = [\"panel{g}\"]\nlumens = 3000\n");
    }
    std::fs::create_dir_all(dir)?;
    std::fs::write(dir.join("room.obj"), obj)?;
    std::fs::write(
        dir.join("room.mtl"),
        "newmtl floor\nKd 0.2 0.2 0.2\nnewmtl white\nKd 0.8 0.8 0.8\nnewmtl wall\nKd 0.5 0.5 0.5\n\
         newmtl panel\nKd 0 0 0\nKe 1000 1000 1000\n",
    )?;
    std::fs::write(dir.join("scene.toml"), toml)
}
