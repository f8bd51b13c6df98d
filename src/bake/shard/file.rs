//! The shard file: `"RLSHARD\0" | u32 LE version | u32 LE header length H | H bytes JSON
//! header | links × 13 bytes | hits × 12 bytes`, written atomically and read back with
//! every check (magic, version, key, mesh, shard index, lengths, checksum) before the data
//! is decoded.

use std::io::{BufReader, BufWriter, Read, Write};
use std::path::Path;

use serde::{Deserialize, Serialize};
use xxhash_rust::xxh3::Xxh3;

use super::ShardId;
use crate::bake::cache;
use crate::transport::hierarchy::refine::Link;
use crate::transport::hierarchy::Part;

const MAGIC: &[u8; 8] = b"RLSHARD\0";
pub(super) const VERSION: u32 = 1;
const LINK_BYTES: u64 = 13;
const HIT_BYTES: u64 = 12;

/// The JSON header of a shard file.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(super) struct Header {
    pub(super) format_version: u32,
    pub(super) scene_id: String,
    pub(super) key: String,
    pub(super) mesh_fingerprint: String,
    pub(super) shard: usize,
    pub(super) shards: usize,
    pub(super) roots: Vec<u32>,
    pub(super) links: u64,
    pub(super) hits: u64,
    pub(super) refine_s: f64,
    pub(super) closure_s: f64,
    pub(super) xxh3: String,
}

/// The data section of a part.
fn encode(part: &Part) -> Vec<u8> {
    let mut out = Vec::with_capacity(
        (LINK_BYTES * part.links.len() as u64 + HIT_BYTES * part.hits.len() as u64) as usize,
    );
    for l in &part.links {
        out.extend_from_slice(&l.r.to_le_bytes());
        out.extend_from_slice(&l.s.to_le_bytes());
        out.extend_from_slice(&l.k.to_bits().to_le_bytes());
        out.push(l.vis);
    }
    for &(i, h) in &part.hits {
        out.extend_from_slice(&i.to_le_bytes());
        out.extend_from_slice(&h.to_bits().to_le_bytes());
    }
    out
}

