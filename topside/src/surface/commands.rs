//! The commands a ground station sends (`COMMAND_LONG`, `COMMAND_INT`, `SET_MODE`,
//! `PARAM_SET`): arming, modes, parameters and the rest, each answered (`COMMAND_ACK`,
//! `PARAM_VALUE`) and every refusal said in words with what is needed.

use super::params;
use super::topside::Topside;
use super::transport::StationId;
use super::{ardusub_mode, telemetry};
use anyhow::Result;
use mavlink::dialects::ardupilotmega::{
    MavCmd, MavResult, MavSeverity, COMMAND_INT_DATA, COMMAND_LONG_DATA, PARAM_SET_DATA,
};
use protocol::{Command, Mode};

/// ArduSub's name of a custom mode, as ground stations show it.
pub fn mode_name(custom: u32) -> &'static str {
    match custom {
        ardusub_mode::STABILIZE => "STABILIZE",
        ardusub_mode::ALT_HOLD => "ALT_HOLD",
        ardusub_mode::AUTO => "AUTO",
        ardusub_mode::GUIDED => "GUIDED",
        ardusub_mode::SURFACE => "SURFACE",
        ardusub_mode::POSHOLD => "POSHOLD",
        ardusub_mode::MANUAL => "MANUAL",
        _ => "this mode",
    }
}

/// The modes a ground station may ask for, as a list for a refusal.
const MODES_OFFERED: &str = "MANUAL 19, STABILIZE 0, ALT_HOLD 2, AUTO 3, GUIDED 4, POSHOLD 16";

/// `MAV_CMD_DO_SET_MODE`'s param2 as a custom mode number: a whole number from 0 to
/// `u32::MAX`; NaN, a fraction or a negative is no mode (a plain `as u32` would read NaN and
/// -5 as 0, STABILIZE).
pub fn custom_mode_of_param(param2: f32) -> Option<u32> {
    (param2.is_finite() && param2.fract() == 0.0 && (0.0..=u32::MAX as f32).contains(&param2))
        .then_some(param2 as u32)
}

impl Topside {
    pub(super) fn set_mode(&mut self, station: StationId, custom: u32) -> Result<()> {
        let cmd = MavCmd::MAV_CMD_DO_SET_MODE;
        let v = &mut self.v;
        let name = mode_name(custom);
        let firmware_mode = match custom {
            ardusub_mode::MANUAL => Mode::Manual,
            ardusub_mode::STABILIZE => Mode::Stabilize,
            ardusub_mode::ALT_HOLD => Mode::DepthHold,
            ardusub_mode::POSHOLD => Mode::Hold,
            ardusub_mode::GUIDED => Mode::Guided,
            ardusub_mode::AUTO => Mode::Auto,
            other => {
                let why =
                    format!("Mode {other} refused: no such mode here (offered: {MODES_OFFERED})");
                return self.refuse(station, cmd, &why);
            }
        };
        match v.command(&Command::SetMode(firmware_mode))? {
            Ok(()) => {
                // The vehicle took it: shown (and judged, e.g. a mission upload in AUTO) now,
                // not at its next telemetry. GUIDED holds where the vehicle is.
                v.tel.mode = firmware_mode;
                self.guided_target = (firmware_mode == Mode::Guided).then_some([
                    v.state.x_m,
                    v.state.y_m,
                    v.state.z_m,
                ]);
                self.sticks_seen_centred = false;
                self.gcs.ack(station, cmd, MavResult::MAV_RESULT_ACCEPTED)
            }
            Err(why) => {
                let why = match (custom, why) {
                    (
                        ardusub_mode::AUTO,
                        super::vehicle::Refusal::Nack(protocol::NackReason::NoReference),
                    ) => "no mission on the vehicle: upload one first".to_string(),
                    (_, why) => why.to_string(),
                };
                self.refuse(station, cmd, &format!("{name} refused: {why}"))
            }
        }
    }

