//! The pilot's joystick as ArduSub reads it (`ArduSub/joystick.cpp`): the buttons of
//! `MANUAL_CONTROL` (`buttons`, buttons 0-15; the ArduPilot dialect the surface parses has no
//! `buttons2`) each run the function of `BTNn_FUNCTION`, or of `BTNn_SFUNCTION` while a
//! button whose function is shift is held, with ArduSub's defaults; the sticks are scaled by
//! the joystick gain (`JS_GAIN_DEFAULT` at start, stepped between `JS_GAIN_MIN` and
//! `JS_GAIN_MAX` in `JS_GAIN_STEPS` steps by the gain buttons).
//!
//! A button acts once per press: on the frame where it goes down, never while held. A frame
//! acts only when it belongs to the commander's live stream: another station's is ignored
//! (`commander`), one whose MAVLink sequence number is not newer than the previous frame's
//! (a replay or a duplicate) is ignored, and after the stream lapsed (no frame for
//! `MANUAL_CONTROL_TIMEOUT`) or control changed hands, the buttons held in the first frame
//! count as held before it: they act only once released and pressed again.

use anyhow::{bail, Result};

/// Buttons read (`MANUAL_CONTROL.buttons`).
pub const BUTTONS: usize = 16;

/// ArduSub's button functions (`AP_JSButton.h`) that act here.
pub mod function {
    /// Nothing.
    pub const NONE: u8 = 0;
    /// Shift: the other buttons run their shift function while it is held.
    pub const SHIFT: u8 = 1;
    /// Arm if disarmed, disarm if armed.
    pub const ARM_TOGGLE: u8 = 2;
    /// Arm.
    pub const ARM: u8 = 3;
    /// Disarm.
    pub const DISARM: u8 = 4;
    /// MANUAL.
    pub const MODE_MANUAL: u8 = 5;
    /// STABILIZE.
    pub const MODE_STABILIZE: u8 = 6;
    /// ALT_HOLD.
    pub const MODE_DEPTH_HOLD: u8 = 7;
    /// POSHOLD.
    pub const MODE_POSHOLD: u8 = 8;
    /// AUTO.
    pub const MODE_AUTO: u8 = 9;
    /// GUIDED.
    pub const MODE_GUIDED: u8 = 11;
    /// The gain between 50 % and 100 %.
    pub const GAIN_TOGGLE: u8 = 41;
    /// The gain one step up.
    pub const GAIN_INC: u8 = 42;
    /// The gain one step down.
    pub const GAIN_DEC: u8 = 43;
    /// Largest function number ArduSub defines (custom 6).
    pub const LAST: u8 = 96;
}

/// ArduSub's defaults (`default_js_buttons`): function and shift function of buttons 0-15.
/// Those with no meaning here (the camera mount 21-23, input hold 48, lights 32-33, trims
/// 44-47) are listed as ArduSub lists them and do nothing.
pub const DEFAULTS: [[u8; 2]; BUTTONS] = [
    [0, 0],
    [5, 0],
    [7, 0],
    [6, 0],
    [4, 0],
    [1, 0],
    [3, 0],
    [21, 0],
    [48, 0],
    [23, 0],
    [22, 0],
    [42, 47],
    [43, 46],
    [33, 45],
    [32, 44],
    [0, 0],
];

/// The joystick's parameters, as a ground station shows them (numbers).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JoystickSettings {
    /// `BTNn_FUNCTION`, `BTNn_SFUNCTION`.
    pub buttons: [[f32; 2]; BUTTONS],
    /// `JS_GAIN_DEFAULT` (0.1-1).
    pub gain_default: f32,
    /// `JS_GAIN_MAX` (0.2-1).
    pub gain_max: f32,
    /// `JS_GAIN_MIN` (0.1-0.8, at most `JS_GAIN_MAX`).
    pub gain_min: f32,
    /// `JS_GAIN_STEPS` (1-10 whole; 1 always `JS_GAIN_DEFAULT`).
    pub gain_steps: f32,
}

/// What a button press does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    /// Arm.
    Arm,
    /// Disarm.
    Disarm,
    /// Arm or disarm, whichever the vehicle is not.
    ArmToggle,
    /// A mode (ArduSub's custom mode number).
    Mode(u32),
    /// The gain one step up (`true`) or down.
    GainStep(bool),
    /// The gain between 50 % and 100 %.
    GainToggle,
    /// A function with no meaning on this vehicle (its number).
    Nothing(u8),
}

impl Default for JoystickSettings {
    fn default() -> Self {
        Self {
            buttons: DEFAULTS.map(|[f, s]| [f32::from(f), f32::from(s)]),
            gain_default: 0.5,
            gain_max: 1.0,
            gain_min: 0.25,
            gain_steps: 4.0,
        }
    }
}

