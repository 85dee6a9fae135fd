//! Sampling helpers shared by the final gather and the path tracer: per-index seeding
//! (results independent of the thread count), orthonormal frames, cosine-weighted
//! hemisphere directions (Malley's method on the concentric disk).

use glam::DVec3;
use rand::SeedableRng;
use rand_pcg::Pcg64;

/// SplitMix64 finaliser: a bijective 64-bit mix.
pub(crate) fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A generator for stream `(seed, a, b)`: the same numbers whichever thread asks.
pub(crate) fn rng_for(seed: u64, a: u64, b: u64) -> Pcg64 {
    Pcg64::seed_from_u64(mix(mix(seed ^ mix(a)) ^ mix(b.wrapping_add(0x5151))))
}

/// An orthonormal basis `(t, b)` completing the unit normal `n` (Duff et al. 2017).
pub(crate) fn frame(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        DVec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Shirley–Chiu concentric map of `[0,1]²` onto the unit disk.
pub(crate) fn concentric(u: f64, v: f64) -> (f64, f64) {
    let (x, y) = (2.0 * u - 1.0, 2.0 * v - 1.0);
    if x == 0.0 && y == 0.0 {
        return (0.0, 0.0);
    }
    let q = std::f64::consts::FRAC_PI_4;
    let (r, phi) = if x.abs() > y.abs() {
        (x, q * (y / x))
    } else {
        (y, 2.0 * q - q * (x / y))
    };
    (r * phi.cos(), r * phi.sin())
}

/// Cosine-weighted direction about the unit normal `n` from `(u, v) ∈ [0,1)²`
/// (pdf `cos θ / π`).
pub(crate) fn cosine_dir(n: DVec3, u: f64, v: f64) -> DVec3 {
    let (x, y) = concentric(u, v);
    let z = (1.0 - x * x - y * y).max(0.0).sqrt();
    let (t, b) = frame(n);
    (t * x + b * y + n * z).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::RngExt;

    #[test]
    fn frame_is_orthonormal() {
        let mut r = rng_for(1, 2, 3);
        for _ in 0..200 {
            let n = DVec3::new(
                r.random_range(-1.0..1.0),
                r.random_range(-1.0..1.0),
                r.random_range(-1.0..1.0),
            )
            .normalize();
            let (t, b) = frame(n);
            assert!(t.dot(n).abs() < 1e-12 && b.dot(n).abs() < 1e-12 && t.dot(b).abs() < 1e-12);
            assert!((t.length() - 1.0).abs() < 1e-12 && (b.length() - 1.0).abs() < 1e-12);
            assert!((t.cross(b) - n).length() < 1e-12);
        }
    }

    #[test]
    fn cosine_directions_have_mean_cosine_two_thirds() {
        // E[cos θ] under the pdf cos θ/π is 2/3.
        let n = DVec3::new(0.3, -0.5, 0.8).normalize();
        let mut r = rng_for(7, 0, 0);
        let m = 200_000;
        let mean = (0..m)
            .map(|_| cosine_dir(n, r.random(), r.random()).dot(n))
            .sum::<f64>()
            / m as f64;
        // sd of cos θ is sqrt(1/2 − 4/9) ≈ 0.236; 5 standard errors.
        assert!((mean - 2.0 / 3.0).abs() < 5.0 * 0.236 / (m as f64).sqrt());
    }
}
