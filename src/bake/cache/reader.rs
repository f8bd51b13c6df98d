//! Reading a cache entry. Nothing in the file is trusted: the header length is checked
//! against the file size (bytes), the section table against the sections the patch count,
//! groups and mode imply, and every section's XXH3-64 checksum as it is read.

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufReader, Read};
use std::path::Path;

use xxhash_rust::xxh3::Xxh3;

use super::format::{
    expected_sections, gather_sections, grid_section, sky_section, Header, Kind, Section,
    FORMAT_VERSION, MAGIC, MAX_HEADER_BYTES, PREAMBLE,
};
use super::CacheError;
use crate::color::{Rgb, Rgb64};
use crate::transport::hierarchy::{Hierarchy, Links};
use crate::transport::probe::GridGather;
use crate::transport::transfer::{Factored, GroupColumns, SkyColumns, Transfer, TransferMode};

/// The file at `path`, opened, and its size in bytes.
fn open_sized(path: &Path) -> Result<(File, u64), CacheError> {
    let file = File::open(path).map_err(|source| CacheError::Io {
        path: path.into(),
        source,
    })?;
    let size = file
        .metadata()
        .map_err(|source| CacheError::Io {
            path: path.into(),
            source,
        })?
        .len();
    Ok((file, size))
}

/// Reads only the header (for listings and checks).
pub fn read_header(path: &Path) -> Result<Header, CacheError> {
    let (file, size) = open_sized(path)?;
    let mut r = BufReader::new(file);
    read_header_from(path, &mut r, size).map(|(h, _)| h)
}

/// The header and its length in bytes.
fn read_header_from(
    path: &Path,
    r: &mut impl Read,
    size: u64,
) -> Result<(Header, u64), CacheError> {
    let corrupt = |message: String| CacheError::Corrupt {
        path: path.into(),
        message,
    };
    let mut magic = [0u8; 8];
    r.read_exact(&mut magic)
        .map_err(|_| corrupt("file too short".into()))?;
    if &magic != MAGIC {
        return Err(CacheError::Foreign { path: path.into() });
    }
    let mut u = [0u8; 4];
    r.read_exact(&mut u)
        .map_err(|_| corrupt("file too short".into()))?;
    let version = u32::from_le_bytes(u);
    if version != FORMAT_VERSION {
        return Err(CacheError::Version {
            path: path.into(),
            found: version,
        });
    }
    r.read_exact(&mut u)
        .map_err(|_| corrupt("file too short".into()))?;
    let hlen = u32::from_le_bytes(u) as u64;
    if hlen > MAX_HEADER_BYTES as u64 {
        return Err(corrupt(format!("header length {hlen} is implausible")));
    }
    if PREAMBLE + hlen > size {
        return Err(corrupt(format!(
            "header length {hlen} runs past the end of the {size}-byte file"
        )));
    }
    let mut h = vec![0u8; hlen as usize];
    r.read_exact(&mut h)
        .map_err(|_| corrupt("truncated header".into()))?;
    let header = serde_json::from_slice(&h).map_err(|e| corrupt(format!("bad header: {e}")))?;
    Ok((header, hlen))
}

/// Reads and verifies a transfer. `expect_key` and `expect_fingerprint` must match.
///
/// Nothing is allocated from a number in the file before it is checked: the header length
/// against the file size; then the section table against the sections the patch count,
/// groups and mode imply (names, exact lengths, contiguous offsets), and their total
/// against the bytes left in the file.
pub fn read(
    path: &Path,
    expect_key: &str,
    expect_fingerprint: u64,
) -> Result<Transfer, CacheError> {
    let (file, size) = open_sized(path)?;
    let mut r = BufReader::with_capacity(1 << 20, file);
    let (h, hlen) = read_header_from(path, &mut r, size)?;
    let corrupt = |message: String| CacheError::Corrupt {
        path: path.into(),
        message,
    };
    if h.key != expect_key {
        return Err(corrupt(
            "stale: built from other scene files or settings".into(),
        ));
    }
    if h.mesh_fingerprint != format!("{expect_fingerprint:016x}") {
        return Err(corrupt("stale: the mesh differs".into()));
    }
    let plan = plan_sections(path, &h, hlen, size)?;
    let sections = read_sections(path, &mut r, plan, h.patch_count)?;
    assemble(path, &h, sections)
}

