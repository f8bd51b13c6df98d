//! A primitive's accessors decoded: float positions, unsigned indices checked against the
//! vertex count, and strips and fans unrolled into triangles.

use super::buffers::accessor_bytes;
use super::{Buffers, Reader};
use crate::input_limits::{MAX_OBJ_TRIANGLES, MAX_OBJ_VERTICES};
use crate::scene::SceneError;

/// A primitive's positions (file units, untransformed) and triangles.
pub(super) type Triangles = (Vec<[f32; 3]>, Vec<[u32; 3]>);

impl Reader<'_> {
    /// The positions (file units, untransformed) and triangles of one primitive; None for
    /// primitives that are not triangles.
    pub(super) fn primitive(
        &self,
        prim: &gltf::Primitive<'_>,
        mesh: &gltf::Mesh<'_>,
        buffers: &Buffers,
    ) -> Result<Option<Triangles>, SceneError> {
        use gltf::mesh::Mode;
        let what = format!("meshes[{}].primitives[{}]", mesh.index(), prim.index());
        let mode = prim.mode();
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            return Ok(None);
        }
        let positions = self.positions(prim, &what, buffers)?;
        let n = positions.len();
        let list: Vec<u32> = match prim.indices() {
            None => (0..n as u32).collect(),
            Some(acc) => self.indices(&acc, &what, buffers, n)?,
        };
        let tris: Vec<[u32; 3]> = match mode {
            Mode::Triangles => list.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
            Mode::TriangleStrip => (2..list.len())
                .map(|i| {
                    if i % 2 == 0 {
                        [list[i - 2], list[i - 1], list[i]]
                    } else {
                        [list[i - 1], list[i - 2], list[i]]
                    }
                })
                .collect(),
            _ => (2..list.len())
                .map(|i| [list[0], list[i - 1], list[i]])
                .collect(),
        };
        Ok(Some((positions, tris)))
    }

    /// The POSITION attribute of primitive `prim` (named `what` in errors): floats, or
    /// the integers of `KHR_mesh_quantization` (normalized or not), as floats. The node
    /// transform then dequantizes them, as the extension intends.
    fn positions(
        &self,
        prim: &gltf::Primitive<'_>,
        what: &str,
        buffers: &Buffers,
    ) -> Result<Vec<[f32; 3]>, SceneError> {
        let pos = prim
            .get(&gltf::Semantic::Positions)
            .ok_or_else(|| self.err(format!("{what}: no POSITION attribute")))?;
        use gltf::accessor::DataType;
        if pos.dimensions() != gltf::accessor::Dimensions::Vec3 {
            return Err(self.err(format!("{what}: POSITION must be VEC3")));
        }
        let (ty, norm) = (pos.data_type(), pos.normalized());
        let size = match ty {
            DataType::F32 if !norm => 4,
            DataType::I8 | DataType::U8 => 1,
            DataType::I16 | DataType::U16 => 2,
            _ => {
                return Err(self.err(format!(
                    "{what}: POSITION of type {ty:?}{} is not read (float, or \
                     KHR_mesh_quantization's 8- and 16-bit integers)",
                    if norm { " (normalized)" } else { "" }
                )))
            }
        };
        let raw = accessor_bytes(&pos, buffers, 3 * size, MAX_OBJ_VERTICES)
            .map_err(|m| self.err(format!("{what}: POSITION {m}")))?;
        Ok(raw
            .map(|b| std::array::from_fn(|k| component(&b[size * k..size * (k + 1)], ty, norm)))
            .collect())
    }

    /// The vertex indices of accessor `acc` (of primitive `what`), each below `n`.
    fn indices(
        &self,
        acc: &gltf::Accessor<'_>,
        what: &str,
        buffers: &Buffers,
        n: usize,
    ) -> Result<Vec<u32>, SceneError> {
        use gltf::accessor::DataType;
        let size = match acc.data_type() {
            DataType::U8 => 1,
            DataType::U16 => 2,
            DataType::U32 => 4,
            other => {
                return Err(self.err(format!(
                    "{what}: indices must be unsigned integers, not {other:?}"
                )))
            }
        };
        if acc.dimensions() != gltf::accessor::Dimensions::Scalar {
            return Err(self.err(format!("{what}: indices must be SCALAR")));
        }
        let raw = accessor_bytes(acc, buffers, size, 3 * MAX_OBJ_TRIANGLES)
            .map_err(|m| self.err(format!("{what}: indices {m}")))?;
        let list: Vec<u32> = raw
            .map(|b| match size {
                1 => b[0] as u32,
                2 => u16::from_le_bytes([b[0], b[1]]) as u32,
                _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            })
            .collect();
        if let Some(bad) = list.iter().find(|&&i| i as usize >= n) {
            return Err(self.err(format!("{what}: index {bad} out of range ({n} vertices)")));
        }
        Ok(list)
    }
}

/// One vertex component of `ty` as a float: normalized integers map to [0, 1] (unsigned)
/// or [−1, 1] (signed, `max(c / (2ⁿ⁻¹ − 1), −1)`), as glTF defines them.
fn component(b: &[u8], ty: gltf::accessor::DataType, normalized: bool) -> f32 {
    use gltf::accessor::DataType;
    let (v, scale) = match ty {
        DataType::I8 => (b[0] as i8 as f32, 127.0),
        DataType::U8 => (b[0] as f32, 255.0),
        DataType::I16 => (i16::from_le_bytes([b[0], b[1]]) as f32, 32767.0),
        DataType::U16 => (u16::from_le_bytes([b[0], b[1]]) as f32, 65535.0),
        _ => return f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
    };
    if normalized {
        (v / scale).max(-1.0)
    } else {
        v
    }
}

#[cfg(test)]
mod tests {
    use super::component;
    use gltf::accessor::DataType;

    #[test]
    fn quantized_components_dequantize_as_gltf_defines() {
        assert_eq!(component(&[0x80], DataType::I8, true), -1.0);
        assert_eq!(component(&[0x81], DataType::I8, true), -1.0);
        assert_eq!(component(&[127], DataType::I8, true), 1.0);
        assert_eq!(component(&[0x81], DataType::I8, false), -127.0);
        assert_eq!(component(&[255], DataType::U8, true), 1.0);
        assert_eq!(component(&[0xff, 0x7f], DataType::I16, true), 1.0);
        assert_eq!(component(&[0x00, 0x80], DataType::I16, false), -32768.0);
        assert_eq!(component(&[0xff, 0xff], DataType::U16, false), 65535.0);
        assert_eq!(component(&1.5f32.to_le_bytes(), DataType::F32, false), 1.5);
    }
}
