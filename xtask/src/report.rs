//! What a reproduction returns: rows of paper-vs-ours numbers with tolerances, the
//! parameters it used, prose on what the paper and we did, figures and extra tables.

use serde::Serialize;
use std::path::PathBuf;

/// How close `ours` must be to `paper` for a row to pass.
#[allow(
    dead_code,
    reason = "the harness offers every criterion to all reproductions; not each is used at every moment"
)]
#[derive(Debug, Clone, Copy, Serialize)]
#[serde(tag = "kind", content = "value", rename_all = "snake_case")]
pub enum Tolerance {
    /// |ours − paper| ≤ value · |paper|.
    Relative(f64),
    /// |ours − paper| ≤ value.
    Absolute(f64),
    /// Both positive and max(ours/paper, paper/ours) ≤ value (for ratios and timings).
    Factor(f64),
    /// ours ≤ value (an upper bound, e.g. an error that must stay small); `paper` is
    /// shown for context only.
    AtMost(f64),
    /// ours ≥ value (a lower bound); `paper` is shown for context only.
    AtLeast(f64),
    /// No pass/fail: a number reported for context (e.g. a timing the paper lacks).
    Info,
}

/// The verdict on a row (the gate of `reproduce-figures`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// `ours` meets the row's tolerance.
    Pass,
    /// `ours` misses the tolerance but lies inside the deviation band declared in the
    /// registration, with its reason, before the run.
    KnownDeviation,
    /// `ours` misses both (or is not finite): the command exits non-zero.
    Fail,
    /// Reported for context; never a pass and never a failure.
    Info,
}

impl Status {
    /// Label used in reports and logs.
    pub fn label(self) -> &'static str {
        match self {
            Status::Pass => "pass",
            Status::KnownDeviation => "known deviation",
            Status::Fail => "FAIL",
            Status::Info => "info",
        }
    }
}

/// A deviation declared in a registration: how far `ours` may miss the tolerance, and
/// the specific reason (a fact a reader can check, not a catch-all).
#[derive(Debug, Clone, Serialize)]
pub struct Deviation {
    /// The wider criterion (same kinds as [`Tolerance`]; never `Info`).
    pub band: Tolerance,
    /// Why the paper's number is not expected to be met.
    pub reason: String,
}

/// One quantity compared between the paper and our run.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    /// What is measured, e.g. "relative L1 error, f, Haar".
    pub quantity: String,
    /// The paper's value, quoted from the seed text (None where the paper gives none).
    pub paper: Option<f64>,
    /// Our value, computed in this run.
    pub ours: f64,
    /// Unit of both values ("" for dimensionless).
    pub unit: String,
    /// Pass criterion.
    pub tolerance: Tolerance,
    /// A deviation band declared with the registration (None: the tolerance alone).
    pub deviation: Option<Deviation>,
    /// The verdict (computed by [`Row::new`] and [`Row::deviation`]).
    pub status: Status,
    /// Context for the reader; never changes the status.
    pub comment: Option<String>,
}

/// Whether `ours` meets `t` against `paper` (`Info` always does).
fn meets(t: Tolerance, paper: Option<f64>, ours: f64) -> bool {
    ours.is_finite()
        && match (t, paper) {
            (Tolerance::Relative(v), Some(p)) => (ours - p).abs() <= v * p.abs(),
            (Tolerance::Absolute(v), Some(p)) => (ours - p).abs() <= v,
            (Tolerance::Factor(f), Some(p)) => {
                p > 0.0 && ours > 0.0 && (ours / p).max(p / ours) <= f
            }
            (Tolerance::AtMost(b), _) => ours <= b,
            (Tolerance::AtLeast(b), _) => ours >= b,
            (Tolerance::Info, _) => true,
            (_, None) => false,
        }
}

impl Row {
    /// A row; its status is computed from the tolerance.
    pub fn new(
        quantity: impl Into<String>,
        paper: Option<f64>,
        ours: f64,
        unit: impl Into<String>,
        tolerance: Tolerance,
    ) -> Self {
        let status = match tolerance {
            Tolerance::Info => Status::Info,
            t if meets(t, paper, ours) => Status::Pass,
            _ => Status::Fail,
        };
        Self {
            quantity: quantity.into(),
            paper,
            ours,
            unit: unit.into(),
            tolerance,
            deviation: None,
            status,
            comment: None,
        }
    }

    /// Declares a deviation band and its reason. A row outside its tolerance but inside
    /// `band` is a known deviation; outside both it fails. Declaring a band on an `Info`
    /// row, an `Info` band or an empty reason is a registration error: the row fails.
    #[must_use]
    pub fn deviation(mut self, band: Tolerance, reason: impl Into<String>) -> Self {
        let reason = reason.into();
        let valid = !matches!(band, Tolerance::Info)
            && !matches!(self.tolerance, Tolerance::Info)
            && !reason.trim().is_empty();
        self.status = match self.status {
            _ if !valid => Status::Fail,
            Status::Fail if meets(band, self.paper, self.ours) => Status::KnownDeviation,
            s => s,
        };
        self.deviation = Some(Deviation { band, reason });
        self
    }

    /// Attaches context for the reader (never changes the status).
    #[must_use]
    pub fn comment(mut self, comment: impl Into<String>) -> Self {
        self.comment = Some(comment.into());
        self
    }
}

/// A figure written by the reproduction into its figure folder.
#[derive(Debug, Clone)]
pub struct Figure {
    /// Path of the written file.
    pub path: PathBuf,
    /// Caption shown under it.
    pub caption: String,
}

/// A free-form table shown in the report (e.g. a full compression table).
#[derive(Debug, Clone)]
pub struct Table {
    /// Heading above the table.
    pub title: String,
    /// Column headers.
    pub headers: Vec<String>,
    /// Cells, row-major.
    pub rows: Vec<Vec<String>>,
}

/// Everything a reproduction reports.
#[derive(Debug, Clone, Default)]
pub struct Report {
    /// What the paper did (markdown).
    pub paper_did: String,
    /// What we did, including every deviation (markdown).
    pub we_did: String,
    /// Parameters of this run: (name, value).
    pub parameters: Vec<(String, String)>,
    /// Compared quantities.
    pub rows: Vec<Row>,
    /// Plots.
    pub figures: Vec<Figure>,
    /// Extra tables.
    pub tables: Vec<Table>,
}

impl Report {
    /// Records a parameter.
    pub fn param(&mut self, name: impl Into<String>, value: impl ToString) {
        self.parameters.push((name.into(), value.to_string()));
    }
}
