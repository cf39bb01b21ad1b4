//! The memory limit every method checks its estimated peak against *before* allocating
//! (DESIGN.md section 6: refuse a request that would not fit with a clear error).

use crate::error::{Error, Result};
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