    /// `COMMAND_LONG`: each command answered with a `COMMAND_ACK`.
    pub(super) fn command_long(&mut self, station: StationId, c: COMMAND_LONG_DATA) -> Result<()> {
        if super::queries::is_query(c.command) {
            return self.query(station, c.command, c.param1, c.param2);
        }
        self.gcs.stats.handled += 1;
        match c.command {
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM => self.arm_disarm(station, c.param1),
            MavCmd::MAV_CMD_DO_SET_MODE => match custom_mode_of_param(c.param2) {
                Some(custom) => self.set_mode(station, custom),
                None => {
                    let why = format!(
                        "Mode refused: param2 must be a whole custom mode number ({MODES_OFFERED}), not {}",
                        c.param2
                    );
                    self.refuse(station, c.command, &why)
                }
            },
            MavCmd::MAV_CMD_DO_START_MAG_CAL => self.start_mag_cal(station),
            MavCmd::MAV_CMD_DO_REPOSITION => self.reposition_long(station, &c),
            MavCmd::MAV_CMD_USER_2 => self.start_ident(station, c.param1, c.param2),
            MavCmd::MAV_CMD_DO_MOTOR_TEST => self.motor_test(
                station,
                &super::motor_test::MotorTestParams {
                    motor: c.param1,
                    throttle_type: c.param2,
                    throttle: c.param3,
                    timeout_s: c.param4,
                    motor_count: c.param5,
                    order: c.param6,
                },
            ),
            // The vehicle's estimator restarted at the latest USBL fix (param1 = 1).
            MavCmd::MAV_CMD_USER_1 if c.param1 == 1.0 => {
                match self.nav.start(&mut self.v, true)? {
                    Some(text) if text.starts_with("Navigation restarted") => {
                        eprintln!("topside: {text}");
                        self.gcs.text(MavSeverity::MAV_SEVERITY_INFO, &text)?;
                        self.gcs
                            .ack(station, c.command, MavResult::MAV_RESULT_ACCEPTED)
                    }
                    other => {
                        let why = other.unwrap_or_else(|| {
                            "Navigation restart refused: the vehicle's clock is not known yet"
                                .into()
                        });
                        self.refuse(station, c.command, &why)
                    }
                }
            }
            other => self
                .gcs
                .ack(station, other, MavResult::MAV_RESULT_UNSUPPORTED),
        }
    }

    /// `COMMAND_INT`: each command answered with a `COMMAND_ACK`.
    pub(super) fn command_int(&mut self, station: StationId, c: COMMAND_INT_DATA) -> Result<()> {
        if super::queries::is_query(c.command) {
            return self.query(station, c.command, c.param1, c.param2);
        }
        match c.command {
            MavCmd::MAV_CMD_DO_REPOSITION => self.reposition_int(station, &c),
            MavCmd::MAV_CMD_DO_MOTOR_TEST => {
                self.gcs.stats.handled += 1;
                self.motor_test(
                    station,
                    &super::motor_test::MotorTestParams {
                        motor: c.param1,
                        throttle_type: c.param2,
                        throttle: c.param3,
                        timeout_s: c.param4,
                        motor_count: c.x as f32,
                        order: c.y as f32,
                    },
                )
            }
            other => {
                self.gcs.stats.handled += 1;
                self.gcs
                    .ack(station, other, MavResult::MAV_RESULT_UNSUPPORTED)
            }
        }
    }

