//! Admission of heavy work: a concurrency limit with load shedding, the memory budget,
//! and cancellation of work whose client has gone.
//!
//! Every handler whose cost grows with its input (renders, batches, point gathers, exact
//! solves, the optimizer, large bodies) runs through [`AppState::heavy`]:
//! 1. it takes one of `max_concurrent` permits, waiting at most `queue_wait` behind at most
//!    `4 × max_concurrent` others; otherwise 503 with `Retry-After` (load shedding);
//! 2. it reserves its estimated peak bytes from the memory budget (422 when one request
//!    could never fit, 503 when the budget is momentarily full);
//! 3. it runs on tokio's blocking pool with a [`Cancel`] flag that is raised when the
//!    request's future is dropped (the client went away or the request timed out); long
//!    loops check it and stop.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

use super::{AppError, AppState};
use crate::budget::BudgetError;

/// How many heavy requests may wait for a permit, per permit.
pub(crate) const QUEUE_PER_PERMIT: usize = 4;

pub use crate::model::Cancel;

/// Raises its [`Cancel`] when dropped unless disarmed.
struct CancelOnDrop(Cancel, bool);

impl Drop for CancelOnDrop {
    fn drop(&mut self) {
        if self.1 {
            self.0.cancel();
        }
    }
}

impl From<BudgetError> for AppError {
    fn from(e: BudgetError) -> Self {
        match e {
            BudgetError::TooLarge { .. } => AppError::Invalid(e.to_string()),
            BudgetError::Busy { .. } => AppError::Unavailable {
                detail: e.to_string(),
                progress: None,
            },
        }
    }
}

/// Counts a waiter for as long as it lives.
struct Waiting<'a>(&'a AtomicUsize);

impl Drop for Waiting<'_> {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::AcqRel);
    }
}

impl AppState {
    /// Runs `f` on the blocking pool under the concurrency limit and the memory budget
    /// (`bytes` = the work's estimated peak, described by `what` in refusals).
    pub(crate) async fn heavy<T: Send + 'static>(
        self: &Arc<Self>,
        bytes: u64,
        what: &str,
        f: impl FnOnce(&Cancel) -> Result<T, AppError> + Send + 'static,
    ) -> Result<T, AppError> {
        let permit = match self.heavy_permits.clone().try_acquire_owned() {
            Ok(p) => p,
            Err(_) => {
                let max_wait = QUEUE_PER_PERMIT * self.config.max_concurrent.max(1);
                if self.heavy_waiting.fetch_add(1, Ordering::AcqRel) >= max_wait {
                    self.heavy_waiting.fetch_sub(1, Ordering::AcqRel);
                    return Err(overloaded(self.config.max_concurrent, "the queue is full"));
                }
                let _w = Waiting(&self.heavy_waiting);
                let acquire = self.heavy_permits.clone().acquire_owned();
                match tokio::time::timeout(self.config.queue_wait, acquire).await {
                    Ok(Ok(p)) => p,
                    _ => {
                        return Err(overloaded(
                            self.config.max_concurrent,
                            &format!(
                                "no slot freed within {} ms",
                                self.config.queue_wait.as_millis()
                            ),
                        ))
                    }
                }
            }
        };
        let reservation = self.budget.reserve(bytes, what)?;
        let cancel = Cancel::default();
        let mut guard = CancelOnDrop(cancel.clone(), true);
        let result = tokio::task::spawn_blocking(move || {
            let _permit = permit;
            let _reservation = reservation;
            f(&cancel)
        })
        .await;
        guard.1 = false;
        match result {
            Ok(r) => r,
            Err(e) if e.is_panic() => {
                let msg = e
                    .into_panic()
                    .downcast::<String>()
                    .map(|s| *s)
                    .or_else(|p| p.downcast::<&str>().map(|s| s.to_string()))
                    .unwrap_or_else(|_| "unknown panic".into());
                Err(AppError::Internal(format!("worker panicked: {msg}")))
            }
            Err(e) => Err(AppError::Internal(format!("worker failed: {e}"))),
        }
    }
}

fn overloaded(max: usize, why: &str) -> AppError {
    AppError::Unavailable {
        detail: format!(
            "the server is busy: {max} heavy requests are running and {why}; retry shortly"
        ),
        progress: None,
    }
}

/// Default number of heavy requests running at once: the cores available.
pub(crate) fn default_max_concurrent() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(2)
        .max(2)
}

/// Default time a heavy request may wait for a slot: longer than one legitimate heavy
/// request takes on two cores (a scene's first daylight grid gathers for about 3 s), so a
/// page's small requests queued behind it are served, not shed; the queue's length
/// (four per slot) still bounds the waiting.
pub(crate) const DEFAULT_QUEUE_WAIT: Duration = Duration::from_secs(10);
