//! The analytic catalogue (issue 11 §2) at the `solve` command's default settings, one
//! test per family: every receiver's average radiosity within 0.1 % (regular) or 0.5 %
//! (extreme) of `ρ F E` from Howell's closed forms, evaluated by quadratures
//! independent of the solver's (`wavelux_tests::catalogue`). Also the extremes of
//! issue 11 §4 that the catalogue's geometry makes exact: emitters of 1e-6 and 1e6
//! W/m² in one scene. The coaxial disks (C-41) and elements refined to level 12 take
//! minutes at the test profile's opt-level 1, so C-41 is checked by the
//! `transfer-accuracy` reproduction in release mode (its regular cases in CI's quick
//! run, every case in the full run).

use wavelux::param::glam::DVec3;
use wavelux::scene::parse_native;
use wavelux::solver::solve;
use wavelux_tests::catalogue::{
    self, Family, RHO, default_settings, header, lit_average, quad, quad_to_quad,
};

/// Solves every case of `family` and checks each receiver against its exact value.
fn family(f: Family) {
    let cfg = default_settings();
    let mut n = 0;
    for c in catalogue::cases().into_iter().filter(|c| c.family == f) {
        let scene = c.scene().unwrap();
        let sol = solve(&scene, &cfg).unwrap();
        for (name, exact) in &c.receivers {
            let i = scene.surfaces.iter().position(|s| &s.name == name).unwrap();
            let ours = lit_average(&sol, i);
            let err = (ours - exact).abs() / exact;
            assert!(
                err <= c.tolerance(),
                "{} {} [{name}]: ours {ours} vs exact {exact} (relative error {err:.3e}, tolerance {})",
                f.label(),
                c.name,
                c.tolerance()
            );
            n += 1;
        }
    }
    assert!(n > 0, "no case of {}", f.label());
}

#[test]
fn c11_parallel_rectangles() {
    family(Family::C11);
}

#[test]
fn c14_perpendicular_rectangles_and_dihedral_angles() {
    family(Family::C14);
}

#[test]
fn b3_small_receiver_under_a_rectangle_corner() {
    family(Family::B3);
}

#[test]
fn b13_small_receiver_under_a_disk() {
    family(Family::B13);
}

#[test]
fn sphere_interior() {
    family(Family::Sphere);
}

#[test]
fn lights_inside_elements_and_t_junctions() {
    family(Family::Junction);
}

/// Two lamps of 1e6 and 1e-6 W/m² over two receivers in one plane: each receiver's
/// average is `ρ (F_a E_a + F_b E_b)`, so the dim lamp's share of the receiver under it
/// (about 2e-7 W/m² against the bright lamp's ~3e-3 from 10 units away) must survive
/// next to a contribution ten orders of magnitude larger in the same system.
#[test]
fn emitters_of_1e6_and_1e_minus_6_in_one_scene() {
    let (x, y) = (DVec3::X, DVec3::Y);
    let r = [[DVec3::ZERO, x, y], [DVec3::new(10.0, 0.0, 0.0), x, y]];
    let e = [
        [DVec3::new(0.0, 0.0, 1.0), y, x],
        [DVec3::new(10.0, 0.0, 1.0), y, x],
    ];
    let emission = [1e6, 1e-6];
    let mut t = header("bright-and-dim");
    t += "[[material]]\nname = \"bright\"\nreflectance = 0.0\nemission = 1e6\n\n";
    t += "[[material]]\nname = \"dim\"\nreflectance = 0.0\nemission = 1e-6\n\n";
    t += &quad("r0", "white", r[0][0], r[0][1], r[0][2]);
    t += &quad("r1", "white", r[1][0], r[1][1], r[1][2]);
    t += &quad("bright", "bright", e[0][0], e[0][1], e[0][2]);
    t += &quad("dim", "dim", e[1][0], e[1][1], e[1][2]);
    let scene = parse_native(&t, "<bright and dim>", None).unwrap();
    let sol = solve(&scene, &default_settings()).unwrap();
    for (i, ri) in r.iter().enumerate() {
        let exact: f64 = (0..2)
            .map(|j| RHO * emission[j] * quad_to_quad(*ri, e[j]))
            .sum();
        let own = RHO * emission[i] * quad_to_quad(*ri, e[i]);
        let ours = lit_average(&sol, i);
        let err = (ours - exact).abs() / exact;
        println!("r{i}: ours {ours:e} exact {exact:e} (own lamp {own:e}), error {err:.2e}");
        assert!(err < 1e-3, "r{i}: ours {ours} vs exact {exact} ({err:e})");
    }
}
