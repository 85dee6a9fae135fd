//! The `wavelux` command.
//!
//! Until the solver and renderer land, the command reports only what is real: its
//! version and the crates it is built from. Reproductions of the papers run through
//! `cargo xtask reproduce-figures`.

use clap::{Parser, Subcommand};

/// Hierarchical and wavelet global illumination.
#[derive(Parser)]
#[command(name = "wavelux", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// List the crates this build of wavelux is made of.
    Crates,
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Some(Command::Crates) | None => {
            println!("wavelux {}", env!("CARGO_PKG_VERSION"));
            for (name, job) in wavelux::CRATES {
                println!("  {name:<20} {job}");
            }
            if cli.command.is_none() {
                println!(
                    "\nThe solver and renderer are not built yet; `cargo xtask reproduce-figures` \
                     regenerates the papers' tables and figures."
                );
            }
        }
    }
    Ok(())
}