    /// MAVLink: 1 arms, 0 disarms; anything else (NaN, 0.5, -1) is refused rather than read
    /// as one of them (ArduPilot's rule too).
    pub(super) fn arm_disarm(&mut self, station: StationId, param1: f32) -> Result<()> {
        let command = MavCmd::MAV_CMD_COMPONENT_ARM_DISARM;
        let cmd = if param1 == 1.0 {
            Command::Arm
        } else if param1 == 0.0 {
            Command::Disarm
        } else {
            let why = format!("Arming refused: param1 must be 1 (arm) or 0 (disarm), not {param1}");
            return self.refuse(station, command, &why);
        };
        if cmd == Command::Arm {
            if let Some(why) = self.sticks_refuse_arming()? {
                return self.refuse(station, command, &why);
            }
            // Nothing given before arming is flown after it: the vehicle in GUIDED holds
            // where it is until a target is sent.
            if self.guided() {
                let s = &self.v.state;
                self.guided_target = Some([s.x_m, s.y_m, s.z_m]);
            }
        }
        match self.v.command(&cmd)? {
            Ok(()) => {
                // Shown now, not at the vehicle's next telemetry.
                self.v.tel.armed = cmd == Command::Arm;
                if cmd == Command::Arm {
                    self.sticks_seen_centred = false;
                }
                self.gcs
                    .ack(station, command, MavResult::MAV_RESULT_ACCEPTED)
            }
            Err(why) => {
                let what = if cmd == Command::Arm {
                    "Arming"
                } else {
                    "Disarming"
                };
                self.refuse(station, command, &format!("{what} refused: {why}"))
            }
        }
    }

    pub(super) fn param_set(&mut self, station: StationId, p: &PARAM_SET_DATA) -> Result<()> {
        self.gcs.stats.handled += 1;
        let warn = MavSeverity::MAV_SEVERITY_WARNING;
        let name = telemetry::param_name(&p.param_id);
        let Some((i, param)) = params::find(&name) else {
            return self.gcs.text_to(
                station,
                warn,
                &format!(
                    "{name} refused: no such parameter ({} parameters listed)",
                    params::count()
                ),
            );
        };
        let value = params::show(p.param_value);
        let refusal = if let Some(why) = params::read_only(&name) {
            Some(format!("{name} refused: {value} is read-only, {why}"))
        } else {
            let mut proposed = self.v.settings;
            (param.set)(&mut proposed, p.param_value);
            let group = params::group(param);
            // The checks the vehicle makes, here first (a clear reason), then the vehicle's.
            match proposed.check(group) {
                Err(e) => Some(refused_param(&self.v.settings, param, &value, &e)),
                Ok(()) => match self.v.apply(proposed, group)? {
                    Ok(()) => None,
                    Err(why) => Some(format!("{name} refused by the vehicle: {value}: {why}")),
                },
            }
        };
        match refusal {
            Some(text) => self.gcs.text_to(station, warn, &text)?,
            None => {
                // The operator's value wins over a saved one still waiting.
                let group = params::group(param);
                self.pending.forget(group);
                super::params_file::save(
                    &self.params_file,
                    &self.pending.merged(&self.v.settings),
                )?;
                if name == "SYSID_THISMAV"
                    && self.v.settings.surface.system_id() != Some(self.gcs.system_id())
                {
                    let text = format!(
                        "SYSID_THISMAV {value} saved: taken at the next start (now {})",
                        self.gcs.system_id()
                    );
                    self.gcs
                        .text_to(station, MavSeverity::MAV_SEVERITY_INFO, &text)?;
                }
            }
        }
        // The answer is the value in force (the new one, or the old one on a refusal), to
        // every station: all see what the vehicle holds.
        telemetry::send_param(&mut self.gcs, &self.v.settings, i, None)
    }
}

