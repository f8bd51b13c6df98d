//! `EXT_meshopt_compression` (and its ratified twin `KHR_meshopt_compression`): buffer
//! views stored compressed by meshoptimizer's codecs, as gltfpack and many web exporters
//! write them.
//!
//! A compressed view names a source range in another buffer, an element `count` and
//! `byteStride`, a `mode` (`ATTRIBUTES`, `TRIANGLES` or `INDICES`) and an optional `filter`
//! (`NONE`, `OCTAHEDRAL`, `QUATERNION`, `EXPONENTIAL`, `COLOR`). Decoded, it is exactly
//! `count × byteStride` bytes, which then stand in for the view's own bytes; the view's
//! buffer may be a fallback with no data at all.
//!
//! The codecs are meshoptimizer's own (the `meshopt` crate builds its C++ source), whose
//! decoders validate their input and return an error for a malformed stream rather than
//! read or write out of bounds. Every precondition they assert (strides, counts) is
//! checked here first, and the output size is checked against the limit before anything
//! is allocated.

use serde_json::Value;

/// The extension names read, in the order they are looked for on a view.
pub(super) const EXTENSIONS: [&str; 2] = ["EXT_meshopt_compression", "KHR_meshopt_compression"];

/// How a compressed view is coded.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Mode {
    Attributes,
    Triangles,
    Indices,
}

/// The post-decode filter of an `ATTRIBUTES` view.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Filter {
    None,
    Octahedral,
    Quaternion,
    Exponential,
    Color,
}

/// A compressed view's extension object, checked.
#[derive(Debug)]
pub(super) struct Compressed {
    /// The buffer holding the compressed bytes, and their range in it.
    buffer: usize,
    offset: usize,
    length: usize,
    /// Elements and bytes per element of the decoded view.
    count: usize,
    stride: usize,
    mode: Mode,
    filter: Filter,
}

impl Compressed {
    /// Reads the extension object `ext` of a view; errors say which field is wrong.
    pub(super) fn parse(ext: &Value) -> Result<Compressed, String> {
        let int = |key: &str, default: Option<u64>| -> Result<usize, String> {
            match ext.get(key) {
                None => default.map(|d| d as usize).ok_or(format!("has no '{key}'")),
                Some(v) => v
                    .as_u64()
                    .and_then(|x| usize::try_from(x).ok())
                    .ok_or(format!("'{key}' is not a non-negative integer")),
            }
        };
        let text = |key: &str| ext.get(key).and_then(Value::as_str);
        let mode = match text("mode") {
            Some("ATTRIBUTES") => Mode::Attributes,
            Some("TRIANGLES") => Mode::Triangles,
            Some("INDICES") => Mode::Indices,
            Some(other) => {
                return Err(format!(
                    "mode '{other}' is not one of ATTRIBUTES, TRIANGLES, INDICES"
                ))
            }
            None => return Err("has no 'mode'".into()),
        };
        let filter = match text("filter") {
            None | Some("NONE") => Filter::None,
            Some("OCTAHEDRAL") => Filter::Octahedral,
            Some("QUATERNION") => Filter::Quaternion,
            Some("EXPONENTIAL") => Filter::Exponential,
            Some("COLOR") => Filter::Color,
            Some(other) => return Err(format!("filter '{other}' is not known")),
        };
        let c = Compressed {
            buffer: int("buffer", None)?,
            offset: int("byteOffset", Some(0))?,
            length: int("byteLength", None)?,
            count: int("count", None)?,
            stride: int("byteStride", None)?,
            mode,
            filter,
        };
        c.check()?;
        Ok(c)
    }

