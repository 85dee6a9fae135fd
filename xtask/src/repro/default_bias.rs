//! Issue 13 §2 (and the printed-error target of issue 12 §4): the default command's
//! result against the path tracer. Not a paper result: the property a user relies on
//! when reading the default command's `error` line.
//!
//! The release binary runs as `wavelux solve --no-image` (the default command's
//! scene, method and settings; the image changes nothing in the solution), and its
//! JSON is judged three ways:
//!
//! 1. **No significant bias**: `error_estimate.max_z`, the largest `|B − B̂| / σ̂` over
//!    surfaces and channels against the command's own 65,536-sample check, at most 4.
//!    Derivation: an unbiased result has `z ~ N(0, 1)` per comparison, so over `n`
//!    surface channels `P(max |z| > 4) ≈ n · 6.3e-5` (the report prints it).
//! 2. **Consistent with its noise and its bias bound**: the largest
//!    `|B − B̂| / (4 σ̂ + 0.01 |B̂ − E|)`, at most 1: every surface and channel within
//!    four standard errors of the check plus the 1 % bias that issue 12 §4 allows the
//!    default command's printed error. A solver accurate to 1 % passes at any sample
//!    count; one biased beyond it fails once the check is fine enough to see it.
//! 3. **The printed error is honest**: the printed relative L1 against the same L1
//!    measured here with an independent path-traced check (another seed, 4× the
//!    samples), `|L1_printed − L1_independent| / (noise_printed + noise_independent)` at
//!    most 1. Derivation: both L1 values are the same solution's error plus the
//!    checks' noise; by the triangle inequality their difference is at most the L1 of
//!    the difference of the two checks, whose expectation is `≈ 0.8 √(σ₁² + σ₂²)` per
//!    comparison, below `σ₁ + σ₂`.
//!
//! Quick and full runs are the same run: the default command has one size.

use std::time::Instant;

use wavelux::render::{PathTracer, ReferenceOptions};
use wavelux::scene::builtin;

use super::release_binary::run_wavelux;
use crate::report::{Report, Row, Tolerance};
use crate::reproduce::Ctx;

/// Samples per surface of the default command's check (`--samples`' default).
const CHECK_SAMPLES: u64 = 65_536;
/// Samples per surface of the independent check.
const INDEPENDENT_SAMPLES: u64 = 4 * CHECK_SAMPLES;
/// The independent check's seed (the command's is 1).
const INDEPENDENT_SEED: u64 = 0x1_3b1a5;
/// The bias issue 12 §4 allows the default command (its printed error ≤ 1 %).
const BIAS_BOUND: f64 = 0.01;

/// One surface of the command's JSON.
struct Surface {
    name: String,
    back: bool,
    emission: [f64; 3],
    radiosity: [f64; 3],
}

fn triple(v: &serde_json::Value, what: &str) -> anyhow::Result<[f64; 3]> {
    let mut t = [0.0; 3];
    for (c, x) in t.iter_mut().enumerate() {
        *x = v[c]
            .as_f64()
            .ok_or_else(|| anyhow::anyhow!("{what}[{c}] missing in the JSON"))?;
    }
    Ok(t)
}

fn surfaces(json: &serde_json::Value) -> anyhow::Result<Vec<Surface>> {
    json["surfaces"]
        .as_array()
        .ok_or_else(|| anyhow::anyhow!("no surfaces in the JSON"))?
        .iter()
        .map(|s| {
            Ok(Surface {
                name: s["name"].as_str().unwrap_or_default().to_string(),
                back: s["side"].as_str() == Some("back"),
                emission: triple(&s["emission"], "emission")?,
                radiosity: triple(&s["radiosity"], "radiosity")?,
            })
        })
        .collect()
}

fn number(v: &serde_json::Value, what: &str) -> anyhow::Result<f64> {
    v.as_f64()
        .ok_or_else(|| anyhow::anyhow!("{what} missing in the JSON"))
}

/// The independent path-traced check of the command's result.
struct Check {
    /// Relative L1 of the command's radiosity against the check.
    l1: f64,
    /// The check's noise floor, relative to the same normaliser.
    noise: f64,
    /// The largest `|B − B̂| / (4 σ̂ + 1 % |B̂ − E|)` over surfaces and channels.
    allowance: f64,
    /// Where the largest allowance ratio is, in words.
    worst: String,
    /// Wall time of the check (s).
    seconds: f64,
}

/// Path-traces every surface side of `scene` with [`INDEPENDENT_SAMPLES`] samples and
/// [`INDEPENDENT_SEED`], and compares the command's radiosity (`surf`, areas from
/// `json`) with it.
fn independent_check(
    scene: &wavelux::scene::Scene,
    json: &serde_json::Value,
    surf: &[Surface],
) -> anyhow::Result<Check> {
    let pt = PathTracer::new(scene)?;
    let opts = ReferenceOptions {
        seed: INDEPENDENT_SEED,
        ..ReferenceOptions::default()
    };
    let t = Instant::now();
    let (mut num, mut den, mut noise, mut allowance, mut worst) =
        (0.0, 0.0, 0.0, 0.0f64, String::new());
    let areas: Vec<f64> = json["surfaces"]
        .as_array()
        .map(|a| {
            a.iter()
                .map(|s| s["area"].as_f64().unwrap_or(0.0))
                .collect()
        })
        .unwrap_or_default();
    for (i, s) in surf.iter().enumerate() {
        let e = pt.side_average(i, s.back, INDEPENDENT_SAMPLES, &opts)?;
        for c in 0..3 {
            let d = (s.radiosity[c] - e.mean[c]).abs();
            num += areas[i] * d;
            den += areas[i] * (e.mean[c] - s.emission[c]).abs();
            noise += areas[i] * e.std_error[c];
            let a = d / (4.0 * e.std_error[c] + BIAS_BOUND * (e.mean[c] - s.emission[c]).abs());
            if a > allowance {
                allowance = a;
                worst = format!(
                    "{} channel {c}: B = {:.5}, check {:.5} ± {:.5} ({:+.2} %)",
                    s.name,
                    s.radiosity[c],
                    e.mean[c],
                    e.std_error[c],
                    100.0 * (s.radiosity[c] - e.mean[c]) / (e.mean[c] - s.emission[c]).abs()
                );
            }
        }
    }
    let seconds = t.elapsed().as_secs_f64();
    anyhow::ensure!(den > 0.0, "the independent check found no reflected light");
    Ok(Check {
        l1: num / den,
        noise: noise / den,
        allowance,
        worst,
        seconds,
    })
}