impl JoystickSettings {
    /// ArduSub's ranges, with a reason naming the parameter and the range.
    pub fn check(&self) -> Result<()> {
        let last = f32::from(function::LAST);
        for (i, pair) in self.buttons.iter().enumerate() {
            for (f, which) in pair.iter().zip(["FUNCTION", "SFUNCTION"]) {
                if !(f.is_finite() && f.fract() == 0.0 && (0.0..=last).contains(f)) {
                    bail!("BTN{i}_{which} must be a whole function number, allowed 0 to {last}");
                }
            }
        }
        let within = |v: f32, lo: f32, hi: f32| v.is_finite() && (lo..=hi).contains(&v);
        if !within(self.gain_default, 0.1, 1.0) {
            bail!("JS_GAIN_DEFAULT must be 0.1-1");
        }
        if !within(self.gain_max, 0.2, 1.0) {
            bail!("JS_GAIN_MAX must be 0.2-1");
        }
        if !within(self.gain_min, 0.1, 0.8) || self.gain_min > self.gain_max {
            bail!("JS_GAIN_MIN must be 0.1-0.8 and at most JS_GAIN_MAX");
        }
        let n = self.gain_steps;
        if !(within(n, 1.0, 10.0) && n.fract() == 0.0) {
            bail!("JS_GAIN_STEPS must be a whole number, allowed 1 to 10");
        }
        Ok(())
    }

    /// Button `i`'s function (its shift function while shift is held).
    pub fn function(&self, i: usize, shift: bool) -> u8 {
        self.buttons
            .get(i)
            .and_then(|p| p.get(usize::from(shift)))
            .map_or(function::NONE, |&f| f as u8)
    }

    /// The gain at start (`init_joystick`): `JS_GAIN_DEFAULT` within the limits, or the
    /// step nearest the middle when it is outside them.
    pub fn start_gain(&self) -> f32 {
        let (lo, hi, n) = (self.gain_min, self.gain_max, self.gain_steps);
        let g = if n <= 1.0 || (self.gain_default > lo - 0.01 && self.gain_default < hi + 0.01) {
            self.gain_default.clamp(lo, hi)
        } else {
            lo + ((n / 2.0).floor() - 1.0) * (hi - lo) / (n - 1.0)
        };
        g.clamp(0.1, 1.0)
    }

    /// The gain one step up or down from `gain` (`k_gain_inc` / `k_gain_dec`).
    pub fn step_gain(&self, gain: f32, up: bool) -> f32 {
        let (lo, hi, n) = (self.gain_min, self.gain_max, self.gain_steps);
        if n <= 1.0 {
            return self.gain_default.clamp(lo, hi);
        }
        let step = (hi - lo) / (n - 1.0);
        (gain + if up { step } else { -step }).clamp(lo, hi)
    }

    /// What pressing button `i` does, shift held or not.
    pub fn action(&self, i: usize, shift: bool) -> Option<Action> {
        use super::ardusub_mode as m;
        use function as f;
        Some(match self.function(i, shift) {
            f::NONE | f::SHIFT => return None,
            f::ARM_TOGGLE => Action::ArmToggle,
            f::ARM => Action::Arm,
            f::DISARM => Action::Disarm,
            f::MODE_MANUAL => Action::Mode(m::MANUAL),
            f::MODE_STABILIZE => Action::Mode(m::STABILIZE),
            f::MODE_DEPTH_HOLD => Action::Mode(m::ALT_HOLD),
            f::MODE_POSHOLD => Action::Mode(m::POSHOLD),
            f::MODE_AUTO => Action::Mode(m::AUTO),
            f::MODE_GUIDED => Action::Mode(m::GUIDED),
            f::GAIN_TOGGLE => Action::GainToggle,
            f::GAIN_INC => Action::GainStep(true),
            f::GAIN_DEC => Action::GainStep(false),
            other => Action::Nothing(other),
        })
    }
}

/// The button state of the commander's stream: what was held in the previous frame and its
/// sequence number.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ButtonState {
    held: Option<u16>,
    seq: Option<u8>,
}

impl ButtonState {
    /// Forget the stream (control changed hands): the next frame's held buttons act only
    /// once released and pressed again.
    pub fn forget(&mut self) {
        *self = Self::default();
    }

