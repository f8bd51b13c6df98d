//! Writing a cache entry: the sections of a transfer (little-endian f32/u32 arrays, LUs
//! streamed column by column), their checksums and the JSON header, written to a
//! temporary name in the same folder, synced, then renamed into place.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use xxhash_rust::xxh3::Xxh3;

use super::folder::temp_path;
use super::format::{
    gather_sections, grid_section, sky_section, Header, Section, ALGORITHM_VERSION, FORMAT_VERSION,
    MAGIC,
};
use super::CacheError;
use crate::transport::transfer::Transfer;
use faer::Mat;

/// One section's data, as it is written.
enum Data<'a> {
    Bytes(Vec<u8>),
    Slice(&'a [u8]),
    /// An n × n matrix, streamed column by column (no copy of n² floats).
    Matrix(&'a Mat<f32>),
}

impl Data<'_> {
    fn len(&self) -> u64 {
        match self {
            Data::Bytes(b) => b.len() as u64,
            Data::Slice(b) => b.len() as u64,
            Data::Matrix(m) => 4 * (m.nrows() as u64) * (m.ncols() as u64),
        }
    }

    fn each_chunk(&self, f: &mut dyn FnMut(&[u8]) -> std::io::Result<()>) -> std::io::Result<()> {
        match self {
            Data::Bytes(b) => f(b),
            Data::Slice(b) => f(b),
            Data::Matrix(m) => {
                for j in 0..m.ncols() {
                    f(bytemuck::cast_slice(m.col_as_slice(j)))?;
                }
                Ok(())
            }
        }
    }

    fn xxh3(&self) -> u64 {
        let mut h = Xxh3::new();
        let _ = self.each_chunk(&mut |b| {
            h.update(b);
            Ok(())
        });
        h.digest()
    }
}

/// Writes a transfer atomically. Returns the file size in bytes.
pub fn write(
    path: &Path,
    scene_id: &str,
    key: &str,
    settings: &serde_json::Value,
    mesh_fingerprint: u64,
    t: &Transfer,
) -> Result<u64, CacheError> {
    let io = |source| CacheError::Io {
        path: path.to_path_buf(),
        source,
    };
    let dir = path.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(io)?;

    let all = sections_of(t);
    let header = Header {
        format_version: FORMAT_VERSION,
        algorithm_version: ALGORITHM_VERSION,
        relight_version: env!("CARGO_PKG_VERSION").into(),
        scene_id: scene_id.into(),
        key: key.into(),
        settings: settings.clone(),
        patch_count: t.n,
        mesh_fingerprint: format!("{mesh_fingerprint:016x}"),
        mode: t.mode,
        groups: t.groups.len(),
        group_flux: t.groups.iter().map(|g| [g.flux.0, g.landed.0]).collect(),
        channel_response: t.factored.as_ref().map(|f| f.channel),
        response_count: t.factored.as_ref().map_or(0, |f| f.responses.len()),
        info: t.info,
        links: t.hierarchy.as_ref().map_or(0, |h| h.links.src.len() as u64),
        hierarchy: t.hierarchy.as_ref().map(|h| h.stats),
        grid_points: t
            .grids
            .iter()
            .map(|g| g.first().map_or(0, |c| c.len() / 3))
            .collect(),
        grid_weights: t
            .grid_gathers
            .iter()
            .map(|g| [g.points() as u64, g.patch.len() as u64])
            .collect(),
        sky_patches: t.sky.as_ref().map_or(0, |s| s.k),
        sections: section_table(&all),
    };
    let hjson = serde_json::to_vec(&header).map_err(|e| io(std::io::Error::other(e)))?;

    let tmp = temp_path(dir, path);
    let result = write_file(&tmp, path, &hjson, &all);
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(io)
}

