//! The walk over the node tree: each node's world transform, its mesh's primitives as
//! parts (decoded once per mesh, transformed per instance, re-wound where mirrored) and
//! its light as a luminaire.

use std::collections::hash_map::Entry;
use std::collections::HashMap;

use glam::{DMat4, DVec3};

use super::primitives::Triangles;
use super::{tree, Buffers, GltfModel, Reader, Unique};
use crate::input_limits::{MAX_COORD_M, MAX_OBJ_TRIANGLES, MAX_OBJ_VERTICES};
use crate::scene::materials::MaterialTable;
use crate::scene::obj::ObjPart;
use crate::scene::SceneError;

/// What the walk keeps for the mesh instances: the buffers and the relight material of
/// each glTF material, unique surface names, the vertex and triangle counts so far, the
/// primitives skipped, and each primitive's triangles, decoded at its first instance.
struct Instances<'b> {
    buffers: &'b Buffers,
    mats: &'b [u32],
    surfaces: Unique,
    counts: (usize, usize),
    skipped_modes: usize,
    decoded: HashMap<(usize, usize), Option<Triangles>>,
}

/// What the walk keeps for the lights: unique luminaire ids, the light group of each
/// light definition (by index) with unique group names, and the lights skipped.
#[derive(Default)]
pub(super) struct LightNames {
    pub(super) ids: Unique,
    pub(super) groups: HashMap<usize, String>,
    pub(super) group_names: Unique,
    pub(super) skipped_directional: usize,
}

impl Reader<'_> {
    /// Walks the node tree: meshes become parts, lights luminaires.
    pub(super) fn walk(
        &mut self,
        doc: &gltf::Document,
        buffers: &Buffers,
        mats: &[u32],
        out: &mut GltfModel,
    ) -> Result<(), SceneError> {
        // The hierarchy is a forest of strict trees within the limits (checked in one
        // pass, before any mesh is decoded), so every node below is visited once.
        let roots = tree::roots(doc).map_err(|m| self.err(m))?;
        let all: Vec<gltf::Node<'_>> = doc.nodes().collect();
        let mut instances = Instances {
            buffers,
            mats,
            surfaces: Unique::default(),
            counts: (0, 0),
            skipped_modes: 0,
            decoded: HashMap::new(),
        };
        let mut lights = LightNames::default();
        // Each node with the name of its nearest named ancestor: optimizers (gltfpack)
        // move meshes onto unnamed child nodes, which are named after it.
        let mut stack: Vec<(gltf::Node<'_>, DMat4, Option<String>)> = roots
            .into_iter()
            .rev()
            .map(|i| (all[i].clone(), DMat4::IDENTITY, None))
            .collect();
        while let Some((node, parent, ancestor)) = stack.pop() {
            let local = node.transform().matrix().map(|c| c.map(f64::from));
            let world = parent * DMat4::from_cols_array_2d(&local);
            if !world.is_finite() {
                return Err(self.err(format!("nodes[{}]: transform is not finite", node.index())));
            }
            if let Some(mesh) = node.mesh() {
                self.mesh_parts(
                    &node,
                    ancestor.as_deref(),
                    &mesh,
                    &world,
                    &mut instances,
                    out,
                )?;
            }
            if let Some(light) = node.light() {
                self.light(&node, &light, &world, &mut lights, out)?;
            }
            let named = node
                .name()
                .map(str::trim)
                .filter(|n| !n.is_empty())
                .map(str::to_string)
                .or(ancestor);
            for c in node.children().collect::<Vec<_>>().into_iter().rev() {
                stack.push((c, world, named.clone()));
            }
        }
        self.warn_skipped(instances.skipped_modes, lights.skipped_directional);
        Ok(())
    }

    /// The parts of `mesh` instanced by `node` at `world`. Its surfaces take the node's
    /// name, else the mesh's, else `ancestor`'s (the nearest named one), else `node<i>`.
    fn mesh_parts(
        &mut self,
        node: &gltf::Node<'_>,
        ancestor: Option<&str>,
        mesh: &gltf::Mesh<'_>,
        world: &DMat4,
        inst: &mut Instances<'_>,
        out: &mut GltfModel,
    ) -> Result<(), SceneError> {
        let name = [node.name(), mesh.name()]
            .into_iter()
            .flatten()
            .find(|n| !n.trim().is_empty())
            .or(ancestor);
        let base = inst.surfaces.take(name, || format!("node{}", node.index()));
        let names = surface_names(&base, mesh, inst, &out.table);
        for prim in mesh.primitives() {
            let name = &names[&prim.material().index()];
            let tris = match inst.decoded.entry((mesh.index(), prim.index())) {
                Entry::Occupied(e) => e.into_mut(),
                Entry::Vacant(e) => e.insert(self.primitive(&prim, mesh, inst.buffers)?),
            };
            let Some((positions, indices)) = tris else {
                inst.skipped_modes += 1;
                continue;
            };
            inst.counts.0 += positions.len();
            inst.counts.1 += indices.len();
            if inst.counts.0 > MAX_OBJ_VERTICES || inst.counts.1 > MAX_OBJ_TRIANGLES {
                return Err(self.err(format!(
                    "more than {MAX_OBJ_VERTICES} vertices or {MAX_OBJ_TRIANGLES} \
                     triangles over all mesh instances"
                )));
            }
            let part = self.part(name, world, positions, indices, &prim, inst.mats)?;
            out.parts.push(part);
        }
        Ok(())
    }
}

