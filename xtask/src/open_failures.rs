//! The list of open failures: reproduction rows that fail today, each named with the
//! issue that owns it and why it is still open (`docs/reproductions/open-failures.md`).
//!
//! The list changes nothing in the reports: such a row is still a **failure** there and
//! in the index, and never counts as a pass or a known deviation. What it changes is the
//! exit status of `reproduce-figures --open-failures FILE` (used by CI): a failing row
//! on the list is reported as an open failure, a failing row *not* on the list fails the
//! command, so the gate still catches every new failure and every regression while the
//! work that makes the listed rows pass is under way. An entry naming an unknown
//! reproduction, or the same row twice, is an error; an entry whose row passed is
//! reported so the list can shrink (not an error: some listed rows are timing ratios on
//! a shared machine).
//!
//! Format: one Markdown list item per row, `- ID | quantity | reason`, where `quantity`
//! is the row's text exactly as the report prints it and `reason` names the issue.
//! Every other line is prose and ignored.

use anyhow::{Context, bail};
use std::collections::BTreeSet;
use std::path::Path;

/// One listed row.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OpenFailure {
    /// Reproduction id, e.g. `ziegler-4.2`.
    pub id: String,
    /// The row's quantity, exactly as in the report.
    pub quantity: String,
    /// Why it is open and which issue owns it (never empty).
    pub reason: String,
}

/// The parsed list.
#[derive(Debug, Clone, Default)]
pub struct OpenFailures {
    entries: Vec<OpenFailure>,
}

impl OpenFailures {
    /// Reads and parses `path`; `known` are the registered reproduction ids.
    pub fn read(path: &Path, known: &[&str]) -> anyhow::Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("reading the open-failure list {}", path.display()))?;
        Self::parse(&text, known).with_context(|| format!("in {}", path.display()))
    }

    /// Parses the list's text; `known` are the registered reproduction ids.
    pub fn parse(text: &str, known: &[&str]) -> anyhow::Result<Self> {
        let mut entries = Vec::new();
        let mut seen = BTreeSet::new();
        for (n, line) in text.lines().enumerate() {
            let Some(item) = line.strip_prefix("- ") else {
                continue;
            };
            let fields: Vec<&str> = item.split(" | ").map(str::trim).collect();
            let [id, quantity, reason] = fields[..] else {
                bail!(
                    "line {}: expected `- ID | quantity | reason`, found `{line}`",
                    n + 1
                );
            };
            if !known.contains(&id) {
                bail!("line {}: unknown reproduction `{id}`", n + 1);
            }
            if quantity.is_empty() || reason.is_empty() {
                bail!("line {}: an entry needs its quantity and its reason", n + 1);
            }
            if !seen.insert((id.to_string(), quantity.to_string())) {
                bail!("line {}: `{id} | {quantity}` is listed twice", n + 1);
            }
            entries.push(OpenFailure {
                id: id.into(),
                quantity: quantity.into(),
                reason: reason.into(),
            });
        }
        Ok(Self { entries })
    }

    /// The entry for row `quantity` of reproduction `id`, if listed.
    pub fn find(&self, id: &str, quantity: &str) -> Option<&OpenFailure> {
        self.entries
            .iter()
            .find(|e| e.id == id && e.quantity == quantity)
    }

    /// Entries of reproduction `id`.
    pub fn of<'a>(&'a self, id: &'a str) -> impl Iterator<Item = &'a OpenFailure> + 'a {
        self.entries.iter().filter(move |e| e.id == id)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_items_and_skips_prose() {
        let text = "# Open failures\n\nSome prose.\n\
                    - a | ratio x / y | issue 13: not explained\n\
                    * not an entry\n";
        let l = OpenFailures::parse(text, &["a", "b"]).unwrap();
        let e = l.find("a", "ratio x / y").unwrap();
        assert_eq!(e.reason, "issue 13: not explained");
        assert!(l.find("a", "ratio x").is_none());
        assert_eq!(l.of("a").count(), 1);
        assert_eq!(l.of("b").count(), 0);
    }

    #[test]
    fn rejects_malformed_unknown_reasonless_and_duplicate_entries() {
        let known = ["a"];
        for bad in [
            "- a | only two",
            "- zz | q | why",
            "- a | q |  ",
            "- a | q | why\n- a | q | again",
        ] {
            assert!(OpenFailures::parse(bad, &known).is_err(), "{bad}");
        }
    }
}
