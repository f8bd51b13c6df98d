//! The memory budget: how many bytes relight may hold at once, and admission of work
//! against it.
//!
//! The budget defaults to [`DEFAULT_FRACTION`] of the memory this process may use: the
//! cgroup limit when there is one (a container), else the machine's `MemTotal`. Work that
//! allocates in proportion to its input (a render's view buffer, a batch's answers, a
//! bake's matrices) first estimates its peak and reserves it:
//! - an estimate over the per-request share ([`MemoryBudget::request_max`]) can never
//!   run, and is refused ([`BudgetError::TooLarge`], HTTP 422);
//! - an estimate that fits the share but not the bytes free right now waits for nothing:
//!   it is refused for now ([`BudgetError::Busy`], HTTP 503 with `Retry-After`).
//!
//! A [`Reservation`] gives its bytes back when dropped.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// Share of the available memory taken as the default budget.
pub const DEFAULT_FRACTION: f64 = 0.5;
/// Share of the budget one request may reserve.
pub const REQUEST_SHARE: f64 = 0.5;
/// Share of the budget the server's view-buffer cache may keep.
pub const VIEW_CACHE_SHARE: f64 = 0.25;
/// The smallest budget accepted, bytes.
pub const MIN_BUDGET: u64 = 64 << 20;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BudgetError {
    #[error(
        "{what} needs about {need} of memory; one request may use at most {limit} \
         (half of the memory budget less the loaded scenes and the view cache; --memory-budget)",
        need = human_bytes(*need), limit = human_bytes(*limit)
    )]
    TooLarge { what: String, need: u64, limit: u64 },
    #[error(
        "{what} needs about {need} of memory and only {free} of the memory budget is free \
         right now; retry shortly",
        need = human_bytes(*need), free = human_bytes(*free)
    )]
    Busy { what: String, need: u64, free: u64 },
}

/// A byte budget shared by every request of a process. Three things draw on it:
/// - *pinned* bytes: data held for the process's life (the loaded scenes);
/// - the view cache's allowance ([`VIEW_CACHE_SHARE`]), kept aside whole;
/// - *reserved* bytes: the estimated peaks of requests in flight.
#[derive(Debug)]
pub struct MemoryBudget {
    total: u64,
    used: AtomicU64,
    pinned: AtomicU64,
}

/// Bytes held against a [`MemoryBudget`]: reserved by a request
/// ([`MemoryBudget::reserve`]) or pinned by loaded data ([`MemoryBudget::pin`]); given
/// back when dropped.
#[derive(Debug)]
pub struct Reservation {
    budget: Arc<MemoryBudget>,
    bytes: u64,
    pinned: bool,
}

impl Drop for Reservation {
    fn drop(&mut self) {
        let held = if self.pinned {
            &self.budget.pinned
        } else {
            &self.budget.used
        };
        held.fetch_sub(self.bytes, Ordering::AcqRel);
    }
}

impl Reservation {
    pub fn bytes(&self) -> u64 {
        self.bytes
    }
}

impl MemoryBudget {
    pub fn new(total: u64) -> Arc<MemoryBudget> {
        Arc::new(MemoryBudget {
            total: total.max(MIN_BUDGET),
            used: AtomicU64::new(0),
            pinned: AtomicU64::new(0),
        })
    }

    /// Pins `bytes` for as long as the returned guard lives (data that stays loaded).
    pub fn pin(self: &Arc<Self>, bytes: u64) -> Reservation {
        self.pinned.fetch_add(bytes, Ordering::AcqRel);
        Reservation {
            budget: self.clone(),
            bytes,
            pinned: true,
        }
    }

    /// Bytes pinned by loaded data.
    pub fn pinned(&self) -> u64 {
        self.pinned.load(Ordering::Acquire)
    }

    /// Bytes that requests may reserve in all: the budget less the pinned data and the
    /// view cache's allowance.
    fn for_requests(&self) -> u64 {
        self.total
            .saturating_sub(self.pinned())
            .saturating_sub(self.view_cache_max())
    }

