//! Escaped power measured by rays, independently of the transfer operator.
//!
//! A solver's own count of the power that reaches no receiver is `Σ∫B − Σ∫H` (the
//! discrete operator's row-sum deficit, [`crate::Energy::operator_loss`]); with it the
//! balance `emitted = absorbed + unshot + escaped` would be an identity. Here the
//! escaped power is measured from the geometry instead: on every leaf element, `m × m`
//! stratified points of its real part (VirtualMesh §4: only real points emit) each
//! send one cosine-distributed ray, the directions stratified as well (an `m × m` grid
//! of the unit square, randomly permuted against the points); `m ≥ ESCAPE_STRATA`, and
//! large enough that every patch casts at least `TOTAL_RAYS / patches` rays (at least
//! 256, `m ≤ 128`), so about [`TOTAL_RAYS`] rays in all unless leaves are many. A
//! ray escapes when it hits nothing or a side that does not receive (the back of a
//! one-sided surface, a black side). So
//!
//! `escaped ≈ Σ_leaves Σ_samples w · B_prop(x) · [ray from x escapes]`,
//!
//! with `w = J(s,t) · h² / ESCAPE_STRATA²` the sample's area (`J` the support's
//! Jacobian, `h` the leaf's side in parameter space) and `B_prop` the radiosity the
//! method propagated (`B` for gathering, `B − ΔB̃` for shooting). Because the cosine
//! density equals the form-factor kernel, the indicator's mean is the point's escape
//! fraction `1 − Σ_j F(x → j)` over receiving sides `j`: the estimate is unbiased and
//! deterministic (one seeded stream per leaf, sums in leaf order, whatever the thread
//! count). Its standard error is estimated from the spread of the samples in each leaf.
//! In a closed enclosure every ray arrives and the estimate is exactly 0.

use glam::DVec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use wavelux_geometry::Ray;
use wavelux_param::concentric_square_to_disc;

use crate::Prepared;
use crate::hierarchy::Hierarchy;
use crate::support::Side;

/// Least strata per axis of the sample points on each leaf (`ESCAPE_STRATA²` rays).
pub const ESCAPE_STRATA: usize = 2;

/// Target number of rays, shared equally by the patches (patches with few leaves get
/// more strata per leaf).
pub const TOTAL_RAYS: usize = 1 << 18;

/// Seed of the sample streams (one stream per leaf).
const SEED: u64 = 0x5EED_E5CA_9E00_0001;

/// A ray measurement of escaped power (W per RGB channel).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Escape {
    /// Estimated escaped power.
    pub power: [f64; 3],
    /// Standard error of `power` (from the spread of the samples within each leaf).
    pub std_error: [f64; 3],
    /// Rays cast.
    pub rays: u64,
}

/// SplitMix64 finaliser (a bijective mix for per-leaf seeds).
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Cosine-distributed unit direction about the unit normal `n` from `(u, v) ∈ [0,1)²`
/// (Malley's method on the concentric disc; pdf `cos θ / π`).
fn cosine_dir(n: DVec3, u: f64, v: f64) -> DVec3 {
    let d = concentric_square_to_disc(glam::DVec2::new(2.0 * u - 1.0, 2.0 * v - 1.0));
    let z = (1.0f64 - d.length_squared()).max(0.0).sqrt();
    let (t, b) = n.any_orthonormal_pair();
    (t * d.x + b * d.y + n * z).normalize()
}

