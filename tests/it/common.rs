//! Helpers shared by the integration tests: the gate that keeps the timing tests alone,
//! scenes written to temporary folders, and form factors of small scenes.

use std::path::{Path, PathBuf};
use std::sync::{Mutex, PoisonError, RwLock, RwLockReadGuard, RwLockWriteGuard};

use relight::bake::scene_bvh;
use relight::geometry::mesh::Mesh;
use relight::scene::Scene;
use relight::server::AppState;
use relight::transport::formfactor::{self, FormFactorOptions};

/// Every test holds the gate for its whole run: [`shared`] by default, [`alone`] for the
/// few that need the machine to themselves. libtest runs the tests of this binary on
/// parallel threads of one process, where the separate binaries they once were ran one
/// after another.
static GATE: RwLock<()> = RwLock::new(());

/// The gate held by a test that may run alongside others.
///
/// A wrapper rather than the bare guard: the async tests hold it across `.await`, which is
/// safe here (nothing on a test's runtime ever waits for the gate; a test blocks on it
/// before its first `.await`), but `clippy::await_holding_lock` would flag the guard.
#[must_use = "bind it to `_gate` so that it is held until the test ends"]
pub struct Shared {
    _guard: RwLockReadGuard<'static, ()>,
}

/// The gate held by a test that needs the machine to itself: one that asserts latencies
/// or reports timings.
#[must_use = "bind it to `_gate` so that it is held until the test ends"]
pub struct Alone {
    _guard: RwLockWriteGuard<'static, ()>,
}

/// Waits while a test holding [`alone`] runs (or waits to run).
pub fn shared() -> Shared {
    Shared {
        // A test that failed while holding the gate poisons it; the others still run.
        _guard: GATE.read().unwrap_or_else(PoisonError::into_inner),
    }
}

/// Waits until the tests in flight have ended, and keeps the others from starting until
/// the returned gate is dropped.
pub fn alone() -> Alone {
    Alone {
        _guard: GATE.write().unwrap_or_else(PoisonError::into_inner),
    }
}

/// Bakes (or loads from the cache) every scene of `state`, while no other state does.
///
/// The modules that serve the bundled scenes (`http`, `hardening`, `fuzz_requests`,
/// `saturation`) each build their own state over one cache folder. On a cold cache, states
/// baking at once would each bake every scene; one after another, the first bakes and the
/// others load its entries.
pub fn bake_all(state: &AppState) {
    static BAKING: Mutex<()> = Mutex::new(());
    let _one = BAKING.lock().unwrap_or_else(PoisonError::into_inner);
    state.bake_all();
}

/// A scene folder in a temporary directory, removed on drop.
pub struct TempScene {
    pub dir: tempfile::TempDir,
}

impl TempScene {
    pub fn path(&self) -> &Path {
        self.dir.path()
    }
}

/// Writes `scene.obj`, `scene.mtl` and (if given) `scene.toml` into a fresh folder.
pub fn write_scene(obj: &str, mtl: &str, toml: Option<&str>) -> TempScene {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(
        dir.path().join("scene.obj"),
        format!("mtllib scene.mtl\n{obj}"),
    )
    .unwrap();
    std::fs::write(dir.path().join("scene.mtl"), mtl).unwrap();
    if let Some(t) = toml {
        std::fs::write(dir.path().join("scene.toml"), t).unwrap();
    }
    TempScene { dir }
}

/// OBJ text for one quad (object `name`, material `mat`) whose front faces `normal`.
/// `p` are the corners in order around the quad.
pub fn quad(name: &str, mat: &str, p: [[f64; 3]; 4], normal: [f64; 3]) -> String {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let (u, v) = (sub(p[1], p[0]), sub(p[2], p[0]));
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    let mut p = p.to_vec();
    if n[0] * normal[0] + n[1] * normal[1] + n[2] * normal[2] < 0.0 {
        p.reverse();
    }
    polygon(name, mat, &p)
}

