//! The result of a global cube solve: the active cells with their face powers, the
//! per-voxel fields derived from them, the solve records, the energy account, and
//! the comparison metrics of GlobalCube §5 (`Q_square`, eq. (35)) and RMS.

use glam::DVec3;
use ndarray::Array3;

use crate::active::{ActiveSet, Leaf, LeafData};
use crate::backend::FaceRgb;
use crate::error::VolumeError;
use crate::grid::VolumeGrid;
use crate::solve::{GlobalCubeConfig, StepRecord};
use crate::system::{Energy, System, Work};

/// A solved medium.
#[derive(Debug, Clone, serde::Serialize)]
pub struct VolumeSolution {
    /// Medium name.
    pub name: String,
    /// Voxels per axis (padded cube).
    pub side: usize,
    /// The medium's voxel counts before padding `[nx, ny, nz]`.
    pub extent: [usize; 3],
    /// Voxel edge (m).
    pub voxel: f64,
    /// Lattice minimum corner.
    #[serde(skip)]
    pub min: DVec3,
    /// The configuration used.
    pub config: GlobalCubeConfig,
    /// The projector's name.
    pub projector: String,
    /// Active cells.
    #[serde(skip)]
    pub set: ActiveSet,
    /// Per-leaf medium values.
    #[serde(skip)]
    pub data: LeafData,
    /// Per-leaf `Ĝ` (side²·sr).
    #[serde(skip)]
    pub total_weight: Vec<f64>,
    /// Per leaf, the outgoing power per face and channel (W).
    #[serde(skip)]
    pub chi: Vec<FaceRgb>,
    /// Per leaf, the collided power per entry face and channel (W; 0 for cells that
    /// do not receive).
    #[serde(skip)]
    pub collided: Vec<FaceRgb>,
    /// The solve records.
    pub steps: Vec<StepRecord>,
    /// Energy account of the final state.
    pub energy: Energy,
    /// Projector work.
    pub work: Work,
    /// Wall seconds of the whole solve.
    pub seconds: f64,
}

impl VolumeSolution {
    #[allow(clippy::too_many_arguments)] // reason: assembled once, by `solve`
    pub(crate) fn new(
        grid: &VolumeGrid,
        config: GlobalCubeConfig,
        projector: String,
        sys: &System<'_>,
        chi: Vec<FaceRgb>,
        collided_r: &[FaceRgb],
        steps: Vec<StepRecord>,
        work: Work,
        seconds: f64,
    ) -> Self {
        let mut collided = vec![[[0.0; 3]; 6]; sys.len()];
        for (r, c) in collided_r.iter().enumerate() {
            collided[sys.receivers[r].cell as usize] = *c;
        }
        let energy = steps.last().map(|s| s.energy).unwrap_or_default();
        Self {
            name: grid.name.clone(),
            side: grid.side,
            extent: grid.extent,
            voxel: grid.voxel,
            min: grid.min,
            config,
            projector,
            set: sys.set.clone(),
            data: sys.data.clone(),
            total_weight: sys.traversal.cells[..sys.len()]
                .iter()
                .map(|c| c.total_weight)
                .collect(),
            chi,
            collided,
            steps,
            energy,
            work,
            seconds,
        }
    }

    /// Number of active cells.
    #[must_use]
    pub fn elements(&self) -> usize {
        self.set.leaves.len()
    }

    /// Voxel → leaf index map (`side³`, x fastest).
    #[must_use]
    pub fn leaf_map(&self) -> Vec<u32> {
        let n = self.side;
        let mut map = vec![0u32; n * n * n];
        for (i, l) in self.set.leaves.iter().enumerate() {
            let [x0, y0, z0] = l.origin().map(|v| v as usize);
            let s = l.size() as usize;
            for z in z0..z0 + s {
                for y in y0..y0 + s {
                    let row = n * (y + n * z);
                    map[row + x0..row + x0 + s].fill(i as u32);
                }
            }
        }
        map
    }

    /// A per-voxel field (per channel) from a per-leaf density (value per m³),
    /// `[z, y, x]` arrays.
    fn per_voxel(&self, density: impl Fn(usize) -> [f64; 3]) -> [Array3<f64>; 3] {
        let n = self.side;
        let mut out = [0, 1, 2].map(|_| Array3::zeros((n, n, n)));
        for (i, l) in self.set.leaves.iter().enumerate() {
            let d = density(i);
            let [x0, y0, z0] = l.origin().map(|v| v as usize);
            let s = l.size() as usize;
            for c in 0..3 {
                out[c]
                    .slice_mut(ndarray::s![z0..z0 + s, y0..y0 + s, x0..x0 + s])
                    .fill(d[c]);
            }
        }
        out
    }

