//! Cooperative interruption of long calls.
//!
//! A caller that wants to stop a call (the Python layer on Ctrl-C) runs it under a [`Cancel`]
//! token with [`Cancel::run`]; the call's own thread then sees the token, and the methods'
//! long loops call [`check`] between rounds of work ([`rounds`]), returning
//! [`Error::Interrupted`] soon after the token is raised. Checks happen only in the sequential
//! code between parallel rounds, which always runs on the thread that runs the call, so a
//! worker thread that steals a parallel job of another call never reads this call's token.
//! Where one parallel item is itself long (a band of receivers with thousands of samples each),
//! the sequential code takes a [`watch`] of its token and hands it to the items, which stop
//! early when it is raised; the round's check then reports the interrupt.
//! Without a token (plain Rust use, `cargo test`) every check passes.

use crate::error::{Error, Result};
use std::cell::RefCell;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

thread_local! {
    static CURRENT: RefCell<Option<Cancel>> = const { RefCell::new(None) };
}

/// A request to stop one call, shared between the call and whoever may stop it.
#[derive(Debug, Clone, Default)]
pub struct Cancel(Arc<AtomicBool>);

impl Cancel {
    pub fn new() -> Self {
        Self::default()
    }

    /// Asks the call running under this token to stop at its next check.
    pub fn request(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    pub fn is_requested(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }

    /// Runs `f` on this thread with this token as the current one (the previous one is restored
    /// afterwards, so calls nested on one thread keep their own tokens).
    pub fn run<T>(&self, f: impl FnOnce() -> T) -> T {
        let previous = CURRENT.with(|c| c.replace(Some(self.clone())));
        let out = f();
        CURRENT.with(|c| *c.borrow_mut() = previous);
        out
    }
}

/// The current call's token, taken on the call's own thread, for parallel items to look at.
#[derive(Debug, Clone, Default)]
pub struct Watch(Option<Cancel>);

impl Watch {
    /// Whether the call was asked to stop.
    pub fn requested(&self) -> bool {
        self.0.as_ref().is_some_and(Cancel::is_requested)
    }
}

/// A [`Watch`] of the current call's token.
pub fn watch() -> Watch {
    Watch(CURRENT.with(|c| c.borrow().clone()))
}

/// `Err(Error::Interrupted)` when the current call's token was raised.
pub fn check() -> Result<()> {
    let requested = CURRENT.with(|c| c.borrow().as_ref().is_some_and(Cancel::is_requested));
    if requested {
        Err(Error::Interrupted)
    } else {
        Ok(())
    }
}

/// The work one round should hold per worker thread: about 2^21 elementary operations (rays,
/// bitmask words, texels), a few tens of milliseconds on one core, so a raised token is seen
/// well within a second while the barrier between rounds costs nothing measurable.
const ROUND_OPS_PER_THREAD: u64 = 1 << 21;

/// The length of a round over items of `cost` operations each, a multiple of `unit` (the
/// parallel chunk of the loop, so chunk boundaries and hence results stay as without rounds),
/// and at least one unit per thread so rounds keep every thread busy (an expensive unit, a band
/// of receivers with thousands of samples each, then sets the time between checks).
pub fn round_len(unit: usize, cost: u64) -> usize {
    let unit = unit.max(1);
    let threads = rayon::current_num_threads().max(1) as u64;
    let items = (ROUND_OPS_PER_THREAD * threads) / cost.max(1);
    let units = (items / unit as u64).max(threads);
    usize::try_from(units)
        .unwrap_or(usize::MAX / unit)
        .saturating_mul(unit)
}

/// Calls `f(offset, part)` on consecutive parts of `items` of `round` items each (the last may
/// be shorter), checking for an interrupt before each part; `f` runs its part in parallel.
pub fn rounds<T>(items: &mut [T], round: usize, mut f: impl FnMut(usize, &mut [T])) -> Result<()> {
    for (r, part) in items.chunks_mut(round.max(1)).enumerate() {
        check()?;
        f(r * round.max(1), part);
    }
    Ok(())
}

/// `(0..n).map(f)` computed in parallel, in interruptible rounds over items of `cost`
/// operations each; the same values as one parallel map.
pub fn par_map<T: Send>(n: usize, cost: u64, f: impl Fn(usize) -> T + Sync) -> Result<Vec<T>> {
    use rayon::prelude::*;
    let round = round_len(1, cost);
    let mut out = Vec::with_capacity(n);
    for start in (0..n).step_by(round.max(1)) {
        check()?;
        out.par_extend(
            (start..n.min(start.saturating_add(round)))
                .into_par_iter()
                .map(&f),
        );
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_raised_token_stops_the_rounds_of_its_call_only() {
        let cancel = Cancel::new();
        let mut items = vec![0u32; 10];
        let mut seen = Vec::new();
        let out = cancel.run(|| {
            rounds(&mut items, 3, |offset, part| {
                seen.push(offset);
                part.iter_mut().for_each(|v| *v = 1);
                if offset == 3 {
                    cancel.request();
                }
            })
        });
        assert_eq!(out, Err(Error::Interrupted));
        assert_eq!(seen, vec![0, 3]);
        assert_eq!(items.iter().sum::<u32>(), 6);
        // Outside the token's run, and under another token, checks pass.
        assert_eq!(check(), Ok(()));
        assert_eq!(Cancel::new().run(check), Ok(()));
        let watched = cancel.run(watch);
        assert!(watched.requested() && !watch().requested());
    }

    #[test]
    fn a_parallel_map_in_rounds_keeps_order_and_stops_when_asked() {
        assert_eq!(
            par_map(10_000, 1_000_000, |i| 2 * i),
            Ok((0..10_000).map(|i| 2 * i).collect::<Vec<_>>())
        );
        let cancel = Cancel::new();
        cancel.request();
        assert_eq!(cancel.run(|| par_map(3, 1, |i| i)), Err(Error::Interrupted));
    }

    #[test]
    fn rounds_are_whole_units_and_keep_threads_busy() {
        let threads = rayon::current_num_threads();
        assert_eq!(round_len(64, u64::MAX), threads * 64);
        let len = round_len(64, 1);
        assert_eq!(len % 64, 0);
        assert!(len >= (ROUND_OPS_PER_THREAD as usize) * threads - 64);
    }
}
