//! Images of a solved medium (the outputs of `--method global-cube`): an
//! emission–absorption render of the global cube's radiance field through a camera
//! (GlobalCube §1/§6: the solution is displayed by "low-albedo volume rendering" of the
//! emission `χ`), and axis-aligned slices of the emitted power density.
//!
//! The render shows exactly the model's radiance (`wavelux_volume`'s crate docs): a
//! camera ray composites the active cells it crosses front to back; a cell adds
//! `T · e_s · α`, with `α = 1 − (1 − σ)^{ℓ/H}` the opacity of its chord `ℓ` (cell edge
//! `H`), `e_s` the emission coefficient of the face `s` the ray enters the cell through
//! (the face the light leaves it by, [`VolumeSolution::emission_coefficients`]), and
//! `T` the transmittance so far; cells of zero opacity add `e · ℓ` (their coefficient
//! is per unit length). An opaque cell (σ = 1) ends the ray with its face's radiance
//! `Chi_s / (π H²)`. Pixels are `spp × spp` stratified sub-pixel centres (no
//! randomness). Outside the lattice is black. Units: W/(m²·sr).

use ndarray::Array3;
use rayon::prelude::*;
use wavelux_volume::VolumeSolution;

use crate::camera::View;
use crate::image::Image;
use crate::{RenderError, invalid};

/// Emission–absorption image of `sol` seen through `view`, `spp × spp` stratified
/// samples per pixel (1..=16).
///
/// # Errors
/// [`RenderError::Invalid`] for `spp` outside `1..=16`.
pub fn render_volume(sol: &VolumeSolution, view: &View, spp: usize) -> Result<Image, RenderError> {
    if !(1..=16).contains(&spp) {
        return Err(invalid("volume image spp", format!("{spp} outside 1..=16")));
    }
    let march = Marcher::new(sol);
    let mut img = Image::new(view.width, view.height);
    img.pixels
        .par_chunks_mut(view.width)
        .enumerate()
        .for_each(|(y, row)| {
            for (x, px) in row.iter_mut().enumerate() {
                let mut sum = [0.0; 3];
                for sy in 0..spp {
                    for sx in 0..spp {
                        let ray = view.ray(
                            x as f64 + (sx as f64 + 0.5) / spp as f64,
                            y as f64 + (sy as f64 + 0.5) / spp as f64,
                        );
                        let l = march.radiance(ray.origin.to_array(), ray.dir.to_array());
                        for c in 0..3 {
                            sum[c] += l[c];
                        }
                    }
                }
                let k = 1.0 / (spp * spp) as f64;
                *px = sum.map(|v| v * k);
            }
        });
    Ok(img)
}

/// The slice `index` across `axis` (0 = x, 1 = y, 2 = z) of the emitted power density
/// (W/m³, [`VolumeSolution::emission_density`]) as an image: pixel `(u, v)` is the voxel
/// with the other two coordinates `(u, side − 1 − v)` in axis order (x then y for a z
/// slice, x then z for a y slice, z then y for an x slice), so that `+y` (or `+z`) is
/// up.
///
/// # Errors
/// [`RenderError::Invalid`] for an axis above 2 or an index outside the lattice.
pub fn volume_slice(sol: &VolumeSolution, axis: usize, index: usize) -> Result<Image, RenderError> {
    let n = sol.side;
    if axis > 2 || index >= n {
        return Err(invalid(
            "volume slice",
            format!("axis {axis} / index {index} outside 0..=2 / 0..{n}"),
        ));
    }
    let e: [Array3<f64>; 3] = sol.emission_density();
    let mut img = Image::new(n, n);
    for v in 0..n {
        for u in 0..n {
            let w = n - 1 - v;
            let (z, y, x) = match axis {
                0 => (u, w, index),
                1 => (w, index, u),
                _ => (index, w, u),
            };
            img.pixels[v * n + u] = [0, 1, 2].map(|c| e[c][[z, y, x]]);
        }
    }
    Ok(img)
}

/// Traversal data of one solution.
struct Marcher<'a> {
    sol: &'a VolumeSolution,
    map: Vec<u32>,
    coeff: Vec<[[f64; 3]; 6]>,
}

