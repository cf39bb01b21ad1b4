//! Per-call statistics: stage seconds and the papers' work counters, returned by every method.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// The keys every method's call returns beside its own (`STATS` in each method's module): the
/// memory guard's peak bytes and the work guard's estimated operations.
pub const COMMON: &[&str] = &["peak_bytes", "work"];

/// Named values in insertion order; the Python layer turns them into a dict.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Stats {
    pub entries: Vec<(String, f64)>,
}

impl Stats {
    /// Stats holding 0 under each of `keys`, then each of [`COMMON`]: a method starts from its
    /// declared keys, so that every call returns all of them, an early exit included.
    pub fn declared(keys: &[&str]) -> Self {
        Stats {
            entries: keys
                .iter()
                .chain(COMMON)
                .map(|key| (key.to_string(), 0.0))
                .collect(),
        }
    }

    /// Records `value` under `name` (a later record of the same name replaces it).
    pub fn set(&mut self, name: &str, value: f64) {
        match self.entries.iter_mut().find(|(n, _)| n == name) {
            Some(entry) => entry.1 = value,
            None => self.entries.push((name.to_string(), value)),
        }
    }

    /// Adds `value` to the value recorded under `name` (0 when absent).
    pub fn add(&mut self, name: &str, value: f64) {
        let total = self.get(name).unwrap_or(0.0) + value;
        self.set(name, total);
    }

    /// The value recorded under `name`.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.entries
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| *v)
    }

    /// Runs `f`, records its wall time as `"<stage>_seconds"` and returns its result.
    pub fn time<T>(&mut self, stage: &str, f: impl FnOnce() -> T) -> T {
        let start = Instant::now();
        let out = f();
        self.set(&format!("{stage}_seconds"), start.elapsed().as_secs_f64());
        out
    }

    /// Like [`Stats::time`], but adds the wall time to `"<stage>_seconds"`: for stages run in
    /// several passes.
    pub fn time_add<T>(&mut self, stage: &str, f: impl FnOnce() -> T) -> T {
        let start = Instant::now();
        let out = f();
        self.add(&format!("{stage}_seconds"), start.elapsed().as_secs_f64());
        out
    }
}

/// `N` work counters that the workers of a parallel pass add to, each in its own cache line: a
/// shared atomic, added to once per receiver and primitive pair, bounces between the cores.
/// The totals are sums, the same for any thread count.
pub struct Tally<const N: usize> {
    slots: Vec<Slot<N>>,
}

/// One worker's counters, alone in its cache line.
#[repr(align(128))]
struct Slot<const N: usize>([AtomicU64; N]);

impl<const N: usize> Tally<N> {
    /// Zeroed counters for the workers of the current thread pool (and one for any other thread).
    pub fn new() -> Self {
        Self {
            slots: (0..=rayon::current_num_threads())
                .map(|_| Slot(std::array::from_fn(|_| AtomicU64::new(0))))
                .collect(),
        }
    }

    /// Adds `counts` to the counters of the calling worker.
    pub fn add(&self, counts: [u64; N]) {
        match rayon::current_thread_index() {
            // A worker's own slot: no other thread writes it, so no locked instruction is needed.
            Some(i) if i + 1 < self.slots.len() => {
                for (c, v) in self.slots[i + 1].0.iter().zip(counts) {
                    c.store(c.load(Ordering::Relaxed) + v, Ordering::Relaxed);
                }
            }
            _ => {
                for (c, v) in self.slots[0].0.iter().zip(counts) {
                    c.fetch_add(v, Ordering::Relaxed);
                }
            }
        }
    }

    /// The sums over every worker.
    pub fn totals(&self) -> [u64; N] {
        std::array::from_fn(|k| {
            self.slots
                .iter()
                .map(|s| s.0[k].load(Ordering::Relaxed))
                .sum()
        })
    }
}

impl<const N: usize> Default for Tally<N> {
    fn default() -> Self {
        Self::new()
    }
}
