//! Tensor products (d = 1..4), standard vs non-standard, projection, polynomial
//! reproduction and vanishing moments for every MRA.
#![allow(missing_docs)]

use proptest::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use wavelux_mra::project::{GaussOptions, evaluate, project};
use wavelux_mra::tensor::{
    eval_decomposed, nonstandard_basis_function, nonstandard_decompose, nonstandard_reconstruct,
    standard_decompose, standard_reconstruct, wavelet_types,
};
use wavelux_mra::transform::decompose;
use wavelux_mra::{Alpert, Cdv, Mra};

fn all_mras() -> Vec<Box<dyn Mra>> {
    let mut v: Vec<Box<dyn Mra>> = Vec::new();
    for k in 1..=4 {
        v.push(Box::new(Alpert::new(k).unwrap()));
    }
    v.push(Box::new(Cdv::new()));
    v
}

fn random(n: usize, seed: u64, scale: f64) -> Vec<f64> {
    let mut rng = Pcg64::seed_from_u64(seed);
    (0..n)
        .map(|_| scale * (rng.random::<f64>() - 0.5))
        .collect()
}

fn norm(v: &[f64]) -> f64 {
    let s = v.iter().fold(0.0f64, |a, &x| a.max(x.abs()));
    if s == 0.0 {
        return 0.0;
    }
    s * v.iter().map(|x| (x / s).powi(2)).sum::<f64>().sqrt()
}

fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    norm(&d) / norm(b).max(f64::MIN_POSITIVE)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(40))]
    #[test]
    fn tensor_round_trips_and_parseval(which in 0usize..5, dim in 1usize..=4, extra in 0u32..3,
                                       seed in any::<u64>(), e in -300i32..=300, std_ in any::<bool>()) {
        let m = &all_mras()[which];
        let j0 = m.min_level();
        let extra = if dim >= 3 { extra.min(1) } else { extra };
        let top = j0 + extra + 1;
        let n = m.len(top).pow(dim as u32);
        prop_assume!(n <= 1 << 16);
        let data = random(n, seed, 10f64.powi(e));
        let mut w = data.clone();
        if std_ {
            standard_decompose(m.as_ref(), dim, top, j0, &mut w).unwrap();
        } else {
            nonstandard_decompose(m.as_ref(), dim, top, j0, &mut w).unwrap();
        }
        prop_assert!((norm(&w) - norm(&data)).abs() <= 1e-13 * norm(&data));
        if std_ {
            standard_reconstruct(m.as_ref(), dim, top, j0, &mut w).unwrap();
        } else {
            nonstandard_reconstruct(m.as_ref(), dim, top, j0, &mut w).unwrap();
        }
        prop_assert!(rel_diff(&w, &data) <= 1e-12);
    }
}

/// Both decompositions represent the same function: evaluating the scaling expansion,
/// the standard expansion and the non-standard expansion at random points agrees.
#[test]
fn standard_and_nonstandard_represent_the_same_function() {
    for m in all_mras() {
        for dim in 1..=3usize {
            let j0 = m.min_level();
            let top = j0 + 2;
            if m.len(top).pow(dim as u32) > 5000 {
                continue;
            }
            let n = m.len(top).pow(dim as u32);
            let data = random(n, 7 + dim as u64, 1.0);
            let mut s = data.clone();
            standard_decompose(m.as_ref(), dim, top, j0, &mut s).unwrap();
            let mut ns = data.clone();
            nonstandard_decompose(m.as_ref(), dim, top, j0, &mut ns).unwrap();
            // The pure coarsest scaling block agrees between both.
            let n0 = m.len(j0);
            let ntop = m.len(top);
            for flat in 0..n {
                let idx = wavelux_mra::tensor::unflatten(flat, ntop, dim);
                if idx.iter().all(|&p| p < n0) {
                    assert!((s[flat] - ns[flat]).abs() < 1e-12);
                }
            }
            let mut rng = Pcg64::seed_from_u64(3);
            for _ in 0..5 {
                // Dyadic points (exact CDV evaluation).
                let x: Vec<f64> = (0..dim)
                    .map(|_| f64::from(rng.random_range(0..=1024u32)) / 1024.0)
                    .collect();
                let v0 = evaluate(m.as_ref(), dim, top, &data, &x).unwrap();
                let v1 = eval_decomposed(m.as_ref(), dim, top, j0, &s, true, &x).unwrap();
                let v2 = eval_decomposed(m.as_ref(), dim, top, j0, &ns, false, &x).unwrap();
                assert!(
                    (v0 - v1).abs() < 1e-10,
                    "{} d={dim} std {v0} {v1}",
                    m.name()
                );
                assert!(
                    (v0 - v2).abs() < 1e-10,
                    "{} d={dim} nonstd {v0} {v2}",
                    m.name()
                );
            }
        }
    }
}

