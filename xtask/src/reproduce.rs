//! `cargo xtask reproduce-figures`: runs the registered reproductions and writes
//! `docs/reproductions/<ID>.md` (with figures in `docs/reproductions/<ID>/`),
//! `target/reproductions/<ID>.json` and the index `docs/reproductions/README.md`.
//!
//! With `--quick` every reproduction still computes everything, on smaller sizes, and
//! the outputs go under `target/reproductions/quick/` so the committed reports always
//! come from full runs. Every row is a pass (within its tolerance), a known deviation
//! (outside the tolerance, inside a deviation band declared with its reason in the
//! registration), a failure (outside both) or info (context, never a pass). The command
//! exits non-zero when any row fails, in full and `--quick` runs alike, except rows on
//! the open-failure list (`docs/reproductions/open-failures.md`, or the file given with
//! `--open-failures`; see [`crate::open_failures`]): those stay failures in every report
//! and in the index (marked as listed) but do not change the exit status. Full and quick
//! runs read the same list.

use crate::cpu::Stopwatch;
use crate::open_failures::OpenFailures;
use crate::report::{Report, Row, Status, Tolerance};
use crate::repro::{self, Reproduction};
use anyhow::{Context, bail};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Arguments of `reproduce-figures`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Run only these reproductions (repeatable).
    #[arg(long, value_name = "ID", num_args = 1..)]
    only: Vec<String>,
    /// Smaller problem sizes for CI; everything is still computed.
    #[arg(long)]
    quick: bool,
    /// List the registered reproductions and exit.
    #[arg(long)]
    list: bool,
    /// Rows known to fail today, each with its issue: they stay failures in the reports,
    /// but only a failing row not on this list makes the command exit non-zero. Default:
    /// `docs/reproductions/open-failures.md` (full and quick runs alike).
    #[arg(long, value_name = "FILE")]
    open_failures: Option<PathBuf>,
}

/// What a reproduction function receives.
pub struct Ctx {
    /// Smaller sizes requested.
    pub quick: bool,
    fig_dir: PathBuf,
}

impl Ctx {
    /// Path for a figure file named `name`; the folder exists.
    pub fn figure_path(&self, name: &str) -> PathBuf {
        self.fig_dir.join(name)
    }
}

#[derive(Serialize)]
struct JsonReport<'a> {
    id: &'a str,
    source: String,
    title: &'a str,
    quick: bool,
    wall_seconds: f64,
    /// CPU seconds of the whole run (every thread and waited-for child, [`Stopwatch`]);
    /// `None` where `/proc` is not readable.
    cpu_seconds: Option<f64>,
    /// The build profile of the xtask that ran ([`BUILD_PROFILE`]).
    build: &'a str,
    /// The commit of the source tree that ran ([`source_commit`]).
    commit: &'a str,
    rows: &'a [Row],
}

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask lives one level below the workspace root")
        .to_path_buf()
}

/// Writes `contents` to `path` through a temporary file and a rename, so an interrupted
/// run never leaves a half-written report in place of an older one.
pub fn write_atomic(path: &Path, contents: &[u8]) -> anyhow::Result<()> {
    let dir = path.parent().context("output path has no parent")?;
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, contents).with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("renaming onto {}", path.display()))?;
    Ok(())
}

/// Runs the command on the registry.
pub fn run(args: &Args) -> anyhow::Result<()> {
    run_with(&repro::all(), args, &workspace_root())
}

