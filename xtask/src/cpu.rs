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
//! Sources (Linux): `/proc/self/stat` gives `utime + stime` of every thread of this
//! process, living or exited, and `cutime + cstime` of children that were waited for
//! (the release `wavelux` binary, the Mitsuba script), in clock ticks of 1/100 s
//! (`USER_HZ`, fixed at 100 in the kernel's ABI for this file); the first field of
//! `/proc/self/task/*/schedstat` gives each living thread's time on a CPU in
//! nanoseconds. A run's own CPU time is the change of the nanosecond sum when it agrees
//! with the tick count (no thread that worked during the run has exited: the rayon pool
//! and the main thread live as long as the process), and the tick count otherwise, so
//! a short run is resolved to microseconds and no work is ever dropped; children are
//! counted by ticks (10 ms). Multi-threaded runs count the CPU time of all their
//! threads: a ratio of CPU times compares the work of the two sides, not their latency.
//! Where `/proc` is not readable the CPU time is `None` and callers use wall time.

use std::time::Instant;

/// Clock ticks per second of `/proc/<pid>/stat` (`USER_HZ`).
const TICKS_PER_SECOND: f64 = 100.0;

/// Largest difference (s) between the tick count and the nanosecond sum that is
/// still the ticks' rounding: two ticks.
const TICK_SLACK: f64 = 2.0 / TICKS_PER_SECOND;

/// One reading of the CPU clocks, seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Reading {
    /// This process's threads, living or exited (ticks).
    own_ticks: f64,
    /// Waited-for children (ticks).
    children: f64,
    /// This process's living threads (nanoseconds), where readable.
    live: Option<f64>,
}

impl Reading {
    fn now() -> Option<Self> {
        let (own_ticks, children) = parse_stat(&std::fs::read_to_string("/proc/self/stat").ok()?)?;
        Some(Self {
            own_ticks,
            children,
            live: live_thread_seconds(),
        })
    }

    /// CPU seconds from `self` to `later`: the nanosecond sum where it agrees with the
    /// ticks, else the ticks; plus the children's ticks.
    fn until(&self, later: &Reading) -> f64 {
        let ticks = later.own_ticks - self.own_ticks;
        let own = match (self.live, later.live) {
            (Some(a), Some(b)) if (ticks - (b - a)).abs() <= TICK_SLACK => b - a,
            _ => ticks,
        };
        (own + later.children - self.children).max(0.0)
    }
}

/// `(utime + stime, cutime + cstime)` of a `/proc/<pid>/stat` line, in seconds. The
/// command name (field 2) is in parentheses and may contain spaces: fields are counted
/// after its closing parenthesis.
fn parse_stat(line: &str) -> Option<(f64, f64)> {
    let rest = &line[line.rfind(')')? + 1..];
    // After the name: state is field 3; utime, stime, cutime, cstime are 14..=17.
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let t: Vec<f64> = fields
        .get(11..15)?
        .iter()
        .map(|f| f.parse::<f64>().ok())
        .collect::<Option<_>>()?;
    Some((
        (t[0] + t[1]) / TICKS_PER_SECOND,
        (t[2] + t[3]) / TICKS_PER_SECOND,
    ))
}

/// Sum over this process's living threads of their time on a CPU (s), from the first
/// field of `/proc/self/task/*/schedstat` (nanoseconds).
fn live_thread_seconds() -> Option<f64> {
    let mut ns = 0u64;
    for entry in std::fs::read_dir("/proc/self/task").ok()? {
        let path = entry.ok()?.path().join("schedstat");
        // A thread that exited between the listing and the read contributes nothing.
        if let Ok(text) = std::fs::read_to_string(path) {
            ns += text.split_whitespace().next()?.parse::<u64>().ok()?;
        }
    }
    Some(ns as f64 * 1e-9)
}

/// Wall and CPU time since a start.
#[derive(Debug, Clone, Copy)]
pub struct Stopwatch {
    wall: Instant,
    cpu: Option<Reading>,
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
            cpu: Reading::now(),
            wall: Instant::now(),
        }
    }

    /// Time since [`Stopwatch::start`].
    pub fn elapsed(&self) -> Elapsed {
        let wall = self.wall.elapsed().as_secs_f64();
        let cpu = match (self.cpu, Reading::now()) {
            (Some(a), Some(b)) => Some(a.until(&b)),
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
        assert_eq!(parse_stat(line), Some((3.0, 1.5)));
        assert_eq!(parse_stat("42 (x) R 1 2"), None);
        assert_eq!(parse_stat("no parenthesis"), None);
    }

    #[test]
    fn uses_nanoseconds_unless_a_working_thread_exited() {
        let r = |own_ticks, children, live| Reading {
            own_ticks,
            children,
            live,
        };
        let a = r(1.00, 0.5, Some(0.998_000_001));
        // Ticks agree with the living threads' nanoseconds: the nanoseconds count.
        let b = r(1.01, 0.5, Some(1.003_000_001));
        assert!((a.until(&b) - 0.005).abs() < 1e-9);
        // A thread that worked 0.5 s exited: only the ticks saw it.
        let c = r(1.60, 0.5, Some(1.098_000_001));
        assert!((a.until(&c) - 0.6).abs() < 1e-9);
        // Children add their ticks; no nanosecond reading: ticks alone.
        let d = r(1.20, 2.5, None);
        assert!((a.until(&d) - 2.2).abs() < 1e-9);
    }

    #[test]
    fn reads_this_process_on_linux() {
        if cfg!(target_os = "linux") {
            let a = Reading::now().expect("/proc/self/stat is readable on Linux");
            let b = Reading::now().unwrap();
            assert!(
                a.own_ticks >= 0.0 && b.own_ticks >= a.own_ticks,
                "{a:?} {b:?}"
            );
            assert!(a.live.is_some_and(|s| s >= 0.0), "{a:?}");
            assert!(a.until(&b) >= 0.0);
            let e = Stopwatch::start().elapsed();
            assert!(e.cpu.is_some_and(|c| c >= 0.0) && e.wall >= 0.0, "{e:?}");
        }
    }
}
