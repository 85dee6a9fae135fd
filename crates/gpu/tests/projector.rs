//! The GPU global-cube projector (issue 17 (c)) against the CPU projector
//! (`CpuProjector`, exact sampling, no supersampling): the volume crate's conformance
//! suite at the f32 tolerance 1e-5,
//! random dyadic grids 8³–32³ (empty, thin and thick cells, coarse leaves, odd and
//! even framebuffers, both collision modes) within 1e-5 of each receiver's largest
//! face power, also with opaque cells and per-face emission (rays through cell edges
//! and corners, where both use the mean over the orders of the tied axes and the GPU
//! decides each crossing on the CPU's f64 values), both invariant under the cyclic
//! axis rotation; bitwise repeatability, chunked
//! dispatches equal to one, an opaque wall that zeroes everything behind it, the
//! escape sum, and typed errors for bad input.

mod common;

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use wavelux_gpu::GpuProjector;
use wavelux_volume::backend::conformance::{self, Tolerances};
use wavelux_volume::backend::cpu::{AntiAlias, CpuProjector, Projection};
use wavelux_volume::backend::{
    Emission, FaceRgb, ProjectionScene, Projector, Receiver, TraversalCell,
};
use wavelux_volume::cell::{Collision, total_weight_fast};

/// The contract of issue 17 (c).
const CONTRACT: f64 = 1e-5;

struct Scene {
    side: usize,
    voxel: f64,
    cells: Vec<TraversalCell>,
    map: Vec<u32>,
    coefficients: Vec<FaceRgb>,
    power: Vec<[f64; 3]>,
}

impl Scene {
    fn view(&self) -> ProjectionScene<'_> {
        ProjectionScene {
            side: self.side,
            voxel: self.voxel,
            cells: &self.cells,
            cell_map: &self.map,
        }
    }
    fn emission(&self) -> Emission<'_> {
        Emission {
            coefficients: &self.coefficients,
            power: &self.power,
        }
    }
    fn push(&mut self, origin: [u32; 3], size: u32, extinction: f64, e: FaceRgb) {
        let i = self.cells.len() as u32;
        let depth = if extinction == f64::INFINITY {
            f64::INFINITY
        } else {
            extinction * f64::from(size)
        };
        self.cells.push(TraversalCell {
            origin,
            size,
            extinction,
            // The tabulated Ĝ (1e-3 relative): both projectors read the same cell
            // weights, so agreement does not depend on them being exact, and the exact
            // quadrature at opt-level 1 cost 9 s for the 32³ grids' 25 000 cells.
            total_weight: if extinction > 0.0 {
                total_weight_fast(depth)
            } else {
                0.0
            },
        });
        self.coefficients.push(e);
        self.power.push([0.0; 3]);
        let n = self.side;
        for z in origin[2]..origin[2] + size {
            for y in origin[1]..origin[1] + size {
                for x in origin[0]..origin[0] + size {
                    self.map[x as usize + n * (y as usize + n * z as usize)] = i;
                }
            }
        }
    }
}

/// A random dyadic grid: each 4³ block is one coarse leaf (30 %) or 64 voxels; cells
/// are opaque (10 %), empty (15 %) or of optical depth 10⁻³…10 per voxel, with random
/// per-face emission.
fn random_scene(side: usize, seed: u64) -> Scene {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut s = Scene {
        side,
        voxel: 0.25,
        cells: Vec::new(),
        map: vec![0; side * side * side],
        coefficients: Vec::new(),
        power: Vec::new(),
    };
    let cell = |rng: &mut Pcg64| {
        let r: f64 = rng.random_range(0.0..1.0);
        let ext = if r < 0.1 {
            f64::INFINITY
        } else if r < 0.25 {
            0.0
        } else {
            10f64.powf(rng.random_range(-3.0..1.0))
        };
        let e: FaceRgb =
            std::array::from_fn(|_| std::array::from_fn(|_| rng.random_range(0.0..1.0)));
        (ext, e)
    };
    let b = side as u32 / 4;
    for bz in 0..b {
        for by in 0..b {
            for bx in 0..b {
                let o = [4 * bx, 4 * by, 4 * bz];
                if rng.random_range(0.0..1.0) < 0.3 {
                    let (ext, e) = cell(&mut rng);
                    s.push(o, 4, ext, e);
                } else {
                    for z in 0..4 {
                        for y in 0..4 {
                            for x in 0..4 {
                                let (ext, e) = cell(&mut rng);
                                s.push([o[0] + x, o[1] + y, o[2] + z], 1, ext, e);
                            }
                        }
                    }
                }
            }
        }
    }
    s
}