/// Writes a shard file atomically (temporary name, sync, rename); returns its size.
pub(super) fn write_shard(
    cache: &Path,
    path: &Path,
    mut header: Header,
    part: &Part,
) -> std::io::Result<u64> {
    let data = encode(part);
    let mut h = Xxh3::new();
    h.update(&data);
    header.xxh3 = format!("{:016x}", h.digest());
    let hjson = serde_json::to_vec(&header).map_err(std::io::Error::other)?;
    let tmp = cache::temp_path(cache, path);
    let result = (|| {
        let file = std::fs::File::create(&tmp)?;
        let mut w = BufWriter::with_capacity(1 << 20, file);
        w.write_all(MAGIC)?;
        w.write_all(&VERSION.to_le_bytes())?;
        w.write_all(&(hjson.len() as u32).to_le_bytes())?;
        w.write_all(&hjson)?;
        w.write_all(&data)?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        let size = file.metadata()?.len();
        drop(file);
        std::fs::rename(&tmp, path)?;
        Ok(size)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Reads and checks shard file `path` against the bake's key, mesh and shard id.
pub(super) fn read_shard(
    path: &Path,
    key: &str,
    fingerprint: u64,
    id: ShardId,
) -> Result<Part, String> {
    let name = path
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    read_checked_shard(path, key, fingerprint, id)
        .map_err(|m| format!("shard {} of {} ({name}): {m}", id.k, id.n))
}

/// [`read_shard`], its errors without the shard's name.
fn read_checked_shard(
    path: &Path,
    key: &str,
    fingerprint: u64,
    id: ShardId,
) -> Result<Part, String> {
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let size = file.metadata().map_err(|e| e.to_string())?.len();
    let mut r = BufReader::with_capacity(1 << 20, file);
    let (h, hlen) = read_header(&mut r, size)?;
    check_header(&h, key, fingerprint, id)?;
    let data = read_data(&mut r, &h, size - 16 - hlen)?;
    let (links, hits) = decode(&data, h.links);
    Ok(Part {
        roots: h.roots,
        links,
        hits,
        refine_s: h.refine_s,
        closure_s: h.closure_s,
    })
}

/// The header of a shard file of `size` bytes, and its length, once the magic and
/// version are this relight's.
fn read_header(r: &mut impl Read, size: u64) -> Result<(Header, u64), String> {
    let mut pre = [0u8; 16];
    r.read_exact(&mut pre)
        .map_err(|_| "corrupt: too short".to_string())?;
    if &pre[..8] != MAGIC {
        return Err("not a relight shard file".into());
    }
    let version = u32::from_le_bytes([pre[8], pre[9], pre[10], pre[11]]);
    if version != VERSION {
        return Err(format!(
            "shard format {version}, this relight reads {VERSION}"
        ));
    }
    let hlen = u32::from_le_bytes([pre[12], pre[13], pre[14], pre[15]]) as u64;
    if hlen > (16 << 20) || 16 + hlen > size {
        return Err(format!("corrupt: header length {hlen}"));
    }
    let mut hb = vec![0u8; hlen as usize];
    r.read_exact(&mut hb)
        .map_err(|_| "corrupt: truncated header".to_string())?;
    let h: Header = serde_json::from_slice(&hb).map_err(|e| format!("corrupt header: {e}"))?;
    Ok((h, hlen))
}

/// Checks that a shard's header is of this bake: its cache key, mesh and shard id.
fn check_header(h: &Header, key: &str, fingerprint: u64, id: ShardId) -> Result<(), String> {
    if h.key != key {
        return Err(format!(
            "foreign: made for cache key {} (other scene files or settings), this bake is {key}",
            h.key
        ));
    }
    if h.mesh_fingerprint != format!("{fingerprint:016x}") {
        return Err("foreign: made from another mesh".into());
    }
    if (h.shard, h.shards) != (id.k, id.n) {
        return Err(format!(
            "its header says shard {} of {}: renamed or duplicated",
            h.shard, h.shards
        ));
    }
    Ok(())
}

/// The data section, `len` bytes after the header, once its size matches the header's
/// counts and its checksum the header's.
fn read_data(r: &mut impl Read, h: &Header, len: u64) -> Result<Vec<u8>, String> {
    let want = h
        .links
        .checked_mul(LINK_BYTES)
        .and_then(|a| h.hits.checked_mul(HIT_BYTES).and_then(|b| a.checked_add(b)));
    if want != Some(len) {
        return Err(format!(
            "corrupt: {len} data bytes, the header implies {}",
            want.map_or("too many".to_string(), |w| w.to_string())
        ));
    }
    let mut data = vec![0u8; len as usize];
    r.read_exact(&mut data)
        .map_err(|_| "corrupt: truncated data".to_string())?;
    let mut x = Xxh3::new();
    x.update(&data);
    if format!("{:016x}", x.digest()) != h.xxh3 {
        return Err("corrupt: checksum mismatch".into());
    }
    Ok(data)
}

/// The links and closure hits of a data section holding `links` links (the inverse of
/// [`encode`]).
fn decode(data: &[u8], links: u64) -> (Vec<Link>, Vec<(u32, f64)>) {
    let word = |b: &[u8], i: usize| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    let (lb, hb) = data.split_at((links * LINK_BYTES) as usize);
    let links = lb
        .chunks_exact(LINK_BYTES as usize)
        .map(|c| Link {
            r: word(c, 0),
            s: word(c, 4),
            k: f32::from_bits(word(c, 8)),
            vis: c[12],
        })
        .collect();
    let hits = hb
        .chunks_exact(HIT_BYTES as usize)
        .map(|c| {
            let mut f = [0u8; 8];
            f.copy_from_slice(&c[4..12]);
            (word(c, 0), f64::from_bits(u64::from_le_bytes(f)))
        })
        .collect();
    (links, hits)
}