#[test]
fn wavelet_type_counts() {
    let m = Alpert::haar();
    for dim in 1..=4usize {
        assert_eq!(wavelet_types(dim), (1 << dim) - 1);
        // Count the distinct φ/ψ patterns on the finest non-standard level.
        let top = 2;
        let n = m.len(top).pow(dim as u32);
        let mut patterns = std::collections::BTreeSet::new();
        for flat in 0..n {
            let f = nonstandard_basis_function(&m, dim, top, 0, flat).unwrap();
            if f[0].level == top - 1 {
                patterns.insert(f.iter().map(|x| x.wavelet).collect::<Vec<_>>());
            }
        }
        let wavelet_patterns = patterns.iter().filter(|p| p.iter().any(|&w| w)).count();
        assert_eq!(wavelet_patterns, wavelet_types(dim));
    }
}

/// Projection reproduces polynomials of degree ≤ polynomial_degree exactly (checked by
/// evaluation, in 1D and 2D); wavelet coefficients of x^μ vanish for μ < ν and not for
/// μ = ν.
#[test]
fn polynomial_reproduction_and_vanishing_moments() {
    let opts = GaussOptions {
        order: 8,
        tolerance: 0.0,
        max_depth: 0,
    };
    for m in all_mras() {
        let level = m.min_level() + 2;
        for p in 0..=m.polynomial_degree() {
            let c = project(m.as_ref(), 1, level, |x| x[0].powi(p as i32), opts).unwrap();
            for s in 0..=64 {
                let x = s as f64 / 64.0;
                let v = evaluate(m.as_ref(), 1, level, &c, &[x]).unwrap();
                assert!(
                    (v - x.powi(p as i32)).abs() < 1e-12,
                    "{} p={p} x={x} {v}",
                    m.name()
                );
            }
            let c2 = project(
                m.as_ref(),
                2,
                level,
                |x| x[0].powi(p as i32) * (1.0 - x[1]).powi(p as i32),
                opts,
            )
            .unwrap();
            for s in 0..=16 {
                let x = [s as f64 / 16.0, 1.0 - s as f64 / 32.0];
                let v = evaluate(m.as_ref(), 2, level, &c2, &x).unwrap();
                let e = x[0].powi(p as i32) * (1.0 - x[1]).powi(p as i32);
                assert!((v - e).abs() < 1e-12, "{} 2D p={p}", m.name());
            }
        }
        let nu = m.vanishing_moments();
        for mu in 0..=nu {
            let mut c = project(
                m.as_ref(),
                1,
                level + 1,
                |x| (x[0] - 0.3).powi(mu as i32),
                opts,
            )
            .unwrap();
            let n = m.len(level);
            decompose(m.as_ref(), level + 1, level, &mut c).unwrap();
            let dmax = c[n..].iter().fold(0.0f64, |a, x| a.max(x.abs()));
            if mu < nu {
                assert!(dmax < 1e-13, "{} μ={mu}: {dmax}", m.name());
            } else {
                assert!(
                    dmax > 1e-6,
                    "{} μ={mu}: moment after the vanishing ones is {dmax}",
                    m.name()
                );
            }
        }
    }
}