/// The header's sections in file order, each with its kind, once checked against the
/// sections the header implies (names, exact lengths, contiguous offsets) and their total
/// against the `size` of the file (bytes) after the `hlen`-byte header.
fn plan_sections<'h>(
    path: &Path,
    h: &'h Header,
    hlen: u64,
    size: u64,
) -> Result<Vec<(&'h Section, Kind)>, CacheError> {
    let corrupt = |message: String| CacheError::Corrupt {
        path: path.into(),
        message,
    };
    let expected = expected_sections(h)
        .ok_or_else(|| corrupt("the header's patch count, groups or mode are invalid".into()))?;
    if expected.len() != h.sections.len() {
        return Err(corrupt(format!(
            "{} sections listed, {} expected",
            h.sections.len(),
            expected.len()
        )));
    }
    let mut kinds: HashMap<&str, (Kind, u64)> = expected
        .iter()
        .map(|(name, kind, len)| (name.as_str(), (*kind, *len)))
        .collect();
    let mut pos = 0u64;
    let mut plan = Vec::with_capacity(h.sections.len());
    for s in &h.sections {
        let (kind, len) = kinds
            .remove(s.name.as_str())
            .ok_or_else(|| corrupt(format!("unexpected or repeated section '{}'", s.name)))?;
        if s.offset != pos || s.len != len {
            return Err(corrupt(format!(
                "section '{}' has a bad extent (offset {}, length {}; expected {pos}, {len})",
                s.name, s.offset, s.len
            )));
        }
        pos += len;
        plan.push((s, kind));
    }
    let data_start = PREAMBLE + hlen;
    if data_start.checked_add(pos) != Some(size) {
        return Err(corrupt(format!(
            "the sections need {pos} bytes after the header, the file has {}",
            size.saturating_sub(data_start)
        )));
    }
    Ok(plan)
}

/// The sections' contents by name: f32 arrays, and n × n matrices.
struct Sections {
    floats: HashMap<String, Vec<f32>>,
    matrices: HashMap<String, faer::Mat<f32>>,
}

/// Reads the planned sections, verifying each one's checksum; `n` is the patch count.
fn read_sections(
    path: &Path,
    r: &mut impl Read,
    plan: Vec<(&Section, Kind)>,
    n: usize,
) -> Result<Sections, CacheError> {
    let corrupt = |message: String| CacheError::Corrupt {
        path: path.into(),
        message,
    };
    let mut out = Sections {
        floats: HashMap::new(),
        matrices: HashMap::new(),
    };
    for (s, kind) in plan {
        let mut hasher = Xxh3::new();
        let truncated = |_| corrupt(format!("truncated in section '{}'", s.name));
        match kind {
            Kind::Floats => {
                let mut v = vec![0f32; (s.len / 4) as usize];
                r.read_exact(bytemuck::cast_slice_mut(&mut v))
                    .map_err(truncated)?;
                hasher.update(bytemuck::cast_slice(&v));
                out.floats.insert(s.name.clone(), v);
            }
            Kind::Matrix => {
                let mut m = faer::Mat::<f32>::zeros(n, n);
                for j in 0..n {
                    let col = m.col_as_slice_mut(j);
                    r.read_exact(bytemuck::cast_slice_mut(col))
                        .map_err(truncated)?;
                    hasher.update(bytemuck::cast_slice(m.col_as_slice(j)));
                }
                out.matrices.insert(s.name.clone(), m);
            }
        }
        if format!("{:016x}", hasher.digest()) != s.xxh3 {
            return Err(corrupt(format!(
                "checksum mismatch in section '{}'",
                s.name
            )));
        }
    }
    Ok(out)
}

