//! glTF buffers: the GLB binary chunk, base64 data URIs and files in the scene folder,
//! the views meshopt decodes ([`super::meshopt`]), and bounds-checked views of their bytes.

use std::collections::{HashMap, HashSet};
use std::path::PathBuf;

use base64::Engine as _;

use super::meshopt::{self, Compressed};
use super::Reader;
use crate::input_limits::{MAX_GLTF_BYTES, MAX_GLTF_DECODED_BYTES};
use crate::scene::files;
use crate::scene::SceneError;

/// The bytes a file's accessors read: each buffer's, exactly its declared length (empty
/// for a compression fallback buffer), and the decoded bytes of the compressed views
/// that geometry reads, by view index.
#[derive(Default)]
pub(super) struct Buffers {
    data: Vec<Vec<u8>>,
    decoded: HashMap<usize, Vec<u8>>,
}

impl Reader<'_> {
    /// The bytes of every buffer: the GLB binary chunk, a data URI, or a file in the folder.
    pub(super) fn buffers(
        &self,
        gltf: &gltf::Gltf,
        files: &mut Vec<PathBuf>,
    ) -> Result<Buffers, SceneError> {
        let mut total = 0u64;
        let mut out = Vec::new();
        for b in gltf.document.buffers() {
            let what = format!("buffers[{}]", b.index());
            if meshopt::is_fallback(&b) {
                // Its views are decoded from other buffers: its own bytes are not read.
                out.push(Vec::new());
                continue;
            }
            let mut data = match b.source() {
                gltf::buffer::Source::Bin => gltf
                    .blob
                    .clone()
                    .ok_or_else(|| self.err(format!("{what}: no binary chunk in the file")))?,
                gltf::buffer::Source::Uri(uri) => {
                    self.uri_bytes(uri, &what, MAX_GLTF_BYTES, files)?
                }
            };
            let len = b.length();
            if data.len() < len {
                return Err(self.err(format!(
                    "{what}: byteLength is {len} but the data has {} bytes",
                    data.len()
                )));
            }
            data.truncate(len);
            total += len as u64;
            if total > MAX_GLTF_BYTES {
                return Err(self.err(format!(
                    "the buffers hold more than {} in all",
                    files::human_bytes(MAX_GLTF_BYTES)
                )));
            }
            out.push(data);
        }
        let decoded = self.decode_views(&gltf.document, &out)?;
        Ok(Buffers { data: out, decoded })
    }

    /// Decodes the compressed views that geometry reads (POSITION and indices of every
    /// primitive), each checked against [`MAX_GLTF_DECODED_BYTES`] over all views before
    /// it is allocated.
    fn decode_views(
        &self,
        doc: &gltf::Document,
        data: &[Vec<u8>],
    ) -> Result<HashMap<usize, Vec<u8>>, SceneError> {
        let mut wanted = HashSet::new();
        for mesh in doc.meshes() {
            for prim in mesh.primitives() {
                let pos = prim.get(&gltf::Semantic::Positions);
                for acc in pos.into_iter().chain(prim.indices()) {
                    if let Some(v) = acc.view() {
                        if meshopt::extension(&v).is_some() {
                            wanted.insert(v.index());
                        }
                    }
                }
            }
        }
        let mut wanted: Vec<usize> = wanted.into_iter().collect();
        wanted.sort_unstable();
        let views: Vec<gltf::buffer::View<'_>> = doc.views().collect();
        let mut total = 0usize;
        let mut out = HashMap::new();
        for i in wanted {
            let what = format!("bufferViews[{i}] (meshopt compression)");
            let Some(ext) = views.get(i).and_then(meshopt::extension) else {
                continue;
            };
            let c = Compressed::parse(ext).map_err(|m| self.err(format!("{what}: {m}")))?;
            total = c
                .decoded_len()
                .and_then(|n| total.checked_add(n))
                .filter(|&t| t as u64 <= MAX_GLTF_DECODED_BYTES)
                .ok_or_else(|| {
                    self.err(format!(
                        "{what}: the decoded views would hold more than {}",
                        files::human_bytes(MAX_GLTF_DECODED_BYTES)
                    ))
                })?;
            let bytes = c
                .decode(data)
                .map_err(|m| self.err(format!("{what}: {m}")))?;
            out.insert(i, bytes);
        }
        Ok(out)
    }

    /// The bytes a URI names: a base64 data URI, or a file inside the scene folder.
    pub(super) fn uri_bytes(
        &self,
        uri: &str,
        what: &str,
        limit: u64,
        files: &mut Vec<PathBuf>,
    ) -> Result<Vec<u8>, SceneError> {
        if let Some(rest) = uri.strip_prefix("data:") {
            let (_, payload) = rest
                .split_once(";base64,")
                .ok_or_else(|| self.err(format!("{what}: only base64 data URIs are read")))?;
            if payload.len() as u64 / 4 * 3 > limit {
                return Err(self.err(format!(
                    "{what}: data URI larger than {}",
                    files::human_bytes(limit)
                )));
            }
            return base64::engine::general_purpose::STANDARD
                .decode(payload.trim_end())
                .map_err(|e| self.err(format!("{what}: bad base64 data URI ({e})")));
        }
        let name =
            percent_decode(uri).ok_or_else(|| self.err(format!("{what}: bad URI '{uri}'")))?;
        let p = self.sd.resolve(&name, self.shown, 0, what)?;
        let bytes = self.sd.read(&p, limit)?;
        if !files.contains(&p) {
            files.push(p);
        }
        Ok(bytes)
    }
}

/// `%XX` escapes decoded (URIs in glTF are URI-encoded); None for bad escapes or UTF-8.
pub(super) fn percent_decode(uri: &str) -> Option<String> {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = std::str::from_utf8(b.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// The bytes of a buffer view (decoded, when compressed), if it lies inside its buffer.
pub(super) fn view_bytes<'b>(
    view: &gltf::buffer::View<'_>,
    buffers: &'b Buffers,
) -> Option<&'b [u8]> {
    if let Some(d) = buffers.decoded.get(&view.index()) {
        return Some(d);
    }
    let data = buffers.data.get(view.buffer().index())?;
    let end = view.offset().checked_add(view.length())?;
    data.get(view.offset()..end)
}

/// The `count` elements of `size` bytes an accessor reads, each bounds-checked against its
/// view and buffer. Sparse accessors and accessors without a view are refused.
pub(super) fn accessor_bytes<'b>(
    acc: &gltf::Accessor<'_>,
    buffers: &'b Buffers,
    size: usize,
    max_count: usize,
) -> Result<impl Iterator<Item = &'b [u8]>, String> {
    if acc.sparse().is_some() {
        return Err("is sparse; sparse accessors are not read".into());
    }
    let view = acc.view().ok_or("has no bufferView")?;
    let count = acc.count();
    if count > max_count {
        return Err(format!("has {count} elements, more than {max_count}"));
    }
    let stride = view.stride().unwrap_or(size);
    if stride < size {
        return Err(format!(
            "byteStride {stride} is smaller than an element ({size} bytes)"
        ));
    }
    let data = view_bytes(&view, buffers).ok_or("lies outside its buffer (bufferView)")?;
    let start = acc.offset();
    if count > 0 {
        let end = (count - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(start))
            .and_then(|x| x.checked_add(size))
            .ok_or("is too large")?;
        if end > data.len() {
            return Err(format!(
                "reads bytes {start}..{end} of a bufferView of {} bytes",
                data.len()
            ));
        }
    }
    Ok((0..count).map(move |k| &data[start + k * stride..start + k * stride + size]))
}
