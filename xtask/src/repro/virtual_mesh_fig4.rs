//! VirtualMesh §3.1.3, Fig. 4: a ring-torus patch with a curve drawn on it, flattened
//! by the constant-Jacobian map Ψ⁻¹ = (2θ, φ + ½ sin φ) (Fig. 4.b) and by natural
//! coordinates (2θ, φ) (Fig. 4.c), both onto the paper's domain [0, π]².
//!
//! Paper (seed 001, §3.1.3): torus `x = cos θ (cos φ + 2)`, `y = sin θ (cos φ + 2)`,
//! `z = sin φ`, θ ∈ [0, π/2], φ ∈ [0, π); with f(u) = u/2 and c = 1, Ψ has constant
//! Jacobian 1/c = 1 on [0, π]². The paper quotes no number for the natural map; its
//! Jacobian is ∝ R + r cos φ, so over the patch max/min = (R + r)/(R − r) = 3.
//!
//! Ours: `wavelux_param::Torus` (R = 2, r = 1) with its equal-area and natural maps on
//! [0, 1]², rescaled by π to the paper's domain. Jacobians are *measured* by sixth-order
//! finite differences of the 3D positions on a grid (not read from the analytic
//! formula), and the patch area by Gauss quadrature of the natural area element.

use crate::plot::{Axis, Series, Style, xy_plot};
use crate::report::{Figure, Report, Row, Tolerance};
use crate::reproduce::Ctx;
use wavelux::param::glam::{DVec2, DVec3};
use wavelux::param::{Frame, Parametrization, Torus};

use std::f64::consts::{FRAC_PI_2, PI};

const MAJOR: f64 = 2.0;
const MINOR: f64 = 1.0;

/// Sixth-order central difference of the position along `dir`.
fn fd(m: &dyn Parametrization, uv: DVec2, dir: DVec2, h: f64) -> DVec3 {
    let p = |k: f64| m.position(uv + dir * (k * h));
    ((p(1.0) - p(-1.0)) * 45.0 - (p(2.0) - p(-2.0)) * 9.0 + (p(3.0) - p(-3.0))) / (60.0 * h)
}

/// Measured Jacobian of the map in the paper's [0, π]² units at unit-square `uv`.
fn measured_jacobian(m: &dyn Parametrization, uv: DVec2) -> f64 {
    let d = uv.x.min(1.0 - uv.x).min(uv.y.min(1.0 - uv.y)).min(0.1);
    let h = 1e-3 * d;
    fd(m, uv, DVec2::X, h)
        .cross(fd(m, uv, DVec2::Y, h))
        .length()
        / (PI * PI)
}

