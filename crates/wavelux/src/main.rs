//! The `wavelux` command: solve and render scenes, list the built-ins, compare results.
//!
//! `wavelux` with no arguments solves and renders the built-in Cornell box with the
//! default settings and writes `out/cornell.{exr,png,json}`. See `docs/cli.md` for every
//! option and the JSON schema.

mod cli;
mod compare;
mod pipeline;
mod progress;
mod report;

use clap::Parser;

use crate::cli::{Cli, Command, SolveOnly};

fn main() {
    let cli = Cli::parse();
    let r = match cli.command {
        None => pipeline::run(&SolveOnly::parse_from(["wavelux"]).args, None),
        Some(Command::Solve(a)) => pipeline::run(&a, None),
        Some(Command::Render(r)) => pipeline::run(&r.solve, Some(&r.camera)),
        Some(Command::Scenes) => {
            pipeline::list_scenes();
            Ok(())
        }
        Some(Command::Compare(c)) => compare::run(&c),
        Some(Command::Relight(r)) => pipeline::relight(&r),
        Some(Command::Crates) => {
            println!("wavelux {}", env!("CARGO_PKG_VERSION"));
            for (name, job) in wavelux::CRATES {
                if *name == "wavelux-gpu" && !wavelux::GPU {
                    println!("  {name:<20} (not in this build: the `gpu` feature is off) {job}");
                } else {
                    println!("  {name:<20} {job}");
                }
            }
            Ok(())
        }
    };
    if let Err(e) = r {
        eprintln!("wavelux: error: {e:#}");
        // 2: `--device gpu` found no device (or a build without the `gpu` feature).
        let code = if e.downcast_ref::<pipeline::NoDevice>().is_some() {
            2
        } else {
            1
        };
        std::process::exit(code);
    }
}
