//! The thread pool every heavy call runs on, sized by `set_num_threads` and rebuilt in a forked
//! child.
//!
//! Calls run on a rayon pool of our own rather than rayon's global one, for two reasons: its size
//! can change at run time (the global pool is fixed once started), and a forked child can get a
//! fresh one. After `fork` only the forking thread exists in the child, so a pool inherited from
//! the parent would wait forever on workers that are gone; Python's `os.register_at_fork` calls
//! [`after_fork_in_child`], which drops the reference to the parent's pool (without joining its
//! threads, which do not exist) so the next call builds a new pool in the child.

use pyo3::prelude::*;
use std::sync::{Arc, Mutex};

/// The configured pool (`None`: not built yet) and its requested size (0: one per core).
struct State {
    pool: Option<Arc<rayon::ThreadPool>>,
    threads: usize,
}

static STATE: Mutex<State> = Mutex::new(State { pool: None, threads: 0 });

/// The pool, built on first use.
fn pool() -> PyResult<Arc<rayon::ThreadPool>> {
    let mut state = STATE.lock().map_err(|_| pyo3::exceptions::PyRuntimeError::new_err("softshadows: the thread-pool lock is poisoned"))?;
    if let Some(pool) = &state.pool {
        return Ok(pool.clone());
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(state.threads)
        .thread_name(|i| format!("softshadows-{i}"))
        .build()
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(format!("softshadows: cannot start the thread pool: {e}")))?;
    let pool = Arc::new(pool);
    state.pool = Some(pool.clone());
    Ok(pool)
}

/// Runs `f` with the GIL released, on the configured pool (on rayon's global pool if ours
/// cannot start: the results are the same, only the thread count differs).
pub fn detached<T: Send>(py: Python<'_>, f: impl FnOnce() -> T + Send) -> T {
    match pool() {
        Ok(pool) => py.detach(|| pool.install(f)),
        Err(_) => py.detach(f),
    }
}

/// Sets the number of worker threads of every heavy call (0: one per core); results do not
/// depend on it.
#[pyfunction]
pub fn set_num_threads(threads: usize) -> PyResult<()> {
    let mut state = STATE.lock().map_err(|_| pyo3::exceptions::PyRuntimeError::new_err("softshadows: the thread-pool lock is poisoned"))?;
    state.threads = threads;
    state.pool = None;
    Ok(())
}

/// The number of worker threads of the pool.
#[pyfunction]
pub fn num_threads() -> PyResult<usize> {
    Ok(pool()?.current_num_threads())
}

/// Forgets the parent's pool in a forked child (see the module doc).
#[pyfunction]
pub fn after_fork_in_child() {
    // The child has one thread, so no lock is held by another; a poisoned lock keeps its data.
    let mut state = match STATE.lock() {
        Ok(state) => state,
        Err(poisoned) => poisoned.into_inner(),
    };
    // Leaked, not dropped: dropping would signal threads that only exist in the parent.
    if let Some(pool) = state.pool.take() {
        std::mem::forget(pool);
    }
}
