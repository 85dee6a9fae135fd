//! The multiresolution representation of the medium (GlobalCube §2.3, eqs. (25)–(27)):
//! the non-standard 3D Haar decomposition of source and opacity (seven wavelet types
//! per cell) by `wavelux_mra::tensor`, the lowpass levels used as clusters, and the
//! max-detail pyramids the static oracle reads (§4.2).
//!
//! Levels: level 0 is the input lattice (the paper's `m0`), level `l` has cells of
//! `2^l` voxels (`m = m0 + l`), up to `L` (`M = m0 + L`).
//!
//! **Units of details.** `wavelux-mra` is orthonormal; the paper's Haar lowpass is an
//! average (Fig. 13a: opaque objects turn half-transparent at coarse levels). A detail
//! coefficient `d` produced by the `l`-th decomposition step is converted to the
//! average convention `d / (2√2)^l`: the amplitude by which the eight children of a
//! level-`l` cell deviate from their mean in that wavelet's ± pattern, in the unit of
//! the field (σ dimensionless, `χᵗ` in W/m³). Thresholds are in these units.
//!
//! **Coarse values.** Source: the average (power-preserving). Opacity: the average of
//! σ (the paper, [`CoarseOpacity::Average`]) or the mean extinction
//! ([`CoarseOpacity::MeanExtinction`]: `A_{l} = 2 · mean(A_{l−1})`, exact for
//! homogeneous regions, opaque if any child is). Albedo: the σ-weighted mean per
//! channel (the plain mean where all σ are 0).

use ndarray::Array3;
use wavelux_mra::{Alpert, tensor};

use crate::cell::{depth_of, sigma_of};
use crate::error::VolumeError;
use crate::grid::VolumeGrid;

/// How coarse opacities are formed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CoarseOpacity {
    /// Mean of the children's σ (GlobalCube eq. (27); default).
    #[default]
    Average,
    /// Mean of the children's optical depths per voxel (homogeneous media exact).
    MeanExtinction,
}

/// Lowpass values and max-detail pyramids of a [`VolumeGrid`].
#[derive(Debug, Clone)]
pub struct Hierarchy {
    /// Number of coarse levels `L` (`0` = the standard, non-hierarchical method).
    pub levels: usize,
    /// Voxels per axis at level 0.
    pub side: usize,
    /// Opacity per level (`[z, y, x]`, side `side >> l`).
    pub opacity: Vec<Array3<f64>>,
    /// Source per level and channel (W/m³).
    pub source: Vec<[Array3<f64>; 3]>,
    /// Albedo per level and channel.
    pub albedo: Vec<[Array3<f64>; 3]>,
    /// Largest |detail| of σ inside each cell (its own seven and all its
    /// descendants'), average units; level 0 is zero.
    pub max_detail_opacity: Vec<Array3<f64>>,
    /// Same for the source (largest over the channels), W/m³.
    pub max_detail_source: Vec<Array3<f64>>,
}

/// Mean of the 8 children of every cell of `a` (side halves).
fn coarsen(a: &Array3<f64>, f: impl Fn([f64; 8]) -> f64) -> Array3<f64> {
    let n = a.dim().0 / 2;
    Array3::from_shape_fn((n, n, n), |(z, y, x)| {
        let mut v = [0.0; 8];
        for (k, slot) in v.iter_mut().enumerate() {
            let (dz, dy, dx) = (k >> 2, (k >> 1) & 1, k & 1);
            *slot = a[[2 * z + dz, 2 * y + dy, 2 * x + dx]];
        }
        f(v)
    })
}