impl<'a> Marcher<'a> {
    fn new(sol: &'a VolumeSolution) -> Self {
        Self {
            sol,
            map: sol.leaf_map(),
            coeff: sol.emission_coefficients(),
        }
    }

    /// Radiance arriving at `o` from direction `−d` (`d` a unit vector).
    fn radiance(&self, o: [f64; 3], d: [f64; 3]) -> [f64; 3] {
        let sol = self.sol;
        let n = sol.side;
        let h = sol.voxel;
        let min = sol.min.to_array();
        let size = n as f64 * h;
        // Slab clipping against the lattice; remember the entry axis.
        let (mut t0, mut t1, mut axis0) = (f64::NEG_INFINITY, f64::INFINITY, 0);
        for a in 0..3 {
            if d[a] == 0.0 {
                if o[a] < min[a] || o[a] > min[a] + size {
                    return [0.0; 3];
                }
                continue;
            }
            let (mut ta, mut tb) = ((min[a] - o[a]) / d[a], (min[a] + size - o[a]) / d[a]);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            if ta > t0 {
                t0 = ta;
                axis0 = a;
            }
            t1 = t1.min(tb);
        }
        if t0 < 0.0 {
            // The eye is inside: enter through the face facing the dominant direction.
            t0 = 0.0;
            axis0 = (0..3)
                .max_by(|&a, &b| d[a].abs().total_cmp(&d[b].abs()))
                .unwrap_or(0);
        }
        if t1 <= t0 {
            return [0.0; 3];
        }
        let entry_face = |a: usize| 2 * a + usize::from(d[a] > 0.0);
        let mut cell = [0usize; 3];
        let (mut step, mut t_max, mut t_delta) =
            ([0i64; 3], [f64::INFINITY; 3], [f64::INFINITY; 3]);
        for a in 0..3 {
            // The lattice boundary falls into the outermost cell (clamped).
            let i = ((o[a] + d[a] * t0 - min[a]) / h).floor();
            cell[a] = (i.max(0.0) as usize).min(n - 1);
            if d[a] > 0.0 {
                step[a] = 1;
                t_max[a] = (min[a] + (cell[a] + 1) as f64 * h - o[a]) / d[a];
                t_delta[a] = h / d[a];
            } else if d[a] < 0.0 {
                step[a] = -1;
                t_max[a] = (min[a] + cell[a] as f64 * h - o[a]) / d[a];
                t_delta[a] = -h / d[a];
            }
        }
        let mut out = [0.0; 3];
        let mut trans = 1.0;
        let mut t = t0;
        let mut leaf = u32::MAX;
        let mut face = entry_face(axis0);
        let mut last_axis = axis0;
        loop {
            let l = self.map[cell[0] + n * (cell[1] + n * cell[2])];
            if l != leaf {
                leaf = l;
                face = entry_face(last_axis);
            }
            let li = l as usize;
            let a_next = (0..3)
                .min_by(|&a, &b| t_max[a].total_cmp(&t_max[b]))
                .unwrap_or(0);
            let t_next = t_max[a_next].min(t1);
            let len = (t_next - t).max(0.0);
            let sigma = sol.data.opacity[li];
            let edge = f64::from(sol.set.leaves[li].size()) * h;
            let e = self.coeff[li][face];
            if sigma >= 1.0 {
                let k = trans / (std::f64::consts::PI * edge * edge);
                for c in 0..3 {
                    out[c] += k * sol.chi[li][face][c];
                }
                return out;
            }
            if sigma > 0.0 {
                let alpha = 1.0 - (1.0 - sigma).powf(len / edge);
                for c in 0..3 {
                    out[c] += trans * e[c] * alpha;
                }
                trans *= 1.0 - alpha;
            } else {
                for c in 0..3 {
                    out[c] += trans * e[c] * len;
                }
            }
            if t_next >= t1 || trans < 1e-9 {
                return out;
            }
            t = t_next;
            let ni = cell[a_next] as i64 + step[a_next];
            if ni < 0 || ni >= n as i64 {
                return out;
            }
            cell[a_next] = ni as usize;
            t_max[a_next] += t_delta[a_next];
            last_axis = a_next;
        }
    }
}
