//! Cornell box at refinement level 4 (regression for near-field transfer blocks).
//!
//! The Cornell box's walls are triangle supports whose level-4 elements at the
//! collapsed vertex are sliver wedges; wedges of perpendicular walls that share an
//! edge were once integrated by the plain Gauss rule at the splitting limit, giving a
//! Haar form factor of 1.94 for one link, an operator of spectral radius > 1 and a
//! diverging Picard iteration. Checked here, for the Haar basis (block `T` of a link
//! between nodes of areas `A_r`, `A_e`, form factor `F = T·√(A_e/A_r)`):
//!
//! - every link's `F` is at most the exact unoccluded polygon-to-polygon form factor
//!   of the two elements (`wavelux-geometry`'s contour integral): the constant part
//!   of a block is that exact value times the pair's visible fraction (closure links,
//!   from a leaf to itself, are not form factors and are skipped);
//! - the reflectance-weighted row sums `ρ_l Σ F` of the leaves, the ∞-norm of
//!   `K` in the area-scaled basis, are below 1 (so Picard must converge);
//! - Picard converges in every channel.

use glam::DVec3;
use wavelux_geometry::formfactor::{newell, polygon_to_polygon};
use wavelux_scene::builtin::cornell_box;
use wavelux_solver::support::Patch;
use wavelux_solver::transfer::Region;
use wavelux_solver::{BasisKind, LinearMethod, SolverConfig, solve};

fn polygon(p: &Patch, r: &Region) -> Vec<DVec3> {
    let mut v: Vec<DVec3> = Vec::new();
    for q in p.support.corners(r.s0, r.t0, r.h) {
        if v.last().is_none_or(|l| (*l - q).length() > 1e-12) {
            v.push(q);
        }
    }
    if (v[0] - v[v.len() - 1]).length() < 1e-12 {
        v.pop();
    }
    if newell(&v).dot(p.support.normal) < 0.0 {
        v.reverse();
    }
    v
}

#[test]
fn cornell_level4_links_bounded_and_picard_converges() {
    let scene = cornell_box();
    let config = SolverConfig {
        basis: BasisKind::Haar,
        eps: 0.02,
        max_level: 4,
        linear_method: LinearMethod::Picard,
        max_iterations: 300,
        tolerance: 1e-8,
        ..SolverConfig::default()
    };
    let sol = solve(&scene, &config).unwrap();
    let sys = sol.system();
    let h = sys.hierarchy();

    // Per-link bound against the exact unoccluded form factor.
    let mut worst_f: f64 = 0.0;
    let mut worst_ratio: f64 = 0.0;
    for r in 0..h.keys().len() {
        let ar = sys.node_area[r];
        for (e, block) in h.links_into(r) {
            if e == r {
                continue;
            }
            let f = block[0] * (sys.node_area[e] / ar).sqrt();
            let (kr, ke) = (h.keys()[r], h.keys()[e]);
            let pr = &sol.patches[kr.patch as usize];
            let pe = &sol.patches[ke.patch as usize];
            let exact =
                polygon_to_polygon(&polygon(pr, &kr.region()), &polygon(pe, &ke.region())).unwrap();
            worst_f = worst_f.max(f);
            if f > 1e-3 {
                worst_ratio = worst_ratio.max(f / exact.max(1e-12));
            }
            assert!(
                f <= exact * (1.0 + 1e-9) + 1e-15,
                "link {kr:?} <- {ke:?}: F {f} exceeds exact unoccluded {exact}"
            );
        }
    }
    assert!(worst_f <= 1.0, "largest link form factor {worst_f}");

    // Reflectance-weighted row sums of the leaves (unit radiosity: Haar
    // coefficient √area).
    let ones: Vec<f64> = h
        .leaves()
        .iter()
        .map(|&i| sys.node_area[i as usize].sqrt())
        .collect();
    let irr = sys.irradiance(&ones);
    let mut worst_row: f64 = 0.0;
    let mut worst_krow: f64 = 0.0;
    for (l, &i) in h.leaves().iter().enumerate() {
        let f = irr[l] / sys.node_area[i as usize].sqrt();
        worst_row = worst_row.max(f);
        for ch in 0..3 {
            worst_krow = worst_krow.max(sys.leaf_rho[l][ch] * f);
        }
    }
    println!(
        "leaves {}, links {}, largest link F {worst_f:.4}, largest F/exact {worst_ratio:.4}, \
         largest row sum {worst_row:.4}, largest rho-weighted row sum {worst_krow:.4}",
        h.leaves().len(),
        sol.stats.links
    );
    assert!(worst_krow < 1.0, "weighted row sum {worst_krow}");
    for (ch, c) in sol.convergence.iter().enumerate() {
        println!(
            "channel {ch}: converged {} after {} iterations, residual {:.3e}",
            c.converged,
            c.iterations.len(),
            c.final_relative_residual
        );
        assert!(
            c.converged,
            "channel {ch}: Picard residual {}",
            c.final_relative_residual
        );
    }
}
