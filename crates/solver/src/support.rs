//! Patches of the diffuse solver: the unit-square supports of `wavelux-support`
//! (re-exported here) with the diffuse reflectance and emitted exitance of each lit
//! side (Ziegler §3.3.1; VirtualMesh §3–§4 for virtual supports).

use wavelux_param::ParamKind;
use wavelux_scene::Scene;
pub use wavelux_support::{Coverage, Mask, Side, Support, SupportMap};

use crate::error::SolverError;

/// One lit side of one support: the unit that carries an element quadtree.
#[derive(Debug, Clone, PartialEq)]
pub struct Patch {
    /// Index of the scene surface.
    pub surface: usize,
    /// Index of the piece within the surface (mesh element or polygon rectangle).
    pub piece: usize,
    /// Which side.
    pub side: Side,
    /// The support (normal of this side).
    pub support: Support,
    /// Diffuse reflectance per RGB channel, `0 ≤ ρ < 1`.
    pub reflectance: [f64; 3],
    /// Emitted exitance per RGB channel (W/m²).
    pub emission: [f64; 3],
    /// Primitive id of the support in the visibility accelerator.
    pub prim: u32,
}

impl Patch {
    /// Whether the patch can receive (reflects in some channel).
    pub fn reflects(&self) -> bool {
        self.reflectance.iter().any(|&r| r > 0.0)
    }

    /// Whether the patch can ever be bright (emits or reflects).
    pub fn can_emit(&self) -> bool {
        self.reflects() || self.emission.iter().any(|&e| e > 0.0)
    }
}

/// Patches and geometric primitives of a scene.
#[derive(Debug, Clone)]
pub struct PatchSet {
    /// The patches.
    pub patches: Vec<Patch>,
    /// One support per geometric piece (front orientation), indexed by [`Patch::prim`].
    pub pieces: Vec<Support>,
    /// For each surface, the indices of its patches.
    pub by_surface: Vec<Vec<usize>>,
}

/// Diffuse reflectance and exitance of a material (textures by their mean).
fn material_values(
    scene: &Scene,
    id: usize,
    what: &str,
) -> Result<([f64; 3], [f64; 3]), SolverError> {
    let m = scene.materials.get(id).ok_or_else(|| {
        SolverError::InvalidScene(format!("{what}: material id {id} out of range"))
    })?;
    m.checked_diffuse_means(&scene.textures)
        .map_err(|why| SolverError::InvalidScene(format!("{what}: {why}")))
}

/// Builds the patches of a scene with equal-area supports
/// (`build_patches_with(scene, ParamKind::EqualArea)`).
///
/// # Errors
/// As [`build_patches_with`].
pub fn build_patches(scene: &Scene) -> Result<PatchSet, SolverError> {
    build_patches_with(scene, ParamKind::EqualArea)
}

/// Builds the patches of a scene: the supports of
/// [`wavelux_support::build_supports`] (one per lit side) with the diffuse reflectance
/// and exitance of each side's material. Textured materials use the texture mean
/// (this solver has constant reflectance and emission per support).
///
/// # Errors
/// [`SolverError::UnsupportedSurface`] for a trimmed patch whose trim has a point
/// without a natural-coordinate preimage (with `ParamKind::Natural`),
/// [`SolverError::InvalidScene`] for bad materials or degenerate pieces.
pub fn build_patches_with(scene: &Scene, kind: ParamKind) -> Result<PatchSet, SolverError> {
    let set = wavelux_support::build_supports(scene, kind)?;
    let mut patches = Vec::with_capacity(set.sides.len());
    for s in set.sides {
        let what = format!("surface {:?}", scene.surfaces[s.surface].name);
        let (reflectance, emission) = material_values(scene, s.material, &what)?;
        patches.push(Patch {
            surface: s.surface,
            piece: s.piece,
            side: s.side,
            support: s.support,
            reflectance,
            emission,
            prim: s.prim,
        });
    }
    Ok(PatchSet {
        patches,
        pieces: set.pieces,
        by_surface: set.by_surface,
    })
}
