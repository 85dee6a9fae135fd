//! `cornell-faces` (issue 11 §2, last sentence): the Cornell box brought as a user
//! would bring it — a glTF file with one node per face from the published "Cornell Box
//! Data" coordinates (floor with holes under the blocks, ceiling with a hole for the
//! light, every face triangulated by a tessellator without Steiner points,
//! `doubleSided: false`) — loaded through the glTF loader with its default mesh
//! grouping and solved at the command's default settings; every face's mean radiosity
//! must be within 0.5 % of an independent path-traced reference, small dim faces
//! included.
//!
//! The reference is `wavelux_render::reference::PathTracer` on the same loaded scene
//! (exact geometry, no discretisation): each face's area average from walks started
//! at points uniform by area, sampled until its standard error is at most
//! [`reference_se`] of its mean (a pilot of [`PILOT`] walks sets the count; capped),
//! so that a 0.5 % miss is resolved at about five standard errors. A face whose
//! reference could not reach that precision within the cap makes the standard-error
//! row fail: a comparison the reference cannot resolve is never a pass.

use crate::cpu::Stopwatch;

use wavelux::render::reference::{PathTracer, ReferenceOptions};
use wavelux::scene::{
    GltfOptions, Scene, TessellateOptions, fixtures, load_gltf_slice, tessellated, to_glb,
};
use wavelux::solver::{TargetConfig, solve_to_target};

use crate::report::{Report, Row, Table, Tolerance};
use crate::reproduce::Ctx;

/// Target of every face: relative error of each RGB channel of its mean radiosity
/// (issue 11 §2: "every face within 0.5 % of the path tracer at default settings").
const TARGET: f64 = 5e-3;

/// Standard error the reference must reach on every face and channel, relative to its
/// mean: a fifth of [`TARGET`] (a 0.5 % miss is five standard errors); quick runs half
/// of it (two standard errors), so that they stay under a minute.
fn reference_se(ctx: &Ctx) -> f64 {
    if ctx.quick { 2.5e-3 } else { 1e-3 }
}

/// Walks of the pilot run that sets each face's sample count.
const PILOT: u64 = 1 << 16;

/// The scene as the user's file: written to GLB in memory and loaded back.
fn load() -> anyhow::Result<Scene> {
    let faces = tessellated(&fixtures::cornell_faces(), &TessellateOptions::default())?;
    let glb = to_glb(&faces, "cornell-faces.glb")?;
    Ok(load_gltf_slice(
        &glb,
        "cornell-faces.glb",
        None,
        &GltfOptions::default(),
    )?)
}

