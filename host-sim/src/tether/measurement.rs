//! A simulated sensor's measurement as the tether command that carries it to the firmware:
//! a depth travels as the pressure the sensor would read (the firmware converts it back, as
//! on the real board).

use controller_core::nav::onboard::PressureDepth;
use firmware::protocol::Command;
use sim_world::sensors::Measurement;

/// The command that carries `m`, a depth as the pressure `pressure` reads at it.
pub fn command_of(m: &Measurement, pressure: &PressureDepth) -> Command {
    match *m {
        Measurement::Imu(s) => Command::Imu(s),
        Measurement::Depth(d) => Command::Pressure {
            t_us: d.t_us,
            pressure_pa: pressure.pressure_pa(d.depth_m),
        },
        Measurement::Heading(h) => Command::Compass(h),
        Measurement::Dvl(d) => Command::DvlFix(d),
        Measurement::Position(p, _) => Command::UsblFix(p),
    }
}
