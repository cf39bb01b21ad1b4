//! The memory and work limits every method checks its estimates against *before* allocating
//! or computing anything: a request that would not fit, or would run for hours, is refused with
//! a clear error naming the estimate and the setting that raises the limit.

use crate::error::{Error, Result};
use crate::stats::Stats;
use std::sync::atomic::{AtomicU64, Ordering};

static LIMIT: AtomicU64 = AtomicU64::new(0);
static WORK_LIMIT: AtomicU64 = AtomicU64::new(0);

/// Physical memory in bytes, read from `/proc/meminfo`; 8 GiB where that is unavailable.
fn physical_memory() -> u64 {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| {
            let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
            let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
            Some(kib * 1024)
        })
        .unwrap_or(8 << 30)
}

/// The current limit in bytes: set by [`set_memory_limit`], else 75% of physical memory.
pub fn memory_limit() -> u64 {
    match LIMIT.load(Ordering::Relaxed) {
        0 => physical_memory() / 4 * 3,
        limit => limit,
    }
}

/// Sets the limit in bytes; 0 restores the default.
pub fn set_memory_limit(bytes: u64) {
    LIMIT.store(bytes, Ordering::Relaxed);
}

/// Refuses `bytes` of working memory for `what` when above the limit.
pub fn check_memory(what: &str, bytes: u64) -> Result<()> {
    let limit = memory_limit();
    if bytes > limit {
        return Err(Error::TooLarge {
            what: what.to_string(),
            bytes,
            limit,
        });
    }
    Ok(())
}

/// The default work limit: 10^12 operations, in the units of [`Work`] (a ray counts 100, a
/// texel or a receiver-sample pair 1): on the order of a quarter of an hour of one core, so an
/// ordinary research run (a 1024^2 image with 1024 samples per receiver is 10^11) passes and a
/// mistyped sample or view count is refused instead of running for hours.
pub const DEFAULT_WORK_LIMIT: u64 = 1_000_000_000_000;

/// The current work limit in operations: set by [`set_work_limit`], else [`DEFAULT_WORK_LIMIT`].
pub fn work_limit() -> u64 {
    match WORK_LIMIT.load(Ordering::Relaxed) {
        0 => DEFAULT_WORK_LIMIT,
        limit => limit,
    }
}

/// Sets the work limit in operations; 0 restores the default.
pub fn set_work_limit(operations: u64) {
    WORK_LIMIT.store(operations, Ordering::Relaxed);
}

/// A call's estimated work in operations: the sum of its main loops, each the product of its
/// trip counts and a weight for one trip (see [`DEFAULT_WORK_LIMIT`] for the units).
#[derive(Debug, Clone, Copy, Default)]
pub struct Work {
    operations: u64,
}

impl Work {
    /// The weight of one ray-scene query (a BVH traversal, hundreds of nanoseconds).
    pub const RAY: u64 = 100;
    /// The weight of one triangle set up for rasterization or clipping.
    pub const TRIANGLE: u64 = 50;

    /// Adds a loop of `counts` multiplied together operations (saturating).
    pub fn loop_of(self, counts: &[u64]) -> Self {
        Work {
            operations: self.operations.saturating_add(bytes(counts)),
        }
    }

    /// Adds another estimate.
    pub fn and(self, other: Work) -> Self {
        Work {
            operations: self.operations.saturating_add(other.operations),
        }
    }

    pub fn operations(&self) -> u64 {
        self.operations
    }

    /// Records the estimate as the stat `work`, then refuses it, naming `method`, when it is
    /// above the limit.
    pub fn check(self, method: &str, stats: &mut Stats) -> Result<()> {
        stats.set("work", self.operations as f64);
        self.refuse_above_limit(method)
    }