/// Max-detail pyramid of one scalar field by the orthonormal Haar transform.
fn detail_pyramid(field: &Array3<f64>, levels: usize) -> Result<Vec<Array3<f64>>, VolumeError> {
    let n = field.dim().0;
    let big_j = n.trailing_zeros();
    let mut out = vec![Array3::zeros((n, n, n))];
    if levels == 0 {
        return Ok(out);
    }
    let haar = Alpert::haar();
    let mut data: Vec<f64> = field.iter().copied().collect();
    let j0 = big_j - levels as u32;
    tensor::nonstandard_decompose(&haar, 3, big_j, j0, &mut data)
        .map_err(|e| VolumeError::Solver(format!("Haar decomposition: {e}")))?;
    let scale = 2.0 * std::f64::consts::SQRT_2;
    for l in 1..=levels {
        // Cells of level l: resolution 2^j with j = J − l; their details were made by
        // the l-th step.
        let m = n >> l;
        let conv = scale.powi(l as i32);
        let prev = &out[l - 1];
        let lev = Array3::from_shape_fn((m, m, m), |(z, y, x)| {
            let mut best = 0.0f64;
            for e in 1..8usize {
                let (ez, ey, ex) = (e >> 2, (e >> 1) & 1, e & 1);
                let (zz, yy, xx) = (z + ez * m, y + ey * m, x + ex * m);
                let d = data[xx + n * (yy + n * zz)] / conv;
                best = best.max(d.abs());
            }
            for k in 0..8usize {
                let (dz, dy, dx) = (k >> 2, (k >> 1) & 1, k & 1);
                best = best.max(prev[[2 * z + dz, 2 * y + dy, 2 * x + dx]]);
            }
            best
        });
        out.push(lev);
    }
    Ok(out)
}

impl Hierarchy {
    /// Builds `levels` coarse levels of `grid`.
    ///
    /// # Errors
    /// [`VolumeError::Levels`] when `levels > log2(side)`.
    pub fn new(
        grid: &VolumeGrid,
        levels: usize,
        coarse: CoarseOpacity,
    ) -> Result<Self, VolumeError> {
        let n = grid.side;
        let max = n.trailing_zeros() as usize;
        if levels > max {
            return Err(VolumeError::Levels {
                medium: grid.name.clone(),
                levels,
                side: n,
                max,
            });
        }
        let mean = |v: [f64; 8]| v.iter().sum::<f64>() / 8.0;
        let mut opacity = vec![grid.opacity.clone()];
        let mut source = vec![grid.source.clone()];
        let mut albedo = vec![grid.albedo.clone()];
        for l in 1..=levels {
            let s = &opacity[l - 1];
            let o = match coarse {
                CoarseOpacity::Average => coarsen(s, mean),
                CoarseOpacity::MeanExtinction => coarsen(s, |v| {
                    let a = v.iter().map(|&x| depth_of(x)).sum::<f64>() / 8.0;
                    sigma_of(2.0 * a)
                }),
            };
            let src = [0, 1, 2].map(|c| coarsen(&source[l - 1][c], mean));
            // σ-weighted albedo: coarsen σ·ω and σ, divide.
            let prev_op = &opacity[l - 1];
            let alb = [0, 1, 2].map(|c| {
                let a = &albedo[l - 1][c];
                let m = prev_op.dim().0 / 2;
                Array3::from_shape_fn((m, m, m), |(z, y, x)| {
                    let (mut sw, mut s, mut plain) = (0.0, 0.0, 0.0);
                    for k in 0..8usize {
                        let (dz, dy, dx) = (k >> 2, (k >> 1) & 1, k & 1);
                        let i = [2 * z + dz, 2 * y + dy, 2 * x + dx];
                        sw += prev_op[i] * a[i];
                        s += prev_op[i];
                        plain += a[i];
                    }
                    if s > 0.0 { sw / s } else { plain / 8.0 }
                })
            });
            opacity.push(o);
            source.push(src);
            albedo.push(alb);
        }
        let max_detail_opacity = detail_pyramid(&grid.opacity, levels)?;
        let per_channel: Vec<Vec<Array3<f64>>> = grid
            .source
            .iter()
            .map(|s| detail_pyramid(s, levels))
            .collect::<Result<_, _>>()?;
        let max_detail_source = (0..=levels)
            .map(|l| {
                let mut m = per_channel[0][l].clone();
                for c in 1..3 {
                    m.zip_mut_with(&per_channel[c][l], |a, &b| *a = a.max(b));
                }
                m
            })
            .collect();
        Ok(Self {
            levels,
            side: n,
            opacity,
            source,
            albedo,
            max_detail_opacity,
            max_detail_source,
        })
    }