    /// The budget in bytes.
    pub fn total(&self) -> u64 {
        self.total
    }

    /// The most one request may reserve, bytes: [`REQUEST_SHARE`] of the budget, and no
    /// more than what the loaded scenes and the view cache leave.
    pub fn request_max(&self) -> u64 {
        ((self.total as f64 * REQUEST_SHARE) as u64).min(self.for_requests())
    }

    /// The most the view cache may keep, bytes.
    pub fn view_cache_max(&self) -> u64 {
        (self.total as f64 * VIEW_CACHE_SHARE) as u64
    }

    /// Bytes reserved right now.
    pub fn used(&self) -> u64 {
        self.used.load(Ordering::Acquire)
    }

    /// Reserves `bytes` for `what` (a phrase such as "a 4096×4096 view buffer").
    pub fn reserve(self: &Arc<Self>, bytes: u64, what: &str) -> Result<Reservation, BudgetError> {
        let limit = self.request_max();
        if bytes > limit {
            return Err(BudgetError::TooLarge {
                what: what.into(),
                need: bytes,
                limit,
            });
        }
        let room = self.for_requests();
        let mut cur = self.used.load(Ordering::Acquire);
        loop {
            let free = room.saturating_sub(cur);
            if bytes > free {
                return Err(BudgetError::Busy {
                    what: what.into(),
                    need: bytes,
                    free,
                });
            }
            match self.used.compare_exchange_weak(
                cur,
                cur + bytes,
                Ordering::AcqRel,
                Ordering::Acquire,
            ) {
                Ok(_) => {
                    return Ok(Reservation {
                        budget: self.clone(),
                        bytes,
                        pinned: false,
                    })
                }
                Err(now) => cur = now,
            }
        }
    }
}

/// Memory this process may use, bytes: the cgroup limit (v2 or v1) when set, else the
/// machine's `MemTotal`; None when neither can be read.
pub fn available_memory() -> Option<u64> {
    let cgroup = [
        "/sys/fs/cgroup/memory.max",
        "/sys/fs/cgroup/memory/memory.limit_in_bytes",
    ]
    .iter()
    .filter_map(|p| std::fs::read_to_string(p).ok())
    .filter_map(|s| s.trim().parse::<u64>().ok())
    // v1 reports "no limit" as a huge number.
    .find(|&v| v < 1 << 60);
    let total = std::fs::read_to_string("/proc/meminfo").ok().and_then(|s| {
        s.lines()
            .find(|l| l.starts_with("MemTotal:"))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|kb| kb.parse::<u64>().ok())
            .map(|kb| kb * 1024)
    });
    match (cgroup, total) {
        (Some(c), Some(t)) => Some(c.min(t)),
        (c, t) => c.or(t),
    }
}

/// The default budget: [`DEFAULT_FRACTION`] of [`available_memory`], or 2 GiB when it
/// cannot be read.
pub fn default_budget() -> u64 {
    available_memory()
        .map(|m| (m as f64 * DEFAULT_FRACTION) as u64)
        .unwrap_or(2 << 30)
        .max(MIN_BUDGET)
}