/// Runs the reproduction.
pub fn run(_ctx: &Ctx) -> anyhow::Result<Report> {
    let mut r = Report::default();
    let (json, time): (serde_json::Value, _) = run_wavelux(
        "default-bias",
        &["solve", "--no-image", "--quiet", "--json", "default.json"],
        |dir| {
            Ok(serde_json::from_slice(&std::fs::read(
                dir.join("default.json"),
            )?)?)
        },
    )?;
    let est = &json["error_estimate"];
    let printed = number(&est["relative_l1"], "error_estimate.relative_l1")?;
    let check_noise = number(&est["check_noise"], "error_estimate.check_noise")?;
    let max_z = number(&est["max_z"], "error_estimate.max_z")?;
    let samples = est["samples"].as_u64().unwrap_or(0);
    anyhow::ensure!(
        samples == CHECK_SAMPLES,
        "the default check used {samples} samples per surface, expected {CHECK_SAMPLES}"
    );
    let surf = surfaces(&json)?;
    let scene = builtin::cornell_box();
    anyhow::ensure!(
        surf.len() == scene.surfaces.len()
            && surf
                .iter()
                .zip(&scene.surfaces)
                .all(|(a, b)| a.name == b.name),
        "the default command's surfaces are not builtin::cornell_box()'s"
    );

    let check = independent_check(&scene, &json, &surf)?;
    let (indep, indep_noise, allowance, worst) =
        (check.l1, check.noise, check.allowance, &check.worst);
    let t_check = check.seconds;

    r.param(
        "command",
        "wavelux solve --no-image --quiet --json FILE (release)",
    );
    r.param("command wall time (s)", format!("{:.2}", time.wall));
    if let Some(cpu) = time.cpu {
        r.param("command CPU time (s)", format!("{cpu:.2}"));
    }
    r.param(
        "command's check",
        format!("{CHECK_SAMPLES} samples per surface, seed 1"),
    );
    r.param(
        "independent check",
        format!(
            "{INDEPENDENT_SAMPLES} samples per surface, seed {INDEPENDENT_SEED}, {t_check:.1} s"
        ),
    );
    r.param("bias bound", "1 % of the reflected radiosity (issue 12 §4)");
    for key in ["basis", "eps", "oracle", "max_level", "solver"] {
        r.param(format!("method.{key}"), &json["method"][key]);
    }
    r.param("links", &json["statistics"]["links"]);
    r.paper_did = "Not a paper result. Issue 13 §2 asks for a test that the default \
        command's result has no statistically significant bias against the path tracer \
        (max |z| ≤ 4 at the default check's sample count), and issue 12 §4 bounds the \
        default command's printed error by 1 %."
        .into();
    r.we_did = format!(
        "Ran the release binary as `wavelux solve --no-image` (the default scene, method \
         and settings) and read its JSON: the printed relative L1 ({:.2} %), the check's \
         noise ({:.2} %) and max |z| against its own {CHECK_SAMPLES}-sample check. Then \
         path-traced every surface again here with another seed and {INDEPENDENT_SAMPLES} \
         samples (relative L1 {:.2} %, noise {:.2} %). The derivation of each tolerance \
         is in `xtask/src/repro/default_bias.rs`. Largest allowance ratio at {worst}.",
        100.0 * printed,
        100.0 * check_noise,
        100.0 * indep,
        100.0 * indep_noise,
    );
    r.rows.push(
        Row::new(
            "default command: largest z-score against its own 65,536-sample check",
            None,
            max_z,
            "",
            Tolerance::AtMost(4.0),
        )
        .comment(format!(
            "issue 13 §2: no statistically significant bias; for an unbiased result the \
             chance of a z-score above 4 among {} surface channels is ≈ {:.1e}",
            3 * surf.len(),
            3.0 * surf.len() as f64 * 6.334e-5
        )),
    );
    r.rows.push(
        Row::new(
            "default command: largest difference to the independent check / (4 σ̂ + 1 % of the reflected radiosity)",
            None,
            allowance,
            "",
            Tolerance::AtMost(1.0),
        )
        .comment(format!(
            "every surface within its noise plus the 1 % bias bound; worst {worst}"
        )),
    );
    r.rows.push(
        Row::new(
            "default command: difference of the printed and the independent relative L1 / (sum of the two noise floors)",
            None,
            (printed - indep).abs() / (check_noise + indep_noise),
            "",
            Tolerance::AtMost(1.0),
        )
        .comment(format!(
            "printed {:.3} % (noise {:.3} %), independent {:.3} % (noise {:.3} %)",
            100.0 * printed,
            100.0 * check_noise,
            100.0 * indep,
            100.0 * indep_noise
        )),
    );
    Ok(r)
}
