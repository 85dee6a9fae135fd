//! Glossy §6.2: the Ward BRDF's directional albedo `a(θᵢ) = ∫ f_s(ωᵢ, ωₒ) cos θₒ dωₒ`
//! (`ρ_s = 1`) for the three normalisations of `wavelux_glossy::ward`.
//!
//! The paper (seed 003, §6.2) uses Ward's original normalisation and quotes no albedo.
//! The reference values are those measured when issue 16 was written (α = 0.2,
//! θᵢ = 0°/85°: Original 0.895/0.182, Product 0.928/1.13, Bounded 0.960/0.806; at
//! α = 0.01 Original ≈ cos θᵢ); ours are computed here by `WardLobe::albedo` (Gauss
//! quadrature in the half-vector sampling variables) and checked against an
//! independent brute-force midpoint rule over the hemisphere in `(cos θₒ, φₒ)`.

use crate::report::{Report, Row, Table, Tolerance};
use crate::reproduce::Ctx;
use std::f64::consts::TAU;
use wavelux::glossy::{WardLobe, WardVariant};
use wavelux::param::glam::DVec3;

/// Tolerance of a registered albedo: half a unit in its last digit (issue 16 quotes
/// three significant digits: `5e-4` below 1, `5e-3` for 1.13). Our quadrature's own
/// error (the brute-force rows: ≤ 2e-6 in the last committed run) is far below it.
fn registered_tolerance(value: f64) -> f64 {
    if value >= 1.0 { 5e-3 } else { 5e-4 }
}

/// `|quadrature − brute force|` bound, registered in issue 16 ("match by quadrature
/// to 1e-3"). It is loose on purpose: the brute-force midpoint rule's own error is
/// `O(n_μ^{-2})` for smooth integrands and `O(n_μ^{-3/2})` for Original's `√cos θₒ`
/// edge at the horizon, `≈ 7e-5 · f` at the quick run's `n_μ = 600`, so the bound
/// catches a wrong quadrature (a lost lobe or a mis-cut horizon costs ≥ 1e-2), not
/// rounding.
const QUADRATURE_MATCH: f64 = 1e-3;

/// Leading correction `a(θᵢ) − cos θᵢ ≈ α²(sin²θᵢ/(4 cos θᵢ) − 3 cos θᵢ)` of the
/// Original variant's albedo for a sharp isotropic lobe (ours, derived for these
/// rows). With `ωₒ` the mirror of `ωᵢ` about the half vector `h` and
/// `p = tan θ_h (cos φ_h, sin φ_h)`, `dω_h = (1 + |p|²)^{-3/2} d²p` and
/// `dωₒ = 4 (ωᵢ·h) dω_h`, so `a = (πα²)⁻¹ ∫ e^{−|p|²/α²} g(p) d²p` with
/// `g = (ωᵢ·h) √(cos θₒ / cos θᵢ) (1 + |p|²)^{-3/2}`: a Gaussian average of variance
/// `α²/2` per axis, `a = g(0) + (α²/4) ∇²g(0) + O(α⁴)`. With `ωᵢ = (s, 0, c)`, to
/// second order `ωᵢ·h ≈ c + s p_x − c|p|²/2`, `cos θₒ ≈ c + 2 s p_x − 2c|p|²`, so
/// `g ≈ c + 2 s p_x − 3c|p|² + s² p_x²/(2c)` and `∇²g(0) = −12c + s²/c`. At θᵢ = 0 it
/// gives `1 − 3α²` (0.9997 at α = 0.01). The rows allow twice this term: the
/// remainder is `O(α⁴)` (≈ 1e-8 · sec⁴θᵢ ≤ 1.1e-5 at 80°), far below it at the four
/// angles used, which stay away from the term's zero at `tan²θᵢ = 12` (73.9°).
fn sharp_albedo_correction(alpha: f64, theta_i: f64) -> f64 {
    let (s, c) = theta_i.sin_cos();
    alpha * alpha * (s * s / (4.0 * c) - 3.0 * c)
}

/// Brute-force albedo: midpoint rule with `n_mu × 4 n_mu` cells in `(cos θₒ, φₒ)`.
fn brute_force(lobe: &WardLobe, theta_i: f64, n_mu: usize) -> f64 {
    let wi = DVec3::new(theta_i.sin(), 0.0, theta_i.cos());
    let n_phi = 4 * n_mu;
    let mut total = 0.0;
    for i in 0..n_mu {
        let mu = (i as f64 + 0.5) / n_mu as f64;
        let s = (1.0 - mu * mu).sqrt();
        let mut ring = 0.0;
        for j in 0..n_phi {
            let (sp, cp) = (TAU * (j as f64 + 0.5) / n_phi as f64).sin_cos();
            ring += lobe.eval(wi, DVec3::new(s * cp, s * sp, mu));
        }
        total += ring * mu;
    }
    total * TAU / (n_mu * n_phi) as f64
}