/// (min, max) of the measured Jacobian over an n×n grid of cell centres.
fn jacobian_range(m: &dyn Parametrization, n: usize) -> (f64, f64) {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for i in 0..n {
        for j in 0..n {
            let uv = DVec2::new((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
            let jac = measured_jacobian(m, uv);
            lo = lo.min(jac);
            hi = hi.max(jac);
        }
    }
    (lo, hi)
}

/// The curve drawn on the patch: a closed loop given on the surface (natural
/// parameters of an off-centre ellipse, evaluated to 3D points).
fn curve_points(n: usize) -> Vec<DVec3> {
    (0..=n)
        .map(|k| {
            let s = std::f64::consts::TAU * k as f64 / n as f64;
            let th = PI / 4.0 + 0.55 * s.cos() + 0.1 * (2.0 * s).sin();
            let phi = 1.55 + 1.15 * s.sin();
            let rho = MAJOR + MINOR * phi.cos();
            DVec3::new(rho * th.cos(), rho * th.sin(), MINOR * phi.sin())
        })
        .collect()
}

/// Boustrophedon polyline through the images of the natural iso-lines θ = const
/// (`along_theta = false`) or φ = const (`true`); consecutive lines are joined along
/// the patch boundary, which is itself an iso-line, so the picture is exact.
fn iso_lines(
    map: &dyn Fn(f64, f64) -> (f64, f64),
    lines: usize,
    samples: usize,
    along_theta: bool,
) -> Vec<(f64, f64)> {
    let mut pts = Vec::new();
    for l in 0..=lines {
        let a = l as f64 / lines as f64;
        for k in 0..=samples {
            let mut b = k as f64 / samples as f64;
            if l % 2 == 1 {
                b = 1.0 - b;
            }
            let (th, phi) = if along_theta {
                (b * FRAC_PI_2, a * PI)
            } else {
                (a * FRAC_PI_2, b * PI)
            };
            pts.push(map(th, phi));
        }
    }
    pts
}

/// Runs the reproduction.
pub fn run(ctx: &Ctx) -> anyhow::Result<Report> {
    let grid = if ctx.quick { 32 } else { 128 };
    let patch = Torus::new(
        Frame::canonical(),
        MAJOR,
        MINOR,
        (0.0, FRAC_PI_2),
        (0.0, PI),
    )?;
    let ea = patch.equal_area();
    let nat = patch.natural();

    let mut rep = Report {
        paper_did: "Fig. 4 maps a ring-torus patch (R = 2, r = 1, θ ∈ [0, π/2], φ ∈ [0, π)) \
            with a curve drawn on it to [0, π]² twice: (b) by the energy-preserving map \
            Ψ⁻¹ = (2θ, φ + ½ sin φ), whose Jacobian is the constant 1/c = 1, and (c) by the \
            natural coordinates (2θ, φ), whose Jacobian varies. The paper shows the two \
            flattened images and quotes no Jacobian numbers besides c = 1."
            .into(),
        we_did: "Built the same patch as `wavelux_param::Torus` and used its equal-area map \
            (v linear in Rφ + r sin φ, inverted by safeguarded Newton) and its natural map, \
            both from [0, 1]², scaled by π to the paper's [0, π]². Jacobians are measured by \
            sixth-order finite differences of the 3D positions at the centres of an n×n grid \
            (independent of the maps' analytic Jacobians); the patch area by a 64×64 \
            Gauss–Legendre rule on r(R + r cos φ). The curve is a closed loop given on the \
            surface as 3D points and flattened with each map's inverse. The figures draw the \
            images of the natural iso-lines (every π/32 in θ and π/16 in φ) and of the curve; \
            the patch is also drawn in an oblique 3D view (Fig. 4.a)."
            .into(),
        ..Default::default()
    };
    rep.param("major radius R", MAJOR);
    rep.param("minor radius r", MINOR);
    rep.param("θ range", "[0, π/2]");
    rep.param("φ range", "[0, π)");
    rep.param(
        "Jacobian sampling grid",
        format!("{grid}×{grid} cell centres"),
    );

    // Rows: the measured Jacobian ranges, for context. That Ψ has the constant Jacobian
    // 1/c, that its inverse is the paper's (2θ, φ + ½ sin φ) and that the natural map's
    // ratio is (R + r)/(R − r) are identities of the construction: they are tests of
    // wavelux-param (`paper_torus_patch_matches_section_3_1_3`), not reproductions.
    let (ea_lo, ea_hi) = jacobian_range(&ea, grid);
    let (nat_lo, nat_hi) = jacobian_range(&nat, grid);
    rep.rows.push(
        Row::new(
            "max/min measured Jacobian, constant-Jacobian map Ψ (Fig. 4.b)",
            Some(1.0),
            ea_hi / ea_lo,
            "",
            Tolerance::Info,
        )
        .comment("the paper's c = 1 makes this 1; the map is equal-area by construction"),
    );
    rep.rows.push(
        Row::new(
            "max/min measured Jacobian, natural map (2θ, φ) (Fig. 4.c)",
            None,
            nat_hi / nat_lo,
            "",
            Tolerance::Info,
        )
        .comment(
            "the paper quotes no number; on cell centres the ratio approaches \
             (R + r)/(R − r) = 3 from below",
        ),
    );

    // Figures.
    let curve = curve_points(if ctx.quick { 200 } else { 800 });
    let lines_th = 16;
    let lines_ph = 16;
    let samples = if ctx.quick { 32 } else { 128 };
    let flat = |m: &Torus, name: &str, title: &str, caption: &str| -> anyhow::Result<Figure> {
        let map = |th: f64, phi: f64| {
            let uv = m.unit_coordinates(DVec2::new(th, phi));
            (uv.x * PI, uv.y * PI)
        };
        let mut c = Vec::with_capacity(curve.len());
        for p in &curve {
            let uv = m
                .inverse(*p)
                .ok_or_else(|| anyhow::anyhow!("curve point off the torus"))?;
            c.push((uv.x * PI, uv.y * PI));
        }
        let series = [
            Series::new(
                "θ = const",
                iso_lines(&map, lines_th, samples, false),
                Style::Line,
            ),
            Series::new(
                "φ = const",
                iso_lines(&map, lines_ph, samples, true),
                Style::Line,
            ),
            Series::new("curve on the patch", c, Style::Line),
        ];
        let path = ctx.figure_path(name);
        xy_plot(
            &path,
            title,
            &Axis::linear("u"),
            &Axis::linear("v"),
            &series,
        )?;
        Ok(Figure {
            path,
            caption: caption.into(),
        })
    };
    rep.figures.push(flat(
        &ea,
        "fig4b_constant_jacobian.svg",
        "Fig. 4.b: constant-Jacobian map Ψ⁻¹ = (2θ, φ + ½ sin φ)",
        "Fig. 4.b — the patch flattened by the constant-Jacobian map: the φ iso-lines crowd \
         where the torus is narrow (φ → π, inner side), so equal areas on the surface stay \
         equal in the square.",
    )?);
    rep.figures.push(flat(
        &nat,
        "fig4c_natural.svg",
        "Fig. 4.c: natural coordinates (2θ, φ)",
        "Fig. 4.c — the same patch and curve in natural coordinates: a uniform grid whose \
         cells have surface areas varying by the factor (R + r)/(R − r) = 3.",
    )?);
    rep.figures
        .push(fig4a(ctx, &curve, lines_th, lines_ph, samples)?);
    rep.figures.push(jacobian_profiles(ctx, &ea, &nat)?);
    Ok(rep)
}

/// Fig. 4.a: an oblique view of the patch with its natural iso-lines (`lines_th`,
/// `lines_ph`, `samples` points each) and the `curve`.
fn fig4a(
    ctx: &Ctx,
    curve: &[DVec3],
    lines_th: usize,
    lines_ph: usize,
    samples: usize,
) -> anyhow::Result<Figure> {
    let view = |p: DVec3| -> (f64, f64) {
        let (c30, s30) = (PI / 6.0).sin_cos();
        ((p.x - p.y) * s30, p.z + (p.x + p.y) * c30 * 0.35)
    };
    let map3 = |th: f64, phi: f64| {
        let rho = MAJOR + MINOR * phi.cos();
        view(DVec3::new(
            rho * th.cos(),
            rho * th.sin(),
            MINOR * phi.sin(),
        ))
    };
    let series = [
        Series::new(
            "θ = const",
            iso_lines(&map3, lines_th, samples, false),
            Style::Line,
        ),
        Series::new(
            "φ = const",
            iso_lines(&map3, lines_ph, samples, true),
            Style::Line,
        ),
        Series::new(
            "curve",
            curve.iter().map(|p| view(*p)).collect(),
            Style::Line,
        ),
    ];
    let path = ctx.figure_path("fig4a_patch.svg");
    xy_plot(
        &path,
        "Fig. 4.a: ring-torus patch (R = 2, r = 1) with a curve, oblique view",
        &Axis::linear("screen x"),
        &Axis::linear("screen y"),
        &series,
    )?;
    Ok(Figure {
        path,
        caption: "Fig. 4.a — the torus patch θ ∈ [0, π/2], φ ∈ [0, π) with its natural iso-lines \
                  and the curve, oblique projection."
            .into(),
    })
}

/// The measured Jacobians of both maps along `v` (at `u = π/2`, paper units).
fn jacobian_profiles(ctx: &Ctx, ea: &Torus, nat: &Torus) -> anyhow::Result<Figure> {
    let n = 200;
    let prof = |m: &Torus| -> Vec<(f64, f64)> {
        (0..n)
            .map(|k| {
                let v = (k as f64 + 0.5) / n as f64;
                (v * PI, measured_jacobian(m, DVec2::new(0.5, v)))
            })
            .collect()
    };
    let path = ctx.figure_path("jacobian_profiles.svg");
    xy_plot(
        &path,
        "Measured Jacobian along v (u = π/2), paper units",
        &Axis::linear("v"),
        &Axis::linear("Jacobian"),
        &[
            Series::new("constant-Jacobian map Ψ", prof(ea), Style::Line),
            Series::new("natural map (2θ, φ)", prof(nat), Style::Line),
        ],
    )?;
    Ok(Figure {
        path,
        caption: "Finite-difference Jacobians of both maps along the v direction: 1 for Ψ, \
                  (cos φ + 2)/2 for the natural map."
            .into(),
    })
}
