//! Helpers shared by the volume tests: grids from closures.

#![allow(dead_code)]

use glam::DVec3;
use ndarray::Array3;
use wavelux_volume::VolumeGrid;

/// Per-voxel values: opacity, source RGB (W/m³), albedo RGB.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vox {
    pub opacity: f64,
    pub source: [f64; 3],
    pub albedo: [f64; 3],
}

pub const EMPTY: Vox = Vox {
    opacity: 0.0,
    source: [0.0; 3],
    albedo: [0.0; 3],
};

/// An `n³` grid of voxel edge `h` from `f(x, y, z)`.
pub fn grid(n: usize, h: f64, f: impl Fn(usize, usize, usize) -> Vox) -> VolumeGrid {
    let v = Array3::from_shape_fn((n, n, n), |(z, y, x)| f(x, y, z));
    let opacity = v.map(|c| c.opacity);
    let source = [0, 1, 2].map(|k| v.map(|c| c.source[k]));
    let albedo = [0, 1, 2].map(|k| v.map(|c| c.albedo[k]));
    VolumeGrid::new("test", h, DVec3::ZERO, opacity, source, albedo).unwrap()
}
