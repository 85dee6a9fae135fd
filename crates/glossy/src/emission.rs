//! Emitted radiance and importance decomposed up front onto the patches' trees
//! (Glossy §6.3: "storing the wavelet decomposition of an image as the initial
//! coefficients on a patch"; §4.2 for the eye's importance).
//!
//! Every emitter here is separable, `F(s, t, u₃, u₄) = e(s, t)·g(u₃, u₄)`: the
//! exitance (times an emission texture, per channel) in space, and the angular profile
//! in direction — `1/π` for Lambertian emitters, `(n + 2) cosⁿθ/(2π)` for spotlights,
//! the viewing-pyramid indicator for the eye, `1` for importance patches. The 4D
//! non-standard coefficient of node `(j; i₀, i₁, i₂, i₃)` and type `τ` of a separable
//! function is the product of 2D non-standard coefficients of level `j`: spatial type
//! `τ & 3` of `e` at `(i₀, i₁)` (its scaling coefficient for type 0) times angular type
//! `τ >> 2` of `g` at `(i₂, i₃)`. Both 2D pyramids start from cell integrals on a
//! `2^J × 2^J` grid (`J` = `level`; angular cells by [`crate::directions`]' diagonal-split
//! rules, spatial cells by 4 × 4 point samples of the texture) and are analysed by the
//! 2D Haar step. Coefficients below `tolerance ×` the largest are dropped (nodes are
//! created only where something is kept).

use glam::DVec2;

use crate::basis::{CHILDREN, NodeKey};
use crate::directions::{CellRule, DirectionKind, integrate_cell};
use crate::error::GlossyError;
use crate::patch::GlossyScene;
use crate::tree::{Functions, IMPORTANCE, RADIANCE};
use crate::ward::cosine_power_radiance;

/// A 2D Haar pyramid: per level `j ≤ J`, `4` values per cell (scaling, then the three
/// wavelet types: bit 0 = ψ on the first axis, bit 1 = on the second), row-major.
#[derive(Debug, Clone)]
struct Pyramid {
    /// `levels[j][(i1·2^j + i0)·4 + type]`.
    levels: Vec<Vec<f64>>,
}

impl Pyramid {
    /// From scaling coefficients on level `top` (`2^top × 2^top`, row-major `i1·n + i0`).
    fn new(top: u8, fine: Vec<f64>) -> Self {
        let mut levels = vec![Vec::new(); usize::from(top) + 1];
        let n = 1usize << top;
        let mut cur: Vec<f64> = fine;
        let mut top_level = vec![0.0; n * n * 4];
        for (i, v) in cur.iter().enumerate() {
            top_level[i * 4] = *v;
        }
        levels[usize::from(top)] = top_level;
        let r = std::f64::consts::FRAC_1_SQRT_2;
        for j in (0..top).rev() {
            let m = 1usize << j;
            let mut out = vec![0.0; m * m * 4];
            let mut next = vec![0.0; m * m];
            for i1 in 0..m {
                for i0 in 0..m {
                    let c = |a: usize, b: usize| cur[(2 * i1 + b) * (2 * m) + 2 * i0 + a];
                    let (c00, c10, c01, c11) = (c(0, 0), c(1, 0), c(0, 1), c(1, 1));
                    let k = (i1 * m + i0) * 4;
                    // h = (1, 1)/√2, g = (1, −1)/√2 per axis (wavelux-mra's Haar rows).
                    out[k] = r * r * (c00 + c10 + c01 + c11);
                    out[k + 1] = r * r * (c00 - c10 + c01 - c11);
                    out[k + 2] = r * r * (c00 + c10 - c01 - c11);
                    out[k + 3] = r * r * (c00 - c10 - c01 + c11);
                    next[i1 * m + i0] = out[k];
                }
            }
            levels[usize::from(j)] = out;
            cur = next;
        }
        Self { levels }
    }

    fn at(&self, j: u8, i: [u16; 2], t: usize) -> f64 {
        let m = 1usize << j;
        self.levels[usize::from(j)][(usize::from(i[1]) * m + usize::from(i[0])) * 4 + t]
    }

    fn max_abs(&self) -> f64 {
        self.levels
            .iter()
            .flatten()
            .fold(0.0, |a: f64, v| a.max(v.abs()))
    }
}

/// Scaling coefficients (`2^J ∫_cell g`) of an angular profile on the `2^J` grid.
fn angular_fine(rule: &CellRule, level: u8, g: &dyn Fn(DVec2) -> f64) -> Vec<f64> {
    let n = 1u16 << level;
    let scale = f64::from(n);
    let mut out = Vec::with_capacity(usize::from(n) * usize::from(n));
    for i1 in 0..n {
        for i0 in 0..n {
            out.push(scale * integrate_cell(rule, level, [i0, i1], g));
        }
    }
    out
}

