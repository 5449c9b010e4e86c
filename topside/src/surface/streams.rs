//! The messages streamed to the ground stations and how often, each station's own rate
//! where it set one (`MAV_CMD_SET_MESSAGE_INTERVAL`, per station as ArduPilot keeps it per
//! link): counted in the surface's control periods (the wall clock in front of a vehicle
//! on its own clock, the simulated one in lock-step).

use super::transport::StationId;
use std::collections::HashMap;

/// The streamed messages (MAVLink ids) and their default intervals (s); `None`: sent only
/// when asked (`MAV_CMD_REQUEST_MESSAGE`) or given an interval.
pub const STREAMS: &[(u32, Option<f64>)] = &[
    (HEARTBEAT, Some(1.0)),
    (SYS_STATUS, Some(1.0)),
    (SYSTEM_TIME, Some(1.0)),
    (ATTITUDE, Some(0.1)),
    (LOCAL_POSITION_NED, Some(0.1)),
    (GLOBAL_POSITION_INT, Some(0.1)),
    (SERVO_OUTPUT_RAW, Some(0.1)),
    (VFR_HUD, Some(0.1)),
    (BATTERY_STATUS, Some(1.0)),
    (EKF_STATUS_REPORT, Some(1.0)),
    (HOME_POSITION, None),
    (AUTOPILOT_VERSION, None),
];

/// MAVLink message ids.
pub const HEARTBEAT: u32 = 0;
/// `SYS_STATUS`.
pub const SYS_STATUS: u32 = 1;
/// `SYSTEM_TIME`.
pub const SYSTEM_TIME: u32 = 2;
/// `ATTITUDE`.
pub const ATTITUDE: u32 = 30;
/// `LOCAL_POSITION_NED`.
pub const LOCAL_POSITION_NED: u32 = 32;
/// `GLOBAL_POSITION_INT`.
pub const GLOBAL_POSITION_INT: u32 = 33;
/// `SERVO_OUTPUT_RAW`.
pub const SERVO_OUTPUT_RAW: u32 = 36;
/// `VFR_HUD`.
pub const VFR_HUD: u32 = 74;
/// `BATTERY_STATUS`.
pub const BATTERY_STATUS: u32 = 147;
/// `AUTOPILOT_VERSION`.
pub const AUTOPILOT_VERSION: u32 = 148;
/// `EKF_STATUS_REPORT`.
pub const EKF_STATUS_REPORT: u32 = 193;
/// `HOME_POSITION`.
pub const HOME_POSITION: u32 = 242;

/// Shortest interval a station may set (s): what a ground station needs at most, and the
/// control period's rate on a real vehicle.
pub const MIN_INTERVAL_S: f64 = 0.02;
/// Longest interval (s).
pub const MAX_INTERVAL_S: f64 = 3600.0;

/// A station's rate for one message.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Rate {
    /// Not sent to it.
    Off,
    /// Every this many seconds.
    Every(f64),
}

/// The schedule: the default rates, each station's own, and when each was last sent.
#[derive(Debug, Default)]
pub struct Streams {
    /// A station's own rate for a message.
    own: HashMap<(StationId, u32), Rate>,
    /// The control period each message was last sent at, to the stations on the default
    /// rate (`None`) or to one on its own.
    last: HashMap<(Option<StationId>, u32), u64>,
}

/// A message's default interval (s), `None` for one not streamed unless asked.
pub fn default_interval(id: u32) -> Option<Option<f64>> {
    STREAMS.iter().find(|(m, _)| *m == id).map(|(_, i)| *i)
}