/// Runs the command on `all` with outputs under `root` (the workspace root): full runs
/// write `root/docs/reproductions/` and `root/target/reproductions/`, quick runs
/// `root/target/reproductions/quick/`. Fails when any selected row fails.
fn run_with(all: &[Reproduction], args: &Args, root: &Path) -> anyhow::Result<()> {
    if args.list {
        for r in all {
            println!("{:<24} {} ({}) — {}", r.id, r.source, r.seed_file, r.title);
        }
        return Ok(());
    }
    for id in &args.only {
        if !all.iter().any(|r| r.id == id) {
            let known: Vec<_> = all.iter().map(|r| r.id).collect();
            bail!("unknown reproduction `{id}`; known: {}", known.join(", "));
        }
    }
    let (doc_dir, json_dir) = if args.quick {
        let q = root.join("target/reproductions/quick");
        (q.clone(), q)
    } else {
        (
            root.join("docs/reproductions"),
            root.join("target/reproductions"),
        )
    };
    let ids: Vec<&str> = all.iter().map(|r| r.id).collect();
    let open_list = match &args.open_failures {
        Some(path) => OpenFailures::read(path, &ids)?,
        None => {
            let path = root.join(OPEN_FAILURES);
            if path.exists() {
                OpenFailures::read(&path, &ids)?
            } else {
                OpenFailures::default()
            }
        }
    };
    let selected: Vec<&Reproduction> = all
        .iter()
        .filter(|r| args.only.is_empty() || args.only.iter().any(|o| o == r.id))
        .collect();

    let commit = source_commit(root);
    let mut failed = Vec::new();
    let mut open = 0usize;
    for r in selected {
        eprintln!(
            "reproducing {} ({}){}",
            r.id,
            r.source,
            if args.quick { " [quick]" } else { "" }
        );
        let fig_dir = doc_dir.join(r.id);
        std::fs::create_dir_all(&fig_dir)
            .with_context(|| format!("creating {}", fig_dir.display()))?;
        let ctx = Ctx {
            quick: args.quick,
            fig_dir,
        };
        let start = Stopwatch::start();
        let mut report = (r.run)(&ctx).with_context(|| format!("reproduction {} failed", r.id))?;
        let elapsed = start.elapsed();
        let wall = elapsed.wall;
        // Times depend on the build, and every number on the code: every report says
        // which build and which commit produced it, and what the whole run cost in CPU
        // time (wall time on the shared machine depends on its load).
        report.param("xtask build", BUILD_PROFILE);
        report.param("commit", &commit);
        report.param("CPU time of the whole run", fmt_cpu(elapsed.cpu));

        let json = JsonReport {
            id: r.id,
            source: format!("{} ({})", r.source, r.seed_file),
            title: r.title,
            quick: args.quick,
            wall_seconds: wall,
            cpu_seconds: elapsed.cpu,
            build: BUILD_PROFILE,
            commit: &commit,
            rows: &report.rows,
        };
        let json_text = serde_json::to_string_pretty(&json)?;
        write_atomic(
            &json_dir.join(format!("{}.json", r.id)),
            json_text.as_bytes(),
        )?;
        // The docs keep a copy so the index can be rebuilt from a fresh checkout.
        if !args.quick {
            write_atomic(
                &doc_dir.join(format!("{}.json", r.id)),
                json_text.as_bytes(),
            )?;
        }
        let md = render_markdown(r, &report, wall, args.quick, &doc_dir);
        write_atomic(&doc_dir.join(format!("{}.md", r.id)), md.as_bytes())?;

        for row in &report.rows {
            eprintln!(
                "  [{:>15}] {}: ours {} vs paper {}",
                row.status.label(),
                row.quantity,
                fmt_num(row.ours),
                row.paper.map_or("—".into(), fmt_num)
            );
            if row.status == Status::Fail {
                if let Some(e) = open_list.find(r.id, &row.quantity) {
                    open += 1;
                    eprintln!("    open failure, listed: {}", e.reason);
                    continue;
                }
                failed.push(format!(
                    "{}: {} (ours {}, paper {}, tolerance {}{})",
                    r.id,
                    row.quantity,
                    fmt_num(row.ours),
                    row.paper.map_or("—".into(), fmt_num),
                    fmt_tol(row.tolerance),
                    row.deviation
                        .as_ref()
                        .map_or(String::new(), |d| format!(", band {}", fmt_tol(d.band)))
                ));
            }
        }
        for e in open_list.of(r.id) {
            let rows: Vec<&Status> = report
                .rows
                .iter()
                .filter(|row| row.quantity == e.quantity)
                .map(|row| &row.status)
                .collect();
            let run = if args.quick { "quick" } else { "full" };
            if rows.is_empty() {
                // A quick-only or full-only row: this run says nothing about it.
                eprintln!(
                    "  listed as an open failure, not a row of this {run} run: {}",
                    e.quantity
                );
            } else if rows.iter().all(|s| **s == Status::Info) {
                // Judged only in the other mode (e.g. a target row, info in quick runs):
                // an info row is never a pass.
                eprintln!(
                    "  listed as an open failure, an info row (not judged) in this {run} run: {}",
                    e.quantity
                );
            } else if !rows.iter().any(|s| **s == Status::Fail) {
                eprintln!(
                    "  listed as an open failure but passed: {}; remove it from the list \
                     once it passes reliably (in the quick and the full run where it is a \
                     row of both)",
                    e.quantity
                );
            }
        }
        eprintln!("  wall time {wall:.2} s, CPU time {}", fmt_cpu(elapsed.cpu));
    }
    write_index(all, &doc_dir, &open_list)?;
    if open > 0 {
        eprintln!(
            "{open} row(s) fail and are on the open-failure list (still failures in the reports)"
        );
    }
    if !failed.is_empty() {
        bail!(
            "{} row(s) outside their tolerance and any declared deviation band:\n  {}",
            failed.len(),
            failed.join("\n  ")
        );
    }
    Ok(())
}

