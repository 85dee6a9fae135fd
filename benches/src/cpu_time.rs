//! A criterion [`Measurement`] that reads the CPU time of the bench process instead of
//! the wall clock (issue 13: speed is reported in CPU time). On the shared machine a
//! wall clock also counts the time other processes held the cores; the CPU time of the
//! process's threads does not.
//!
//! Source (Linux): the first field of `/proc/self/task/*/schedstat`, each living
//! thread's time on a CPU in nanoseconds, summed over the threads (so a multi-threaded
//! sample counts the work of every thread: run with `RAYON_NUM_THREADS=1` for the time
//! of one core). The kernel brings the running thread's count up to date at a tick or a
//! switch, so a read first yields the thread (which updates it); a sample should still
//! last several scheduler ticks (4 ms) for its error to stay within a few per cent.

use criterion::Criterion;
use criterion::measurement::{Measurement, ValueFormatter, WallTime};

/// CPU time of this process's living threads, in nanoseconds (shown by criterion's
/// duration formatter, so reports read as times).
pub struct CpuTime {
    wall: WallTime,
}

impl CpuTime {
    /// The process's CPU nanoseconds now (0 where `/proc` cannot be read).
    pub fn now() -> u64 {
        std::thread::yield_now();
        let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
            return 0;
        };
        tasks
            .filter_map(|t| std::fs::read_to_string(t.ok()?.path().join("schedstat")).ok())
            .filter_map(|s| s.split_whitespace().next()?.parse::<u64>().ok())
            .sum()
    }
}

impl Measurement for CpuTime {
    type Intermediate = u64;
    type Value = u64;

    fn start(&self) -> u64 {
        Self::now()
    }
    fn end(&self, start: u64) -> u64 {
        Self::now().saturating_sub(start)
    }
    fn add(&self, a: &u64, b: &u64) -> u64 {
        a + b
    }
    fn zero(&self) -> u64 {
        0
    }
    fn to_f64(&self, ns: &u64) -> f64 {
        *ns as f64
    }
    fn formatter(&self) -> &dyn ValueFormatter {
        self.wall.formatter()
    }
}

/// A criterion configuration that measures [`CpuTime`].
pub fn cpu_time() -> Criterion<CpuTime> {
    Criterion::default().with_measurement(CpuTime { wall: WallTime })
}
