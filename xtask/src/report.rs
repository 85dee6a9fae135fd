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
    /// Whether `ours` meets `tolerance` (filled in by [`Row::new`]).
    pub ok: bool,
    /// Why a deviation is expected or acceptable; required when `ok` is false.
    pub note: Option<String>,
}

impl Row {
    /// A row; `ok` is computed from the tolerance.
    pub fn new(
        quantity: impl Into<String>,
        paper: Option<f64>,
        ours: f64,
        unit: impl Into<String>,
        tolerance: Tolerance,
    ) -> Self {
        let ok = ours.is_finite()
            && match (tolerance, paper) {
                (Tolerance::Relative(t), Some(p)) => (ours - p).abs() <= t * p.abs(),
                (Tolerance::Absolute(t), Some(p)) => (ours - p).abs() <= t,
                (Tolerance::Factor(f), Some(p)) => {
                    p > 0.0 && ours > 0.0 && (ours / p).max(p / ours) <= f
                }
                (Tolerance::AtMost(b), _) => ours <= b,
                (Tolerance::AtLeast(b), _) => ours >= b,
                (Tolerance::Info, _) => true,
                (_, None) => false,
            };
        Self {
            quantity: quantity.into(),
            paper,
            ours,
            unit: unit.into(),
            tolerance,
            ok,
            note: None,
        }
    }

    /// Attaches an explanation (required for a row that misses its tolerance).
    #[must_use]
    pub fn note(mut self, note: impl Into<String>) -> Self {
        self.note = Some(note.into());
        self
    }

    /// True when the row fails and nothing explains why.
    pub fn unexplained_failure(&self) -> bool {
        !self.ok && self.note.is_none()
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
