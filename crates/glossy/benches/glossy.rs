//! Glossy benches (issue 16): Ward BRDF evaluation and half-vector sampling per
//! variant (evaluations per second on one core); on the Cornell box with Ward
//! (α = 0.2) walls: one transport link (kernel samples per second) beside raw
//! occlusion queries between the same two patches (rays per second, same run), one
//! Gauss–Seidel sweep over the links of a refined solution (links per second), and the
//! final gather (Glossy §5.5) per pixel after the `V⁰` solve for the three sender
//! choices (all senders, linked senders, root links only).
//!
//! Times are the CPU time of the bench process ([`CpuTime`]), not wall time: on the
//! shared machine a wall clock counts the time other processes held the cores.
#![allow(missing_docs)] // reason: criterion's macros generate undocumented items

use criterion::measurement::{Measurement, ValueFormatter, WallTime};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::{DVec2, DVec3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use std::hint::black_box;
use wavelux_glossy::basis::NodeKey;
use wavelux_glossy::solve::solve;
use wavelux_glossy::transport::{End, Transport};
use wavelux_glossy::tree::RADIANCE;
use wavelux_glossy::{
    GatherMode, GlossyConfig, GlossySolution, LinearSolver, WardLobe, WardVariant,
};
use wavelux_scene::builtin::cornell_box;
use wavelux_scene::{Rgb, WardParams};

const N: usize = 4096;

/// CPU time (ns) of this process's living threads: the sum of the first field of
/// `/proc/self/task/*/schedstat` (Linux; each thread's time on a CPU). The scheduler
/// brings the running thread's count up to date only at a tick or a switch, so a read
/// first yields (`sched_yield` updates it); without that a sample shorter than a tick
/// could read zero. Values are nanoseconds, shown by criterion's duration formatter.
struct CpuTime {
    wall: WallTime,
}

impl CpuTime {
    fn now() -> u64 {
        std::thread::yield_now();
        let tasks = std::fs::read_dir("/proc/self/task").expect("Linux /proc/self/task");
        tasks
            .filter_map(|t| std::fs::read_to_string(t.ok()?.path().join("schedstat")).ok())
            .filter_map(|s| s.split_whitespace().next()?.parse::<u64>().ok())
            .sum()
    }
}

impl Measurement for CpuTime {
    type Intermediate = u64;
    type Value = u64;

    fn start(&self) -> u64 {
        Self::now()
    }
    fn end(&self, start: u64) -> u64 {
        Self::now().saturating_sub(start)
    }
    fn add(&self, a: &u64, b: &u64) -> u64 {
        a + b
    }
    fn zero(&self) -> u64 {
        0
    }
    fn to_f64(&self, ns: &u64) -> f64 {
        *ns as f64
    }
    fn formatter(&self) -> &dyn ValueFormatter {
        self.wall.formatter()
    }
}

fn cpu_time() -> Criterion<CpuTime> {
    Criterion::default().with_measurement(CpuTime { wall: WallTime })
}

/// `N` random upper-hemisphere direction pairs and `N` uniform sample pairs.
fn inputs() -> (Vec<(DVec3, DVec3)>, Vec<[f64; 2]>) {
    let mut rng = Pcg64::seed_from_u64(16);
    let dir = |rng: &mut Pcg64| {
        let z: f64 = rng.random();
        let phi = std::f64::consts::TAU * rng.random::<f64>();
        let r = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(r * phi.cos(), r * phi.sin(), z)
    };
    let pairs = (0..N).map(|_| (dir(&mut rng), dir(&mut rng))).collect();
    let us = (0..N).map(|_| [rng.random(), rng.random()]).collect();
    (pairs, us)
}

fn ward(c: &mut Criterion<CpuTime>) {
    let (pairs, us) = inputs();
    let mut g = c.benchmark_group("glossy/ward");
    g.throughput(Throughput::Elements(N as u64));
    for v in WardVariant::ALL {
        let lobe = WardLobe::new(v, 0.2, 0.1).expect("valid roughness");
        g.bench_with_input(BenchmarkId::new("eval", v.name()), &lobe, |b, l| {
            b.iter(|| {
                let mut s = 0.0;
                for &(wi, wo) in &pairs {
                    s += l.eval(wi, wo);
                }
                black_box(s)
            });
        });
        g.bench_with_input(BenchmarkId::new("sample", v.name()), &lobe, |b, l| {
            b.iter(|| {
                let mut s = 0.0;
                for (k, u) in us.iter().enumerate() {
                    if let Some((_, pdf, w)) = l.sample(pairs[k].0, *u) {
                        s += pdf + w;
                    }
                }
                black_box(s)
            });
        });
    }
    g.finish();
}

/// The Cornell box with Ward (α = 0.2, ρ_s = 0.2) on every reflecting material.
fn ward_cornell() -> wavelux_scene::Scene {
    let mut scene = cornell_box();
    for m in &mut scene.materials {
        if m.emission.0 == [0.0; 3] {
            m.ward = Some(WardParams {
                specular: Rgb::grey(0.2),
                alpha_x: 0.2,
                alpha_y: 0.2,
            });
            m.reflectance = Rgb(m.reflectance.0.map(|r| 0.7 * r));
        }
    }
    scene
}

/// The Ward Cornell box's glossy solution set up for `rounds` refinement rounds.
fn ward_solution(rounds: usize) -> GlossySolution {
    GlossySolution::new(
        &ward_cornell(),
        "builtin:cornell-box",
        GlossyConfig {
            rounds,
            ..GlossyConfig::default()
        },
    )
    .expect("the Cornell box solves")
}

fn link(c: &mut Criterion<CpuTime>) {
    let sol = ward_solution(0);
    let gs = &sol.scene;
    let tr = Transport::new(gs, sol.config.directions, sol.config.transport)
        .expect("valid transport options");
    // The first reflecting patch and the largest patch linked to it.
    let recv = (0..gs.patches.len())
        .find(|&p| !gs.patches[p].is_emitter() && !gs.patches[p].is_eye())
        .expect("a reflecting patch");
    let send = (0..gs.patches.len())
        .filter(|&p| p != recv && !gs.patches[p].is_eye())
        .max_by(|&a, &b| {
            let area = |p: usize| gs.patches[p].support.real_area();
            area(a).total_cmp(&area(b))
        })
        .expect("a sender");
    let end = |patch| End {
        patch,
        key: NodeKey::ROOT,
        tau: 0,
    };
    let v = tr.compute(end(send), end(recv), 1);
    let mut g = c.benchmark_group("glossy/link");
    g.sample_size(20);
    g.throughput(Throughput::Elements(v.samples));
    g.bench_function("transport_samples", |b| {
        b.iter(|| black_box(tr.compute(end(send), end(recv), 1)));
    });
    // Raw occlusion between random points of the same two patches, as many rays.
    let mut rng = Pcg64::seed_from_u64(3);
    let (ps, pr) = (&gs.patches[send].support, &gs.patches[recv].support);
    let (ps_prim, pr_prim) = (gs.patches[send].prim, gs.patches[recv].prim);
    let pts: Vec<(DVec3, DVec3)> = (0..v.rays.max(1))
        .map(|_| {
            let x = ps.visibility_point(rng.random(), rng.random());
            let y = pr.visibility_point(rng.random(), rng.random());
            (x, y)
        })
        .collect();
    g.throughput(Throughput::Elements(pts.len() as u64));
    g.bench_function("occlusion_rays", |b| {
        b.iter(|| {
            let mut n = 0usize;
            for &(x, y) in &pts {
                n += usize::from(gs.accel.occluded(x, y, [ps_prim, pr_prim]));
            }
            black_box(n)
        });
    });
    g.finish();
}

fn sweep(c: &mut Criterion<CpuTime>) {
    let mut sol = ward_solution(1);
    sol.run(|_| {}).expect("one round");
    let links = sol.links.clone();
    let mut funcs = sol.funcs.clone();
    let mut g = c.benchmark_group("glossy/gauss_seidel_sweep");
    g.sample_size(20);
    g.throughput(Throughput::Elements(links.len() as u64));
    g.bench_function("links", |b| {
        b.iter(|| {
            black_box(
                solve(
                    &mut funcs,
                    &links,
                    RADIANCE,
                    LinearSolver::GaussSeidel,
                    0.0,
                    1,
                )
                .expect("finite sweep"),
            )
        });
    });
    g.finish();
}

fn gather(c: &mut Criterion<CpuTime>) {
    let sol = ward_solution(0);
    // A point in the middle of the first reflecting patch, seen from straight above.
    let patch = (0..sol.scene.patches.len())
        .find(|&p| !sol.scene.patches[p].is_emitter() && !sol.scene.patches[p].is_eye())
        .expect("a reflecting patch");
    let n = sol.scene.patches[patch].support.normal_at(0.5, 0.5);
    let w = (n + 0.3 * n.any_orthonormal_vector()).normalize();
    let mut g = c.benchmark_group("glossy/gather_per_pixel");
    g.sample_size(20);
    for mode in [GatherMode::Root, GatherMode::Linked, GatherMode::All] {
        g.bench_function(BenchmarkId::new(mode.name(), 16), |b| {
            let mut rng = Pcg64::seed_from_u64(7);
            b.iter(|| black_box(sol.gather(patch, DVec2::splat(0.5), w, mode, 16, &mut rng, true)));
        });
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = cpu_time();
    targets = ward, link, sweep, gather
}
criterion_main!(benches);
