//! Robust real roots of quadratics and quartics (used for quadrics and the torus).

use proptest::prelude::*;
use wavelux_geometry::poly::{eval, roots_in};

/// Ascending coefficients of `lead · Π (t − r_i)`.
fn from_roots(roots: &[f64], lead: f64) -> Vec<f64> {
    let mut c = vec![lead];
    for &r in roots {
        let mut n = vec![0.0; c.len() + 1];
        for (k, &a) in c.iter().enumerate() {
            n[k + 1] += a;
            n[k] -= r * a;
        }
        c = n;
    }
    c
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]
    #[test]
    fn quartic_with_four_real_roots(mut r in prop::collection::vec(-10.0f64..10.0, 4), lead in 0.1f64..10.0) {
        r.sort_by(f64::total_cmp);
        // Keep roots separated so each is well conditioned.
        for i in 1..4 {
            prop_assume!(r[i] - r[i - 1] > 1e-3);
        }
        let c = from_roots(&r, lead);
        let got = roots_in(&c, -20.0, 20.0);
        prop_assert_eq!(got.len(), 4, "{:?} vs {:?}", got, r);
        for (g, w) in got.iter().zip(&r) {
            prop_assert!((g - w).abs() <= 1e-7 * (1.0 + w.abs()), "{} vs {}", g, w);
        }
    }

    #[test]
    fn quartic_with_two_real_roots_and_a_complex_pair(
        a in -5.0f64..5.0, b in -5.0f64..5.0, re in -5.0f64..5.0, im in 0.01f64..5.0,
    ) {
        prop_assume!((a - b).abs() > 1e-3);
        // (t − a)(t − b)((t − re)² + im²)
        let q = from_roots(&[a, b], 1.0);
        let quad = [re * re + im * im, -2.0 * re, 1.0];
        let mut c = vec![0.0; 5];
        for i in 0..3 {
            for j in 0..3 {
                c[i + j] += q[i] * quad[j];
            }
        }
        let got = roots_in(&c, -10.0, 10.0);
        prop_assert_eq!(got.len(), 2);
        for g in &got {
            prop_assert!(eval(&c, *g).0.abs() <= 1e-9 * (1.0 + c.iter().map(|x| x.abs()).sum::<f64>() * g.abs().powi(4).max(1.0)));
        }
        prop_assert!((got[0] - a.min(b)).abs() <= 1e-8 && (got[1] - a.max(b)).abs() <= 1e-8);
    }

    #[test]
    fn quadratic_without_cancellation(r1 in 1e-8f64..1e-4, r2 in 1e2f64..1e6) {
        let c = from_roots(&[r1, r2], 1.0);
        let got = roots_in(&c, 0.0, 2e6);
        prop_assert_eq!(got.len(), 2);
        prop_assert!((got[0] - r1).abs() <= 1e-12 * r1, "{} vs {}", got[0], r1);
        prop_assert!((got[1] - r2).abs() <= 1e-12 * r2);
    }
}

#[test]
fn roots_respect_the_interval_and_empty_cases() {
    let c = from_roots(&[-1.0, 0.5, 2.0, 3.0], 2.0);
    assert_eq!(roots_in(&c, 0.0, 2.5).len(), 2);
    assert!(roots_in(&c, 4.0, 5.0).is_empty());
    assert!(roots_in(&c, 1.0, 0.0).is_empty());
    assert!(roots_in(&[1.0], -1.0, 1.0).is_empty());
    assert!(roots_in(&c, f64::NAN, 1.0).is_empty());
}
