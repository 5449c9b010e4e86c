//! A condition confirmed after it has held for a while (the failsafes' delays).

/// A timer that confirms a condition after it has held for a while.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Confirm {
    since_us: Option<u64>,
}

impl Confirm {
    /// Feed the condition at `now_us`; true once it has held for `hold_us`.
    pub fn update(&mut self, now_us: u64, condition: bool, hold_us: u64) -> bool {
        if !condition {
            self.since_us = None;
            return false;
        }
        let since = *self.since_us.get_or_insert(now_us);
        now_us.saturating_sub(since) >= hold_us
    }
}