/// Receivers: every `step`-th cell, framebuffers cycling through 3, 4 and 8 (odd
/// sides put pixel centres on the axes, so rays run along voxel planes).
fn receivers(s: &Scene, step: usize) -> Vec<Receiver> {
    (0..s.cells.len())
        .step_by(step)
        .enumerate()
        .map(|(k, c)| Receiver {
            cell: c as u32,
            framebuffer: [3, 4, 8][k % 3],
        })
        .collect()
}

fn gather(
    p: &dyn Projector,
    s: &Scene,
    collision: Collision,
    rec: &[Receiver],
) -> anyhow::Result<Vec<FaceRgb>> {
    let mut out = vec![[[0.0; 3]; 6]; rec.len()];
    p.gather(&s.view(), &s.emission(), collision, rec, &mut out)?;
    Ok(out)
}

/// Worst over receivers of `max |gpu − cpu| / max |cpu|` (per receiver).
fn worst_relative(gpu: &[FaceRgb], cpu: &[FaceRgb]) -> f64 {
    gpu.iter()
        .zip(cpu)
        .map(|(g, c)| {
            let scale = c.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
            let diff = g
                .iter()
                .flatten()
                .zip(c.iter().flatten())
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            if scale > 0.0 {
                diff / scale
            } else if diff == 0.0 {
                0.0
            } else {
                f64::INFINITY
            }
        })
        .fold(0.0, f64::max)
}

#[test]
fn conformance_suite_at_f32_tolerance() -> anyhow::Result<()> {
    for gpu in common::gpus("projector conformance") {
        let p = GpuProjector::new(gpu);
        let tol = Tolerances {
            uniform: CONTRACT,
            cpu: CONTRACT,
        };
        let checks = conformance::run(&p, &tol)?;
        for c in &checks {
            eprintln!(
                "  {}: {} = {:.3e} (tolerance {:.0e}) {}",
                p.name(),
                c.name,
                c.value,
                c.tolerance,
                if c.ok { "ok" } else { "FAIL" }
            );
        }
        assert!(checks.iter().all(|c| c.ok), "{checks:?}");
    }
    Ok(())
}

/// Face-independent emission and no opaque cells: where a ray crosses a cell edge
/// exactly, the order in which a traversal steps across the two faces changes nothing
/// but a zero-length chord, so the projection is a continuous function of the ray and
/// the f32 GPU must agree with the f64 CPU to the contract.
fn tie_free(mut s: Scene) -> Scene {
    let n = s.side;
    let cells = std::mem::take(&mut s.cells);
    let coefficients = std::mem::take(&mut s.coefficients);
    s.power.clear();
    s.map = vec![0; n * n * n];
    for (c, e) in cells.iter().zip(&coefficients) {
        let ext = if c.extinction == f64::INFINITY {
            5.0
        } else {
            c.extinction
        };
        s.push(c.origin, c.size, ext, [e[0]; 6]);
    }
    s
}