/// Runs the reproduction.
pub fn run(ctx: &Ctx) -> anyhow::Result<Report> {
    let mut r = Report::default();
    let n_mu = if ctx.quick { 600 } else { 2000 };
    r.param(
        "quadrature",
        "WardLobe::albedo (48 radial × 8·24 azimuthal Gauss points)",
    );
    r.param(
        "brute force",
        format!("{n_mu} × {} midpoint cells in (cos θₒ, φₒ)", 4 * n_mu),
    );
    r.paper_did = "Glossy §6.2 uses Ward's anisotropic model with the original \
        normalisation 1/(4π α_x α_y √(cos θᵢ cos θₒ)) and quotes no albedo. Issue 16 \
        registered six albedos measured at α = 0.2 for the three normalisations, and \
        Original ≈ cos θᵢ at α = 0.01; the 'paper' column holds those."
        .into();
    r.we_did = "Albedo of the specular lobe (ρ_s = 1) by `WardLobe::albedo`: Gauss \
        quadrature in the half-vector sampling variables, the radial variable cut at the \
        horizon root so the rule stays smooth. Each value is checked against an \
        independent brute-force midpoint rule over the hemisphere (no sampling map \
        shared). Bounded's largest albedo over θᵢ ≤ 89° must stay below 1 at every α; \
        Product exceeds 1 at grazing incidence, Original falls like √cos θᵢ."
        .into();

    // Issue 16's measured table, α = 0.2.
    let registered = [
        (WardVariant::Original, 0.0, 0.895),
        (WardVariant::Original, 85.0, 0.182),
        (WardVariant::Product, 0.0, 0.928),
        (WardVariant::Product, 85.0, 1.13),
        (WardVariant::Bounded, 0.0, 0.960),
        (WardVariant::Bounded, 85.0, 0.806),
    ];
    for (v, deg, value) in registered {
        let lobe = WardLobe::new(v, 0.2, 0.2)?;
        let t = f64::to_radians(deg);
        let ours = lobe.albedo_at(t)?;
        let tol = registered_tolerance(value);
        r.rows.push(Row::new(
            format!("albedo, {}, α = 0.2, θᵢ = {deg}°", v.name()),
            Some(value),
            ours,
            "",
            Tolerance::Absolute(tol),
        ));
        let bf = brute_force(&lobe, t, n_mu);
        r.rows.push(
            Row::new(
                format!(
                    "|quadrature − brute force|, {}, α = 0.2, θᵢ = {deg}°",
                    v.name()
                ),
                None,
                (ours - bf).abs(),
                "",
                Tolerance::AtMost(QUADRATURE_MATCH),
            )
            .comment(format!("brute force {bf:.5}")),
        );
    }

    // α = 0.01, Original: albedo ≈ cos θᵢ, within twice the leading correction.
    let alpha = 0.01;
    let sharp = WardLobe::new(WardVariant::Original, alpha, alpha)?;
    for deg in [0.0, 30.0, 60.0, 80.0] {
        let t = f64::to_radians(deg);
        let lead = sharp_albedo_correction(alpha, t);
        r.rows.push(
            Row::new(
                format!("albedo, original, α = 0.01, θᵢ = {deg}° (cos θᵢ)"),
                Some(t.cos()),
                sharp.albedo_at(t)?,
                "",
                Tolerance::Absolute(2.0 * lead.abs()),
            )
            .comment(format!(
                "tolerance 2 × |α²(sin²θᵢ/(4 cos θᵢ) − 3 cos θᵢ)| = 2 × {:.3e} (derived in \
                 glossy_ward.rs)",
                lead.abs()
            )),
        );
    }

    // Only Bounded stays below 1.
    let alphas = [0.01, 0.05, 0.2, 0.5, 1.0];
    for a in alphas {
        let lobe = WardLobe::new(WardVariant::Bounded, a, a)?;
        r.rows.push(Row::new(
            format!("max albedo over θᵢ ≤ 89°, bounded, α = {a}"),
            None,
            lobe.max_albedo()?,
            "",
            Tolerance::AtMost(1.0),
        ));
    }
    let product = WardLobe::new(WardVariant::Product, 0.2, 0.2)?;
    r.rows.push(Row::new(
        "albedo, product, α = 0.2, θᵢ = 89° (exceeds 1)",
        None,
        product.albedo_at(f64::to_radians(89.0))?,
        "",
        Tolerance::AtLeast(1.0),
    ));

    // The full table.
    let degs = [0.0, 30.0, 60.0, 75.0, 85.0, 89.0];
    let mut headers = vec!["variant".to_string(), "α".to_string()];
    headers.extend(degs.iter().map(|d| format!("θᵢ = {d}°")));
    let mut rows = Vec::new();
    for v in WardVariant::ALL {
        for a in alphas {
            let lobe = WardLobe::new(v, a, a)?;
            let mut row = vec![v.name().to_string(), format!("{a}")];
            for d in degs {
                row.push(format!("{:.4}", lobe.albedo_at(f64::to_radians(d))?));
            }
            rows.push(row);
        }
    }
    r.tables.push(Table {
        title: "Directional albedo a(θᵢ) of the specular lobe (ρ_s = 1), isotropic α".into(),
        headers,
        rows,
    });
    Ok(r)
}
