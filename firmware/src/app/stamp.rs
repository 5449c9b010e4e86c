//! The clock gate's memory: the latest accepted surface time stamp of one kind.

/// Fixed-rate mode: how far a surface time stamp (`Nav`, `Imu`, `Pressure`) may run ahead
/// of the previous one of its kind beyond the time that passed on the vehicle's clock
/// (0.5 s: the tether's jitter and the clocks' drift are milliseconds). One frame stamped
/// far ahead is refused `ClockAhead` and moves nothing.
pub const STAMP_AHEAD_TOLERANCE_US: u64 = 500_000;

/// The latest accepted surface time stamp of one kind and the vehicle's time it came at.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Stamp {
    /// `(stamp, vehicle time)`; `None` before the first of the session.
    last: Option<(u64, u64)>,
}

impl Stamp {
    /// The surface clock now, as projected from the latest stamp by the vehicle's clock.
    pub(super) fn projected(&self, now_us: u64) -> Option<u64> {
        self.last
            .map(|(t, rx)| t.saturating_add(now_us.saturating_sub(rx)))
    }

    /// True when `t_us` is not too far ahead of the projection (the first stamp of a session
    /// sets it).
    pub(super) fn ok(&self, t_us: u64, now_us: u64) -> bool {
        self.projected(now_us)
            .is_none_or(|p| t_us <= p.saturating_add(STAMP_AHEAD_TOLERANCE_US))
    }

    /// Take `t_us` (accepted) at `now_us`.
    pub(super) fn take(&mut self, t_us: u64, now_us: u64) {
        let p = self.projected(now_us).unwrap_or(t_us);
        self.last = Some((t_us.max(p), now_us));
    }
}
