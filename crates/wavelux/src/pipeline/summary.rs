//! The human-readable summary of a run on stdout (the JSON holds the same and more).

use super::Method;
use crate::report;

/// Mebibytes of a byte count.
fn mib(b: u64) -> f64 {
    b as f64 / (1024.0 * 1024.0)
}

/// Prints the summary: method, error, (for wavelet solutions) elements and links, rays,
/// times, memory, the first surfaces' radiosity and the files written.
pub fn print_summary(r: &report::Result, method: &dyn Method, has_solution: bool) {
    let st = &r.statistics;
    println!(
        "wavelux {} — {} ({})",
        env!("CARGO_PKG_VERSION"),
        r.scene.name,
        r.scene.source
    );
    println!("  method      {}", method.describe(r));
    print_error(r);
    if has_solution {
        let res = st
            .residual_history
            .iter()
            .filter_map(|h| h.last().copied())
            .fold(0.0f64, f64::max);
        println!(
            "  elements    {} ({} leaves), links {}, kernel evaluations {}, iterations {:?}, residual {:.1e}",
            st.elements, st.leaves, st.links, st.kernel_evaluations, st.iterations, res
        );
    }
    println!(
        "  rays        {} solver shadow, {} primary, {} gather",
        st.solver_rays, st.primary_rays, st.gather_rays
    );
    let t = &st.time_s;
    println!(
        "  time        {:.2} s total: setup {:.2}, refine {:.2}, solve {:.2}, {}Monte Carlo {:.2}, render {:.2}, write {:.2} ({} threads)",
        t.total,
        t.setup,
        t.refine,
        t.solve,
        if t.estimate > 0.0 {
            format!("estimate {:.2}, ", t.estimate)
        } else {
            String::new()
        },
        t.monte_carlo,
        t.render,
        t.write,
        r.method.threads
    );
    println!(
        "  memory      {:.1} MiB solver, {} peak",
        mib(st.solver_bytes as u64),
        st.peak_memory_bytes
            .map_or("unknown".to_string(), |b| format!("{:.1} MiB", mib(b)))
    );
    println!("  surfaces    name: radiosity W/m² (R, G, B)");
    for s in r.surfaces.iter().take(12) {
        let name = if s.side == "back" {
            format!("{} (back)", s.name)
        } else {
            s.name.clone()
        };
        println!(
            "    {:<28} {:>10.4} {:>10.4} {:>10.4}",
            name, s.radiosity[0], s.radiosity[1], s.radiosity[2]
        );
    }
    if r.surfaces.len() > 12 {
        println!("    ... {} more in the JSON", r.surfaces.len() - 12);
    }
    let o = &r.outputs;
    for p in [&o.exr, &o.png, &o.json, &o.gltf, &o.lightmaps]
        .into_iter()
        .flatten()
    {
        println!("  wrote       {p}");
    }
}

/// The `error` line: the check's estimate, else a Monte Carlo result's own standard
/// error (area-weighted), else that no estimate was made.
fn print_error(r: &report::Result) {
    if let Some(e) = &r.error_estimate {
        println!(
            "  error       {:.2}% relative L1 of surface averages vs a {}-sample path-traced check (check noise {:.2}%, max |z| {:.1})",
            100.0 * e.relative_l1,
            e.samples,
            100.0 * e.check_noise,
            e.max_z
        );
    } else if r.surfaces.iter().any(|s| s.std_error.is_some()) {
        let se: f64 = r
            .surfaces
            .iter()
            .map(|s| {
                s.std_error
                    .map_or(0.0, |se| s.area * se.iter().sum::<f64>())
            })
            .sum();
        let b: f64 = r
            .surfaces
            .iter()
            .map(|s| s.area * s.radiosity.iter().sum::<f64>())
            .sum();
        println!(
            "  error       {:.3}% (area-weighted standard error)",
            100.0 * se / b.max(f64::MIN_POSITIVE)
        );
    } else {
        let why = r
            .error_estimate_skipped
            .as_deref()
            .unwrap_or("no check ran");
        println!("  error       not estimated ({why})");
    }
}
