//! Simulated time as the vehicle counts it: the microsecond stamps (`t_us`) of the tether's
//! commands and of the sensors' samples, from the simulation's seconds.

/// A simulated time (s) as a microsecond stamp: rounded to the nearest microsecond, 0 before
/// the start.
pub fn us(t_s: f64) -> u64 {
    (t_s * 1e6).round().max(0.0) as u64
}
