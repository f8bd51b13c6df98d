//! `relight info`: the scenes under a folder with their patch counts, surfaces, light
//! groups and cameras, their bounds in metres and the units of their files, and their
//! warnings (meshes each scene; bakes nothing).

use std::path::Path;

use anyhow::{Context, Result};

use super::outln;
use relight::bake;

pub fn run(root: &Path) -> Result<()> {
    let dirs = bake::scene_dirs(root).with_context(|| format!("reading {}", root.display()))?;
    if dirs.is_empty() {
        outln!("no scenes under {}", root.display());
    }
    for d in dirs {
        match relight::scene::Scene::load(&d) {
            Ok(s) => {
                let patches = match relight::geometry::mesh::Mesh::try_build_with(
                    &s,
                    s.mesh.max_edge,
                    bake::DEFAULT_MAX_PATCHES,
                ) {
                    // Cluster patches hold several of the model's triangles.
                    Ok(mesh) if mesh.elements.len() > mesh.len() => {
                        format!("{} ({} triangles)", mesh.len(), mesh.elements.len())
                    }
                    Ok(mesh) => mesh.len().to_string(),
                    Err(e) => format!(">{}", e.at_least.max(e.limit as u64)),
                };
                let groups: Vec<String> = s.lights.iter().map(|l| l.id.clone()).collect();
                let cams: Vec<String> = s.cameras.iter().map(|c| c.id.clone()).collect();
                outln!(
                    "{:<16} {:<28} {:>6} patches  surfaces {:<3} lights [{}]  cameras [{}]",
                    s.id,
                    s.name,
                    patches,
                    s.surfaces.len(),
                    groups.join(", "),
                    cams.join(", ")
                );
                let (lo, hi) = s.bounds();
                let xyz = |v: glam::DVec3| format!("[{:.3}, {:.3}, {:.3}]", v.x, v.y, v.z);
                let size = hi - lo;
                outln!(
                    "{:<16} bounds (m) min {} max {}  size {:.3} x {:.3} x {:.3} m  units {}",
                    "",
                    xyz(lo),
                    xyz(hi),
                    size.x,
                    size.y,
                    size.z,
                    units_label(&s)
                );
                for w in &s.warnings {
                    outln!("{:<16} warning: {w}", "");
                }
            }
            Err(e) => outln!(
                "{:<16} FAILED: {e}",
                d.file_name().unwrap_or_default().to_string_lossy()
            ),
        }
    }
    Ok(())
}

/// The scene's file unit and its size in metres (`mm (0.001 m)`), `m` alone for metres.
fn units_label(s: &relight::scene::Scene) -> String {
    if s.scale == 1.0 || s.units == format!("{} m", s.scale) {
        s.units.clone()
    } else {
        format!("{} ({} m)", s.units, s.scale)
    }
}
