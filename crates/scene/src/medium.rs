//! Participating media as voxel grids of source, opacity and albedo, ready for the
//! Global Cube (GlobalCube §2.1, §3): the source term `χᵗ` (emitted power density),
//! the opacity `σ = 1 − e^{−A}` of a voxel (`A` the optical depth across it, eq. (2))
//! and the scattering albedo `αˢ/α` (the fraction of extinction that scatters;
//! GlobalCube eq. (3) uses isotropic scattering `αˢ/4π`).
//!
//! Grids are gray (one value per voxel), as in GlobalCube's "stationary gray
//! equation of transfer". Storage is x-fastest: index `x + nx·(y + ny·z)`. The Haar
//! pyramid of GlobalCube §3.1 wants power-of-two resolutions; [`Medium::is_dyadic`]
//! tells, but any resolution is accepted.

use glam::DVec3;

use crate::error::SceneError;

/// A voxel grid of a participating medium over an axis-aligned box.
#[derive(Debug, Clone, PartialEq)]
pub struct Medium {
    /// Unique name.
    pub name: String,
    /// Minimum corner of the box (scene units).
    pub min: DVec3,
    /// Maximum corner of the box, `> min` in every axis.
    pub max: DVec3,
    /// Voxel counts `[nx, ny, nz]`, each `>= 1`.
    pub resolution: [usize; 3],
    /// Source term `χᵗ >= 0` per voxel (emitted power per unit volume, gray).
    pub source: Vec<f64>,
    /// Opacity `σ ∈ [0, 1]` per voxel (`σ = 1 − e^{−A}`, GlobalCube §3.1).
    pub opacity: Vec<f64>,
    /// Scattering albedo `∈ [0, 1)` per voxel.
    pub albedo: Vec<f64>,
}

impl Medium {
    /// Number of voxels `nx·ny·nz` (saturating).
    pub fn voxel_count(&self) -> usize {
        self.resolution
            .iter()
            .fold(1usize, |a, &n| a.saturating_mul(n))
    }

    /// Flat index of voxel `(x, y, z)` (x fastest).
    pub fn index(&self, x: usize, y: usize, z: usize) -> usize {
        x + self.resolution[0] * (y + self.resolution[1] * z)
    }

    /// Edge lengths of one voxel.
    pub fn voxel_size(&self) -> DVec3 {
        (self.max - self.min)
            / DVec3::new(
                self.resolution[0] as f64,
                self.resolution[1] as f64,
                self.resolution[2] as f64,
            )
    }

    /// Whether every resolution is a power of two (what the Haar pyramid wants).
    pub fn is_dyadic(&self) -> bool {
        self.resolution.iter().all(|n| n.is_power_of_two())
    }

    /// Checks sizes and ranges: box finite and non-empty, grids of `nx·ny·nz`
    /// values, source finite and `>= 0`, opacity in `[0, 1]`, albedo in `[0, 1)`.
    pub fn validate(&self, file: &str) -> Result<(), SceneError> {
        let element = format!("medium {:?}", self.name);
        for v in self.min.to_array().into_iter().chain(self.max.to_array()) {
            if !v.is_finite() {
                return Err(SceneError::NonFinite {
                    file: file.into(),
                    element,
                    what: "bounding box".into(),
                    value: v,
                });
            }
        }
        if !(self.max.cmpgt(self.min).all()) {
            return Err(SceneError::Malformed {
                file: file.into(),
                element,
                what: "bounding box max must exceed min in every axis".into(),
            });
        }
        if self.resolution.contains(&0) || self.resolution.iter().any(|&n| n > 4096) {
            return Err(SceneError::Malformed {
                file: file.into(),
                element,
                what: format!(
                    "resolution {:?} must be in 1..=4096 per axis",
                    self.resolution
                ),
            });
        }
        let n = self.voxel_count();
        for (what, grid, lo, hi, hi_open) in [
            ("source", &self.source, 0.0, f64::INFINITY, true),
            ("opacity", &self.opacity, 0.0, 1.0, false),
            ("albedo", &self.albedo, 0.0, 1.0, true),
        ] {
            if grid.len() != n {
                return Err(SceneError::Malformed {
                    file: file.into(),
                    element,
                    what: format!("{what} grid has {} values, expected {n}", grid.len()),
                });
            }
            for &v in grid.iter() {
                let ok = v >= lo && if hi_open { v < hi } else { v <= hi };
                if !ok {
                    return Err(SceneError::InvalidMedium {
                        file: file.into(),
                        element,
                        what: what.into(),
                        value: v,
                        range: if hi_open {
                            format!("[{lo}, {hi})")
                        } else {
                            format!("[{lo}, {hi}]")
                        },
                    });
                }
            }
        }
        Ok(())
    }
}
