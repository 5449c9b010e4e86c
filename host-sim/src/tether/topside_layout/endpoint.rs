//! The topside layout as the closed loop's controller endpoint: the PC's set-up at time 0,
//! the MCUs run to each tick, the plant's measurements to the node and the surface's fixes
//! to the topside.

use super::{ControlView, DvlPath, TopsideLayout, HEARTBEAT_PERIOD_US};
use crate::closed_loop::{ControllerEndpoint, StepReply};
use anyhow::{bail, Result};
use controller_core::reference::RefSample;
use controller_core::state::NavState;
use protocol::{fault, Answer, Command, Event};
use sim_world::clock::us;
use sim_world::sensors::Measurement;

impl ControllerEndpoint for TopsideLayout {
    /// The USBL fixes the topside's estimator refused on its gate (its `Nack`s).
    fn usbl_fixes_rejected(&self) -> Option<u64> {
        Some(self.report.usbl_fixes_rejected)
    }

    /// At virtual time 0: the topside's first downlink (disarmed: the node's arm transition
    /// needs it), then the PC's set-up as `hil` sends it to the onboard App (with an external
    /// PC: only the vehicle's description and, if asked, the estimator's start).
    fn start(&mut self, nav0: &NavState) -> Result<()> {
        self.pass(0)?;
        if self.external.is_some() {
            // The PC is outside: the vehicle's description (as configured on a real
            // vehicle) and, if asked, the estimator's start go in at the next pass.
            self.pending_pc.push((0, Command::SetVehicle(self.vehicle)));
            if self.external_start_nav {
                self.pending_pc.push((
                    0,
                    Command::StartNav {
                        t_us: 0,
                        initial: *nav0,
                        config: self.onboard,
                    },
                ));
            }
            return Ok(());
        }
        self.open_session()?;
        // A heartbeat is answered by `Status`, not `Ack`.
        let hb = self.pc_send(&Command::Heartbeat { t_us: 0 })?;
        for e in self.pc_exchange()? {
            if let Event::Reply {
                answer:
                    Some(Answer::Command {
                        seq,
                        result: Err(reason),
                    }),
                ..
            } = e
            {
                if seq == hb {
                    bail!("the topside refused the first heartbeat: {reason:?}");
                }
            }
        }
        self.next_heartbeat_us = HEARTBEAT_PERIOD_US;
        self.command(&Command::SetVehicle(self.vehicle))?;
        self.command(&Command::StartNav {
            t_us: 0,
            initial: *nav0,
            config: self.onboard,
        })?;
        self.command(&Command::SetReference {
            reference: self.reference,
            start_us: Some(0),
        })?;
        self.command(&Command::SetMode(self.mode))?;
        self.command(&Command::Arm)?;
        Ok(())
    }

    fn step(&mut self, t_s: f64, _nav: &NavState, _reference: &RefSample) -> Result<StepReply> {
        self.run_to(us(t_s))?;
        // In process the App's latest step; emulated, the latest telemetry's (every 100 ms).
        let out = self.roles.control().unwrap_or_else(|| {
            self.latest_telemetry
                .as_ref()
                .map_or_else(ControlView::default, ControlView::from_telemetry)
        });
        let pulse = self.node_view.pulse_us;
        let applied = pulse.map(|p| f64::from(self.pwm.thrust_n(f32::from(p))));
        Ok(StepReply {
            requested: out.requested,
            achieved: out.achieved,
            thrust_cmd_n: out.thrust_n,
            applied_n: applied,
            pulse_us: pulse.map(f64::from),
            errors: out.errors,
            saturated: out.faults & fault::SATURATED != 0,
            estimate: Some((out.nav, out.position_std_m.map(f64::from))),
        })
    }

    /// IMU and depth to the node's sensors (available from their time stamps), the DVL's
    /// reports to its UART on the node ([`DvlPath::NodeUart`]); the fixes that come from
    /// the surface to the topside over the PC's tether.
    fn forward(&mut self, measurements: &[Measurement]) -> Result<()> {
        for m in measurements {
            match *m {
                Measurement::Imu(s) => self.roles.push_imu(s),
                Measurement::Depth(d) => {
                    let p = self.onboard.pressure.pressure_pa(d.depth_m);
                    self.roles.push_pressure(d.t_us, p);
                }
                // On the vehicle, without a port on the node: it shares the tether's latency.
                Measurement::Heading(h) => self
                    .pending_pc
                    .push((self.t_us + self.vehicle_fix_delay_us, Command::Compass(h))),
                // On the vehicle: its A50 reports on the node's DVL UART, or its own cable.
                Measurement::Dvl(d) => match self.dvl_path {
                    DvlPath::NodeUart => self.roles.push_dvl(&d),
                    DvlPath::Tether => self
                        .pending_pc
                        .push((self.t_us + self.vehicle_fix_delay_us, Command::DvlFix(d))),
                },
                // At the surface: at once.
                Measurement::Position(p, _) => self.pending_pc.push((0, Command::UsblFix(p))),
            }
        }
        Ok(())
    }
}
