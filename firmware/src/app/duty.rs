//! The PWM map: ESC pulse widths to duty cycles and back.

use controller_core::alloc::{PwmMap, ESC_MAX_US, ESC_MIN_US, ESC_NEUTRAL_US};
use embedded_hal::pwm::SetDutyCycle;

/// Duty for a pulse width: `pulse_us / period_us * max_duty`, rounded, with the pulse clamped
/// to the map's `[min_us, max_us]` and then to the ESC's range first (NaN -> the ESC's
/// neutral, [`ESC_NEUTRAL_US`]): no pulse outside 1100-1900 us ever reaches an output.
pub fn duty_for_pulse(pulse_us: f32, map: &PwmMap, period_us: u32, max_duty: u16) -> u16 {
    use controller_core::math::clamp;
    // `math::clamp`, not `f32::clamp`: the bounds come from the PWM map at run time, and
    // `f32::clamp` panics when `min > max`; the firmware has no panic path.
    let p = if pulse_us.is_nan() {
        ESC_NEUTRAL_US
    } else {
        clamp(
            clamp(pulse_us, map.min_us, map.max_us),
            ESC_MIN_US,
            ESC_MAX_US,
        )
    };
    // `as` saturates (a negative pulse is 0 us).
    let p = u64::from((p + 0.5) as u32);
    let period = u64::from(period_us.max(1));
    let max = u64::from(max_duty);
    ((p * max + period / 2) / period).min(max) as u16
}

/// Pulse width a duty gives, microseconds (what the ESC sees), rounded.
pub fn pulse_for_duty(duty: u16, period_us: u32, max_duty: u16) -> u16 {
    let m = u64::from(max_duty.max(1));
    let p = (u64::from(duty) * u64::from(period_us) + m / 2) / m;
    p.min(u64::from(u16::MAX)) as u16
}

/// Write the duty cycles for `pulse_us` (ESC pulse widths, microseconds) to the three
/// outputs; returns the duties and whether every output took its duty.
pub(super) fn set_duties<P: SetDutyCycle>(
    pwm: &mut [P; 3],
    map: &PwmMap,
    period_us: u32,
    pulse_us: [f32; 3],
) -> ([u16; 3], bool) {
    let mut duty = [0; 3];
    let mut ok = true;
    for ((d, o), p) in duty.iter_mut().zip(pwm).zip(pulse_us) {
        *d = duty_for_pulse(p, map, period_us, o.max_duty_cycle());
        ok &= o.set_duty_cycle(*d).is_ok();
    }
    (duty, ok)
}