/// Parses a budget: bytes with an optional unit (`K`, `M`, `G`, `T`, binary, with or
/// without `iB`/`B`), or a percentage of [`available_memory`] (`"40%"`).
pub fn parse_budget(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let bad = || {
        format!("memory budget '{s}': give bytes with an optional unit (e.g. 4G, 512M) or a percentage (e.g. 40%)")
    };
    let bytes = if let Some(p) = t.strip_suffix('%') {
        let p: f64 = p.trim().parse().map_err(|_| bad())?;
        if !(p > 0.0 && p <= 100.0) {
            return Err(format!(
                "memory budget '{s}': a percentage must be in (0, 100]"
            ));
        }
        let avail = available_memory().ok_or(
            "memory budget as a percentage: the machine's memory cannot be read; give bytes",
        )?;
        (avail as f64 * p / 100.0) as u64
    } else {
        let upper = t.to_ascii_uppercase();
        let num_end = upper
            .find(|c: char| !(c.is_ascii_digit() || c == '.'))
            .unwrap_or(upper.len());
        let (num, unit) = upper.split_at(num_end);
        let x: f64 = num.parse().map_err(|_| bad())?;
        let mult = match unit.trim().trim_end_matches("IB").trim_end_matches('B') {
            "" => 1u64,
            "K" => 1 << 10,
            "M" => 1 << 20,
            "G" => 1 << 30,
            "T" => 1 << 40,
            _ => return Err(bad()),
        };
        let v = x * mult as f64;
        if !v.is_finite() || v >= 1e19 {
            return Err(bad());
        }
        v as u64
    };
    if bytes < MIN_BUDGET {
        return Err(format!(
            "memory budget '{s}' is below the minimum of {}",
            human_bytes(MIN_BUDGET)
        ));
    }
    Ok(bytes)
}

/// "1.5 GB", "640 MB", "12 kB" (decimal units, as people read them).
pub fn human_bytes(b: u64) -> String {
    let b = b as f64;
    if b >= 1e9 {
        format!("{:.1} GB", b / 1e9)
    } else if b >= 1e6 {
        format!("{:.0} MB", b / 1e6)
    } else if b >= 1e3 {
        format!("{:.0} kB", b / 1e3)
    } else {
        format!("{b} bytes")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reservations_add_up_and_are_returned_on_drop() {
        // 1000 MB: 250 MB kept for the view cache, 750 MB for requests.
        let b = MemoryBudget::new(1000 << 20);
        let r1 = b.reserve(300 << 20, "a").unwrap();
        let r2 = b.reserve(300 << 20, "b").unwrap();
        assert_eq!(b.used(), 600 << 20);
        match b.reserve(200 << 20, "c") {
            Err(BudgetError::Busy { free, .. }) => assert_eq!(free, 150 << 20),
            other => panic!("expected Busy, got {other:?}"),
        }
        drop(r1);
        let _r3 = b.reserve(200 << 20, "c").unwrap();
        drop(r2);
        assert_eq!(b.used(), 200 << 20);
    }

    #[test]
    fn loaded_scenes_shrink_what_requests_may_take() {
        let b = MemoryBudget::new(1000 << 20);
        assert_eq!(b.request_max(), 500 << 20);
        let pin = b.pin(600 << 20);
        // 1000 − 600 (scenes) − 250 (view cache) = 150 MB left for requests.
        assert_eq!(b.request_max(), 150 << 20);
        assert!(matches!(
            b.reserve(200 << 20, "x"),
            Err(BudgetError::TooLarge { .. })
        ));
        drop(pin);
        assert!(b.reserve(200 << 20, "x").is_ok());
    }

    #[test]
    fn a_request_over_its_share_is_too_large_even_when_the_budget_is_free() {
        let b = MemoryBudget::new(1000 << 20);
        let e = b.reserve(600 << 20, "a 4096×4096 view buffer").unwrap_err();
        assert!(matches!(e, BudgetError::TooLarge { .. }));
        let msg = e.to_string();
        assert!(msg.contains("4096×4096") && msg.contains("524 MB"), "{msg}");
        assert_eq!(b.used(), 0);
    }

    #[test]
    fn budgets_parse_with_units_and_refuse_nonsense() {
        assert_eq!(parse_budget("4G").unwrap(), 4 << 30);
        assert_eq!(parse_budget("512MiB").unwrap(), 512 << 20);
        assert_eq!(parse_budget("1.5g").unwrap(), 3 << 29);
        assert_eq!(parse_budget("100000000").unwrap(), 100_000_000);
        for bad in ["", "abc", "4X", "-1G", "1e30", "1K", "0%", "150%"] {
            assert!(parse_budget(bad).is_err(), "{bad}");
        }
    }
}