/// OBJ text for one convex polygon, using negative (relative) indices.
pub fn polygon(name: &str, mat: &str, p: &[[f64; 3]]) -> String {
    let mut s = format!("o {name}\nusemtl {mat}\n");
    for v in p {
        s += &format!("v {} {} {}\n", v[0], v[1], v[2]);
    }
    s += "f";
    for k in 0..p.len() {
        s += &format!(" {}", k as i64 - p.len() as i64);
    }
    s + "\n"
}

/// A box face: its name suffix, corners in order around it, and its front's normal.
pub type BoxFace = (&'static str, [[f64; 3]; 4], [f64; 3]);

/// The six faces of an axis-aligned box as (name suffix -x +x -y +y -z +z, corners in
/// order around the face, the front's normal), fronts inward (a room) or outward.
pub fn box_quads(lo: [f64; 3], hi: [f64; 3], inward: bool) -> [BoxFace; 6] {
    let s = if inward { -1.0 } else { 1.0 };
    let [x0, y0, z0] = lo;
    let [x1, y1, z1] = hi;
    [
        (
            "-x",
            [[x0, y0, z0], [x0, y1, z0], [x0, y1, z1], [x0, y0, z1]],
            [-s, 0.0, 0.0],
        ),
        (
            "+x",
            [[x1, y0, z0], [x1, y1, z0], [x1, y1, z1], [x1, y0, z1]],
            [s, 0.0, 0.0],
        ),
        (
            "-y",
            [[x0, y0, z0], [x1, y0, z0], [x1, y0, z1], [x0, y0, z1]],
            [0.0, -s, 0.0],
        ),
        (
            "+y",
            [[x0, y1, z0], [x1, y1, z0], [x1, y1, z1], [x0, y1, z1]],
            [0.0, s, 0.0],
        ),
        (
            "-z",
            [[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0]],
            [0.0, 0.0, -s],
        ),
        (
            "+z",
            [[x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]],
            [0.0, 0.0, s],
        ),
    ]
}

/// The six faces of an axis-aligned box, fronts inward (a room) or outward (a block).
/// Face names are `prefix` + one of -x +x -y +y -z +z.
pub fn box_faces(prefix: &str, mat: &str, lo: [f64; 3], hi: [f64; 3], inward: bool) -> String {
    box_quads(lo, hi, inward)
        .iter()
        .map(|(k, p, n)| quad(&format!("{prefix}{k}"), mat, *p, *n))
        .collect()
}

/// A loaded scene with its mesh and dense form factors.
pub struct Solved {
    pub scene: Scene,
    pub mesh: Mesh,
    pub f: Vec<f32>,
}

pub fn form_factors(dir: &Path) -> Solved {
    let scene = Scene::load(dir).expect("scene loads");
    let mesh = Mesh::build(&scene);
    let bvh = scene_bvh(&scene);
    let f = formfactor::compute(&mesh, &bvh, &FormFactorOptions::default(), &|_| {});
    Solved { scene, mesh, f }
}

impl Solved {
    pub fn n(&self) -> usize {
        self.mesh.len()
    }

    /// Surface-to-surface factor: Σ_{i∈a} A_i Σ_{j∈b} F_ij / A_a.
    pub fn surface_factor(&self, a: &str, b: &str) -> f64 {
        let sa = self.scene.surface_index(a).expect("surface a");
        let sb = self.scene.surface_index(b).expect("surface b");
        let (ra, rb) = (
            self.mesh.surface_patches[sa].clone(),
            self.mesh.surface_patches[sb].clone(),
        );
        let n = self.n();
        let mut num = 0.0;
        let mut area = 0.0;
        for i in ra {
            let ai = self.mesh.patches[i as usize].area;
            area += ai;
            for j in rb.clone() {
                num += ai * self.f[i as usize * n + j as usize] as f64;
            }
        }
        num / area
    }

    pub fn surface_area(&self, a: &str) -> f64 {
        let s = self.scene.surface_index(a).unwrap();
        self.mesh.surface_patches[s]
            .clone()
            .map(|i| self.mesh.patches[i as usize].area)
            .sum()
    }
}

pub const GREY_MTL: &str = "newmtl grey\nKd 0.5 0.5 0.5\n";

/// Bundled scenes the tests do not serve: too large to bake in CI (`relight bench`
/// measures them; `office_floor` checks that it loads).
pub const LARGE_SCENES: [&str; 1] = ["office-floor"];

/// The repository's `scenes/` folder.
pub fn bundled_scenes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes")
}

