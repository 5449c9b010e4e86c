//! The leak probe's debounce: wet for a confirmation time before the leak counts; once
//! counted it stays until the probe reads dry for the same time (a probe that dries in a
//! wave is still in a leaking enclosure).

use super::confirm::Confirm;

/// Debounced leak state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LeakDebounce {
    confirm_us: u64,
    wet: Confirm,
    dry: Confirm,
    leak: bool,
}

impl LeakDebounce {
    /// A leak counts after `confirm_us` of wet readings.
    pub fn new(confirm_us: u64) -> Self {
        Self {
            confirm_us,
            wet: Confirm::default(),
            dry: Confirm::default(),
            leak: false,
        }
    }

    /// Feed the probe at `now_us`; true while a leak counts.
    pub fn update(&mut self, now_us: u64, wet: bool) -> bool {
        let wet_long = self.wet.update(now_us, wet, self.confirm_us);
        let dry_long = self.dry.update(now_us, !wet, self.confirm_us);
        if wet_long {
            self.leak = true;
        } else if dry_long {
            self.leak = false;
        }
        self.leak
    }
}
