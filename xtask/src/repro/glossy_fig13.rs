//! Glossy §7.1, Figs. 12–15: the three-patch scene. Patch 1 (0.01², an emitter facing
//! down at (−0.5, 0, 1)), patch 2 (0.01² at the origin facing up, Ward α = 0.2,
//! original normalisation) and patch 3 (2 × 2 diffuse facing down, centred
//! (0.75, 0, 1.5): beyond patch 1's plane, so it is lit only via patch 2).
//!
//! Paper (seed 003, §7.1): Fig. 12's plot of patch 2's error is lost from the seed text;
//! Fig. 13 shows patch 2's radiance converging to `L₂ = f_r G L_e A₁` as links are added;
//! Figs. 14–15 show patch 3 rendered without importance, with importance emitted by
//! patch 3, and with importance and a final gather — the paper's ranking of their errors
//! is gather < importance < none, and without importance the first four images are
//! equal (refinement spends its links on patch 2's own radiance before anything reaches
//! patch 3).
//!
//! Ours: `wavelux_glossy::GlossySolution` on the same scene (`L_e = 1`, `ρ_s = 0.5`,
//! `ρ₃ = 0.5`). The references are the paper's point-patch formulas evaluated at the
//! patch midpoints: `L₂(ω) = f_r(ω₁₂, ω) G(x₁, y₂) L_e A₁` and
//! `L₃(z) = (ρ₃/π) L₂(ω_{2→z}) G(y₂, z) A₂` (the patches 1 and 2 are 0.01 wide at
//! distances ≥ 1, so the midpoint formulas are accurate to ~1e-4 relative).

use crate::cpu::Stopwatch;
use crate::report::{Report, Row, Table, Tolerance};
use crate::reproduce::Ctx;
use std::f64::consts::PI;
use wavelux::glossy::directions::DirectionKind;
use wavelux::glossy::solution::Field;
use wavelux::glossy::{
    GatherMode, GlossyConfig, GlossySolution, ImportanceSource, WardLobe, WardVariant,
};
use wavelux::param::glam::{DVec2, DVec3};
use wavelux::scene::{Material, Rgb, Scene, Shape, Sidedness, Surface, WardParams};

const RHO_S2: f64 = 0.5;
const RHO_3: f64 = 0.5;
const AREA: f64 = 1e-4;

/// A one-sided square of side `a` centred at `c` with unit normal `n` (±z here).
fn square(scene: &mut Scene, name: &str, c: DVec3, n: DVec3, a: f64, mat: Material) {
    let t = DVec3::X;
    let b = n.cross(t);
    let m = scene.add_material(mat);
    scene.add_surface(Surface {
        name: name.into(),
        shape: Shape::Parallelogram {
            origin: c - 0.5 * a * (t + b),
            edge_u: a * t,
            edge_v: a * b,
        },
        material: m,
        sides: Sidedness::OneSided,
    });
}

/// The three patches of Glossy Fig. 12.
pub(super) fn three_patches() -> Scene {
    let mut s = Scene::new("glossy-fig13");
    // Exitance π: radiance L_e = 1.
    let light = Material::lambertian("light", Rgb::BLACK, Rgb::grey(PI));
    square(
        &mut s,
        "patch1",
        DVec3::new(-0.5, 0.0, 1.0),
        -DVec3::Z,
        0.01,
        light,
    );
    let mut glossy = Material::lambertian("glossy", Rgb::BLACK, Rgb::BLACK);
    glossy.ward = Some(WardParams {
        specular: Rgb::grey(RHO_S2),
        alpha_x: 0.2,
        alpha_y: 0.2,
    });
    square(&mut s, "patch2", DVec3::ZERO, DVec3::Z, 0.01, glossy);
    let diffuse = Material::lambertian("diffuse", Rgb::grey(RHO_3), Rgb::BLACK);
    square(
        &mut s,
        "patch3",
        DVec3::new(0.75, 0.0, 1.5),
        -DVec3::Z,
        2.0,
        diffuse,
    );
    s
}

/// `L₂(ω)` at patch 2's midpoint (world direction `w`, patch 2's frame is the world's).
pub(super) fn reference_l2(lobe: &WardLobe, w: DVec3) -> f64 {
    let x1 = DVec3::new(-0.5, 0.0, 1.0);
    let d = -x1;
    let r2 = d.length_squared();
    let dir = d / r2.sqrt();
    let g = dir.z * dir.z / r2;
    RHO_S2 * lobe.eval(-dir, w) * g * AREA
}