#[test]
fn tie_free_random_grids_agree_with_the_cpu_projector() -> anyhow::Result<()> {
    let cpu = CpuProjector::new(Projection::Exact, AntiAlias::OFF);
    for gpu in common::gpus("projector random grids") {
        let p = GpuProjector::new(gpu);
        for (side, seed, step) in [(8, 1, 1), (16, 2, 13), (32, 3, 401)] {
            let s = tie_free(random_scene(side, seed));
            let rec = receivers(&s, step);
            for collision in [Collision::Exact, Collision::Plain] {
                let g = gather(&p, &s, collision, &rec)?;
                let c = gather(&cpu, &s, collision, &rec)?;
                let w = worst_relative(&g, &c);
                eprintln!(
                    "  {side}³, {} receivers, {collision:?}: worst relative face error {w:.3e}",
                    rec.len()
                );
                assert!(w <= CONTRACT, "{side}³ {collision:?}: {w:e}");
                // Repeatable bit for bit.
                assert!(
                    gather(&p, &s, collision, &rec)? == g,
                    "{side}³ not repeatable"
                );
            }
            // The rotation argument holds for the CPU here (checks `rotate`).
            let c = gather(&cpu, &s, Collision::Exact, &rec)?;
            let cr = rotated_gather(&cpu, &s, &rec)?;
            let w = worst_relative(&cr, &c);
            assert!(
                w <= 1e-9,
                "{side}³: CPU not rotation invariant without ties: {w:e}"
            );
        }
    }
    Ok(())
}

/// The scene turned by the cyclic axis permutation `x → y → z → x` (cell order kept).
/// The cube map is invariant under it bit for bit, so an exact projector gives the
/// same face powers, faces permuted; the CPU's tie rule at exact edge crossings (the
/// mean over the orders of the tied axes) is invariant, a rule that prefers one axis
/// (the WGSL's lowest axis first) is not.
fn rotate(s: &Scene) -> Scene {
    let mut r = Scene {
        side: s.side,
        voxel: s.voxel,
        cells: Vec::new(),
        map: vec![0; s.map.len()],
        coefficients: Vec::new(),
        power: Vec::new(),
    };
    for (c, e) in s.cells.iter().zip(&s.coefficients) {
        let o = c.origin;
        // Face `2a + s` goes to face `2((a + 1) mod 3) + s`.
        let f: FaceRgb = std::array::from_fn(|g| e[2 * ((g / 2 + 2) % 3) + g % 2]);
        r.push([o[2], o[0], o[1]], c.size, c.extinction, f);
    }
    r
}

/// The gather of the rotated scene, faces mapped back.
fn rotated_gather(p: &dyn Projector, s: &Scene, rec: &[Receiver]) -> anyhow::Result<Vec<FaceRgb>> {
    Ok(gather(p, &rotate(s), Collision::Exact, rec)?
        .iter()
        .map(|f| std::array::from_fn(|g| f[2 * ((g / 2 + 1) % 3) + g % 2]))
        .collect())
}

/// With opaque cells and per-face emission, a ray through a cell edge enters the
/// next cells in an order the traversal decides by comparing crossing distances,
/// and cube-map pixel centres hit edges exactly and systematically. Both projectors
/// take the mean over every order of stepping across the tied axes, so neither
/// depends on how the axes are labelled: each is invariant under the cyclic axis
/// rotation (an exact symmetry of the cube map), the CPU to 1e-12, the GPU to its f32
/// sums (1e-6). The GPU decides every crossing (which planes first, which at once,
/// which neighbour of a coarse cell's face) on the CPU's f64 values
/// (`wavelux_gpu::projector`, "Ties"), so the two agree to the contract.
#[test]
fn tie_sensitive_grids_are_rotation_invariant_and_agree_with_the_cpu() -> anyhow::Result<()> {
    let cpu = CpuProjector::new(Projection::Exact, AntiAlias::OFF);
    for gpu in common::gpus("projector tie-sensitive grids") {
        let p = GpuProjector::new(gpu);
        for (side, seed, step) in [(8, 1, 1), (16, 2, 13), (32, 3, 401)] {
            let s = random_scene(side, seed);
            let rec = receivers(&s, step);
            let g = gather(&p, &s, Collision::Exact, &rec)?;
            let c = gather(&cpu, &s, Collision::Exact, &rec)?;
            let cr = rotated_gather(&cpu, &s, &rec)?;
            let gr = rotated_gather(&p, &s, &rec)?;
            let total = |v: &[FaceRgb]| v.iter().flatten().flatten().sum::<f64>();
            let (tg, tc, tr, tgr) = (total(&g), total(&c), total(&cr), total(&gr));
            let (face_gpu, face_cpu, face_rot) = (
                worst_relative(&g, &c),
                worst_relative(&cr, &c),
                worst_relative(&gr, &g),
            );
            let (tot_gpu, tot_cpu, tot_rot) = (
                ((tg - tc) / tc).abs(),
                ((tr - tc) / tc).abs(),
                ((tgr - tg) / tg).abs(),
            );
            eprintln!(
                "  {side}³, {} receivers: worst face gpu–cpu {face_gpu:.3e}, gpu–rotated gpu \
                 {face_rot:.3e}, cpu–rotated cpu {face_cpu:.3e}; total power gpu–cpu \
                 {tot_gpu:.3e}, gpu–rotated gpu {tot_rot:.3e}, cpu–rotated cpu {tot_cpu:.3e}",
                rec.len()
            );
            assert!(
                face_cpu <= 1e-12,
                "{side}³: CPU rotation spread {face_cpu:e}"
            );
            assert!(
                face_rot <= 1e-6,
                "{side}³: GPU rotation spread {face_rot:e}"
            );
            assert!(tot_gpu <= CONTRACT, "{side}³: total {tot_gpu:e}");
            assert!(face_gpu <= CONTRACT, "{side}³: worst face {face_gpu:e}");
        }
    }
    Ok(())
}

