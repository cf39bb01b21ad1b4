//! The memory limit every method checks its estimated peak against *before* allocating
//! (DESIGN.md section 6: refuse a request that would not fit with a clear error).

use crate::error::{Error, Result};
use crate::stats::Stats;
use std::sync::atomic::{AtomicU64, Ordering};

static LIMIT: AtomicU64 = AtomicU64::new(0);

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
        return Err(Error::TooLarge { what: what.to_string(), bytes, limit });
    }
    Ok(())
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
        Peak { bytes: self.bytes.saturating_add(bytes(counts)) }
    }

    /// Adds another estimate (a shared stage's).
    pub fn and(self, other: Peak) -> Self {
        Peak { bytes: self.bytes.saturating_add(other.bytes) }
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
        let peak = Peak::default().buffer(&[3, 4]).and(Peak::default().buffer(&[5]));
        assert_eq!(peak.bytes(), 17);
        assert_eq!(Peak::default().buffer(&[u64::MAX, 2]).buffer(&[1]).bytes(), u64::MAX);
        let mut stats = Stats::default();
        assert!(peak.check("method", &mut stats).is_ok());
        assert_eq!(stats.get("peak_bytes"), Some(17.0));
        let refused = Peak::default().buffer(&[u64::MAX]).check("method", &mut stats).unwrap_err().to_string();
        assert!(refused.starts_with("method needs about 16.00 EiB (18446744073709551615 bytes)"), "{refused}");
        assert!(refused.contains("softshadows.set_memory_limit"), "{refused}");
    }
}