    /// The codec's preconditions, which its C++ asserts and a release build does not check.
    fn check(&self) -> Result<(), String> {
        let s = self.stride;
        match self.mode {
            Mode::Attributes if s == 0 || s > 256 || !s.is_multiple_of(4) => {
                return Err(format!(
                    "byteStride {s} of an ATTRIBUTES view must be a multiple of 4 up to 256"
                ))
            }
            Mode::Triangles | Mode::Indices if s != 2 && s != 4 => {
                return Err(format!("byteStride {s} of an index view must be 2 or 4"))
            }
            Mode::Triangles if !self.count.is_multiple_of(3) => {
                return Err(format!(
                    "count {} of a TRIANGLES view is not a multiple of 3",
                    self.count
                ))
            }
            _ => {}
        }
        let ok = match (self.mode, self.filter) {
            (_, Filter::None) => true,
            (Mode::Attributes, Filter::Octahedral | Filter::Color) => s == 4 || s == 8,
            (Mode::Attributes, Filter::Quaternion) => s == 8,
            (Mode::Attributes, Filter::Exponential) => true,
            _ => false,
        };
        if !ok {
            return Err(format!(
                "filter {:?} does not apply to a {:?} view of byteStride {s}",
                self.filter, self.mode
            ));
        }
        Ok(())
    }

    /// The decoded size in bytes (`count × byteStride`), None on overflow.
    pub(super) fn decoded_len(&self) -> Option<usize> {
        self.count.checked_mul(self.stride)
    }

    /// Decodes the view from `buffers`. The caller has checked [`Self::decoded_len`]
    /// against its limits.
    pub(super) fn decode(&self, buffers: &[Vec<u8>]) -> Result<Vec<u8>, String> {
        let src = buffers
            .get(self.buffer)
            .ok_or(format!("buffer {} does not exist", self.buffer))?;
        let end = self.offset.checked_add(self.length).ok_or("is too large")?;
        let src = src.get(self.offset..end).ok_or(format!(
            "bytes {}..{end} lie outside buffer {} ({} bytes)",
            self.offset,
            self.buffer,
            src.len()
        ))?;
        let len = self.decoded_len().ok_or("is too large")?;
        let mut out = vec![0u8; len];
        let (dst, n, s) = (out.as_mut_ptr().cast(), self.count, self.stride);
        // SAFETY: `out` holds exactly count × stride bytes; `src` is a valid slice; the
        // strides and counts meet the preconditions in `check` (vertex size a multiple
        // of 4 up to 256, index size 2 or 4, triangle counts a multiple of 3, filter
        // strides); the decoders bound every read by `src.len()`.
        let rc = unsafe {
            match self.mode {
                Mode::Attributes => {
                    meshopt::ffi::meshopt_decodeVertexBuffer(dst, n, s, src.as_ptr(), src.len())
                }
                Mode::Triangles => {
                    meshopt::ffi::meshopt_decodeIndexBuffer(dst, n, s, src.as_ptr(), src.len())
                }
                Mode::Indices => {
                    meshopt::ffi::meshopt_decodeIndexSequence(dst, n, s, src.as_ptr(), src.len())
                }
            }
        };
        if rc != 0 {
            return Err(format!("is malformed (meshopt decoder error {rc})"));
        }
        // SAFETY: as above; the filters rewrite count × stride bytes in place.
        unsafe {
            match self.filter {
                Filter::None => {}
                Filter::Octahedral => meshopt::ffi::meshopt_decodeFilterOct(dst, n, s),
                Filter::Quaternion => meshopt::ffi::meshopt_decodeFilterQuat(dst, n, s),
                Filter::Exponential => meshopt::ffi::meshopt_decodeFilterExp(dst, n, s),
                Filter::Color => meshopt::ffi::meshopt_decodeFilterColor(dst, n, s),
            }
        }
        Ok(out)
    }
}

/// The compression extension object of a view, if it has one.
pub(super) fn extension<'v>(view: &'v gltf::buffer::View<'_>) -> Option<&'v Value> {
    EXTENSIONS.iter().find_map(|e| view.extension_value(e))
}