/// The sections of `t`, named, in file order (f32 data is stored little-endian: this
/// crate targets little-endian machines, checked at compile time).
fn sections_of(t: &Transfer) -> Vec<(String, Data<'_>)> {
    let mut all: Vec<(String, Data)> = Vec::new();
    all.push((
        "rho".into(),
        Data::Bytes(bytemuck::cast_slice(&t.rho).to_vec()),
    ));
    if let Some(f) = &t.factored {
        for (k, m) in f.responses.iter().enumerate() {
            all.push((format!("resp{k}"), Data::Matrix(m)));
        }
    }
    all.push(("area".into(), Data::Slice(bytemuck::cast_slice(&t.area))));
    all.push((
        "escape".into(),
        Data::Slice(bytemuck::cast_slice(&t.escape)),
    ));
    for (g, col) in t.groups.iter().enumerate() {
        all.push((format!("e{g}"), Data::Slice(bytemuck::cast_slice(&col.e))));
        all.push((format!("b{g}"), Data::Slice(bytemuck::cast_slice(&col.b))));
        all.push((format!("h{g}"), Data::Slice(bytemuck::cast_slice(&col.h))));
    }
    for (i, (grid, gather)) in t.grids.iter().zip(&t.grid_gathers).enumerate() {
        for (g, col) in grid.iter().enumerate() {
            all.push((grid_section(i, g), Data::Slice(bytemuck::cast_slice(col))));
        }
        let [o, j, w] = gather_sections(i);
        all.push((o, Data::Slice(bytemuck::cast_slice(&gather.offsets))));
        all.push((j, Data::Slice(bytemuck::cast_slice(&gather.patch))));
        all.push((w, Data::Slice(bytemuck::cast_slice(&gather.weight))));
    }
    if let Some(sky) = &t.sky {
        all.push((
            "skyd".into(),
            Data::Slice(bytemuck::cast_slice(&sky.direct)),
        ));
        for (k, col) in sky.indirect.iter().enumerate() {
            all.push((sky_section(k), Data::Slice(bytemuck::cast_slice(col))));
        }
    }
    if let Some(h) = &t.hierarchy {
        all.push((
            "children".into(),
            Data::Slice(bytemuck::cast_slice(&h.children)),
        ));
        all.push((
            "offsets".into(),
            Data::Slice(bytemuck::cast_slice(&h.links.offsets)),
        ));
        all.push((
            "src".into(),
            Data::Slice(bytemuck::cast_slice(&h.links.src)),
        ));
        all.push(("k".into(), Data::Slice(bytemuck::cast_slice(&h.links.k))));
        // Padded with zeros to whole 4-byte words.
        let mut vis = h.links.vis.clone();
        vis.resize(h.links.vis.len().div_ceil(4) * 4, 0);
        all.push(("vis".into(), Data::Bytes(vis)));
        all.push(("sigma".into(), Data::Slice(bytemuck::cast_slice(&h.sigma))));
    }
    all
}

/// The section table of the header: contiguous offsets, lengths and checksums.
fn section_table(all: &[(String, Data)]) -> Vec<Section> {
    let mut sections = Vec::new();
    let mut offset = 0u64;
    for (name, data) in all {
        sections.push(Section {
            name: name.clone(),
            offset,
            len: data.len(),
            xxh3: format!("{:016x}", data.xxh3()),
        });
        offset += data.len();
    }
    sections
}

/// Writes preamble, header and sections to `tmp`, syncs it and renames it to `path`.
/// Returns the file size in bytes.
fn write_file(
    tmp: &Path,
    path: &Path,
    hjson: &[u8],
    all: &[(String, Data)],
) -> std::io::Result<u64> {
    let file = File::create(tmp)?;
    let mut w = BufWriter::with_capacity(1 << 20, file);
    w.write_all(MAGIC)?;
    w.write_all(&FORMAT_VERSION.to_le_bytes())?;
    w.write_all(&(hjson.len() as u32).to_le_bytes())?;
    w.write_all(hjson)?;
    for (_, data) in all {
        data.each_chunk(&mut |b| w.write_all(b))?;
    }
    let file = w.into_inner().map_err(|e| e.into_error())?;
    file.sync_all()?;
    let size = file.metadata()?.len();
    drop(file);
    std::fs::rename(tmp, path)?;
    Ok(size)
}
