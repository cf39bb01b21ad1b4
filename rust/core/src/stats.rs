//! Per-call statistics: stage seconds and the papers' work counters, returned by every method.

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