    fn leaf_volume(&self, l: &Leaf) -> f64 {
        (f64::from(l.size()) * self.voxel).powi(3)
    }

    /// Emitted power density `Σ_s Chi_s / V` per voxel (W/m³), the emission `χ` of
    /// GlobalCube §3 spread over each active cell.
    #[must_use]
    pub fn emission_density(&self) -> [Array3<f64>; 3] {
        self.per_voxel(|i| {
            let v = self.leaf_volume(&self.set.leaves[i]);
            [0, 1, 2].map(|c| self.chi[i].iter().map(|f| f[c]).sum::<f64>() / v)
        })
    }

    /// Collided power density per voxel (W/m³).
    #[must_use]
    pub fn collided_density(&self) -> [Array3<f64>; 3] {
        self.per_voxel(|i| {
            let v = self.leaf_volume(&self.set.leaves[i]);
            [0, 1, 2].map(|c| self.collided[i].iter().map(|f| f[c]).sum::<f64>() / v)
        })
    }

    /// Collided power per voxel (W), `[channel][z, y, x]`.
    #[must_use]
    pub fn collided_per_voxel(&self) -> [Array3<f64>; 3] {
        let v = self.voxel.powi(3);
        self.collided_density().map(|a| a * v)
    }

    /// Emitted power per voxel (W).
    #[must_use]
    pub fn emission_per_voxel(&self) -> [Array3<f64>; 3] {
        let v = self.voxel.powi(3);
        self.emission_density().map(|a| a * v)
    }

    /// Per-leaf emission coefficients (W/(m²·sr) per face and channel; W/(m³·sr) for
    /// cells of zero opacity), as the projector uses them (see `crate::system`).
    #[must_use]
    pub fn emission_coefficients(&self) -> Vec<FaceRgb> {
        self.set
            .leaves
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let edge = f64::from(l.size()) * self.voxel;
                let scale = if self.data.opacity[i] > 0.0 {
                    if self.total_weight[i] > 0.0 {
                        6.0 / (self.total_weight[i] * edge * edge)
                    } else {
                        0.0
                    }
                } else {
                    6.0 / (4.0 * std::f64::consts::PI * edge * edge * edge)
                };
                self.chi[i].map(|f| f.map(|v| v * scale))
            })
            .collect()
    }

    /// The raw emission grid: `side³ × 3` little-endian `f32`, x fastest, RGB
    /// interleaved, W/m³ (over the padded cube).
    #[must_use]
    pub fn emission_raw(&self) -> Vec<u8> {
        let e = self.emission_density();
        let n = self.side;
        let mut out = Vec::with_capacity(n * n * n * 12);
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    for c in &e {
                        out.extend_from_slice(&(c[[z, y, x]] as f32).to_le_bytes());
                    }
                }
            }
        }
        out
    }
}

/// `Q_square` of GlobalCube eq. (35) between two per-voxel fields (all channels):
/// `√(Σ (a − b)²) / count`.
///
/// # Errors
/// [`VolumeError::Shape`] when the shapes differ.
pub fn q_square(a: &[Array3<f64>; 3], b: &[Array3<f64>; 3]) -> Result<f64, VolumeError> {
    let (s, n) = sum_sq(a, b)?;
    Ok(s.sqrt() / n as f64)
}

/// Root-mean-square difference of two per-voxel fields (all channels).
///
/// # Errors
/// [`VolumeError::Shape`] when the shapes differ.
pub fn rms(a: &[Array3<f64>; 3], b: &[Array3<f64>; 3]) -> Result<f64, VolumeError> {
    let (s, n) = sum_sq(a, b)?;
    Ok((s / n as f64).sqrt())
}

fn sum_sq(a: &[Array3<f64>; 3], b: &[Array3<f64>; 3]) -> Result<(f64, usize), VolumeError> {
    let mut s = 0.0;
    let mut n = 0;
    for c in 0..3 {
        if a[c].dim() != b[c].dim() {
            return Err(VolumeError::Shape {
                medium: "comparison".into(),
                what: format!("fields of shapes {:?} and {:?}", a[c].dim(), b[c].dim()),
            });
        }
        for (x, y) in a[c].iter().zip(b[c].iter()) {
            s += (x - y) * (x - y);
            n += 1;
        }
    }
    Ok((s, n.max(1)))
}