/// Adds the separable function `e_c(s,t)·g(u)` of every channel to `bands` of
/// `patch`'s emitted coefficients.
fn add_separable(
    funcs: &mut Functions,
    patch: usize,
    level: u8,
    tolerance: f64,
    spatial: [&Pyramid; 3],
    angular: &Pyramid,
    bands: std::ops::Range<usize>,
) {
    let smax = spatial.iter().map(|p| p.max_abs()).fold(0.0, f64::max);
    let amax = angular.max_abs();
    let cut = tolerance * smax * amax;
    // Root φ.
    let root = funcs.trees[patch].root_phi as usize;
    for (c, b) in bands.clone().enumerate() {
        funcs.emit[root][b] += spatial[c].at(0, [0, 0], 0) * angular.at(0, [0, 0], 0);
    }
    for j in 0..level {
        let m = 1u16 << j;
        for a1 in 0..m {
            for a0 in 0..m {
                let ang: [f64; 4] = std::array::from_fn(|t| angular.at(j, [a0, a1], t));
                for s1 in 0..m {
                    for s0 in 0..m {
                        let mut vals = [[0.0; 3]; CHILDREN];
                        let mut keep = false;
                        for tau in 1..CHILDREN {
                            for c in 0..3 {
                                let v = spatial[c].at(j, [s0, s1], tau & 3) * ang[tau >> 2];
                                if v.abs() > cut {
                                    keep = true;
                                }
                                vals[tau][c] = v;
                            }
                        }
                        if !keep {
                            continue;
                        }
                        let key = NodeKey {
                            level: j,
                            idx: [s0, s1, a0, a1],
                        };
                        let node = funcs.node(patch, key);
                        let base = funcs.trees[patch].base[node as usize] as usize;
                        for tau in 1..CHILDREN {
                            for (c, b) in bands.clone().enumerate() {
                                funcs.emit[base + tau - 1][b] += vals[tau][c];
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Spatial pyramids (per channel) of a patch's exitance times `factor`.
fn spatial_pyramids(
    scene: &GlossyScene,
    patch: usize,
    level: u8,
    importance: bool,
) -> [Pyramid; 3] {
    let p = &scene.patches[patch];
    let textured = !importance && p.emission_texture.is_some();
    let n = 1usize << level;
    let scale = n as f64; // φ_J = 2^J on cells of area 4^{-J}: coefficient 2^J ∫ e
    std::array::from_fn(|c| {
        let mut fine = Vec::with_capacity(n * n);
        for i1 in 0..n {
            for i0 in 0..n {
                let area = 1.0 / (n * n) as f64;
                let v = if importance {
                    1.0
                } else if textured {
                    let mut s = 0.0;
                    for k in 0..16 {
                        let (a, b) = ((k % 4) as f64 + 0.5, (k / 4) as f64 + 0.5);
                        let st = DVec2::new(
                            (i0 as f64 + a / 4.0) / n as f64,
                            (i1 as f64 + b / 4.0) / n as f64,
                        );
                        s += scene.exitance_at(patch, st.x, st.y)[c];
                    }
                    s / 16.0
                } else {
                    p.emission[c]
                };
                fine.push(scale * area * v);
            }
        }
        Pyramid::new(level, fine)
    })
}

/// Projects every emitter's `L_e` and every importance source's `Γ_e` onto the trees
/// at `level` (`tolerance`: relative cut-off of kept coefficients).
///
/// # Errors
/// [`GlossyError::Dependency`] if the quadrature rule cannot be built.
pub fn project_emission(
    scene: &GlossyScene,
    dirs: DirectionKind,
    funcs: &mut Functions,
    level: u8,
    tolerance: f64,
) -> Result<(), GlossyError> {
    let rule = CellRule::new(16)?;
    for (i, p) in scene.patches.iter().enumerate() {
        if p.is_emitter() {
            let spatial = spatial_pyramids(scene, i, level, false);
            let n = p.emission_exponent.unwrap_or(0.0);
            let (lvl, angular) = if n == 0.0 && p.emission_texture.is_none() {
                // Lambertian and constant: the root φ alone is exact.
                (0, Pyramid::new(0, vec![std::f64::consts::FRAC_1_PI]))
            } else if n == 0.0 {
                (
                    level,
                    Pyramid::new(
                        level,
                        angular_fine(&rule, level, &|_| std::f64::consts::FRAC_1_PI),
                    ),
                )
            } else {
                let g = move |u: DVec2| cosine_power_radiance(1.0, n, dirs.direction(u).z);
                (level, Pyramid::new(level, angular_fine(&rule, level, &g)))
            };
            let spatial = if lvl == 0 {
                std::array::from_fn(|c| Pyramid::new(0, vec![p.emission[c]]))
            } else {
                spatial
            };
            add_separable(
                funcs,
                i,
                lvl,
                tolerance,
                [&spatial[0], &spatial[1], &spatial[2]],
                &angular,
                RADIANCE,
            );
        }
        if p.importance {
            let one = Pyramid::new(0, vec![1.0]);
            add_separable(funcs, i, 0, tolerance, [&one, &one, &one], &one, IMPORTANCE);
        }
        if let Some(fr) = p.frustum {
            let frame = p.frame(0.5, 0.5);
            let g = move |u: DVec2| {
                let w = frame.to_world(dirs.direction(u));
                if fr.contains(w) { 1.0 } else { 0.0 }
            };
            let fine_rule = CellRule::new(16)?;
            let angular = Pyramid::new(level, angular_fine(&fine_rule, level, &g));
            let spatial = spatial_pyramids(scene, i, level, true);
            add_separable(
                funcs,
                i,
                level,
                tolerance,
                [&spatial[0], &spatial[1], &spatial[2]],
                &angular,
                IMPORTANCE,
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pyramid_preserves_energy() {
        let fine: Vec<f64> = (0..16).map(|k| (k as f64 * 0.7).cos()).collect();
        let e: f64 = fine.iter().map(|v| v * v).sum();
        let p = Pyramid::new(2, fine);
        let mut s = p.at(0, [0, 0], 0).powi(2);
        for j in 0..2u8 {
            let m = 1u16 << j;
            for a in 0..m {
                for b in 0..m {
                    for t in 1..4 {
                        s += p.at(j, [a, b], t).powi(2);
                    }
                }
            }
        }
        assert!((s - e).abs() < 1e-12);
    }
}
