//! The input of the method: a participating medium as validated `ndarray` grids on a
//! cubic, dyadic voxel lattice (GlobalCube §2.3 eq. (25): source `χᵗ` and opacity `σ`
//! sampled on an equidistant grid; §3.1: a voxel is a small cube).
//!
//! Arrays are `Array3<f64>` indexed `[z, y, x]` (x fastest in memory), the layout of
//! `wavelux_scene::Medium` and of `wavelux_mra::tensor`. Opacity is grey; source
//! (W/m³, power leaving per unit volume) and albedo are RGB. A medium of any shape is
//! padded to the next `2^k` cube with empty voxels (`σ = 0`, no source); voxels must
//! be cubes.

use glam::DVec3;
use ndarray::Array3;
use wavelux_scene::Medium;

use crate::error::VolumeError;

/// Largest padded side accepted (`2^12`; memory, not the method, is the limit).
pub const MAX_SIDE: usize = 4096;

/// A validated medium on a cubic `side³` lattice.
#[derive(Debug, Clone, PartialEq)]
pub struct VolumeGrid {
    /// The medium's name (for errors and reports).
    pub name: String,
    /// Voxels per axis of the padded cube (a power of two).
    pub side: usize,
    /// The medium's own voxel counts `[nx, ny, nz]` before padding.
    pub extent: [usize; 3],
    /// Voxel edge (scene units, metres).
    pub voxel: f64,
    /// Minimum corner of the lattice (scene units).
    pub min: DVec3,
    /// Opacity `σ ∈ [0, 1]` across one voxel edge, `[z, y, x]`.
    pub opacity: Array3<f64>,
    /// Source `χᵗ ≥ 0` per channel (W/m³).
    pub source: [Array3<f64>; 3],
    /// Scattering albedo `ω ∈ [0, 1)` per channel.
    pub albedo: [Array3<f64>; 3],
}

fn voxel_xyz(i: (usize, usize, usize)) -> [usize; 3] {
    [i.2, i.1, i.0]
}

impl VolumeGrid {
    /// Validates and pads the grids. `opacity`, `source` and `albedo` must share one
    /// shape `(nz, ny, nx)`; values must be finite with `σ ∈ [0, 1]`, `χᵗ ≥ 0`,
    /// `ω ∈ [0, 1)`; `voxel > 0`.
    ///
    /// # Errors
    /// [`VolumeError`] naming the medium and the first bad voxel.
    pub fn new(
        name: &str,
        voxel: f64,
        min: DVec3,
        opacity: Array3<f64>,
        source: [Array3<f64>; 3],
        albedo: [Array3<f64>; 3],
    ) -> Result<Self, VolumeError> {
        let shape_err = |what: String| VolumeError::Shape {
            medium: name.into(),
            what,
        };
        let dim = opacity.dim();
        if dim.0 == 0 || dim.1 == 0 || dim.2 == 0 {
            return Err(shape_err(format!("empty grid {dim:?}")));
        }
        for (what, g) in [
            ("source", &source[0]),
            ("source", &source[1]),
            ("source", &source[2]),
            ("albedo", &albedo[0]),
            ("albedo", &albedo[1]),
            ("albedo", &albedo[2]),
        ] {
            if g.dim() != dim {
                return Err(shape_err(format!(
                    "{what} grid has shape {:?}, opacity {dim:?} (z, y, x)",
                    g.dim()
                )));
            }
        }
        if !(voxel.is_finite() && voxel > 0.0 && min.is_finite()) {
            return Err(shape_err(format!(
                "voxel edge {voxel} / minimum corner {min} must be finite (edge > 0)"
            )));
        }
        let check = |what: &str,
                     g: &Array3<f64>,
                     ok: &dyn Fn(f64) -> bool,
                     range: &str|
         -> Result<(), VolumeError> {
            for (i, &v) in g.indexed_iter() {
                if !v.is_finite() {
                    return Err(VolumeError::NonFinite {
                        medium: name.into(),
                        what: what.into(),
                        voxel: voxel_xyz(i),
                        value: v,
                    });
                }
                if !ok(v) {
                    return Err(VolumeError::OutOfRange {
                        medium: name.into(),
                        what: what.into(),
                        voxel: voxel_xyz(i),
                        value: v,
                        range: range.into(),
                    });
                }
            }
            Ok(())
        };
        check("opacity", &opacity, &|v| (0.0..=1.0).contains(&v), "[0, 1]")?;
        for (c, g) in source.iter().enumerate() {
            let what = ["source (red)", "source (green)", "source (blue)"][c];
            check(what, g, &|v| v >= 0.0, "[0, ∞)")?;
        }
        for (c, g) in albedo.iter().enumerate() {
            let what = ["albedo (red)", "albedo (green)", "albedo (blue)"][c];
            check(what, g, &|v| (0.0..1.0).contains(&v), "[0, 1)")?;
        }
        let extent = [dim.2, dim.1, dim.0];
        let side = extent
            .iter()
            .copied()
            .max()
            .unwrap_or(1)
            .next_power_of_two();
        if side > MAX_SIDE {
            return Err(shape_err(format!("padded side {side} exceeds {MAX_SIDE}")));
        }
        let pad = |g: Array3<f64>| -> Array3<f64> {
            if g.dim() == (side, side, side) {
                return g;
            }
            let mut p = Array3::zeros((side, side, side));
            p.slice_mut(ndarray::s![..dim.0, ..dim.1, ..dim.2])
                .assign(&g);
            p
        };
        let [s0, s1, s2] = source;
        let [a0, a1, a2] = albedo;
        Ok(Self {
            name: name.into(),
            side,
            extent,
            voxel,
            min,
            opacity: pad(opacity),
            source: [pad(s0), pad(s1), pad(s2)],
            albedo: [pad(a0), pad(a1), pad(a2)],
        })
    }