/// `M = ∫_{patch 3} L₂(ω_{2→z}) G(y₂, z) A₂ dz`, the power arriving at patch 3 (the
/// measure of its `Γ_e = 1`), by the midpoint formula over a `k × k` grid of patch 3.
fn reference_measure(lobe: &WardLobe, k: usize) -> f64 {
    let mut m = 0.0;
    for i in 0..k {
        for j in 0..k {
            let z = DVec3::new(
                0.75 + 2.0 * ((i as f64 + 0.5) / k as f64 - 0.5),
                2.0 * ((j as f64 + 0.5) / k as f64 - 0.5),
                1.5,
            );
            let d = z.length();
            let w = z / d;
            m += reference_l2(lobe, w) * w.z * w.z / (d * d) * AREA * 4.0 / (k * k) as f64;
        }
    }
    m
}

/// Relative L² error of patch 2's radiance at its midpoint over a `k × k` grid of the
/// direction square (the parameter measure).
pub(super) fn error_patch2(sol: &GlossySolution, lobe: &WardLobe, k: usize) -> f64 {
    let (mut e, mut n) = (0.0, 0.0);
    for i in 0..k {
        for j in 0..k {
            let u = DVec2::new((i as f64 + 0.5) / k as f64, (j as f64 + 0.5) / k as f64);
            let w = PAPER_MAP.direction(u);
            let got = sol.radiance(1, DVec2::splat(0.5), w)[0];
            let r = reference_l2(lobe, w);
            e += (got - r).powi(2);
            n += r * r;
        }
    }
    (e / n).sqrt()
}

/// Relative L² error of the best level-`level` Haar expansion of patch 2's reference
/// radiance (its averages over the `2^level × 2^level` direction cells), on the same
/// `k × k` grid as [`error_patch2`] (`2^level` divides `k`): the floor of patch 2's
/// error after `level` rounds, which add at most one level each.
fn projection_error(lobe: &WardLobe, k: usize, level: u32) -> f64 {
    let cells = 1usize << level;
    let per = k / cells;
    let value = |i: usize, j: usize| {
        let u = DVec2::new((i as f64 + 0.5) / k as f64, (j as f64 + 0.5) / k as f64);
        reference_l2(lobe, PAPER_MAP.direction(u))
    };
    let (mut e, mut n) = (0.0, 0.0);
    for ci in 0..cells {
        for cj in 0..cells {
            let pts: Vec<f64> = (0..per * per)
                .map(|p| value(ci * per + p % per, cj * per + p / per))
                .collect();
            let mean = pts.iter().sum::<f64>() / pts.len() as f64;
            for v in pts {
                e += (v - mean).powi(2);
                n += v * v;
            }
        }
    }
    (e / n).sqrt()
}

/// Relative L² error of patch 3's radiance over a `k × k` grid of its support, either
/// read from the expansion or by the final gather.
pub(super) fn error_patch3(
    sol: &GlossySolution,
    lobe: &WardLobe,
    k: usize,
    gather: Option<usize>,
) -> f64 {
    let support = &sol.scene.patches[2].support;
    let mut rng = rand_pcg::Pcg64::new(0xcafe_f00d_d15e_a5e5, 0xa02b_dbf7_bb3c_0a7a);
    let (mut e, mut n) = (0.0, 0.0);
    for i in 0..k {
        for j in 0..k {
            let st = DVec2::new((i as f64 + 0.5) / k as f64, (j as f64 + 0.5) / k as f64);
            let z = support.point(st.x, st.y);
            let d = z.length();
            let w = z / d;
            let g = w.z * w.z / (d * d);
            let r = RHO_3 / PI * reference_l2(lobe, w) * g * AREA;
            let got = match gather {
                None => sol.radiance(2, st, -DVec3::Z)[0],
                Some(rays) => {
                    sol.gather(2, st, -DVec3::Z, GatherMode::All, rays, &mut rng, false)[0]
                }
            };
            e += (got - r).powi(2);
            n += r * r;
        }
    }
    (e / n).sqrt()
}

/// The direction map of every glossy reproduction: the paper's (§3.3), named here so
/// that the library's and the command's default map can change without moving them
/// (patch 2's error is defined in this map's parameter measure).
pub(super) const PAPER_MAP: DirectionKind = DirectionKind::Glossy;

fn config(rounds: usize, importance: ImportanceSource) -> GlossyConfig {
    GlossyConfig {
        variant: WardVariant::Original,
        directions: PAPER_MAP,
        rounds,
        importance,
        ..GlossyConfig::default()
    }
}