/// The transfer of header `h` from its verified sections.
fn assemble(path: &Path, h: &Header, mut s: Sections) -> Result<Transfer, CacheError> {
    let corrupt = |message: String| CacheError::Corrupt {
        path: path.into(),
        message,
    };
    let mut take = |name: &str| -> Result<Vec<f32>, CacheError> {
        s.floats
            .remove(name)
            .ok_or_else(|| corrupt(format!("missing section '{name}'")))
    };
    // The section's size is checked above: 3n floats.
    let rho = Rgb::column(&take("rho")?).to_vec();
    let area = take("area")?;
    let escape = take("escape")?;
    let mut groups = Vec::new();
    for g in 0..h.groups {
        groups.push(GroupColumns {
            e: take(&format!("e{g}"))?,
            b: take(&format!("b{g}"))?,
            h: take(&format!("h{g}"))?,
            flux: h.group_flux.get(g).map_or(Rgb64::ZERO, |f| Rgb64(f[0])),
            landed: h.group_flux.get(g).map_or(Rgb64::ZERO, |f| Rgb64(f[1])),
        });
    }
    let mut grids = Vec::new();
    let mut grid_gathers = Vec::new();
    let words = |v: Vec<f32>| -> Vec<u32> { bytemuck::cast_slice::<f32, u32>(&v).to_vec() };
    for (i, &[rows, _]) in h.grid_weights.iter().enumerate() {
        grids.push(
            (0..h.groups)
                .map(|g| take(&grid_section(i, g)))
                .collect::<Result<Vec<_>, _>>()?,
        );
        let [o, j, w] = gather_sections(i);
        let (o, j, w) = (words(take(&o)?), words(take(&j)?), take(&w)?);
        grid_gathers.push(
            GridGather::from_parts(o, j, w, rows as usize, h.patch_count)
                .ok_or_else(|| corrupt(format!("grid {i}'s gather weights are inconsistent")))?,
        );
    }
    let sky = match h.sky_patches {
        0 => None,
        k => {
            let direct = take("skyd")?;
            let indirect = (0..k)
                .map(|s| take(&sky_section(s)))
                .collect::<Result<Vec<_>, _>>()?;
            Some(SkyColumns {
                k,
                direct,
                indirect,
            })
        }
    };
    let factored = match h.mode {
        TransferMode::Columns | TransferMode::Hierarchical => None,
        TransferMode::Factored => Some(factored(h, &mut s.matrices, &corrupt)?),
    };
    let hierarchy = match h.mode {
        TransferMode::Hierarchical => Some(hierarchy(h, &area, &mut take, &corrupt)?),
        _ => None,
    };
    Ok(Transfer {
        mode: h.mode,
        n: h.patch_count,
        rho,
        area,
        escape,
        groups,
        factored,
        hierarchy,
        coarse: None,
        grids,
        grid_gathers,
        sky,
        info: h.info,
    })
}

/// The links of a hierarchical entry, checked for consistency.
fn hierarchy(
    h: &Header,
    area: &[f32],
    take: &mut impl FnMut(&str) -> Result<Vec<f32>, CacheError>,
    corrupt: &impl Fn(String) -> CacheError,
) -> Result<Hierarchy, CacheError> {
    let words = |v: Vec<f32>| -> Vec<u32> { bytemuck::cast_slice::<f32, u32>(&v).to_vec() };
    let children: Vec<[u32; 2]> = words(take("children")?)
        .chunks_exact(2)
        .map(|c| [c[0], c[1]])
        .collect();
    let offsets = words(take("offsets")?);
    let src = words(take("src")?);
    let k = take("k")?;
    let mut vis = bytemuck::cast_slice::<f32, u8>(&take("vis")?).to_vec();
    vis.truncate(src.len());
    let sigma = take("sigma")?;
    let links = Links {
        offsets,
        src,
        k,
        vis,
    };
    let stats = h.hierarchy.unwrap_or_default();
    Hierarchy::from_parts(area, children, links, sigma, stats)
        .ok_or_else(|| corrupt("the hierarchy's links are inconsistent".into()))
}

/// The irradiance responses of a factored entry, with the channel map.
fn factored(
    h: &Header,
    matrices: &mut HashMap<String, faer::Mat<f32>>,
    corrupt: &impl Fn(String) -> CacheError,
) -> Result<Factored, CacheError> {
    let mut responses = Vec::new();
    for k in 0..h.response_count {
        responses.push(
            matrices
                .remove(&format!("resp{k}"))
                .ok_or_else(|| corrupt(format!("missing section 'resp{k}'")))?,
        );
    }
    let channel = h
        .channel_response
        .ok_or_else(|| corrupt("factored entry without channel map".into()))?;
    if channel.iter().any(|&c| c as usize >= responses.len()) {
        return Err(corrupt("channel map names a missing response".into()));
    }
    Ok(Factored { responses, channel })
}