    /// Refuses the estimate, naming `what`, when it is above the limit.
    pub fn refuse_above_limit(self, what: &str) -> Result<()> {
        let limit = work_limit();
        if self.operations > limit {
            return Err(Error::TooMuchWork {
                what: what.to_string(),
                operations: self.operations,
                limit,
            });
        }
        Ok(())
    }
}

/// The least work of an object-based method: every triangle set up (its influence region or
/// volume), and every receiver-sample pair answered once.
pub fn object_work(scene: &crate::geometry::mesh::Scene, receivers: usize, samples: usize) -> Work {
    Work::default()
        .loop_of(&[scene.num_faces() as u64, Work::TRIANGLE])
        .loop_of(&[receivers as u64, samples as u64])
}

/// `a * b * c` in u64 bytes, saturating, for estimates that must not overflow.
pub fn bytes(counts: &[u64]) -> u64 {
    counts.iter().fold(1u64, |acc, &c| acc.saturating_mul(c))
}

/// A method's whole peak working memory: the sum of its large buffers, each at an upper bound of
/// its size, checked once before the first of them is allocated. The stage checks inside
/// ([`check_memory`]) stay for callers of the stages alone and never ask for more than the peak.
#[derive(Debug, Clone, Copy, Default)]
pub struct Peak {
    bytes: u64,
}

impl Peak {
    /// Adds a buffer of `counts` multiplied together bytes.
    pub fn buffer(self, counts: &[u64]) -> Self {
        Peak {
            bytes: self.bytes.saturating_add(bytes(counts)),
        }
    }

    /// Adds another estimate (a shared stage's).
    pub fn and(self, other: Peak) -> Self {
        Peak {
            bytes: self.bytes.saturating_add(other.bytes),
        }
    }

    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// Records the estimate as the stat `peak_bytes`, then refuses it, naming `method`, when it
    /// is above the limit.
    pub fn check(self, method: &str, stats: &mut Stats) -> Result<()> {
        stats.set("peak_bytes", self.bytes as f64);
        check_memory(method, self.bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_peak_sums_its_buffers_saturating_and_is_refused_above_the_limit() {
        let peak = Peak::default()
            .buffer(&[3, 4])
            .and(Peak::default().buffer(&[5]));
        assert_eq!(peak.bytes(), 17);
        assert_eq!(
            Peak::default().buffer(&[u64::MAX, 2]).buffer(&[1]).bytes(),
            u64::MAX
        );
        let mut stats = Stats::default();
        assert!(peak.check("method", &mut stats).is_ok());
        assert_eq!(stats.get("peak_bytes"), Some(17.0));
        let refused = Peak::default()
            .buffer(&[u64::MAX])
            .check("method", &mut stats)
            .unwrap_err()
            .to_string();
        assert!(
            refused.starts_with("method needs about 16.00 EiB (18446744073709551615 bytes)"),
            "{refused}"
        );
        assert!(
            refused.contains("softshadows.set_memory_limit"),
            "{refused}"
        );
    }

    #[test]
    fn work_is_refused_above_the_limit_with_its_estimate() {
        let mut stats = Stats::default();
        let work = Work::default()
            .loop_of(&[1000, 1_000_000_000, Work::RAY])
            .loop_of(&[5]);
        assert_eq!(work.operations(), 100_000_000_000_005);
        let refused = work.check("ray_traced", &mut stats);
        assert_eq!(stats.get("work"), Some(1.00000000000005e14));
        let message = match refused {
            Err(e) => e.to_string(),
            Ok(()) => String::from("accepted"),
        };
        assert!(
            message.starts_with(
                "ray_traced needs about 1.000e14 operations, above the work limit of 1.000e12"
            ),
            "{message}"
        );
        assert!(message.contains("softshadows.set_work_limit"), "{message}");
        assert!(Work::default().loop_of(&[u64::MAX, 2]).operations() == u64::MAX);
        assert!(Work::default()
            .loop_of(&[DEFAULT_WORK_LIMIT])
            .check("m", &mut stats)
            .is_ok());
    }
}