/// Whether a buffer is a fallback: declared by the extension, with no data of its own.
pub(super) fn is_fallback(buffer: &gltf::Buffer<'_>) -> bool {
    EXTENSIONS.iter().any(|e| {
        buffer
            .extension_value(e)
            .and_then(|v| v.get("fallback"))
            .and_then(Value::as_bool)
            == Some(true)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn encoded_vertices(v: &[[u32; 2]]) -> Vec<u8> {
        meshopt::encoding::encode_vertex_buffer(v).unwrap()
    }

    #[test]
    fn a_vertex_stream_decodes_to_its_input_and_bad_streams_are_errors() {
        let v: Vec<[u32; 2]> = (0..100).map(|i| [i * 7, 1000 - i]).collect();
        let enc = encoded_vertices(&v);
        let ext = json!({"buffer": 0, "byteLength": enc.len(), "count": 100,
            "byteStride": 8, "mode": "ATTRIBUTES"});
        let c = Compressed::parse(&ext).unwrap();
        let out = c.decode(std::slice::from_ref(&enc)).unwrap();
        let want: Vec<u8> = v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        assert_eq!(out, want);
        // Truncated or corrupted streams are refused, not read past.
        let cut = Compressed::parse(&json!({"buffer": 0, "byteLength": enc.len() / 2,
            "count": 100, "byteStride": 8, "mode": "ATTRIBUTES"}))
        .unwrap();
        assert!(cut.decode(std::slice::from_ref(&enc)).is_err());
        let mut bad = enc.clone();
        bad[0] = 0xff;
        assert!(c.decode(&[bad]).unwrap_err().contains("malformed"));
        // A range outside the buffer is refused before decoding.
        let far = Compressed::parse(&json!({"buffer": 0, "byteOffset": 8, "byteLength":
            enc.len(), "count": 100, "byteStride": 8, "mode": "ATTRIBUTES"}))
        .unwrap();
        assert!(far.decode(&[enc]).unwrap_err().contains("outside"));
    }

    #[test]
    fn index_streams_decode_and_strides_the_codec_asserts_are_refused() {
        let idx: Vec<u32> = vec![0, 1, 2, 2, 1, 3, 3, 1, 4];
        let enc = meshopt::encoding::encode_index_buffer(&idx, 5).unwrap();
        let ext = json!({"buffer": 0, "byteLength": enc.len(), "count": 9, "byteStride": 4,
            "mode": "TRIANGLES"});
        let out = Compressed::parse(&ext).unwrap().decode(&[enc]).unwrap();
        let got: Vec<u32> = out
            .chunks_exact(4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        assert_eq!(got, idx);
        for (bad, why) in [
            (
                json!({"buffer": 0, "byteLength": 1, "count": 1, "byteStride": 6, "mode": "ATTRIBUTES"}),
                "multiple of 4",
            ),
            (
                json!({"buffer": 0, "byteLength": 1, "count": 1, "byteStride": 260, "mode": "ATTRIBUTES"}),
                "multiple of 4",
            ),
            (
                json!({"buffer": 0, "byteLength": 1, "count": 4, "byteStride": 4, "mode": "TRIANGLES"}),
                "multiple of 3",
            ),
            (
                json!({"buffer": 0, "byteLength": 1, "count": 3, "byteStride": 1, "mode": "INDICES"}),
                "2 or 4",
            ),
            (
                json!({"buffer": 0, "byteLength": 1, "count": 3, "byteStride": 12, "mode": "ATTRIBUTES", "filter": "OCTAHEDRAL"}),
                "does not apply",
            ),
            (
                json!({"buffer": 0, "byteLength": 1, "count": 3, "byteStride": 4, "mode": "ATTRIBUTES", "filter": "WAVELET"}),
                "not known",
            ),
            (
                json!({"buffer": 0, "byteLength": 1, "count": -3, "byteStride": 4, "mode": "ATTRIBUTES"}),
                "'count'",
            ),
            (
                json!({"buffer": 0, "count": 3, "byteStride": 4, "mode": "ATTRIBUTES"}),
                "byteLength",
            ),
        ] {
            let e = Compressed::parse(&bad).unwrap_err();
            assert!(e.contains(why), "{bad}: {e}");
        }
    }
}
