//! CPU time of this process and its waited-for children, for the time ratios the
//! reproductions report (issue 13 §1: "time ratios from CPU time of each side,
//! measured in the same run").
//!
//! Wall-clock ratios on the shared 2-core machine move by up to ~3× with the load of
//! other processes (virtual-mesh-table3 measured 3.07 and 1.08 for the same ratio in
//! two runs); the CPU time a run consumed does not depend on how long it waited for a
//! core. A [`Stopwatch`] reads both, so every timed run reports its wall and CPU
//! seconds and the ratios use CPU seconds.
//!
//! The source is Linux's `/proc/self/stat` (fields `utime`, `stime` of every thread
//! of this process, living or exited, plus `cutime`, `cstime` of children that were
//! waited for, e.g. the release `wavelux` binary or the Mitsuba script), in clock
//! ticks of 1/100 s (`USER_HZ`, fixed at 100 in the kernel's ABI for this file): the
//! resolution is 10 ms per read, so a ratio of runs of at least 1 s is resolved to
//! about 2 %. Multi-threaded runs count the CPU time of all their threads: a ratio of
//! CPU times compares the work of the two sides, not their latency. Where `/proc` is
//! not readable the CPU time is `None` and callers report wall time and say so.

use std::time::Instant;

/// Clock ticks per second of `/proc/<pid>/stat` (`USER_HZ`).
const TICKS_PER_SECOND: f64 = 100.0;

/// CPU seconds used so far by this process (all threads) and its waited-for children,
/// or `None` where `/proc/self/stat` cannot be read or parsed.
pub fn process_cpu_seconds() -> Option<f64> {
    parse_stat(&std::fs::read_to_string("/proc/self/stat").ok()?)
}

/// `utime + stime + cutime + cstime` of a `/proc/<pid>/stat` line, in seconds. The
/// command name (field 2) is in parentheses and may contain spaces: fields are counted
/// after its closing parenthesis.
fn parse_stat(line: &str) -> Option<f64> {
    let rest = &line[line.rfind(')')? + 1..];
    // After the name: state is field 3; utime, stime, cutime, cstime are 14..=17.
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks: Option<Vec<f64>> = fields
        .get(11..15)?
        .iter()
        .map(|f| f.parse::<f64>().ok())
        .collect();
    Some(ticks?.iter().sum::<f64>() / TICKS_PER_SECOND)
}

/// Wall and CPU time since a start.
#[derive(Debug, Clone, Copy)]
pub struct Stopwatch {
    wall: Instant,
    cpu: Option<f64>,
}

/// What a [`Stopwatch`] measured, seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Elapsed {
    /// Wall-clock seconds.
    pub wall: f64,
    /// CPU seconds of this process and its waited-for children (`None` without
    /// `/proc`).
    pub cpu: Option<f64>,
}

impl Elapsed {
    /// CPU seconds where measured, else wall seconds (the reports say which).
    pub fn cpu_or_wall(&self) -> f64 {
        self.cpu.unwrap_or(self.wall)
    }
}

impl Stopwatch {
    /// Starts both clocks now.
    pub fn start() -> Self {
        Self {
            cpu: process_cpu_seconds(),
            wall: Instant::now(),
        }
    }

    /// Time since [`Stopwatch::start`].
    pub fn elapsed(&self) -> Elapsed {
        let wall = self.wall.elapsed().as_secs_f64();
        let cpu = match (self.cpu, process_cpu_seconds()) {
            (Some(a), Some(b)) => Some((b - a).max(0.0)),
            _ => None,
        };
        Elapsed { wall, cpu }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_four_time_fields_after_a_name_with_spaces() {
        // pid (comm) state ppid pgrp session tty tpgid flags minflt cminflt majflt
        // cmajflt utime stime cutime cstime ...
        let line = "42 (a b) c) R 1 2 3 4 5 6 7 8 9 10 250 50 120 30 20 0 1 0";
        assert_eq!(parse_stat(line), Some(4.5));
        assert_eq!(parse_stat("42 (x) R 1 2"), None);
        assert_eq!(parse_stat("no parenthesis"), None);
    }

    #[test]
    fn reads_this_process_on_linux() {
        if cfg!(target_os = "linux") {
            let a = process_cpu_seconds().expect("/proc/self/stat is readable on Linux");
            let b = process_cpu_seconds().unwrap();
            assert!(a.is_finite() && a >= 0.0 && b >= a, "{a} {b}");
            let e = Stopwatch::start().elapsed();
            assert!(e.cpu.is_some_and(|c| c >= 0.0) && e.wall >= 0.0, "{e:?}");
        }
    }
}