    /// Cells per axis at level `l`.
    #[must_use]
    pub fn side_at(&self, l: usize) -> usize {
        self.side >> l
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn grid(n: usize, f: impl Fn(usize, usize, usize) -> f64) -> VolumeGrid {
        let op = Array3::from_shape_fn((n, n, n), |(z, y, x)| f(x, y, z));
        let src = [0, 1, 2]
            .map(|c| Array3::from_shape_fn((n, n, n), |(z, y, x)| (c + 1) as f64 * f(y, z, x)));
        let alb = [0, 1, 2].map(|_| Array3::from_elem((n, n, n), 0.5));
        VolumeGrid::new("t", 1.0, DVec3::ZERO, op, src, alb).unwrap()
    }

    #[test]
    fn converted_details_are_child_deviations() {
        // One cell's children: the x-type detail is (mean of x=1 − mean of x=0)/2.
        let g = grid(4, |x, y, z| {
            if x % 2 == 1 && y < 2 && z < 2 {
                0.8
            } else {
                0.0
            }
        });
        let h = Hierarchy::new(&g, 2, CoarseOpacity::Average).unwrap();
        // Cell (0,0,0) at level 1: children x=1 are 0.8, x=0 are 0: mean 0.4, the x-type
        // detail amplitude 0.4 (children = 0.4 ± 0.4).
        assert!((h.max_detail_opacity[1][[0, 0, 0]] - 0.4).abs() < 1e-12);
        assert!((h.opacity[1][[0, 0, 0]] - 0.4).abs() < 1e-12);
        // Other level-1 cells are uniform zero.
        assert_eq!(h.max_detail_opacity[1][[1, 1, 1]], 0.0);
        // Level 2 sees the level-1 detail inside it and its own (the level-1 means are
        // 0.4, 0.4, 0, ... so the level-2 mean is 0.1).
        assert!((h.max_detail_opacity[2][[0, 0, 0]] - 0.4).abs() < 1e-12);
        assert!((h.opacity[2][[0, 0, 0]] - 0.1).abs() < 1e-12);
    }

    #[test]
    fn lowpass_matches_haar_scaling_coefficients() {
        let g = grid(8, |x, y, z| ((x * 7 + y * 3 + z * 5) % 11) as f64 / 11.0);
        let h = Hierarchy::new(&g, 3, CoarseOpacity::Average).unwrap();
        let mut data: Vec<f64> = g.opacity.iter().copied().collect();
        tensor::nonstandard_decompose(&Alpert::haar(), 3, 3, 1, &mut data).unwrap();
        let conv = (2.0 * std::f64::consts::SQRT_2).powi(2);
        for z in 0..2 {
            for y in 0..2 {
                for x in 0..2 {
                    let c = data[x + 8 * (y + 8 * z)] / conv;
                    assert!((c - h.opacity[2][[z, y, x]]).abs() < 1e-12);
                }
            }
        }
    }

    #[test]
    fn mean_extinction_keeps_homogeneous_media() {
        let g = grid(4, |_, _, _| 0.3);
        let h = Hierarchy::new(&g, 2, CoarseOpacity::MeanExtinction).unwrap();
        // Across a level-2 cell (4 voxels): 1 − 0.7⁴.
        assert!((h.opacity[2][[0, 0, 0]] - (1.0 - 0.7f64.powi(4))).abs() < 1e-12);
        let a = Hierarchy::new(&g, 2, CoarseOpacity::Average).unwrap();
        assert!((a.opacity[2][[0, 0, 0]] - 0.3).abs() < 1e-12);
        assert!(matches!(
            Hierarchy::new(&g, 3, CoarseOpacity::Average),
            Err(VolumeError::Levels { .. })
        ));
    }
}