    /// A grid from a scene medium. Voxels must be cubes to 1e-9 relative.
    ///
    /// # Errors
    /// [`VolumeError::NonCubicVoxels`], and the errors of [`VolumeGrid::new`].
    pub fn from_medium(m: &Medium) -> Result<Self, VolumeError> {
        let size = m.voxel_size();
        let h = size.x;
        if (size.y - h).abs() > 1e-9 * h || (size.z - h).abs() > 1e-9 * h {
            return Err(VolumeError::NonCubicVoxels {
                medium: m.name.clone(),
                size: size.to_array(),
            });
        }
        let [nx, ny, nz] = m.resolution;
        let shape = (nz, ny, nx);
        let n = nx * ny * nz;
        let wrong = |what: &str, len: usize| VolumeError::Shape {
            medium: m.name.clone(),
            what: format!("{what} grid has {len} values, expected {n}"),
        };
        if m.opacity.len() != n {
            return Err(wrong("opacity", m.opacity.len()));
        }
        if m.source.len() != n {
            return Err(wrong("source", m.source.len()));
        }
        if m.albedo.len() != n {
            return Err(wrong("albedo", m.albedo.len()));
        }
        let grid = |f: &dyn Fn(usize) -> f64| -> Array3<f64> {
            Array3::from_shape_fn(shape, |(z, y, x)| f(x + nx * (y + ny * z)))
        };
        let opacity = grid(&|i| m.opacity[i]);
        let source = [0, 1, 2].map(|c| grid(&|i| m.source[i].0[c]));
        let albedo = [0, 1, 2].map(|c| grid(&|i| m.albedo[i].0[c]));
        Self::new(&m.name, h, m.min, opacity, source, albedo)
    }

    /// Total source power per channel (W): `Σ χᵗ · voxel³`.
    #[must_use]
    pub fn source_power(&self) -> [f64; 3] {
        let v = self.voxel.powi(3);
        [0, 1, 2].map(|c| self.source[c].sum() * v)
    }

    /// Centre of voxel `[x, y, z]` in scene units.
    #[must_use]
    pub fn voxel_centre(&self, v: [usize; 3]) -> DVec3 {
        self.min + (DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64) + 0.5) * self.voxel
    }
}