/// The open-failure list read by default, relative to the workspace root.
pub const OPEN_FAILURES: &str = "docs/reproductions/open-failures.md";

/// Formats a number compactly: scientific outside [1e-3, 1e6); a missing value (NaN or
/// infinite, e.g. a threshold a sweep never reached: the JSON holds `null`) is `—`.
pub fn fmt_num(x: f64) -> String {
    if !x.is_finite() {
        "—".into()
    } else if x == 0.0 {
        "0".into()
    } else if x.abs() >= 1e6 || x.abs() < 1e-3 {
        format!("{x:.3e}")
    } else if x.fract() == 0.0 {
        format!("{x:.0}")
    } else {
        format!("{x:.4}")
    }
}

fn fmt_tol(t: Tolerance) -> String {
    match t {
        Tolerance::Relative(v) => format!("±{:.3}%", 100.0 * v),
        Tolerance::Absolute(v) => format!("±{}", fmt_num(v)),
        Tolerance::Factor(v) => format!("×/÷ {v}"),
        Tolerance::AtMost(v) => format!("≤ {}", fmt_num(v)),
        Tolerance::AtLeast(v) => format!("≥ {}", fmt_num(v)),
        Tolerance::Info => "info".into(),
    }
}

fn render_markdown(
    r: &Reproduction,
    rep: &Report,
    wall: f64,
    quick: bool,
    doc_dir: &Path,
) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# `{}`: {}\n", r.id, r.title);
    let _ = writeln!(
        s,
        "Source: {} (`../shared/seeds/{}`). Generated by `cargo xtask reproduce-figures --only {}`{}; do not edit by hand.\n",
        r.source,
        r.seed_file,
        r.id,
        if quick { " --quick" } else { "" }
    );
    let _ = writeln!(s, "## What the paper did\n\n{}\n", rep.paper_did.trim());
    let _ = writeln!(s, "## What we did\n\n{}\n", rep.we_did.trim());
    if !rep.parameters.is_empty() {
        let _ = writeln!(s, "## Parameters\n\n| parameter | value |\n| --- | --- |");
        for (k, v) in &rep.parameters {
            let _ = writeln!(s, "| {k} | {v} |");
        }
        s.push('\n');
    }
    let _ = writeln!(
        s,
        "## Paper vs ours\n\nStatus: **pass** within the tolerance; **known deviation** outside it but inside the deviation band declared in the registration (before the run) with the reason given; **FAIL** outside both (the command fails); **info** context only, never a pass.\n\n| quantity | paper | ours | unit | tolerance | status | deviation band and reason / comment |\n| --- | --- | --- | --- | --- | --- | --- |"
    );
    for row in &rep.rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} |",
            row.quantity,
            row.paper.map_or("—".into(), fmt_num),
            fmt_num(row.ours),
            row.unit,
            fmt_tol(row.tolerance),
            match row.status {
                Status::Fail => "**FAIL**",
                st => st.label(),
            },
            explanation(row)
        );
    }
    s.push('\n');
    for t in &rep.tables {
        let _ = writeln!(s, "### {}\n", t.title);
        let _ = writeln!(s, "| {} |", t.headers.join(" | "));
        let _ = writeln!(s, "|{}", " --- |".repeat(t.headers.len()));
        for cells in &t.rows {
            let _ = writeln!(s, "| {} |", cells.join(" | "));
        }
        s.push('\n');
    }
    if !rep.figures.is_empty() {
        let _ = writeln!(s, "## Figures\n");
        for f in &rep.figures {
            let rel = f.path.strip_prefix(doc_dir).unwrap_or(&f.path);
            let _ = writeln!(
                s,
                "![{}]({})\n\n*{}*\n",
                f.caption,
                rel.display(),
                f.caption
            );
        }
    }
    let _ = writeln!(s, "## Cost\n\nWall time of this reproduction: {wall:.2} s.");
    s
}