/// Extremes: 10 levels in 2D and 6 in 3D (Haar and CDV), constant and zero inputs.
#[test]
fn deep_multidimensional_transforms() {
    let haar = Alpert::haar();
    let cdv = Cdv::new();
    let cases: Vec<(&dyn Mra, usize, u32)> =
        vec![(&haar, 2, 10), (&cdv, 2, 10), (&haar, 3, 6), (&cdv, 3, 6)];
    for (m, dim, top) in cases {
        let j0 = m.min_level();
        let n = m.len(top).pow(dim as u32);
        let data = random(n, 11, 1e-300);
        let mut w = data.clone();
        nonstandard_decompose(m, dim, top, j0, &mut w).unwrap();
        nonstandard_reconstruct(m, dim, top, j0, &mut w).unwrap();
        assert!(rel_diff(&w, &data) < 1e-12, "{} d={dim}", m.name());
        let mut z = vec![0.0; n];
        standard_decompose(m, dim, top, j0, &mut z).unwrap();
        assert!(z.iter().all(|&x| x == 0.0));
    }
    // Constant function in 2D Haar: only the coarsest scaling coefficient survives.
    let top = 10;
    let n = haar.len(top);
    let mut c = vec![(-(top as f64)).exp2(); n * n]; // f = 1 → c = 2^{-J}
    nonstandard_decompose(&haar, 2, top, 0, &mut c).unwrap();
    assert!((c[0] - 1.0).abs() < 1e-12);
    assert!(c[1..].iter().all(|x| x.abs() < 1e-12));
}

/// Projection of a discontinuous function: the adaptive rule converges to the
/// closed-form Haar coefficients.
#[test]
fn adaptive_projection_handles_a_jump() {
    let haar = Alpert::haar();
    let level = 3;
    let c = project(
        &haar,
        1,
        level,
        |x| if x[0] < 0.3 { 1.0 } else { 0.0 },
        GaussOptions {
            order: 4,
            tolerance: 1e-12,
            max_depth: 40,
        },
    )
    .unwrap();
    let s = (level as f64 / 2.0).exp2();
    // Cells of width 1/8: [0,.125) and [.125,.25) full, [.25,.375) has 0.05.
    let expect = [0.125, 0.125, 0.05, 0.0, 0.0, 0.0, 0.0, 0.0];
    for (a, b) in c.iter().zip(expect) {
        assert!((a - b * s).abs() < 1e-11, "{a} vs {}", b * s);
    }
}

/// Gram matrix of the 2D and 3D non-standard and standard bases of M_k equals I to
/// 1e-12, by tensor Gauss rules on the finest cells (exact for the degree).
#[test]
fn tensor_bases_are_orthonormal() {
    use wavelux_mra::tensor::standard_basis_function;
    use wavelux_quadrature::GaussLegendre;
    for k in 1..=3 {
        let m = Alpert::new(k).unwrap();
        for dim in 2..=3usize {
            let top = if dim == 2 { 2 } else { 1 };
            let n = m.len(top).pow(dim as u32);
            let cells = 1usize << top;
            let gl = GaussLegendre::new(k + 1).unwrap();
            // 1D nodes over all finest cells.
            let mut nodes = Vec::new();
            for c in 0..cells {
                let (p, w) = gl
                    .on_interval(c as f64 / cells as f64, (c + 1) as f64 / cells as f64)
                    .unwrap();
                nodes.extend(p.into_iter().zip(w));
            }
            let np = nodes.len();
            let total = np.pow(dim as u32);
            for standard in [false, true] {
                let vals: Vec<Vec<f64>> = (0..n)
                    .map(|flat| {
                        let fs = if standard {
                            standard_basis_function(&m, dim, top, 0, flat).unwrap()
                        } else {
                            nonstandard_basis_function(&m, dim, top, 0, flat).unwrap()
                        };
                        let per_axis: Vec<Vec<f64>> = fs
                            .iter()
                            .map(|f| nodes.iter().map(|&(x, _)| f.eval(&m, x).unwrap()).collect())
                            .collect();
                        (0..total)
                            .map(|p| {
                                let mut r = p;
                                let mut v = 1.0;
                                for a in (0..dim).rev() {
                                    v *= per_axis[a][r % np];
                                    r /= np;
                                }
                                v
                            })
                            .collect()
                    })
                    .collect();
                let weights: Vec<f64> = (0..total)
                    .map(|p| {
                        let mut r = p;
                        let mut w = 1.0;
                        for _ in 0..dim {
                            w *= nodes[r % np].1;
                            r /= np;
                        }
                        w
                    })
                    .collect();
                for a in 0..n {
                    for b in a..n {
                        let s: f64 = (0..total)
                            .map(|p| weights[p] * vals[a][p] * vals[b][p])
                            .sum();
                        let e = (s - f64::from(u8::from(a == b))).abs();
                        assert!(e < 1e-12, "M{k} d={dim} std={standard} ({a},{b}) {e}");
                    }
                }
            }
        }
    }
}
