//! Development tasks for wavelux.
//!
//! `cargo xtask reproduce-figures [--only ID ...] [--quick] [--list]` regenerates the
//! papers' tables and figures beside our own numbers (see [`reproduce`]).

mod cpu;
mod open_failures;
mod plot;
mod report;
mod repro;
mod reproduce;

use clap::{Parser, Subcommand};

/// wavelux development tasks.
#[derive(Parser)]
#[command(name = "xtask")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Recompute the papers' tables and figures and write the reports.
    ReproduceFigures(reproduce::Args),
}

fn main() -> anyhow::Result<()> {
    match Cli::parse().command {
        Command::ReproduceFigures(args) => reproduce::run(&args),
    }
}
