//! wavelux-mra against wavelux-quadrature: projections agree with independent Gauss
//! integrals, Bessel/Parseval defects decay at the rate set by the vanishing moments,
//! and tensor projections of separable functions factor.

use wavelux::mra::project::{GaussOptions, evaluate, project};
use wavelux::mra::{Alpert, Cdv, Mra};
use wavelux::quadrature::GaussLegendre;

fn smooth(x: f64) -> f64 {
    (3.0 * x).sin() + x * x * x
}

/// For piecewise polynomial bases, ⟨f, φ_{j,k}⟩ from the projection equals a direct
/// Gauss integral of f·φ over the support, evaluated through `eval_scaling`.
#[test]
fn multiwavelet_projection_equals_direct_integrals() {
    let gl = GaussLegendre::new(24).unwrap();
    for k in 1..=4 {
        let m = Alpert::new(k).unwrap();
        let level = 3;
        let c = project(&m, 1, level, |x| smooth(x[0]), GaussOptions::default()).unwrap();
        for (i, &ci) in c.iter().enumerate() {
            let (a, b) = m.support(level, i).unwrap();
            let direct = gl.integrate(a, b, |x| smooth(x) * m.eval_scaling(level, i, x).unwrap());
            assert!((ci - direct).abs() < 1e-13, "M{k} {i}: {ci} vs {direct}");
        }
    }
}

/// Bessel: Σ c² ≤ ‖f‖², and the defect ‖f‖² − Σ c² = ‖f − P_j f‖² decays like
/// 2^{-2pj} with p = polynomial degree + 1 (approximation order), for every MRA
/// (CDV included, whose projection uses exact D4 cell moments).
#[test]
fn projection_defect_decays_at_the_approximation_order() {
    let gl = GaussLegendre::new(40).unwrap();
    let norm2: f64 = (0..16)
        .map(|i| {
            gl.integrate(i as f64 / 16.0, (i + 1) as f64 / 16.0, |x| {
                smooth(x).powi(2)
            })
        })
        .sum();
    let mras: Vec<Box<dyn Mra>> = vec![
        Box::new(Alpert::haar()),
        Box::new(Alpert::new(2).unwrap()),
        Box::new(Cdv::new()),
    ];
    for m in mras {
        let p = m.polynomial_degree() as i32 + 1;
        let mut defects = Vec::new();
        for level in m.min_level() + 2..m.min_level() + 6 {
            let c = project(
                m.as_ref(),
                1,
                level,
                |x| smooth(x[0]),
                GaussOptions::default(),
            )
            .unwrap();
            let s: f64 = c.iter().map(|v| v * v).sum();
            assert!(s <= norm2 * (1.0 + 1e-14), "{} Bessel", m.name());
            defects.push(norm2 - s);
        }
        for w in defects.windows(2) {
            let ratio = w[0] / w[1];
            let expected = 4f64.powi(p);
            assert!(
                ratio > 0.6 * expected && ratio < 1.6 * expected,
                "{}: defect ratio {ratio}, expected about {expected}",
                m.name()
            );
        }
    }
}

/// The projection of f(x)g(y) onto V_j ⊗ V_j is the outer product of the 1D projections,
/// and evaluates to the product of the 1D evaluations.
#[test]
fn separable_projection_factors() {
    let g = |y: f64| (1.0 + y).ln();
    let mras: Vec<Box<dyn Mra>> = vec![Box::new(Alpert::new(3).unwrap()), Box::new(Cdv::new())];
    for m in mras {
        let level = m.min_level() + 2;
        let opts = GaussOptions::default();
        let cx = project(m.as_ref(), 1, level, |x| smooth(x[0]), opts).unwrap();
        let cy = project(m.as_ref(), 1, level, |x| g(x[0]), opts).unwrap();
        let c2 = project(m.as_ref(), 2, level, |x| smooth(x[0]) * g(x[1]), opts).unwrap();
        let n = m.len(level);
        for i in 0..n {
            for j in 0..n {
                assert!(
                    (c2[i * n + j] - cx[i] * cy[j]).abs() < 1e-13,
                    "{}",
                    m.name()
                );
            }
        }
        for s in 0..=8 {
            let (x, y) = (s as f64 / 8.0, 1.0 - s as f64 / 16.0);
            let v2 = evaluate(m.as_ref(), 2, level, &c2, &[x, y]).unwrap();
            let v1 = evaluate(m.as_ref(), 1, level, &cx, &[x]).unwrap()
                * evaluate(m.as_ref(), 1, level, &cy, &[y]).unwrap();
            assert!((v2 - v1).abs() < 1e-12);
        }
    }
}
