//! Seeded random streams and stratified directions shared by point placement and the
//! transfer: every stream is keyed by `(seed, a, b)` (a level and a particle, a
//! receiver, ...) so results do not depend on the thread count; directions over a
//! hemisphere come from `wavelux-param`'s equal-area [`ConcentricHemisphere`] map on
//! stratified unit-square samples (uniform in solid angle).

use glam::{DVec2, DVec3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use wavelux_param::{ConcentricHemisphere, DirectionMap};

fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The generator of stream `(seed, a, b)`.
pub(crate) fn rng_for(seed: u64, a: u64, b: u64) -> Pcg64 {
    Pcg64::seed_from_u64(splitmix(
        splitmix(seed ^ splitmix(a)) ^ splitmix(b ^ 0x6d65_7368),
    ))
}

/// `n` stratified points of `[0, 1)²`: a jittered `m × m` grid when `n = m²`, else
/// Latin-hypercube strata (one point per row and per column of an `n × n` grid).
pub(crate) fn stratified(n: usize, rng: &mut Pcg64, out: &mut Vec<DVec2>) {
    out.clear();
    let m = (n as f64).sqrt().round() as usize;
    if m * m == n {
        let inv = 1.0 / m as f64;
        for i in 0..m {
            for j in 0..m {
                let (a, b): (f64, f64) = (rng.random(), rng.random());
                out.push(DVec2::new((i as f64 + a) * inv, (j as f64 + b) * inv));
            }
        }
    } else {
        let inv = 1.0 / n as f64;
        let mut perm: Vec<usize> = (0..n).collect();
        for i in (1..n).rev() {
            let j = rng.random_range(0..=i);
            perm.swap(i, j);
        }
        for (i, &p) in perm.iter().enumerate() {
            let (a, b): (f64, f64) = (rng.random(), rng.random());
            out.push(DVec2::new((i as f64 + a) * inv, (p as f64 + b) * inv));
        }
    }
}

/// An orthonormal tangent pair `(t, b)` completing the unit normal `n` (the branchless
/// construction of Duff et al. 2017).
pub(crate) fn tangents(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        DVec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// The world direction of square sample `uv` on the hemisphere about unit `n`,
/// uniform in solid angle (ConcentricHemisphere, Jacobian 2π).
pub(crate) fn hemisphere(n: DVec3, t: DVec3, b: DVec3, uv: DVec2) -> DVec3 {
    let d = ConcentricHemisphere.direction(uv);
    (t * d.x + b * d.y + n * d.z).normalize()
}

/// A uniform direction on the sphere from `(u, v) ∈ [0, 1)²`.
pub(crate) fn sphere(u: f64, v: f64) -> DVec3 {
    let z = 1.0 - 2.0 * u;
    let s = (1.0 - z * z).max(0.0).sqrt();
    let phi = std::f64::consts::TAU * v;
    DVec3::new(s * phi.cos(), s * phi.sin(), z)
}

/// A cosine-distributed direction about unit `n` (Malley: the concentric disk lifted).
pub(crate) fn cosine(n: DVec3, u: f64, v: f64) -> DVec3 {
    let p = wavelux_param::concentric_square_to_disc(DVec2::new(2.0 * u - 1.0, 2.0 * v - 1.0));
    let z = (1.0 - p.length_squared()).max(0.0).sqrt();
    let (t, b) = tangents(n);
    (t * p.x + b * p.y + n * z).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strata_cover_each_cell_once() {
        let mut rng = rng_for(1, 2, 3);
        let mut out = Vec::new();
        for n in [16usize, 32, 256, 7] {
            stratified(n, &mut rng, &mut out);
            assert_eq!(out.len(), n);
            let m = (n as f64).sqrt().round() as usize;
            if m * m == n {
                let mut seen = vec![false; n];
                for p in &out {
                    let c = (p.x * m as f64) as usize * m + (p.y * m as f64) as usize;
                    assert!(!seen[c]);
                    seen[c] = true;
                }
            } else {
                let mut rows = vec![false; n];
                let mut cols = vec![false; n];
                for p in &out {
                    let (r, c) = ((p.x * n as f64) as usize, (p.y * n as f64) as usize);
                    assert!(!rows[r] && !cols[c]);
                    rows[r] = true;
                    cols[c] = true;
                }
            }
        }
    }

    #[test]
    fn hemisphere_mean_cosine_is_one_half() {
        let n = DVec3::new(0.3, -0.4, 0.866).normalize();
        let (t, b) = tangents(n);
        assert!(t.dot(n).abs() < 1e-12 && b.dot(n).abs() < 1e-12 && t.dot(b).abs() < 1e-12);
        let mut rng = rng_for(4, 5, 6);
        let mut out = Vec::new();
        stratified(4096, &mut rng, &mut out);
        let mean: f64 = out
            .iter()
            .map(|&uv| hemisphere(n, t, b, uv).dot(n))
            .sum::<f64>()
            / 4096.0;
        assert!((mean - 0.5).abs() < 1e-3, "{mean}");
    }
}
