//! Participating media as voxel grids of source, opacity and albedo, ready for the
//! Global Cube (GlobalCube §2.1, §3): the source term `χᵗ` (emitted power density),
//! the opacity `σ = 1 − e^{−A}` of a voxel (`A` the optical depth across it, eq. (2))
//! and the scattering albedo `αˢ/α` (the fraction of extinction that scatters;
//! GlobalCube eq. (3) uses isotropic scattering `αˢ/4π`).
//!
//! Opacity is grey (one value per voxel: the "stationary gray equation of transfer");
//! source and albedo are RGB, one [`Rgb`] per voxel (a grey file gives three equal
//! channels). Storage is x-fastest: index `x + nx·(y + ny·z)`. The Haar pyramid of
//! GlobalCube §2.3 wants power-of-two resolutions; [`Medium::is_dyadic`] tells, but any
//! resolution is accepted (the volume method pads). [`read_raw_grid`] reads the raw
//! little-endian `f32` grid files the native format refers to.

use std::path::Path;

use glam::DVec3;

use crate::error::SceneError;
use crate::material::Rgb;

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
    /// Source term `χᵗ >= 0` per voxel and channel (emitted power per unit volume,
    /// W/m³).
    pub source: Vec<Rgb>,
    /// Opacity `σ ∈ [0, 1]` per voxel (`σ = 1 − e^{−A}`, GlobalCube §3.1).
    pub opacity: Vec<f64>,
    /// Scattering albedo `∈ [0, 1)` per voxel and channel.
    pub albedo: Vec<Rgb>,
}

impl Medium {
    /// A medium of uniform values over `[min, max]` with the given resolution.
    #[must_use]
    pub fn uniform(
        name: impl Into<String>,
        min: DVec3,
        max: DVec3,
        resolution: [usize; 3],
        source: Rgb,
        opacity: f64,
        albedo: Rgb,
    ) -> Self {
        let n = resolution.iter().product();
        Self {
            name: name.into(),
            min,
            max,
            resolution,
            source: vec![source; n],
            opacity: vec![opacity; n],
            albedo: vec![albedo; n],
        }
    }

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
        let channels = |g: &[Rgb], c: usize| g.iter().map(|v| v.0[c]).collect::<Vec<f64>>();
        let source: [Vec<f64>; 3] = [0, 1, 2].map(|c| channels(&self.source, c));
        let albedo: [Vec<f64>; 3] = [0, 1, 2].map(|c| channels(&self.albedo, c));
        for (what, grid, lo, hi, hi_open) in [
            ("source", &source[0], 0.0, f64::INFINITY, true),
            ("source", &source[1], 0.0, f64::INFINITY, true),
            ("source", &source[2], 0.0, f64::INFINITY, true),
            ("opacity", &self.opacity, 0.0, 1.0, false),
            ("albedo", &albedo[0], 0.0, 1.0, true),
            ("albedo", &albedo[1], 0.0, 1.0, true),
            ("albedo", &albedo[2], 0.0, 1.0, true),
        ] {
            if grid.len() != n {
                return Err(SceneError::Malformed {
                    file: file.into(),
                    element,
                    what: format!("{what} grid has {} values, expected {n}", grid.len()),
                });
            }
            for (i, &v) in grid.iter().enumerate() {
                let ok = v >= lo && if hi_open { v < hi } else { v <= hi };
                if !ok {
                    let [nx, ny] = [self.resolution[0], self.resolution[1]];
                    return Err(SceneError::InvalidMedium {
                        file: file.into(),
                        element: format!(
                            "{element} voxel [{}, {}, {}]",
                            i % nx,
                            (i / nx) % ny,
                            i / (nx * ny)
                        ),
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

/// Reads a raw grid file: little-endian `f32`, x fastest, `channels` values per voxel
/// interleaved (1 = grey, 3 = RGB). Returns one [`Rgb`] per voxel (grey values copied
/// to the three channels).
///
/// # Errors
/// [`SceneError::Io`] when the file cannot be read, [`SceneError::Malformed`] when its
/// size is not `voxels × channels × 4` bytes (both counts named) or `channels` is not
/// 1 or 3; `element` names the medium and grid in the message.
pub fn read_raw_grid(
    path: &Path,
    voxels: usize,
    channels: usize,
    element: &str,
) -> Result<Vec<Rgb>, SceneError> {
    let file = path.display().to_string();
    if channels != 1 && channels != 3 {
        return Err(SceneError::Malformed {
            file,
            element: element.into(),
            what: format!("channels = {channels}; a grid file has 1 (grey) or 3 (RGB)"),
        });
    }
    let bytes = std::fs::read(path).map_err(|e| SceneError::Io {
        file: file.clone(),
        message: e.to_string(),
    })?;
    let expected = voxels.saturating_mul(channels).saturating_mul(4);
    if bytes.len() != expected {
        return Err(SceneError::Malformed {
            file,
            element: element.into(),
            what: format!(
                "grid file has {} bytes, expected {expected} ({voxels} voxels × {channels} channel(s) × 4-byte f32)",
                bytes.len()
            ),
        });
    }
    let vals: Vec<f64> = bytes
        .chunks_exact(4)
        .map(|b| f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])))
        .collect();
    Ok(if channels == 1 {
        vals.into_iter().map(Rgb::grey).collect()
    } else {
        vals.chunks_exact(3)
            .map(|c| Rgb::new(c[0], c[1], c[2]))
            .collect()
    })
}