/// Receiver samples (`k³` points of a cell, `k²` of each entry face of cells touching
/// or being opaque) on the tie-sensitive grids: the GPU averages the same rays as the
/// CPU (origins at multiples of `1/(2k)` voxel, crossings decided on the CPU's f64
/// values), so they agree to the contract; the escape with `k > 1` is the CPU's
/// conserving one, bit for bit; other `k` are a typed error.
#[test]
fn receiver_samples_agree_with_the_cpu() -> anyhow::Result<()> {
    for gpu in common::gpus("projector receiver samples") {
        for (side, seed, step, k) in [(8, 1, 5, 2), (8, 5, 31, 4), (16, 2, 97, 2)] {
            let s = random_scene(side, seed);
            let rec = receivers(&s, step);
            let cpu = CpuProjector::new(Projection::Exact, AntiAlias::OFF).with_receiver_samples(k);
            let p = GpuProjector::new(gpu.clone()).with_receiver_samples(k);
            let g = gather(&p, &s, Collision::Exact, &rec)?;
            let c = gather(&cpu, &s, Collision::Exact, &rec)?;
            let w = worst_relative(&g, &c);
            eprintln!(
                "  {side}³, k = {k}, {} receivers: worst relative face error {w:.3e}",
                rec.len()
            );
            assert!(w <= CONTRACT, "{side}³ k = {k}: {w:e}");
            let e_gpu = p.escape(&s.view(), &s.emission(), 4)?;
            let e_cpu = cpu.escape(&s.view(), &s.emission(), 4)?;
            assert_eq!(e_gpu, e_cpu, "escape k = {k}");
        }
        let s = random_scene(8, 1);
        let rec = receivers(&s, 50);
        let p = GpuProjector::new(gpu).with_receiver_samples(3);
        let err = gather(&p, &s, Collision::Exact, &rec).expect_err("k = 3 is refused");
        assert!(err.to_string().contains("1, 2, 4 or 8"), "{err}");
    }
    Ok(())
}

