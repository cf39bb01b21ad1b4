//! The thread pool every heavy call runs on, sized by `set_num_threads` and rebuilt in a forked
//! child, and the wait that lets Ctrl-C stop a call.
//!
//! Calls run on a rayon pool of our own rather than rayon's global one, for two reasons: its size
//! can change at run time (the global pool is fixed once started), and a forked child can get a
//! fresh one. After `fork` only the forking thread exists in the child, so a pool inherited from
//! the parent would wait forever on workers that are gone; Python's `os.register_at_fork` calls
//! [`after_fork_in_child`], which drops the reference to the parent's pool (without joining its
//! threads, which do not exist) so the next call builds a new pool in the child.

//!
//! Python runs signal handlers (Ctrl-C's `KeyboardInterrupt`) only on the main thread, between
//! bytecodes, so a call that keeps its thread in Rust would ignore Ctrl-C until it returns. Each
//! call therefore runs as a job on the pool under a [`Cancel`] token while its own thread waits,
//! with the GIL released, and asks Python for pending signals every [`SIGNAL_POLL`]. When a
//! handler raises, the token is raised, the core stops at its next check between rounds of work
//! (`softshadows_core::interrupt`), and the handler's exception is raised in place of a result.

use crate::error::to_py;
use pyo3::prelude::*;
use softshadows_core::interrupt::Cancel;
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// How often a waiting call asks Python for pending signals.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// The configured pool (`None`: not built yet) and its requested size (0: one per core).
struct State {
    pool: Option<Arc<rayon::ThreadPool>>,
    threads: usize,
}

static STATE: Mutex<State> = Mutex::new(State {
    pool: None,
    threads: 0,
});

/// The pool, built on first use.
fn pool() -> PyResult<Arc<rayon::ThreadPool>> {
    let mut state = STATE.lock().map_err(|_| {
        pyo3::exceptions::PyRuntimeError::new_err("softshadows: the thread-pool lock is poisoned")
    })?;
    if let Some(pool) = &state.pool {
        return Ok(pool.clone());
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(state.threads)
        .thread_name(|i| format!("softshadows-{i}"))
        .build()
        .map_err(|e| {
            pyo3::exceptions::PyRuntimeError::new_err(format!(
                "softshadows: cannot start the thread pool: {e}"
            ))
        })?;
    let pool = Arc::new(pool);
    state.pool = Some(pool.clone());
    Ok(pool)
}

/// Runs `f` with the GIL released on the configured pool (on the calling thread if the pool
/// cannot start: the results are the same, only the thread count differs), stopping it when a
/// signal handler raises while it runs (see the module doc); core errors become Python's.
pub fn detached<T: Send>(
    py: Python<'_>,
    f: impl FnOnce() -> softshadows_core::Result<T> + Send,
) -> PyResult<T> {
    let cancel = Cancel::new();
    let Ok(pool) = pool() else {
        return py.detach(|| cancel.run(f)).map_err(to_py);
    };
    let (sender, results) = mpsc::channel();
    pool.in_place_scope(|scope| {
        let token = cancel.clone();
        scope.spawn(move |_| {
            // The receiver outlives the scope, so the send cannot fail.
            let _ = sender.send(token.run(f));
        });
        wait_for(py, results, &cancel)
    })
}

/// Waits for the call's result, polling for signals; on a raised handler, stops the call and
/// returns the handler's exception.
fn wait_for<T: Send>(
    py: Python<'_>,
    mut results: Receiver<softshadows_core::Result<T>>,
    cancel: &Cancel,
) -> PyResult<T> {
    loop {
        // The receiver travels into the GIL-free wait and back (it may not be shared).
        let (back, received) = py.detach(move || {
            let received = results.recv_timeout(SIGNAL_POLL);
            (results, received)
        });
        results = back;
        match received {
            Ok(out) => return out.map_err(to_py),
            Err(RecvTimeoutError::Timeout) => {
                if let Err(signal) = py.check_signals() {
                    cancel.request();
                    // The call returns at its next check; its result (interrupted) is dropped.
                    let _ = py.detach(move || results.recv());
                    return Err(signal);
                }
            }
            Err(RecvTimeoutError::Disconnected) => {
                return Err(pyo3::exceptions::PyRuntimeError::new_err(
                    "softshadows: a worker stopped without a result",
                ))
            }
        }
    }
}

/// Sets the number of worker threads of every heavy call (0: one per core); results do not
/// depend on it.
#[pyfunction]
pub fn set_num_threads(threads: usize) -> PyResult<()> {
    let mut state = STATE.lock().map_err(|_| {
        pyo3::exceptions::PyRuntimeError::new_err("softshadows: the thread-pool lock is poisoned")
    })?;
    state.threads = threads;
    state.pool = None;
    Ok(())
}

/// The number of worker threads of the pool.
#[pyfunction]
pub fn num_threads() -> PyResult<usize> {
    Ok(pool()?.current_num_threads())
}

/// Forgets the parent's pool and GPU context in a forked child (see the module doc), so that its
/// next call builds its own of each.
#[pyfunction]
pub fn after_fork_in_child() {
    // First, as it takes no lock: the GPU context's reset cannot wait on the pool's lock below.
    softshadows_core::gpu::after_fork_in_child();
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