impl Streams {
    /// `MAV_CMD_SET_MESSAGE_INTERVAL`'s interval in microseconds for `station`: -1 off, 0 the
    /// default, else the interval (clamped to [`MIN_INTERVAL_S`]); refused with the reason
    /// for a message not streamed here or an interval that is no number.
    pub fn set(
        &mut self,
        station: StationId,
        id: u32,
        interval_us: f32,
    ) -> std::result::Result<Rate, String> {
        if default_interval(id).is_none() {
            return Err(format!(
                "message {id} is not streamed here (streamed: {})",
                STREAMS
                    .iter()
                    .map(|(m, _)| m.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        if id == HEARTBEAT && interval_us != 0.0 {
            return Err("HEARTBEAT stays at 1 Hz: stations judge the link by it".into());
        }
        if !interval_us.is_finite() || (interval_us < 0.0 && interval_us != -1.0) {
            return Err(format!(
                "interval {interval_us} us: -1 (off), 0 (default) or up to {MAX_INTERVAL_S} s"
            ));
        }
        let s = f64::from(interval_us) * 1e-6;
        if s > MAX_INTERVAL_S {
            return Err(format!(
                "interval {s} s: at most {MAX_INTERVAL_S} s (-1 turns it off)"
            ));
        }
        let rate = if interval_us == -1.0 {
            Rate::Off
        } else if interval_us == 0.0 {
            self.own.remove(&(station, id));
            return Ok(self.rate(station, id));
        } else {
            Rate::Every(s.max(MIN_INTERVAL_S))
        };
        self.own.insert((station, id), rate);
        Ok(rate)
    }

    /// The rate `station` gets `id` at.
    pub fn rate(&self, station: StationId, id: u32) -> Rate {
        match self.own.get(&(station, id)) {
            Some(r) => *r,
            None => match default_interval(id).flatten() {
                Some(s) => Rate::Every(s),
                None => Rate::Off,
            },
        }
    }

    /// At control period `k` (of `period_s`), the stations due `id`: whether those on the
    /// default rate are, and the ones on their own rate that are. Each counted as sent.
    pub fn due(&mut self, id: u32, k: u64, period_s: f64) -> (bool, Vec<StationId>) {
        let periods = |s: f64| ((s / period_s).round() as u64).max(1);
        let mut is_due = |who: Option<StationId>, s: f64| {
            let last = self.last.get(&(who, id)).copied();
            let due = last.is_none_or(|l| k >= l + periods(s));
            if due {
                self.last.insert((who, id), k);
            }
            due
        };
        let default_due = match default_interval(id).flatten() {
            Some(s) => is_due(None, s),
            None => false,
        };
        let own: Vec<(StationId, Rate)> = self
            .own
            .iter()
            .filter(|((_, m), _)| *m == id)
            .map(|((s, _), r)| (*s, *r))
            .collect();
        let mut stations = Vec::new();
        for (s, r) in own {
            if let Rate::Every(every) = r {
                if is_due(Some(s), every) {
                    stations.push(s);
                }
            }
        }
        (default_due, stations)
    }

    /// Whether `station` set its own rate for `id` (it then gets `id` only on that rate).
    pub fn has_own(&self, station: StationId, id: u32) -> bool {
        self.own.contains_key(&(station, id))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_station_sets_its_own_rate_and_others_keep_the_default() {
        let mut s = Streams::default();
        assert!(
            matches!(s.set(1, ATTITUDE, 40_000.0), Ok(Rate::Every(r)) if (r - 0.04).abs() < 1e-9)
        );
        assert_eq!(s.rate(2, ATTITUDE), Rate::Every(0.1));
        // 1 s at 50 Hz: the default's stations 10 times, station 1 25 times.
        let (mut default, mut own) = (0, 0);
        for k in 0..50 {
            let (d, st) = s.due(ATTITUDE, k, 0.02);
            default += usize::from(d);
            own += st.iter().filter(|&&x| x == 1).count();
        }
        assert_eq!((default, own), (10, 25));
        assert_eq!(s.set(1, ATTITUDE, -1.0), Ok(Rate::Off));
        assert_eq!(s.due(ATTITUDE, 100, 0.02).1, Vec::<usize>::new());
        assert_eq!(s.set(1, ATTITUDE, 0.0), Ok(Rate::Every(0.1)));
        assert!(!s.has_own(1, ATTITUDE));
    }

    #[test]
    fn bad_intervals_and_unknown_messages_are_refused_in_words() {
        let mut s = Streams::default();
        for (id, us) in [
            (ATTITUDE, f32::NAN),
            (ATTITUDE, -5.0),
            (ATTITUDE, 1e10),
            (HEARTBEAT, 5e5),
            (9999, 1e5),
        ] {
            let why = s.set(1, id, us).unwrap_err();
            assert!(
                crate::surface::words::internal_name(&why).is_none(),
                "{why}"
            );
        }
        assert_eq!(s.set(1, HOME_POSITION, 1e6), Ok(Rate::Every(1.0)));
        assert_eq!(s.rate(2, HOME_POSITION), Rate::Off);
        assert_eq!(s.set(1, SYSTEM_TIME, 1.0), Ok(Rate::Every(MIN_INTERVAL_S)));
    }
}
