//! Closed-cube (white furnace) checks: `B = E/(1−ρ)` everywhere and energy balance.

use wavelux_scene::builtin::white_furnace;
use wavelux_solver::{BasisKind, LinearMethod, SolverConfig, solve};

fn config(basis: BasisKind, method: LinearMethod) -> SolverConfig {
    SolverConfig {
        basis,
        eps: 1e-4,
        max_level: 2,
        quad_points: 4,
        singular_order: 5,
        near_field: 1.5,
        linear_method: method,
        max_iterations: 5000,
        tolerance: 1e-13,
        ..SolverConfig::default()
    }
}

#[test]
fn closed_cube_is_uniform() {
    for rho in [0.5, 0.9, 0.99, 0.999] {
        let scene = white_furnace(1.0, rho).unwrap();
        let method = LinearMethod::Gmres { restart: 50 };
        let sol = solve(&scene, &config(BasisKind::Haar, method)).unwrap();
        let exact = 1.0 / (1.0 - rho);
        let mut worst: f64 = 0.0;
        for p in 0..sol.patches.len() {
            for (s, t) in [(0.1, 0.1), (0.5, 0.5), (0.9, 0.3), (0.02, 0.98)] {
                let b = sol.radiosity(p, s, t)[0];
                worst = worst.max((b - exact).abs() / exact);
            }
        }
        let e = sol.energy;
        println!(
            "rho {rho}: worst rel {worst:.3e}, links {}, leaves {}, emitted {:.6} absorbed {:.6} escaped {:.3e}",
            sol.stats.links, sol.stats.leaves, e.emitted[0], e.absorbed[0], e.escaped[0]
        );
        assert!(worst < 1e-9, "rho {rho}: relative error {worst}");
    }
}
