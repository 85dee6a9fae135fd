//! The meshless relighting product `i = S·e` on the GPU (`GpuTransfer`) against the
//! CPU backend on a real transfer matrix (the white furnace's `S`):
//! `|i_gpu − i_cpu| ≤ 1e-6·(|S||e|) + 1e-30·max|S|·max|e|` per component, for `e`
//! scaled 1e-30 to 1e30 with inactive senders, in one chunk and cut into many blocks
//! and chunks; bitwise repeatable; zero in, zero out; bad lengths are typed errors.

mod common;

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use wavelux_gpu::GpuTransfer;
use wavelux_meshless::{CpuBackend, MeshlessConfig, Precomputed, TransferBackend};
use wavelux_scene::builtin::white_furnace;

fn quiet(_: &str, _: usize, _: usize) {}

/// The white furnace (ρ = 0.9) with 3 receiver and 2 sender levels, 2 bounces.
fn furnace() -> Precomputed {
    let scene = white_furnace(0.0, 0.9).expect("furnace");
    let cfg = MeshlessConfig {
        receiver_levels: 3,
        sender_levels: 2,
        r_coarse: Some(0.2 * 3f64.sqrt()),
        epsilon: 1e-4,
        bounces: 2,
        ..Default::default()
    };
    Precomputed::build(&scene, &cfg, &quiet).expect("precompute")
}

/// Random `e` (three f32 per sender): every third sender inactive, mixed signs.
fn random_e(seed: u64, senders: usize, scale: f64) -> Vec<f32> {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut e = vec![0f32; senders * 3];
    for j in 0..senders {
        if j % 3 == 1 {
            continue;
        }
        for c in 0..3 {
            let m = 10f64.powf(rng.random_range(-2.0..0.0));
            e[j * 3 + c] = (scale * m * rng.random_range(-1.0..1.0)) as f32;
        }
    }
    e
}

/// `(|S||e|)` per output component, in f64 from the f32 values the backends use.
fn abs_product(pre: &Precomputed, e: &[f32]) -> Vec<f64> {
    let s = &pre.s;
    let mut out = vec![0.0; s.rows() * 9];
    for i in 0..s.rows() {
        let (cols, links) = s.row(i);
        for (&j, l) in cols.iter().zip(links) {
            for c in 0..3 {
                let ej = f64::from(e[j as usize * 3 + c]).abs();
                for a in 0..3 {
                    out[i * 9 + c * 3 + a] += f64::from(l[c * 3 + a] as f32).abs() * ej;
                }
            }
        }
    }
    out
}

#[test]
fn gpu_transfer_meets_the_contract_against_the_cpu() {
    let gpus = common::gpus("gpu_transfer_meets_the_contract_against_the_cpu");
    if gpus.is_empty() {
        return;
    }
    let pre = furnace();
    let (rows, cols) = (pre.s.rows(), pre.s.cols());
    assert!(pre.s.nnz() > 1000, "a real matrix: {} links", pre.s.nnz());
    let max_s = (0..rows)
        .flat_map(|i| pre.s.row(i).1.iter().flatten())
        .fold(0.0f64, |m, v| m.max(f64::from(*v as f32).abs()));
    let cpu_prep = CpuBackend.prepare(&pre.s).unwrap();
    for g in gpus {
        for (label, backend) in [
            ("one chunk", GpuTransfer::new(g.clone())),
            // 7 receivers per block, 64 KiB bindings: 109 blocks in dozens of chunks.
            (
                "chunked",
                GpuTransfer::new(g.clone()).with_limits(1 << 16, 7),
            ),
        ] {
            let prep = backend.prepare(&pre.s).unwrap();
            let mut worst = 0.0f64;
            for (k, scale) in [1e-30, 1e-6, 1.0, 1e6, 1e30].into_iter().enumerate() {
                let e = random_e(k as u64, cols, scale);
                let (mut yc, mut yg, mut yg2) = (
                    vec![0f32; rows * 9],
                    vec![0f32; rows * 9],
                    vec![0f32; rows * 9],
                );
                CpuBackend.apply(&cpu_prep, &e, &mut yc).unwrap();
                backend.apply(&prep, &e, &mut yg).unwrap();
                backend.apply(&prep, &e, &mut yg2).unwrap();
                assert!(
                    yg.iter().zip(&yg2).all(|(a, b)| a.to_bits() == b.to_bits()),
                    "{label}: two runs differ"
                );
                let max_e = e.iter().fold(0.0f64, |m, v| m.max(f64::from(*v).abs()));
                let abs = abs_product(&pre, &e);
                for i in 0..rows * 9 {
                    let d = (f64::from(yg[i]) - f64::from(yc[i])).abs();
                    let bound = 1e-6 * abs[i] + 1e-30 * max_s * max_e;
                    assert!(
                        d <= bound,
                        "{label}, scale {scale:e}, component {i}: gpu {} cpu {} (|S||e| {})",
                        yg[i],
                        yc[i],
                        abs[i]
                    );
                    if abs[i] > 0.0 {
                        worst = worst.max(d / abs[i]);
                    }
                }
            }
            println!(
                "transfer {label} on {}: {} receivers, {} senders, {} links, {} chunk(s); \
                 worst |gpu − cpu|/(|S||e|) = {worst:.2e} (bound 1e-6)",
                g.adapter().name,
                rows,
                cols,
                pre.s.nnz(),
                prep.chunks()
            );
            // Zero in, zero out (no sender active).
            let mut y = vec![1f32; rows * 9];
            backend.apply(&prep, &vec![0f32; cols * 3], &mut y).unwrap();
            assert!(y.iter().all(|v| *v == 0.0), "{label}: zero e");
            // Bad lengths and non-finite input are typed errors, not panics.
            let mut short = vec![0f32; rows * 9 - 1];
            assert!(
                backend
                    .apply(&prep, &vec![1f32; cols * 3], &mut short)
                    .is_err()
            );
            let mut nan = vec![1f32; cols * 3];
            nan[0] = f32::NAN;
            assert!(backend.apply(&prep, &nan, &mut y).is_err());
        }
    }
}