/// Runs the reproduction.
pub fn run(ctx: &Ctx) -> anyhow::Result<Report> {
    let mut r = Report::default();
    let rounds = if ctx.quick { 3 } else { 5 };
    let gather_rays = if ctx.quick { 16 } else { 64 };
    let (k2, k3) = (64, if ctx.quick { 8 } else { 16 });
    r.param("refinement rounds", rounds);
    r.param("fraction", GlossyConfig::default().fraction);
    r.param("Ward variant", "original, α = 0.2, ρ_s = 0.5, ρ_d = 0");
    r.param("direction map", PAPER_MAP.name());
    r.param(
        "patch 2 error grid",
        format!("{k2} × {k2} directions at the midpoint"),
    );
    r.param("patch 3 error grid", format!("{k3} × {k3} points"));
    r.param(
        "final gather",
        format!("all senders, {gather_rays} rays per node"),
    );
    r.paper_did = "Three patches (Fig. 12): a tiny emitter, a tiny glossy Ward patch (α = \
        0.2) and a large diffuse patch lit only via the glossy one. Fig. 13 shows patch 2's \
        radiance approach f_r G L_e A₁ as refinement adds links; Figs. 14–15 show patch 3 \
        without importance (the first four images equal: links go to patch 2 first), with \
        importance emitted by patch 3, and with importance and a final gather, the last \
        closest to the reference. Fig. 12's error plot is lost from the seed text."
        .into();
    r.we_did = "The same scene with L_e = 1 and ρ_s = ρ₃ = 0.5. Patch 2's relative L² \
        error (parameter measure of the direction square, at the midpoint) after each \
        round of the no-importance run, with its links, samples and time; patch 3's \
        relative L² error after the same number of rounds without importance, with \
        importance emitted by patch 3 (`ImportanceSource::Surfaces`), and by the final \
        gather (all senders) on the importance solution. References: the paper's \
        midpoint formulas. Rows compare the paper's qualitative claims (monotone \
        convergence, gather < importance < none)."
        .into();

    let scene = three_patches();
    let lobe = WardLobe::new(WardVariant::Original, 0.2, 0.2)?;

    // Run A: no importance, patch 2's convergence.
    let t0 = Stopwatch::start();
    let mut none = GlossySolution::new(
        &scene,
        "glossy-fig13",
        config(rounds, ImportanceSource::Off),
    )?;
    let mut errs = vec![error_patch2(&none, &lobe, k2)];
    let mut trace = vec![vec![
        "0 (V⁰)".to_string(),
        none.links.len().to_string(),
        format!("{:.4}", errs[0]),
        format!("{:.3}", t0.elapsed().cpu_or_wall()),
    ]];
    for _ in 0..rounds {
        let Some(rs) = none.refine_round()? else {
            break;
        };
        let e = error_patch2(&none, &lobe, k2);
        errs.push(e);
        trace.push(vec![
            rs.round.to_string(),
            rs.links.to_string(),
            format!("{e:.4}"),
            format!("{:.3}", t0.elapsed().cpu_or_wall()),
        ]);
    }
    let none_secs = t0.elapsed().cpu_or_wall();
    r.tables.push(Table {
        title: "Patch 2: relative L² error vs links and time (no importance)".into(),
        headers: vec![
            "round".into(),
            "links".into(),
            "relative L² error".into(),
            "cumulative CPU s".into(),
        ],
        rows: trace,
    });
    let grew = errs.windows(2).filter(|w| w[1] > w[0]).count();
    r.rows.push(
        Row::new(
            "patch 2: rounds in which the error grew",
            Some(0.0),
            grew as f64,
            "rounds",
            Tolerance::AtMost(0.0),
        )
        .comment(format!("errors per round: {errs:.4?}")),
    );
    let last = *errs.last().unwrap_or(&errs[0]);
    // Judgment, not derived: Fig. 13 shows convergence without numbers, so the row
    // asks for at least a halving of the V⁰ error. What is reachable is bounded below
    // by the best expansion at the level the rounds reach (the next row, computed from
    // the reference alone): the bound asks the solver to be within a factor
    // 0.5 · e₀ / e_P(R) of it.
    let floor = projection_error(&lobe, k2, rounds as u32);
    r.rows.push(
        Row::new(
            "patch 2: final / initial relative L² error",
            None,
            last / errs[0],
            "",
            Tolerance::AtMost(0.5),
        )
        .comment(format!(
            "at least a halving (a judgment: the paper gives no numbers); the level-{rounds} \
             projection's own error is {floor:.4} ({:.4} of the V⁰ error)",
            floor / errs[0]
        )),
    );
    r.rows.push(
        Row::new(
            format!("patch 2: error after the last round / level-{rounds} projection error"),
            None,
            last / floor,
            "",
            Tolerance::Info,
        )
        .comment("1 is the best a Haar expansion at that level can do on this grid"),
    );
    r.rows.push(Row::new(
        "patch 2: relative L² error after the last round",
        None,
        last,
        "",
        Tolerance::Info,
    ));
    r.rows.push(Row::new(
        "links after the last round (no importance)",
        None,
        none.links.len() as f64,
        "links",
        Tolerance::Info,
    ));
    // Run B: importance emitted by patch 3.
    let t1 = Stopwatch::start();
    let mut imp = GlossySolution::new(
        &scene,
        "glossy-fig13",
        config(rounds, ImportanceSource::Surfaces(vec!["patch3".into()])),
    )?;
    imp.run(|_| {})?;
    let imp_secs = t1.elapsed().cpu_or_wall();
    let e_none = error_patch3(&none, &lobe, k3, None);
    let e_imp = error_patch3(&imp, &lobe, k3, None);
    let t2 = Stopwatch::start();
    let e_gather = error_patch3(&imp, &lobe, k3, Some(gather_rays));
    let gather_secs = t2.elapsed().cpu_or_wall();
    for (name, e, secs, links) in [
        ("no importance", e_none, none_secs, none.links.len()),
        ("importance", e_imp, imp_secs, imp.links.len()),
        (
            "importance + final gather",
            e_gather,
            imp_secs + gather_secs,
            imp.links.len(),
        ),
    ] {
        r.rows.push(
            Row::new(
                format!("patch 3: relative L² error, {name}"),
                None,
                e,
                "",
                Tolerance::Info,
            )
            .comment(format!("{links} links, {secs:.2} s CPU")),
        );
    }
    let into_3 = |s: &GlossySolution| s.links.ranges.get(2).map_or(0, |x| x.len()) as f64;
    for (name, s) in [("no importance", &none), ("importance", &imp)] {
        r.rows.push(
            Row::new(
                format!("links into patch 3 after the last round, {name}"),
                None,
                into_3(s),
                "links",
                Tolerance::Info,
            )
            .comment("1 is the V⁰ root link from patch 2 alone; paper: without importance the first four images of patch 3 are equal, with importance emitted by patch 3 its interactions are refined more"),
        );
    }
    r.rows.push(
        Row::new(
            "patch 3: error with importance / without (paper: < 1)",
            None,
            e_imp / e_none,
            "",
            Tolerance::AtMost(0.99),
        )
        .comment(
            "patch 3, a named importance patch, counts its own emitted importance as arriving \
             (see wavelux_glossy::refine), so the oracle refines the links into it",
        ),
    );
    // Reciprocity (§4.2): the measure of the importance patch, M(Γ_e, L), equals the
    // importance arriving at the light, M(Γ, L_e); both converge to the reference.
    let reference = reference_measure(&lobe, 64);
    let pairing = |s: &GlossySolution, a: Field, b: Field| -> anyhow::Result<f64> {
        Ok(s.pairing(a, b, 8)?[0] / reference - 1.0)
    };
    let v0 = GlossySolution::new(
        &scene,
        "glossy-fig13",
        config(0, ImportanceSource::Surfaces(vec!["patch3".into()])),
    )?;
    for (name, a, b) in [
        (
            "M(Γ_e, L), the importance patch's measure",
            Field::EmittedImportance,
            Field::Radiance,
        ),
        (
            "M(Γ, L_e), the importance arriving at the light",
            Field::Importance,
            Field::EmittedRadiance,
        ),
    ] {
        let (e0, e) = (pairing(&v0, a, b)?, pairing(&imp, a, b)?);
        r.rows.push(
            Row::new(
                format!("{name}: |error| after the last round / in V⁰"),
                None,
                e.abs() / e0.abs(),
                "",
                Tolerance::AtMost(0.5),
            )
            .comment(format!(
                "relative error {e0:+.4} (V⁰) -> {e:+.4} ({rounds} rounds, importance on); \
                 reference {reference:.4e} by the midpoint formula over a 64 × 64 grid of \
                 patch 3"
            )),
        );
    }
    r.rows.push(Row::new(
        "patch 3: error with gather / with importance (paper: < 1)",
        None,
        e_gather / e_imp,
        "",
        Tolerance::AtMost(1.0),
    ));
    Ok(r)
}