/// Measures the escaped power of the radiosity `b_prop(patch, s, t)` (W/m², RGB) over
/// the leaves of `h` (whose patches are `prep`'s), with `prep`'s accelerator.
pub fn measure(
    prep: &Prepared,
    h: &Hierarchy,
    b_prop: &(dyn Fn(usize, f64, f64) -> [f64; 3] + Sync),
) -> Escape {
    let patches = &prep.patches.patches;
    // Which sides of each accelerator primitive receive: [front, back].
    let mut receiving = vec![[false; 2]; prep.patches.pieces.len()];
    for p in patches {
        let side = usize::from(p.side == Side::Back);
        receiving[p.prim as usize][side] |= p.reflects();
    }
    let (center, size) = prep.frame;
    let eps = prep.accel.eps();
    let mut leaves_of = vec![0usize; patches.len()];
    for &node in &h.leaves {
        leaves_of[h.keys[node as usize].patch as usize] += 1;
    }
    let per_patch = (TOTAL_RAYS / patches.len().max(1)).max(256);
    let strata = |patch: usize| -> usize {
        let want = per_patch.div_ceil(leaves_of[patch].max(1));
        ((want as f64).sqrt().ceil() as usize).clamp(ESCAPE_STRATA, 128)
    };
    let per_leaf: Vec<([f64; 3], [f64; 3], u64)> = h
        .leaves
        .par_iter()
        .enumerate()
        .map(|(l, &node)| {
            let key = h.keys[node as usize];
            let reg = key.region();
            let patch = reg.patch;
            let sup = &patches[patch].support;
            let mut rng = Pcg64::seed_from_u64(mix(SEED ^ mix(l as u64)));
            let m = strata(patch);
            // Direction strata, randomly permuted against the position strata.
            let mut perm: Vec<usize> = (0..m * m).collect();
            for i in (1..perm.len()).rev() {
                perm.swap(i, rng.random_range(0..=i));
            }
            let mut sum = [0.0; 3];
            let mut sum2 = [0.0; 3];
            let mut cast = 0u64;
            for k in 0..m * m {
                let (a, b) = ((k % m) as f64, (k / m) as f64);
                let s = reg.s0 + reg.h * (a + rng.random::<f64>()) / m as f64;
                let t = reg.t0 + reg.h * (b + rng.random::<f64>()) / m as f64;
                let (du, dv) = ((perm[k] % m) as f64, (perm[k] / m) as f64);
                let u = (du + rng.random::<f64>()) / m as f64;
                let v = (dv + rng.random::<f64>()) / m as f64;
                if !sup.is_real(s, t) {
                    continue;
                }
                cast += 1;
                let w = sup.jacobian(s, t) * reg.h * reg.h / (m * m) as f64;
                let bp = b_prop(patch, s, t);
                let (x, n) = sup.point_normal(s, t);
                let dir = cosine_dir(n, u, v);
                let origin = (x - center) / size + n * eps;
                let escapes = match Ray::new(origin, dir) {
                    Ok(ray) => match prep.accel.closest_hit(&ray, eps, f64::INFINITY) {
                        None => true,
                        Some(hit) => !receiving
                            .get(hit.prim as usize)
                            .is_some_and(|r| r[usize::from(!hit.front)]),
                    },
                    Err(_) => false,
                };
                if escapes {
                    for c in 0..3 {
                        let y = w * bp[c];
                        sum[c] += y;
                        sum2[c] += y * y;
                    }
                }
            }
            // Variance of the leaf's sum: N · (sample variance of the N terms), the
            // independent-sample formula, which stratification only makes smaller.
            let nn = (m * m) as f64;
            let var = std::array::from_fn(|c| {
                (sum2[c] - sum[c] * sum[c] / nn).max(0.0) * nn / (nn - 1.0)
            });
            (sum, var, cast)
        })
        .collect();
    let mut out = Escape::default();
    let mut var = [0.0; 3];
    for (s, v, cast) in per_leaf {
        out.rays += cast;
        for c in 0..3 {
            out.power[c] += s[c];
            var[c] += v[c];
        }
    }
    out.std_error = var.map(f64::sqrt);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Cosine-distributed directions: mean cosine 2/3, tangential mean 0 (every
    /// azimuth), all in the upper hemisphere.
    #[test]
    fn cosine_directions_cover_the_hemisphere() {
        let n = DVec3::new(0.3, -0.5, 0.8).normalize();
        let (t, b) = n.any_orthonormal_pair();
        let mut rng = Pcg64::seed_from_u64(7);
        let k = 200_000;
        let (mut c, mut ct, mut cb) = (0.0, 0.0, 0.0);
        for _ in 0..k {
            let d = cosine_dir(n, rng.random(), rng.random());
            assert!(d.dot(n) >= 0.0 && (d.length() - 1.0).abs() < 1e-12);
            c += d.dot(n);
            ct += d.dot(t);
            cb += d.dot(b);
        }
        let k = k as f64;
        // Standard errors: cos has variance 1/18, a tangent component 1/4.
        assert!((c / k - 2.0 / 3.0).abs() < 5.0 * (1.0 / 18.0 / k).sqrt());
        assert!((ct / k).abs() < 5.0 * (0.25 / k).sqrt());
        assert!((cb / k).abs() < 5.0 * (0.25 / k).sqrt());
    }
}
