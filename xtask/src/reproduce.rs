//! `cargo xtask reproduce-figures`: runs the registered reproductions and writes
//! `docs/reproductions/<ID>.md` (with figures in `docs/reproductions/<ID>/`),
//! `target/reproductions/<ID>.json` and the index `docs/reproductions/README.md`.
//!
//! With `--quick` every reproduction still computes everything, on smaller sizes, and
//! the outputs go under `target/reproductions/quick/` so the committed reports always
//! come from full runs. The command exits non-zero when a row misses its tolerance
//! without a note explaining why.

use crate::report::{Report, Row, Tolerance};
use crate::repro::{self, Reproduction};
use anyhow::{Context, bail};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

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

/// Runs the command.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let all = repro::all();
    if args.list {
        for r in &all {
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
    let root = workspace_root();
    let (doc_dir, json_dir) = if args.quick {
        let q = root.join("target/reproductions/quick");
        (q.clone(), q)
    } else {
        (
            root.join("docs/reproductions"),
            root.join("target/reproductions"),
        )
    };
    let selected: Vec<&Reproduction> = all
        .iter()
        .filter(|r| args.only.is_empty() || args.only.iter().any(|o| o == r.id))
        .collect();

    let mut unexplained = Vec::new();
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
        let start = Instant::now();
        let report = (r.run)(&ctx).with_context(|| format!("reproduction {} failed", r.id))?;
        let wall = start.elapsed().as_secs_f64();

        let json = JsonReport {
            id: r.id,
            source: format!("{} ({})", r.source, r.seed_file),
            title: r.title,
            quick: args.quick,
            wall_seconds: wall,
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
            let status = if row.ok {
                "ok"
            } else if row.note.is_some() {
                "explained"
            } else {
                "FAIL"
            };
            eprintln!(
                "  [{status:>9}] {}: ours {} vs paper {}",
                row.quantity,
                fmt_num(row.ours),
                row.paper.map_or("—".into(), fmt_num)
            );
            if row.unexplained_failure() {
                unexplained.push(format!("{}: {}", r.id, row.quantity));
            }
        }
        eprintln!("  wall time {wall:.2} s");
    }
    write_index(&all, &doc_dir)?;
    if !unexplained.is_empty() {
        bail!(
            "{} row(s) missed their tolerance without a note:\n  {}",
            unexplained.len(),
            unexplained.join("\n  ")
        );
    }
    Ok(())
}

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

fn status(row: &Row) -> &'static str {
    match (row.ok, row.note.is_some()) {
        (true, _) => "ok",
        (false, true) => "explained",
        (false, false) => "**FAIL**",
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
        "## Paper vs ours\n\n| quantity | paper | ours | unit | tolerance | status | note |\n| --- | --- | --- | --- | --- | --- | --- |"
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
            status(row),
            row.note.as_deref().unwrap_or("")
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

#[derive(serde::Deserialize)]
struct IndexRow {
    quantity: String,
    ok: bool,
    note: Option<String>,
}

#[derive(serde::Deserialize)]
struct IndexEntry {
    wall_seconds: f64,
    rows: Vec<IndexRow>,
}

fn write_index(all: &[Reproduction], doc_dir: &Path) -> anyhow::Result<()> {
    let mut s = String::from(
        "# Reproductions\n\nGenerated by `cargo xtask reproduce-figures`; do not edit by hand. \
         Each report compares the paper's quoted numbers with ours, computed in the same run.\n\n\
         | id | source | rows ok | explained | failed | wall time | report |\n| --- | --- | --- | --- | --- | --- | --- |\n",
    );
    let mut details = String::new();
    for r in all {
        let path = doc_dir.join(format!("{}.json", r.id));
        let entry: Option<IndexEntry> = std::fs::read_to_string(&path)
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok());
        match entry {
            Some(e) => {
                let ok = e.rows.iter().filter(|x| x.ok).count();
                let explained = e.rows.iter().filter(|x| !x.ok && x.note.is_some()).count();
                let failed = e.rows.len() - ok - explained;
                let _ = writeln!(
                    s,
                    "| `{}` | {} | {ok} | {explained} | {failed} | {:.1} s | [{}.md]({}.md) |",
                    r.id, r.source, e.wall_seconds, r.id, r.id
                );
                let _ = writeln!(details, "\n## `{}`\n", r.id);
                for row in &e.rows {
                    let st = match (row.ok, row.note.is_some()) {
                        (true, _) => "pass",
                        (false, true) => "explained",
                        (false, false) => "FAIL",
                    };
                    let _ = writeln!(details, "- {st}: {}", row.quantity);
                }
            }
            None => {
                let _ = writeln!(s, "| `{}` | {} | — | — | — | not run | — |", r.id, r.source);
            }
        }
    }
    s.push_str(&details);
    write_atomic(&doc_dir.join("README.md"), s.as_bytes())
}