#[test]
fn chunked_dispatches_equal_one_and_escape_agrees() -> anyhow::Result<()> {
    let cpu = CpuProjector::new(Projection::Exact, AntiAlias::OFF);
    for gpu in common::gpus("projector chunks/escape") {
        let s = tie_free(random_scene(8, 4));
        let rec = receivers(&s, 1);
        let whole = GpuProjector::new(gpu.clone());
        let small = GpuProjector::new(gpu).with_binding_limit(65536);
        let a = gather(&whole, &s, Collision::Exact, &rec)?;
        let b = gather(&small, &s, Collision::Exact, &rec)?;
        assert!(a == b, "chunked gather differs");
        for fb in [3, 8] {
            let e_gpu = whole.escape(&s.view(), &s.emission(), fb)?;
            let e_cpu = cpu.escape(&s.view(), &s.emission(), fb)?;
            let e_small = small.escape(&s.view(), &s.emission(), fb)?;
            let rel = (0..3)
                .map(|c| (e_gpu[c] - e_cpu[c]).abs() / e_cpu[c].abs())
                .fold(0.0, f64::max);
            eprintln!("  escape fb {fb}: gpu {e_gpu:?} cpu {e_cpu:?} relative {rel:.3e}");
            assert!(rel <= CONTRACT, "escape fb {fb}: {rel:e}");
            assert!(e_small == e_gpu, "chunked escape differs");
        }
    }
    Ok(())
}

#[test]
fn an_opaque_wall_zeroes_everything_behind_it() -> anyhow::Result<()> {
    for gpu in common::gpus("projector opaque wall") {
        let p = GpuProjector::new(gpu);
        // 16³ voxels: emitting medium at x > 8, an opaque non-emitting wall at x = 8
        // spanning the whole grid, a dark thin medium at x < 8.
        let n = 16u32;
        let mut s = Scene {
            side: n as usize,
            voxel: 1.0,
            cells: Vec::new(),
            map: vec![0; (n * n * n) as usize],
            coefficients: Vec::new(),
            power: Vec::new(),
        };
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let (ext, e) = match x {
                        8 => (f64::INFINITY, [[0.0; 3]; 6]),
                        x if x > 8 => (0.5, [[1.0, 2.0, 3.0]; 6]),
                        _ => (0.1, [[0.0; 3]; 6]),
                    };
                    s.push([x, y, z], 1, ext, e);
                }
            }
        }
        let rec: Vec<Receiver> = (0..s.cells.len())
            .filter(|&i| s.cells[i].origin[0] < 8)
            .step_by(5)
            .map(|i| Receiver {
                cell: i as u32,
                framebuffer: 4,
            })
            .collect();
        let out = gather(&p, &s, Collision::Exact, &rec)?;
        let m = out
            .iter()
            .flatten()
            .flatten()
            .fold(0.0f64, |a, v| a.max(v.abs()));
        eprintln!("  {} receivers behind the wall: max power {m:e}", rec.len());
        assert_eq!(m, 0.0);
        // In front of the wall the same projector sees light (the check can fail).
        let lit: Vec<Receiver> = (0..s.cells.len())
            .filter(|&i| s.cells[i].origin[0] > 8)
            .step_by(50)
            .map(|i| Receiver {
                cell: i as u32,
                framebuffer: 4,
            })
            .collect();
        let out = gather(&p, &s, Collision::Exact, &lit)?;
        let cpu = CpuProjector::new(Projection::Exact, AntiAlias::OFF);
        let reference = gather(&cpu, &s, Collision::Exact, &lit)?;
        let w = worst_relative(&out, &reference);
        eprintln!(
            "  {} receivers in front of the wall: worst relative error {w:.3e}",
            lit.len()
        );
        assert!(w <= CONTRACT, "{w:e}");
        assert!(out.iter().flatten().flatten().sum::<f64>() > 0.0);
    }
    Ok(())
}

#[test]
fn bad_input_is_a_typed_error() -> anyhow::Result<()> {
    for gpu in common::gpus("projector bad input") {
        let p = GpuProjector::new(gpu);
        let mut s = random_scene(4, 5);
        let k = s.cells.len() - 1;
        s.cells[k].extinction = f64::NAN;
        let rec = [Receiver {
            cell: 0,
            framebuffer: 2,
        }];
        let err = gather(&p, &s, Collision::Exact, &rec).unwrap_err();
        eprintln!("  NaN extinction: {err}");
        assert!(err.to_string().contains(&format!("cell {k}")), "{err}");
        let s = random_scene(4, 6);
        let bad = [Receiver {
            cell: 0,
            framebuffer: 5000,
        }];
        assert!(gather(&p, &s, Collision::Exact, &bad).is_err());
    }
    Ok(())
}