/// The band and reason of a row, then its comment, as one table cell.
fn explanation(row: &Row) -> String {
    let mut parts = Vec::new();
    if let Some(d) = &row.deviation {
        parts.push(format!("band {}: {}", fmt_tol(d.band), d.reason));
    }
    if let Some(c) = &row.comment {
        parts.push(c.clone());
    }
    parts.join(" — ")
}

/// A row of a report's JSON as the index reads it. Reports written before the gate had
/// `ok`/`note` instead of `status`: they are read under the gate's rule (an `info`
/// tolerance is info, `ok` is a pass, anything else a failure: notes are not bands).
#[derive(serde::Deserialize)]
struct IndexRow {
    quantity: String,
    #[serde(default)]
    status: Option<Status>,
    #[serde(default)]
    ok: Option<bool>,
    #[serde(default)]
    tolerance: Option<serde_json::Value>,
}

impl IndexRow {
    fn status(&self) -> Status {
        if let Some(s) = self.status {
            return s;
        }
        let info = self.tolerance.as_ref().is_some_and(|t| t["kind"] == "info");
        match (info, self.ok) {
            (true, _) => Status::Info,
            (false, Some(true)) => Status::Pass,
            _ => Status::Fail,
        }
    }
}

#[derive(serde::Deserialize)]
struct IndexEntry {
    wall_seconds: f64,
    /// Absent in reports written before session 28.
    #[serde(default)]
    cpu_seconds: Option<f64>,
    /// Absent in reports written before session 27.
    #[serde(default)]
    build: Option<String>,
    /// Absent in reports written before session 27.
    #[serde(default)]
    commit: Option<String>,
    rows: Vec<IndexRow>,
}

impl IndexEntry {
    /// "commit, build" for the index (`release` or `dev`), or "not recorded".
    fn provenance(&self) -> String {
        match (&self.commit, &self.build) {
            (Some(c), Some(b)) => {
                let b = if b == "release" { "release" } else { "dev" };
                format!("{c}, {b}")
            }
            _ => "not recorded".into(),
        }
    }
}