    /// A frame with MAVLink sequence number `seq` and `buttons`; `live` when the previous
    /// frame came within `MANUAL_CONTROL_TIMEOUT`. The buttons pressed in it (down now, up in
    /// the previous frame of the live stream) and whether shift is held; nothing for a
    /// replayed or duplicated frame.
    pub fn frame(
        &mut self,
        settings: &JoystickSettings,
        seq: u8,
        buttons: u16,
        live: bool,
    ) -> (Vec<usize>, bool) {
        if !live {
            self.forget();
        }
        if let Some(prev) = self.seq {
            // Newer: 1-127 ahead, modulo 256 (MAVLink's sequence numbers wrap).
            if !(1..=127).contains(&seq.wrapping_sub(prev)) {
                return (Vec::new(), false);
            }
        }
        self.seq = Some(seq);
        let before = self.held.unwrap_or(u16::MAX);
        self.held = Some(buttons);
        let down = |i: usize| buttons & (1 << i) != 0;
        let shift = (0..BUTTONS).any(|i| down(i) && settings.function(i, false) == function::SHIFT);
        let pressed = (0..BUTTONS)
            .filter(|&i| down(i) && before & (1 << i) == 0)
            .collect();
        (pressed, shift)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ardusubs_defaults_arm_disarm_change_modes_and_the_gain() {
        let s = JoystickSettings::default();
        s.check().unwrap();
        assert_eq!(s.action(6, false), Some(Action::Arm));
        assert_eq!(s.action(4, false), Some(Action::Disarm));
        assert_eq!(
            s.action(1, false),
            Some(Action::Mode(super::super::ardusub_mode::MANUAL))
        );
        assert_eq!(
            s.action(2, false),
            Some(Action::Mode(super::super::ardusub_mode::ALT_HOLD))
        );
        assert_eq!(
            s.action(3, false),
            Some(Action::Mode(super::super::ardusub_mode::STABILIZE))
        );
        assert_eq!(s.action(11, false), Some(Action::GainStep(true)));
        assert_eq!(s.action(12, false), Some(Action::GainStep(false)));
        assert_eq!(s.action(11, true), Some(Action::Nothing(47)));
        assert_eq!(s.action(5, false), None);
    }

    #[test]
    fn the_gain_starts_at_its_default_and_steps_within_its_limits() {
        let s = JoystickSettings::default();
        assert_eq!(s.start_gain(), 0.5);
        assert_eq!(s.step_gain(0.5, true), 0.75);
        assert_eq!(s.step_gain(1.0, true), 1.0);
        assert_eq!(s.step_gain(0.25, false), 0.25);
        let one = JoystickSettings {
            gain_steps: 1.0,
            ..s
        };
        assert_eq!(one.step_gain(0.8, true), 0.5);
        let outside = JoystickSettings {
            gain_default: 0.1,
            gain_min: 0.2,
            gain_steps: 5.0,
            ..s
        };
        assert!(
            (outside.start_gain() - 0.4).abs() < 1e-6,
            "{}",
            outside.start_gain()
        );
    }

    #[test]
    fn a_bad_setting_is_refused_with_its_range() {
        let s = JoystickSettings::default();
        let mut b = s;
        b.buttons[3][1] = 2.5;
        assert!(format!("{}", b.check().unwrap_err()).contains("BTN3_SFUNCTION"));
        b = s;
        b.buttons[0][0] = 97.0;
        assert!(b.check().is_err());
        for (bad, name) in [
            (
                JoystickSettings {
                    gain_default: 0.0,
                    ..s
                },
                "JS_GAIN_DEFAULT",
            ),
            (
                JoystickSettings {
                    gain_max: f32::NAN,
                    ..s
                },
                "JS_GAIN_MAX",
            ),
            (JoystickSettings { gain_min: 0.9, ..s }, "JS_GAIN_MIN"),
            (
                JoystickSettings {
                    gain_steps: 2.5,
                    ..s
                },
                "JS_GAIN_STEPS",
            ),
        ] {
            let why = format!("{}", bad.check().unwrap_err());
            assert!(why.contains(name), "{why}");
        }
    }

    #[test]
    fn a_button_acts_once_per_press_and_never_from_a_replay_or_a_lapsed_stream() {
        let s = JoystickSettings::default();
        let mut b = ButtonState::default();
        let arm = 1 << 6;
        // The first frame of a stream: what is held counts as held before.
        assert_eq!(b.frame(&s, 10, arm, true).0, Vec::<usize>::new());
        assert_eq!(b.frame(&s, 11, 0, true).0, Vec::<usize>::new());
        assert_eq!(b.frame(&s, 12, arm, true).0, vec![6]);
        // Held: no more presses.
        for seq in 13..20 {
            assert!(b.frame(&s, seq, arm, true).0.is_empty());
        }
        assert!(b.frame(&s, 20, 0, true).0.is_empty());
        // A replay of frame 12 (same sequence number, or older) does nothing.
        assert!(b.frame(&s, 12, arm, true).0.is_empty());
        assert!(b.frame(&s, 20, arm, true).0.is_empty());
        // The sequence number wraps.
        let mut w = ButtonState::default();
        w.frame(&s, 254, 0, true);
        assert_eq!(w.frame(&s, 1, arm, true).0, vec![6]);
        // After a lapse, a held button does not act.
        assert!(b.frame(&s, 21, 0, true).0.is_empty());
        assert!(b.frame(&s, 22, arm, false).0.is_empty());
        assert_eq!(b.frame(&s, 23, 0, true).0, Vec::<usize>::new());
        assert_eq!(b.frame(&s, 24, arm, true).0, vec![6]);
    }

    #[test]
    fn shift_selects_the_shift_function() {
        let s = JoystickSettings::default();
        let mut b = ButtonState::default();
        b.frame(&s, 0, 0, true);
        let (pressed, shift) = b.frame(&s, 1, (1 << 5) | (1 << 11), true);
        assert_eq!(pressed, vec![5, 11]);
        assert!(shift);
        assert_eq!(s.action(11, shift), Some(Action::Nothing(47)));
    }
}
