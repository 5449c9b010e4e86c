//! The commander's joystick buttons acting (`joystick` reads them): arming, disarming and
//! modes go the way a ground station's command goes (the same checks, a refusal said in
//! words); the gain buttons step the gain the sticks are scaled by, said as ArduSub says it
//! ("#Gain is 75%"); a function with no meaning here is said once per press.

use super::joystick::Action;
use super::topside::Topside;
use super::transport::StationId;
use anyhow::Result;
use mavlink::dialects::ardupilotmega::MavSeverity;

impl Topside {
    /// The buttons of one `MANUAL_CONTROL` frame from the commander `station`, MAVLink
    /// sequence number `seq`; `live` when the previous frame came within
    /// `MANUAL_CONTROL_TIMEOUT`.
    pub(super) fn on_buttons(
        &mut self,
        station: StationId,
        seq: u8,
        buttons: u16,
        live: bool,
    ) -> Result<()> {
        let js = self.v.settings.joystick;
        let (pressed, shift) = self.buttons.frame(&js, seq, buttons, live);
        for i in pressed {
            let Some(action) = js.action(i, shift) else {
                continue;
            };
            match action {
                Action::Arm => self.arm_disarm(station, 1.0)?,
                Action::Disarm => self.arm_disarm(station, 0.0)?,
                Action::ArmToggle => {
                    let arm = if self.v.tel.armed { 0.0 } else { 1.0 };
                    self.arm_disarm(station, arm)?
                }
                Action::Mode(custom) => self.set_mode(station, custom)?,
                Action::GainStep(up) => {
                    self.js_gain = js.step_gain(self.js_gain, up);
                    self.say_gain()?;
                }
                Action::GainToggle => {
                    self.js_gain = if self.js_gain < 1.0 { 1.0 } else { 0.5 };
                    self.say_gain()?;
                }
                Action::Nothing(f) => self.gcs.text_to(
                    station,
                    MavSeverity::MAV_SEVERITY_INFO,
                    &format!(
                        "Button {i}: function {f} does nothing on this vehicle (no camera \
                         mount, lights, trims, relays or servos)"
                    ),
                )?,
            }
        }
        Ok(())
    }

    fn say_gain(&mut self) -> Result<()> {
        let text = format!("#Gain is {:.0}%", self.js_gain * 100.0);
        self.gcs.text(MavSeverity::MAV_SEVERITY_INFO, &text)
    }
}