/// The source tree's commit as `git` describes it: the short hash of `HEAD`, plus
/// "+ uncommitted changes" when tracked files differ from it (an honest report can then
/// be traced to code, or is marked as not quite any commit); "unknown" without git.
/// The reports themselves ([`REPORT_DIR`]) are outputs, not source: a run that follows
/// another before its reports are committed is not marked for them.
fn source_commit(root: &Path) -> String {
    let git = |args: &[&str]| {
        std::process::Command::new("git")
            .arg("-C")
            .arg(root)
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    describe_commit(
        git(&["rev-parse", "--short=10", "HEAD"]).as_deref(),
        git(&[
            "status",
            "--porcelain",
            "--untracked-files=no",
            "--",
            ".",
            &format!(":(exclude){REPORT_DIR}"),
        ])
        .map(|s| !s.is_empty()),
    )
}

/// Where full runs write their reports, relative to the workspace root.
const REPORT_DIR: &str = "docs/reproductions";

fn describe_commit(head: Option<&str>, dirty: Option<bool>) -> String {
    match (head, dirty) {
        (Some(h), Some(false)) => h.to_string(),
        (Some(h), Some(true)) => format!("{h} + uncommitted changes"),
        (Some(h), None) => format!("{h} (status unknown)"),
        (None, _) => "unknown (no git)".into(),
    }
}

/// A run's CPU seconds as the reports print them ("not recorded" without `/proc`, and in
/// the index for reports written before CPU time was recorded).
fn fmt_cpu(cpu: Option<f64>) -> String {
    cpu.map_or_else(|| "not recorded".into(), |c| format!("{c:.1} s"))
}

/// The build that runs the reproductions, as the reports state it.
const BUILD_PROFILE: &str = if cfg!(debug_assertions) {
    "dev profile (opt-level 1, debug assertions): times are not release times"
} else {
    "release"
};

fn write_index(all: &[Reproduction], doc_dir: &Path, open: &OpenFailures) -> anyhow::Result<()> {
    let mut s = String::from(
        "# Reproductions\n\nGenerated by `cargo xtask reproduce-figures`; do not edit by hand. \
         Each report compares the paper's quoted numbers with ours, computed in the same run. \
         A row is a **pass** (within its tolerance), a **known deviation** (outside it, inside a \
         deviation band declared with its reason in the registration before the run), a \
         **failure** (outside both: the command exits non-zero) or **info** (context, never a \
         pass). A failure on the open-failure list (`open-failures.md`, each row with its \
         issue and measured reason) is still a failure, counted and marked as listed; an \
         unlisted failure fails the command.\n\n\
         The commit and build of each report are those of the run that wrote it; a report \
         older than the code it describes is stale until rerun (`freshness.md` says which \
         are, and why).\n\n\
         | id | source | pass | known deviation | fail | info | wall time | CPU time | commit, build | report |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n",
    );
    let mut details = String::new();
    let mut totals = [0usize; 4];
    let mut total_listed = 0usize;
    for r in all {
        let path = doc_dir.join(format!("{}.json", r.id));
        let entry: Option<IndexEntry> = std::fs::read_to_string(&path)
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok());
        match entry {
            Some(e) => {
                let count = |st: Status| e.rows.iter().filter(|x| x.status() == st).count();
                let c = [
                    count(Status::Pass),
                    count(Status::KnownDeviation),
                    count(Status::Fail),
                    count(Status::Info),
                ];
                let listed = |row: &IndexRow| open.find(r.id, &row.quantity).is_some();
                let n_listed = e
                    .rows
                    .iter()
                    .filter(|x| x.status() == Status::Fail && listed(x))
                    .count();
                for (t, n) in totals.iter_mut().zip(c) {
                    *t += n;
                }
                total_listed += n_listed;
                let fail_cell = if n_listed > 0 {
                    format!("{} ({n_listed} listed)", c[2])
                } else {
                    c[2].to_string()
                };
                let _ = writeln!(
                    s,
                    "| `{}` | {} | {} | {} | {} | {} | {:.1} s | {} | {} | [{}.md]({}.md) |",
                    r.id,
                    r.source,
                    c[0],
                    c[1],
                    fail_cell,
                    c[3],
                    e.wall_seconds,
                    fmt_cpu(e.cpu_seconds),
                    e.provenance(),
                    r.id,
                    r.id
                );
                let _ = writeln!(details, "\n## `{}`\n", r.id);
                for row in &e.rows {
                    let mark = match row.status() {
                        Status::Fail if listed(row) => " (open failure, listed)",
                        Status::Fail => " (not on the open-failure list)",
                        _ => "",
                    };
                    let _ = writeln!(
                        details,
                        "- {}{mark}: {}",
                        row.status().label(),
                        row.quantity
                    );
                }
            }
            None => {
                let _ = writeln!(
                    s,
                    "| `{}` | {} | — | — | — | — | not run | — | — | — |",
                    r.id, r.source
                );
            }
        }
    }
    let _ = writeln!(
        s,
        "| **total** | | {} | {} | {} ({total_listed} listed) | {} | | | | |",
        totals[0], totals[1], totals[2], totals[3]
    );
    s.push_str(&details);
    write_atomic(&doc_dir.join("README.md"), s.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn repro(id: &'static str, run: fn(&Ctx) -> anyhow::Result<Report>) -> Reproduction {
        Reproduction {
            id,
            source: "test",
            seed_file: "none",
            title: "synthetic reproduction",
            run,
        }
    }

    fn report(rows: Vec<Row>) -> anyhow::Result<Report> {
        Ok(Report {
            rows,
            ..Report::default()
        })
    }

    /// Tolerance ±10 %, band ±50 %, ours 2.0 against 1.0: outside both.
    fn outside_band(_: &Ctx) -> anyhow::Result<Report> {
        report(vec![
            Row::new("inside", Some(1.0), 1.05, "", Tolerance::Relative(0.1)),
            Row::new("outside", Some(1.0), 2.0, "", Tolerance::Relative(0.1))
                .deviation(Tolerance::Relative(0.5), "declared reason"),
        ])
    }

    /// Ours 1.3 against 1.0: outside ±10 %, inside the ±50 % band; plus an info row.
    fn inside_band(_: &Ctx) -> anyhow::Result<Report> {
        report(vec![
            Row::new("deviates", Some(1.0), 1.3, "", Tolerance::Relative(0.1))
                .deviation(Tolerance::Relative(0.5), "declared reason"),
            Row::new("context", None, 7.0, "s", Tolerance::Info),
        ])
    }

    fn args(only: &[&str], quick: bool) -> Args {
        Args {
            only: only.iter().map(|s| s.to_string()).collect(),
            quick,
            list: false,
            open_failures: None,
        }
    }

    #[test]
    fn a_row_outside_its_declared_band_fails_the_command() {
        let all = [repro("outside", outside_band), repro("inside", inside_band)];
        for quick in [false, true] {
            let dir = tempfile::tempdir().unwrap();
            let err = run_with(&all, &args(&[], quick), dir.path())
                .expect_err("a row outside its band must fail the command");
            let msg = format!("{err:#}");
            assert!(msg.contains("outside: outside"), "{msg}");
            assert!(msg.contains("band ±50.000%"), "{msg}");
            assert!(!msg.contains("deviates"), "{msg}");
            // The reports are still written, showing the failure.
            let sub = if quick {
                "target/reproductions/quick"
            } else {
                "docs/reproductions"
            };
            let md = std::fs::read_to_string(dir.path().join(sub).join("outside.md")).unwrap();
            assert!(md.contains("**FAIL**"), "{md}");
        }
    }

    #[test]
    fn only_a_failure_off_the_open_list_fails_the_command() {
        let all = [repro("outside", outside_band), repro("inside", inside_band)];
        let dir = tempfile::tempdir().unwrap();
        let list = dir.path().join("open.md");
        let mut a = args(&[], true);
        a.open_failures = Some(list.clone());
        // Listed: the command succeeds, yet the report still shows the failure.
        std::fs::write(&list, "# open\n- outside | outside | issue 0: synthetic\n").unwrap();
        run_with(&all, &a, dir.path()).expect("a listed failure does not fail the command");
        let quick = dir.path().join("target/reproductions/quick");
        let md = std::fs::read_to_string(quick.join("outside.md")).unwrap();
        assert!(md.contains("**FAIL**"), "{md}");
        // The index still counts it as a failure, marked as listed.
        let index = std::fs::read_to_string(quick.join("README.md")).unwrap();
        assert!(index.contains("| 1 | 0 | 1 (1 listed) | 0 |"), "{index}");
        assert!(
            index.contains("- FAIL (open failure, listed): outside"),
            "{index}"
        );
        // The full run reads the workspace's list by default, like the quick one.
        let docs = dir.path().join("docs/reproductions");
        std::fs::create_dir_all(&docs).unwrap();
        std::fs::copy(&list, dir.path().join(OPEN_FAILURES)).unwrap();
        run_with(&all, &args(&[], false), dir.path())
            .expect("the default list applies to full runs");
        // Another row listed instead: the real failure fails the command again.
        std::fs::write(&list, "- outside | inside | issue 0: wrong row\n").unwrap();
        let err = run_with(&all, &a, dir.path()).expect_err("an unlisted failure fails");
        assert!(format!("{err:#}").contains("outside: outside"), "{err:#}");
        // A malformed list is an error naming the file.
        std::fs::write(&list, "- nowhere | q | why\n").unwrap();
        let err = run_with(&all, &a, dir.path()).expect_err("unknown id");
        assert!(format!("{err:#}").contains("open.md"), "{err:#}");
    }

    #[test]
    fn a_row_inside_its_band_is_a_known_deviation_and_info_is_not_a_pass() {
        let all = [repro("outside", outside_band), repro("inside", inside_band)];
        let dir = tempfile::tempdir().unwrap();
        run_with(&all, &args(&["inside"], false), dir.path())
            .expect("a known deviation does not fail the command");
        let index =
            std::fs::read_to_string(dir.path().join("docs/reproductions/README.md")).unwrap();
        // pass | known deviation | fail | info, separately.
        assert!(
            index.contains("| `inside` | test | 0 | 1 | 0 | 1 |"),
            "{index}"
        );
        assert!(index.contains("- known deviation: deviates"), "{index}");
        assert!(index.contains("- info: context"), "{index}");
        assert!(index.contains("| `outside` | test | — |"), "{index}");
        let md = std::fs::read_to_string(dir.path().join("docs/reproductions/inside.md")).unwrap();
        assert!(md.contains("band ±50.000%: declared reason"), "{md}");
        // Provenance: the temporary directory is no git checkout, and the report, its
        // JSON and the index say so, with the build.
        let build = if cfg!(debug_assertions) {
            "dev"
        } else {
            "release"
        };
        assert!(
            index.contains(&format!("| unknown (no git), {build} | [inside.md]")),
            "{index}"
        );
        assert!(md.contains("| commit | unknown (no git) |"), "{md}");
        // The whole run's CPU time is recorded (this process reads `/proc`).
        assert!(md.contains("| CPU time of the whole run | "), "{md}");
        assert!(
            !md.contains("| CPU time of the whole run | not recorded |"),
            "{md}"
        );
        let json =
            std::fs::read_to_string(dir.path().join("docs/reproductions/inside.json")).unwrap();
        assert!(json.contains("\"commit\": \"unknown (no git)\""), "{json}");
        assert!(json.contains("\"cpu_seconds\": "), "{json}");
    }

    #[test]
    fn commits_are_described_with_their_state() {
        assert_eq!(describe_commit(Some("abc123"), Some(false)), "abc123");
        assert_eq!(
            describe_commit(Some("abc123"), Some(true)),
            "abc123 + uncommitted changes"
        );
        assert_eq!(
            describe_commit(Some("abc123"), None),
            "abc123 (status unknown)"
        );
        assert_eq!(describe_commit(None, Some(false)), "unknown (no git)");
        // In a git checkout (CI's), a hexadecimal hash, whatever its state.
        let root = workspace_root();
        if root.join(".git").exists() {
            let here = source_commit(&root);
            let hash = here.split(' ').next().unwrap_or_default();
            assert!(
                hash.len() >= 7 && hash.chars().all(|c| c.is_ascii_hexdigit()),
                "{here}"
            );
        }
    }

    /// A changed report is no uncommitted source change; any other tracked file is.
    #[test]
    fn reports_written_by_an_earlier_run_do_not_mark_the_source_dirty() {
        let git_here = |dir: &Path, args: &[&str]| {
            let out = std::process::Command::new("git")
                .arg("-C")
                .arg(dir)
                .args(["-c", "user.name=t", "-c", "user.email=t@t"])
                .args(args)
                .output()
                .expect("git runs (the reports' provenance needs it)");
            assert!(out.status.success(), "git {args:?}: {out:?}");
        };
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path();
        let report = root.join(REPORT_DIR).join("x.md");
        std::fs::create_dir_all(report.parent().unwrap()).unwrap();
        std::fs::write(&report, "old report").unwrap();
        std::fs::write(root.join("lib.rs"), "fn a() {}").unwrap();
        git_here(root, &["init", "-q"]);
        git_here(root, &["add", "."]);
        git_here(root, &["commit", "-q", "-m", "first"]);
        let clean = source_commit(root);
        assert!(!clean.contains('+'), "{clean}");
        std::fs::write(&report, "new report").unwrap();
        assert_eq!(source_commit(root), clean);
        std::fs::write(root.join("lib.rs"), "fn b() {}").unwrap();
        assert_eq!(
            source_commit(root),
            format!("{clean} + uncommitted changes")
        );
    }

    #[test]
    fn row_status_follows_tolerance_then_band() {
        let r = |ours: f64| Row::new("q", Some(2.0), ours, "", Tolerance::Factor(1.5));
        assert_eq!(r(2.5).status, Status::Pass);
        assert_eq!(r(4.0).status, Status::Fail);
        let band = |ours: f64| r(ours).deviation(Tolerance::Factor(3.0), "why");
        assert_eq!(band(2.5).status, Status::Pass);
        assert_eq!(band(4.0).status, Status::KnownDeviation);
        assert_eq!(band(7.0).status, Status::Fail);
        assert_eq!(band(f64::NAN).status, Status::Fail);
        // A band must be a real criterion with a reason, on a compared row.
        assert_eq!(
            r(4.0).deviation(Tolerance::Info, "why").status,
            Status::Fail
        );
        assert_eq!(
            r(4.0).deviation(Tolerance::Factor(3.0), " ").status,
            Status::Fail
        );
        let info = Row::new("q", None, 1.0, "", Tolerance::Info);
        assert_eq!(info.status, Status::Info);
        assert_eq!(
            info.deviation(Tolerance::AtMost(2.0), "why").status,
            Status::Fail
        );
        // A comment never changes the status.
        assert_eq!(r(4.0).comment("context").status, Status::Fail);
    }

    /// The committed full reports (`docs/reproductions/*.json`) follow the gate's rule:
    /// every row carries its status, and every row that fails there is on the
    /// open-failure list with its reason, as in the quick run CI makes.
    #[test]
    fn committed_reports_fail_only_on_listed_rows() {
        let root = workspace_root();
        let all = repro::all();
        let ids: Vec<&str> = all.iter().map(|r| r.id).collect();
        let list = OpenFailures::read(&root.join(OPEN_FAILURES), &ids).unwrap();
        let mut problems = Vec::new();
        let mut reports = 0;
        for id in &ids {
            let path = root.join(format!("docs/reproductions/{id}.json"));
            let Ok(text) = std::fs::read_to_string(&path) else {
                continue;
            };
            reports += 1;
            let e: IndexEntry = serde_json::from_str(&text)
                .unwrap_or_else(|err| panic!("{}: {err}", path.display()));
            for row in &e.rows {
                if row.status.is_none() {
                    problems.push(format!(
                        "{id}: `{}` has no status (report from before the gate: rerun it)",
                        row.quantity
                    ));
                } else if row.status() == Status::Fail && list.find(id, &row.quantity).is_none() {
                    problems.push(format!(
                        "{id}: `{}` fails in the committed report and is not on {OPEN_FAILURES}",
                        row.quantity
                    ));
                }
            }
        }
        assert!(
            reports > 0,
            "no committed report found under {}",
            root.display()
        );
        assert!(problems.is_empty(), "{}", problems.join("\n"));
    }

    #[test]
    fn reports_from_before_the_gate_count_notes_as_failures() {
        let old = r#"{"wall_seconds": 1.0, "rows": [
            {"quantity": "a", "ok": true, "note": null, "tolerance": {"kind": "relative", "value": 0.1}},
            {"quantity": "b", "ok": false, "note": "explained", "tolerance": {"kind": "relative", "value": 0.1}},
            {"quantity": "c", "ok": true, "note": null, "tolerance": {"kind": "info"}}
        ]}"#;
        let e: IndexEntry = serde_json::from_str(old).unwrap();
        let st: Vec<Status> = e.rows.iter().map(IndexRow::status).collect();
        assert_eq!(st, [Status::Pass, Status::Fail, Status::Info]);
    }
}
