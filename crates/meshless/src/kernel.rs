//! The weight functions of the meshless basis (Meshless §2.2, eqs. (8)–(10)) and the
//! 5D Poisson-disk distance of point placement (§2.3, eq. (11)).
//!
//! A basis point is `p_j = (x_j, n_j)` with a support radius `r_j`;
//! `w_j(x, n) = K(dist_j(x)/r_j) · max(0, n·n_j)²` with the cubic
//! `K(r) = 2r³ − 3r² + 1` on `[0, 1]` (zero beyond) and the squashed (Mahalanobis)
//! distance `dist_j(x) = ‖d + F⟨d, n_j⟩ n_j‖`, `d = x − x_j`, `F = F_squash = 2`.
//! Since `F > 0`, `dist_j(x) >= ‖x − x_j‖`: a function is zero beyond Euclidean
//! distance `r_j`, which is what makes one hashed grid of cell `r_l` per level find
//! every non-zero function (see `grid`).

use glam::DVec3;

/// `F_squash` of eq. (10): the support's extent along the normal is `1/(1 + F)` of its
/// tangential extent.
pub const F_SQUASH: f64 = 2.0;

/// The compactly supported cubic of eq. (9): `2r³ − 3r² + 1` for `0 <= r <= 1`, else 0.
#[inline]
pub fn cubic(r: f64) -> f64 {
    if r >= 1.0 {
        0.0
    } else {
        let r = r.max(0.0);
        (2.0 * r - 3.0) * r * r + 1.0
    }
}

/// Squared squashed distance `dist_j(x)²` of eq. (10) for `d = x − x_j` and the unit
/// normal `n_j`: `‖d‖² + (2F + F²)⟨d, n_j⟩²`.
#[inline]
pub fn dist2(d: DVec3, nj: DVec3) -> f64 {
    let dn = d.dot(nj);
    d.length_squared() + (2.0 * F_SQUASH + F_SQUASH * F_SQUASH) * dn * dn
}

/// The weight `w_j(x, n)` of eq. (8) for a function at `(xj, nj)` with radius `r`.
/// Zero (never NaN) for back-facing normals and beyond the support.
#[inline]
pub fn weight(xj: DVec3, nj: DVec3, r: f64, x: DVec3, n: DVec3) -> f64 {
    let c = n.dot(nj);
    if !(c > 0.0) {
        return 0.0;
    }
    let d2 = dist2(x - xj, nj);
    let r2 = r * r;
    if !(d2 < r2) {
        return 0.0;
    }
    cubic((d2 / r2).sqrt()) * c * c
}

/// The Poisson-disk distance `D(p, q)` of eq. (11): the smaller of the two squashed
/// distances divided by `max(0, n_p·n_q)²`; `+∞` when the normals are at 90° or more
/// (so such points may coincide).
#[inline]
pub fn poisson_distance(xp: DVec3, np: DVec3, xq: DVec3, nq: DVec3) -> f64 {
    let c = np.dot(nq);
    if !(c > 0.0) {
        return f64::INFINITY;
    }
    let d = xq - xp;
    let m = dist2(d, np).min(dist2(-d, nq)).sqrt();
    m / (c * c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn cubic_ends_and_smoothness() {
        assert_eq!(cubic(0.0), 1.0);
        assert_eq!(cubic(1.0), 0.0);
        assert_eq!(cubic(2.0), 0.0);
        // K'(1) = 6r² − 6r = 0 and K'(0) = 0: smooth at both ends.
        let h = 1e-6;
        assert!(((cubic(1.0 - h) - cubic(1.0 - 2.0 * h)) / h).abs() < 1e-4);
        assert!(((cubic(h) - cubic(0.0)) / h).abs() < 1e-4);
    }

    #[test]
    fn squash_shrinks_the_normal_axis_by_one_plus_f() {
        let (xj, nj) = (DVec3::ZERO, DVec3::Z);
        // Tangential distance 0.9 is inside radius 1; normal distance 0.9/3 = 0.3 is the
        // same squashed distance.
        let a = dist2(DVec3::new(0.9, 0.0, 0.0), nj);
        let b = dist2(DVec3::new(0.0, 0.0, 0.3), nj);
        assert!((a - b).abs() < 1e-15);
        assert!(weight(xj, nj, 1.0, DVec3::new(0.0, 0.0, 0.34), DVec3::Z) == 0.0);
        assert!(weight(xj, nj, 1.0, DVec3::new(0.0, 0.0, 0.32), DVec3::Z) > 0.0);
    }

    #[test]
    fn back_facing_and_nan_give_zero() {
        let w = weight(DVec3::ZERO, DVec3::Z, 1.0, DVec3::ZERO, -DVec3::Z);
        assert_eq!(w, 0.0);
        let w = weight(DVec3::ZERO, DVec3::Z, 1.0, DVec3::splat(f64::NAN), DVec3::Z);
        assert_eq!(w, 0.0);
        let w = weight(
            DVec3::ZERO,
            DVec3::Z,
            1.0,
            DVec3::ZERO,
            DVec3::splat(f64::NAN),
        );
        assert_eq!(w, 0.0);
        assert_eq!(
            poisson_distance(DVec3::ZERO, DVec3::Z, DVec3::ZERO, -DVec3::Z),
            f64::INFINITY
        );
    }

    proptest! {
        #[test]
        fn squashed_distance_bounds_euclidean(
            d in prop::array::uniform3(-10.0f64..10.0),
            n in prop::array::uniform3(-1.0f64..1.0),
        ) {
            let n = DVec3::from_array(n);
            prop_assume!(n.length() > 1e-3);
            let n = n.normalize();
            let d = DVec3::from_array(d);
            prop_assert!(dist2(d, n).sqrt() >= d.length() * (1.0 - 1e-12));
            prop_assert!(dist2(d, n).sqrt() <= d.length() * (1.0 + F_SQUASH) * (1.0 + 1e-12));
        }

        #[test]
        fn poisson_distance_is_symmetric(
            a in prop::array::uniform3(-1.0f64..1.0),
            b in prop::array::uniform3(-1.0f64..1.0),
            na in prop::array::uniform3(-1.0f64..1.0),
            nb in prop::array::uniform3(-1.0f64..1.0),
        ) {
            let (na, nb) = (DVec3::from_array(na), DVec3::from_array(nb));
            prop_assume!(na.length() > 1e-3 && nb.length() > 1e-3);
            let (na, nb) = (na.normalize(), nb.normalize());
            let (a, b) = (DVec3::from_array(a), DVec3::from_array(b));
            let pq = poisson_distance(a, na, b, nb);
            let qp = poisson_distance(b, nb, a, na);
            prop_assert!(pq == qp || (pq - qp).abs() <= 1e-12 * pq.abs());
        }
    }
}
