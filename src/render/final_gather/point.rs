//! The points at which the `final` image computes light, as its parts pass them on.
//!
//! A camera sample, a shading vertex or a gather ray's close hit is a [`ShadingPoint`]: a
//! point on a patch, which the gather and the glossy lobe read the solution around. Its
//! shadow rays leave from a [`ShadowOrigin`]: the same point with the scene triangle the
//! patch was cut from, which those rays skip (the scene BVH holds triangles, not patches).

use glam::DVec3;

use crate::geometry::mesh::Mesh;

/// A point on a patch where light is computed.
#[derive(Debug, Clone, Copy)]
pub(super) struct ShadingPoint {
    pub(super) position: DVec3,
    /// The front normal of the element it lies on (the patch's, for a single triangle).
    pub(super) normal: DVec3,
    /// The patch it lies on (an index into the mesh's patches).
    pub(super) patch: u32,
    /// The element (triangle) of the patch it lies on (an index into the mesh's elements).
    pub(super) element: u32,
}

/// A point that shadow rays leave from, on the scene BVH.
#[derive(Debug, Clone, Copy)]
pub(super) struct ShadowOrigin {
    pub(super) position: DVec3,
    pub(super) normal: DVec3,
    /// The scene triangle the point lies on, which its rays skip.
    pub(super) skip_triangle: u32,
}

impl ShadingPoint {
    /// The point `position` on patch `patch`, with the element it lies in.
    pub(super) fn on(mesh: &Mesh, position: DVec3, patch: u32) -> ShadingPoint {
        let (element, _) = mesh.locate(patch as usize, position);
        ShadingPoint {
            position,
            normal: mesh.facet(element).normal,
            patch,
            element: element as u32,
        }
    }

    /// The scene triangle it lies on.
    pub(super) fn triangle(&self, mesh: &Mesh) -> u32 {
        mesh.elements[self.element as usize].source
    }

    /// The shadow rays' origin at this point: the scene triangle it lies on skipped.
    pub(super) fn shadow_origin(&self, mesh: &Mesh) -> ShadowOrigin {
        ShadowOrigin {
            position: self.position,
            normal: self.normal,
            skip_triangle: self.triangle(mesh),
        }
    }
}