/// The surface name of each material among `mesh`'s primitives (by glTF material index,
/// None for the default material): the node's `base` name when they all share one
/// material, else `base / material` for each, so that floor, walls and furniture that an
/// exporter put into one mesh stay apart.
fn surface_names(
    base: &str,
    mesh: &gltf::Mesh<'_>,
    inst: &mut Instances<'_>,
    table: &MaterialTable,
) -> HashMap<Option<usize>, String> {
    let mut used: Vec<Option<usize>> = mesh.primitives().map(|p| p.material().index()).collect();
    used.sort_unstable();
    used.dedup();
    if used.len() == 1 {
        return used.into_iter().map(|m| (m, base.to_string())).collect();
    }
    used.into_iter()
        .map(|m| {
            let material = m
                .and_then(|i| inst.mats.get(i))
                .and_then(|&k| table.materials.get(k as usize))
                .map_or("default", |mat| mat.name.as_str());
            let name = inst
                .surfaces
                .take(Some(&format!("{base} / {material}")), || base.to_string());
            (m, name)
        })
        .collect()
}

impl Reader<'_> {
    /// Warns of the primitives (points, lines) and lights (directional) the walk skipped.
    fn warn_skipped(&mut self, skipped_modes: usize, skipped_directional: usize) {
        if skipped_modes > 0 {
            self.warnings.push(format!(
                "{}: {skipped_modes} primitive(s) of points or lines skipped (only triangles \
                 take part in radiosity)",
                self.shown.display()
            ));
        }
        if skipped_directional > 0 {
            self.warnings.push(format!(
                "{}: {skipped_directional} directional light(s) skipped (luminaires are points \
                 and spots)",
                self.shown.display()
            ));
        }
    }

    /// One part: the primitive's triangles in file units, transformed by `world`.
    fn part(
        &self,
        name: &str,
        world: &DMat4,
        positions: &[[f32; 3]],
        tris: &[[u32; 3]],
        prim: &gltf::Primitive<'_>,
        mats: &[u32],
    ) -> Result<ObjPart, SceneError> {
        let flip = world.determinant() < 0.0;
        let mut flat = Vec::with_capacity(3 * positions.len());
        for p in positions {
            let w = world.transform_point3(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
            if !w.is_finite() || (w * self.scale).abs().max_element() > MAX_COORD_M {
                return Err(self.err(format!(
                    "node '{name}': vertex {w} lies beyond {MAX_COORD_M} m"
                )));
            }
            flat.extend([w.x as f32, w.y as f32, w.z as f32]);
        }
        let indices = tris
            .iter()
            .flat_map(|t| if flip { [t[0], t[2], t[1]] } else { *t })
            .collect();
        let material = prim
            .material()
            .index()
            .and_then(|i| mats.get(i))
            .map(|&m| m as usize);
        Ok(ObjPart {
            name: name.to_string(),
            material,
            positions: flat,
            indices,
        })
    }
}