/// A parameter refused by the checks: its name, the value, the range taken with the other
/// parameters as they are, and the check's own reason where it says more than the range.
pub fn refused_param(
    settings: &params::Settings,
    param: &params::Param,
    value: &str,
    e: &anyhow::Error,
) -> String {
    let name = param.name;
    let reason = format!("{e:#}").replacen(&format!("{name} "), "", 1);
    let generic = reason.contains("is out of range") || reason.contains("is not finite");
    // A range of one value (a whole-number parameter, stepped from by fractions) says
    // nothing: the check's own reason then.
    let range = params::allowed_range(settings, param).filter(|(lo, hi)| hi > lo);
    match range {
        Some((lo, hi)) if generic => format!(
            "{name} refused: {value} is outside the allowed {} to {} (with the other parameters as they are)",
            params::show(lo),
            params::show(hi)
        ),
        Some((lo, hi)) => format!(
            "{name} refused: {value} is outside the allowed {} to {}; {reason}",
            params::show(lo),
            params::show(hi)
        ),
        None => format!("{name} refused: {value}: {reason}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surface::words::internal_name;
    use controller_core::params::VehicleParams;

    /// What a ground station reads for each parameter set to each bad value.
    fn param_refusals() -> Vec<String> {
        let settings = params::Settings::new(VehicleParams::OBSERVER);
        let mut texts = Vec::new();
        for p in params::all() {
            for bad in [5000.0, -5000.0, 1e9, -1e9, f32::NAN, 0.0] {
                let mut s = settings;
                (p.set)(&mut s, bad);
                if let Err(e) = s.check(params::group(p)) {
                    texts.push(refused_param(&settings, p, &params::show(bad), &e));
                }
            }
        }
        texts
    }

    #[test]
    fn a_refused_parameter_says_its_value_and_the_range_allowed() {
        let texts = param_refusals();
        assert!(texts.len() > 60, "{}", texts.len());
        for t in &texts {
            assert!(internal_name(t).is_none(), "{t}");
            assert!(t.contains(" refused: "), "{t}");
        }
        let kp = texts
            .iter()
            .find(|t| t.starts_with("TRK_XY_KP refused: 5000 "))
            .expect("TRK_XY_KP refused: 5000");
        // "allowed LO to HI": the default gain inside, 5000 outside.
        let range = kp.split("allowed ").nth(1);
        let (lo, hi) = range.and_then(|r| r.split_once(" to ")).expect("a range");
        let hi = hi.split(' ').next().unwrap_or_default();
        let (lo, hi): (f32, f32) = (lo.parse().unwrap(), hi.parse().unwrap());
        let kp0 = controller_core::controller::Gains::default().tracking.xy_kp;
        assert!(lo < kp0 && kp0 < hi && hi < 5000.0, "{kp}");
        let with_range = texts.iter().filter(|t| t.contains("allowed ")).count();
        assert!(
            with_range * 10 >= texts.len() * 9,
            "{with_range} of {}",
            texts.len()
        );
    }

    #[test]
    fn the_range_found_is_the_checks_own() {
        let settings = params::Settings::new(VehicleParams::OBSERVER);
        let (_, p) = params::find("MIS_SPEED").unwrap();
        let (lo, hi) = params::allowed_range(&settings, p).unwrap();
        assert!((lo - params::MIN_MISSION_SPEED_M_S).abs() < 1e-6, "{lo}");
        assert!(
            (hi - protocol::limits::MAX_MISSION_SPEED_M_S).abs() < 1e-6,
            "{hi}"
        );
        let (_, p) = params::find("FS_HB_NEUTRAL").unwrap();
        let (lo, hi) = params::allowed_range(&settings, p).unwrap();
        assert_eq!(
            (params::show(lo), params::show(hi)),
            ("0.04".into(), "1".into())
        );
    }

    #[test]
    fn modes_and_arming_are_refused_in_words() {
        for custom in [0, 2, 3, 4, 9, 16, 19, 7] {
            assert!(internal_name(mode_name(custom)).is_none());
        }
        assert_eq!(custom_mode_of_param(f32::NAN), None);
        assert_eq!(custom_mode_of_param(4.0), Some(4));
    }

    #[test]
    #[ignore = "prints the rows of docs/parameters.md"]
    fn print_parameter_table() {
        let s = params::Settings::new(VehicleParams::OBSERVER);
        for p in params::all() {
            let r = params::allowed_range(&s, p)
                .map(|(a, b)| format!("{} to {}", params::show(a), params::show(b)));
            println!(
                "| `{}` | {} | {} |",
                p.name,
                r.unwrap_or_default(),
                params::show((p.get)(&s))
            );
        }
    }
}