/// The bundled scenes the tests serve: every folder of `scenes/` but [`LARGE_SCENES`],
/// as symbolic links in a folder of the test target directory.
pub fn scenes_dir() -> PathBuf {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("bundled-scenes");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        for e in std::fs::read_dir(bundled_scenes()).unwrap().flatten() {
            let name = e.file_name();
            if e.path().is_dir() && !LARGE_SCENES.iter().any(|l| name == *l) {
                std::os::unix::fs::symlink(e.path(), dir.join(&name)).unwrap();
            }
        }
        dir
    })
    .clone()
}

/// A loopback TCP port that was free a moment ago.
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// The bundled Cornell box at its default meshing, baked once for the tests that compare
/// it with the path-traced reference.
pub fn cornell_baked() -> &'static relight::bake::Baked {
    &cornell_model().baked
}

/// [`cornell_baked`] as a model (the scene has no grids, so the bake is unchanged).
pub fn cornell_model() -> &'static relight::model::Model {
    static MODEL: std::sync::OnceLock<relight::model::Model> = std::sync::OnceLock::new();
    MODEL.get_or_init(|| {
        relight::model::Model::new(
            relight::bake::load_or_bake(
                &scenes_dir().join("cornell-box"),
                relight::bake::CachePolicy::Off,
                &relight::bake::BakeOptions::default(),
                &|_, _| {},
            )
            .expect("the Cornell box bakes"),
        )
    })
}

/// The Cornell box's path-traced reference image in tests/data (256², 4,096 samples per
/// pixel, white light; linear radiance), top row first.
pub fn cornell_reference() -> Vec<[f32; 3]> {
    let bytes = std::fs::read(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/cornell_ref_white.pfm"),
    )
    .expect("the reference image");
    // A PFM: three header lines, then little-endian f32 RGB, bottom row first.
    let header_end = bytes
        .iter()
        .enumerate()
        .filter(|(_, &c)| c == b'\n')
        .nth(2)
        .expect("a PFM header")
        .0
        + 1;
    let data: Vec<f32> = bytes[header_end..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    assert_eq!(data.len(), 256 * 256 * 3);
    (0..256 * 256)
        .map(|i| {
            let k = ((255 - i / 256) * 256 + i % 256) * 3;
            [data[k], data[k + 1], data[k + 2]]
        })
        .collect()
}

/// The configuration factor of an a × b rectangle parallel to a receiving point at
/// distance c, the point below one corner (Howell's catalogue, C-11).
fn corner_factor(a: f64, b: f64, c: f64) -> f64 {
    let (x, y) = (a / c, b / c);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
}

/// The factor of the rectangle x0..x1 × z0..z1 at height c above (px, pz), the point
/// below the rectangle or beside it: four corner rectangles (the corner factor is odd in
/// each side, so the ones beyond the point subtract).
pub fn rect_factor(p: (f64, f64), (x0, x1): (f64, f64), (z0, z1): (f64, f64), c: f64) -> f64 {
    let (px, pz) = p;
    [
        (x1 - px, z1 - pz),
        (px - x0, z1 - pz),
        (x1 - px, pz - z0),
        (px - x0, pz - z0),
    ]
    .iter()
    .map(|&(a, b)| corner_factor(a, b, c))
    .sum()
}

/// Relative RMSE of image `a` against image `b`: √(mean |a − b|²) / mean of `b`, over the
/// channels.
pub fn relative_rmse(a: &[relight::color::Rgb], b: &[relight::color::Rgb]) -> f64 {
    let n = (3 * b.len()) as f64;
    let mean = b.iter().flat_map(|p| p.0).map(f64::from).sum::<f64>() / n;
    let sq = a
        .iter()
        .zip(b)
        .flat_map(|(p, q)| (0..3).map(move |k| (p.0[k] - q.0[k]) as f64))
        .map(|d| d * d)
        .sum::<f64>();
    (sq / n).sqrt() / mean
}
