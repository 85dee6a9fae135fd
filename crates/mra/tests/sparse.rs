//! Sparse-tree transforms agree with the full-grid non-standard transforms; push/pull
//! are level-independent and consistent with point evaluation.
#![allow(missing_docs)]

use proptest::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use wavelux_mra::sparse::{SparseLevel, decompose, pull_node, push_node, reconstruct};
use wavelux_mra::tensor::nonstandard_decompose;
use wavelux_mra::transform::{pull, push};
use wavelux_mra::{Alpert, Cdv, Mra};

fn all_mras() -> Vec<Box<dyn Mra>> {
    let mut v: Vec<Box<dyn Mra>> = Vec::new();
    for k in 1..=4 {
        v.push(Box::new(Alpert::new(k).unwrap()));
    }
    v.push(Box::new(Cdv::new()));
    v
}

fn check<const D: usize>(m: &dyn Mra, top: u32, density: f64, seed: u64) {
    let j0 = m.min_level();
    let n = m.len(top);
    let total = n.pow(D as u32);
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut full = vec![0.0; total];
    let mut pairs = Vec::new();
    for (flat, slot) in full.iter_mut().enumerate() {
        if rng.random::<f64>() < density {
            let v = rng.random::<f64>() - 0.5;
            *slot = v;
            let key: [usize; D] = std::array::from_fn(|a| (flat / n.pow((D - 1 - a) as u32)) % n);
            pairs.push((key, v));
        }
    }
    let sparse = SparseLevel::<D>::from_pairs(top, pairs);
    let tree = decompose(m, &sparse, j0).unwrap();
    nonstandard_decompose(m, D, top, j0, &mut full).unwrap();
    // Every sparse coefficient equals the full-grid one at the Mallat position...
    let mut seen = vec![false; total];
    let flat_of = |p: [usize; D]| -> usize { (0..D).fold(0, |acc, a| acc * n + p[a]) };
    for (k, &v) in tree.coarse.keys().iter().zip(tree.coarse.values()) {
        let f = flat_of(*k);
        assert!((full[f] - v).abs() < 1e-13);
        seen[f] = true;
    }
    for d in &tree.details {
        let len = m.len(d.level);
        for (i, key) in d.keys().iter().enumerate() {
            for (t1, &v) in d.node(i).iter().enumerate() {
                let t = t1 + 1;
                let p: [usize; D] =
                    std::array::from_fn(|a| key[a] + if (t >> a) & 1 == 1 { len } else { 0 });
                let f = flat_of(p);
                assert!(
                    (full[f] - v).abs() < 1e-13,
                    "{} level {} key {key:?} t {t}",
                    m.name(),
                    d.level
                );
                seen[f] = true;
            }
        }
    }
    // ...and every full-grid coefficient the tree does not hold is zero.
    for (f, &s) in seen.iter().enumerate() {
        if !s {
            assert!(
                full[f].abs() < 1e-13,
                "{} missing coefficient {f} = {}",
                m.name(),
                full[f]
            );
        }
    }
    let back = reconstruct(m, &tree).unwrap();
    for (k, &v) in back.keys().iter().zip(back.values()) {
        assert!((sparse.get(k) - v).abs() < 1e-12);
    }
    for (k, &v) in sparse.keys().iter().zip(sparse.values()) {
        assert!((back.get(k) - v).abs() < 1e-12);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    #[test]
    fn sparse_matches_full_grid(which in 0usize..5, seed in any::<u64>(), density in 0.01f64..0.3) {
        let m = &all_mras()[which];
        let j0 = m.min_level();
        check::<1>(m.as_ref(), j0 + 4, density, seed);
        check::<2>(m.as_ref(), j0 + 2, density, seed);
        if m.len(j0 + 1) <= 8 {
            check::<3>(m.as_ref(), j0 + 1, density, seed);
        }
    }
}

/// Push then pull is the identity on the parent (orthonormal rows), the pushed children
/// represent the same function (checked by point evaluation), and the coefficients are
/// the same on every level (VirtualMesh §5.2).
#[test]
fn push_pull_level_independent() {
    for m in all_mras() {
        let j = m.min_level() + 2;
        let k = m.len(j) / 2;
        let mut kids = std::collections::BTreeMap::new();
        push(m.as_ref(), j, k, 1.0, |l, v| {
            kids.insert(l, v);
        })
        .unwrap();
        let back = pull(m.as_ref(), j, k, |l| kids.get(&l).copied().unwrap_or(0.0)).unwrap();
        assert!((back - 1.0).abs() < 1e-14);
        for s in 0..=64 {
            let x = s as f64 / 64.0;
            let mut v = 0.0;
            for (&l, &c) in &kids {
                v += c * m.eval_scaling(j + 1, l, x).unwrap();
            }
            assert!((v - m.eval_scaling(j, k, x).unwrap()).abs() < 1e-12);
        }
        // Level independence: the same relative offsets and values one level deeper
        // (interior node, 2k on the finer level).
        let r1 = m.scaling_row(j, k).unwrap();
        let r2 = m.scaling_row(j + 1, 2 * k).unwrap();
        assert_eq!(r1.coeffs, r2.coeffs);
        // Same offset of the first child relative to 2 × (node index).
        assert_eq!(
            2 * k as i64 - r1.start as i64,
            4 * k as i64 - r2.start as i64
        );
        // 2D nodes.
        let mut kids2 = std::collections::BTreeMap::new();
        push_node(m.as_ref(), j, [k, 1], 2.0, |c, v| {
            kids2.insert(*c, v);
        })
        .unwrap();
        let back2 = pull_node(m.as_ref(), j, [k, 1], |c| {
            kids2.get(c).copied().unwrap_or(0.0)
        })
        .unwrap();
        assert!((back2 - 2.0).abs() < 1e-13);
    }
}

#[test]
fn sparse_errors_are_typed() {
    let m = Alpert::haar();
    let bad = SparseLevel::<1>::from_pairs(3, vec![([100], 1.0)]);
    assert!(decompose(&m, &bad, 0).is_err());
    let ok = SparseLevel::<1>::from_pairs(3, vec![([1], 1.0)]);
    assert!(decompose(&m, &ok, 4).is_err());
    let c = Cdv::new();
    assert!(decompose(&c, &SparseLevel::<1>::new(1), 0).is_err());
}