/// Runs the reproduction.
pub fn run(ctx: &Ctx) -> anyhow::Result<Report> {
    let mut report = Report {
        paper_did: "Issue 11 §2: the Cornell box from a glTF file with one node per face \
                    (published geometry) has every face within 0.5 % of the path tracer at \
                    default settings, small dim faces included."
            .into(),
        we_did: format!(
            "`fixtures::cornell_faces` (the published Cornell Box Data, floor and ceiling \
             with holes) tessellated without Steiner points, written as GLB and loaded back \
             with the default glTF options (mesh grouping on: each face's triangles become \
             its polygon again). Solved with the command's default settings (target error 2 %, \
             max level 10, GMRES). Ours: each face's real-area mean radiosity; reference: the \
             path tracer's area average of the same loaded scene, each face sampled until \
             its standard error is at most {:.2} % of its mean (pilot of {PILOT} walks; cap \
             {} walks per face). A face row passes when its largest RGB error is at most \
             {:.1} %.",
            100.0 * reference_se(ctx),
            cap(ctx),
            100.0 * TARGET
        ),
        ..Report::default()
    };
    let scene = load()?;
    // The command's default (`wavelux solve` naming no threshold): the target-error
    // loop at 2 % with the element level 10 as a safety limit.
    let mut cfg = TargetConfig {
        target: 0.02,
        ..TargetConfig::default()
    };
    cfg.solver.max_level = 10;
    report.param(
        "solver",
        "target error 2 %, max level 10 (safety limit), GMRES(30), tolerance 1e-6 (the command's defaults)",
    );
    report.param("reference standard error target", reference_se(ctx));
    report.param("reference walks per face, cap", cap(ctx));
    let t0 = Stopwatch::start();
    let outcome = solve_to_target(&scene, &cfg)?;
    let sol = outcome.solution;
    let solve_s = t0.elapsed().cpu_or_wall();
    let tracer = PathTracer::new(&scene)?;
    let opts = ReferenceOptions::default();
    let t0 = Stopwatch::start();
    let mut table = Vec::new();
    let (mut worst_se, mut worst_se_face) = (0.0f64, String::new());
    let (mut num, mut den) = (0.0, 0.0);
    let mut walks = 0u64;
    for (i, surf) in scene.surfaces.iter().enumerate() {
        let pilot = tracer.surface_average(i, PILOT, &opts)?;
        let need = (0..3)
            .map(|c| {
                let rel = pilot.std_error[c] / pilot.mean[c].abs().max(f64::MIN_POSITIVE);
                // Aim at 90 % of the target: the pilot's own standard error is an
                // estimate, and the final one must not land just above the target.
                (PILOT as f64 * (rel / (0.9 * reference_se(ctx))).powi(2)).ceil() as u64
            })
            .max()
            .unwrap_or(PILOT)
            .clamp(PILOT, cap(ctx));
        let est = if need > PILOT {
            tracer.surface_average(i, need, &opts)?
        } else {
            pilot
        };
        walks += est.samples;
        let ours = sol.lit_average(i);
        let err = [0, 1, 2].map(|c| (ours[c] - est.mean[c]) / est.mean[c]);
        let se = [0, 1, 2].map(|c| est.std_error[c] / est.mean[c]);
        let worst = err.iter().fold(0.0f64, |a, e| a.max(e.abs()));
        let face_se = se.iter().fold(0.0f64, |a, &s| a.max(s));
        if face_se > worst_se {
            worst_se = face_se;
            worst_se_face = surf.name.clone();
        }
        let area = surf.shape.area();
        for c in 0..3 {
            num += area * (ours[c] - est.mean[c]).abs();
            den += area * est.mean[c].abs();
        }
        let rgb = |v: [f64; 3], scale: f64, prec: usize| {
            v.iter()
                .map(|x| format!("{:+.*}", prec, scale * x))
                .collect::<Vec<_>>()
                .join(" / ")
        };
        table.push(vec![
            surf.name.clone(),
            format!("{area:.4}"),
            rgb(est.mean, 1.0, 4).replace('+', ""),
            rgb(ours, 1.0, 4).replace('+', ""),
            rgb(err, 100.0, 2),
            rgb(se, 100.0, 3).replace('+', ""),
            est.samples.to_string(),
        ]);
        report.rows.push(
            Row::new(
                format!(
                    "{}: largest RGB error of the mean radiosity vs the path tracer",
                    surf.name
                ),
                None,
                100.0 * worst,
                "%",
                Tolerance::AtMost(100.0 * TARGET),
            )
            .comment(format!(
                "errors {} %; reference s.e. {} % ({} walks)",
                rgb(err, 100.0, 2),
                rgb(se, 100.0, 3).replace('+', ""),
                est.samples
            )),
        );
    }
    let ref_s = t0.elapsed().cpu_or_wall();
    report.rows.push(
        Row::new(
            "largest reference standard error over faces and channels",
            None,
            100.0 * worst_se,
            "%",
            Tolerance::AtMost(100.0 * reference_se(ctx)),
        )
        .comment(format!("on {worst_se_face}")),
    );
    report.rows.push(Row::new(
        "area-weighted relative L1 error of the face means",
        None,
        100.0 * num / den,
        "%",
        Tolerance::Info,
    ));
    report.rows.push(
        Row::new(
            "solver time at default settings",
            None,
            solve_s,
            "s",
            Tolerance::Info,
        )
        .comment(format!(
            "CPU time (all threads); {} links, {} leaves; reference: {walks} walks in {ref_s:.1} s CPU",
            sol.stats.links, sol.stats.leaves
        )),
    );
    report.tables.push(Table {
        title: "Every face at default settings against the path tracer (RGB)".into(),
        headers: [
            "face",
            "area (m²)",
            "reference (W/m²)",
            "ours (W/m²)",
            "error (%)",
            "reference s.e. (%)",
            "walks",
        ]
        .map(String::from)
        .to_vec(),
        rows: table,
    });
    Ok(report)
}

/// Walks per face at most: full runs resolve the dimmest face; quick runs stop earlier
/// (the standard-error row says when that is not enough).
fn cap(ctx: &Ctx) -> u64 {
    if ctx.quick { 1 << 23 } else { 1 << 25 }
}
