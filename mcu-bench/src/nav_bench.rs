//! The estimator on the MCU (the budget: one predict, the updates due in a step and
//! the control step <= 30,000 instructions).
//!
//! The estimator cruises a 5 m circle at 0.25 m/s with consistent synthetic measurements (so
//! that no fix is gated out and every update does its full work). Items:
//! - `nav.predict`: one IMU sample (tilt, depth and horizontal filters, history);
//! - `nav.fuse_depth`, `nav.fuse_heading`, `nav.fuse_dvl`, `nav.fuse_position` (a USBL fix
//!   0.5 s late, looked up in the history), each after a predict (untimed);
//! - `nav.step_worst`: a predict, all four updates and the tracking 3-D control step on the
//!   estimate, the worst step of a 100 Hz loop (every sensor due at once).

use crate::bench::{Bench, Platform, CALLS};
use controller_core::controller::{ControlMode, Controller, Gains};
use controller_core::math;
use controller_core::nav::{
    DepthFix, DvlFix, Estimator, HeadingFix, ImuSample, NavConfig, PositionFix, GRAVITY_M_S2,
};
use controller_core::params::Vehicle;
use controller_core::reference::Reference;
use controller_core::state::NavState;

const DT_US: u64 = 10_000;

/// One of the estimator's updates, on the cruise.
type Update = fn(&mut Cruise);
const SPEED_M_S: f32 = 0.25;
const RADIUS_M: f32 = 5.0;

/// The vehicle on the circle at `t_us`: position, heading, yaw rate.
fn truth(t_us: u64) -> ([f32; 2], f32, f32) {
    let t = t_us as f32 * 1e-6;
    let r = SPEED_M_S / RADIUS_M;
    let a = r * t;
    let (s, c) = math::sin_cos(a);
    ([RADIUS_M * s, RADIUS_M * (1.0 - c)], math::wrap_angle(a), r)
}

struct Cruise {
    est: Estimator,
    ctl: Controller,
    reference: Reference,
    t_us: u64,
}

impl Cruise {
    fn imu(&self) -> ImuSample {
        let (_, _, r) = truth(self.t_us);
        ImuSample {
            t_us: self.t_us,
            gyro_rad_s: [0.001, -0.001, r],
            accel_m_s2: [0.0, SPEED_M_S * r, -GRAVITY_M_S2],
        }
    }

    /// The IMU sample at the current time.
    fn predict(&mut self) {
        let imu = self.imu();
        let _ = self.est.predict(&imu, [2.0, 2.0, 0.0]);
    }

    /// One sample later.
    fn advance(&mut self) {
        self.t_us += DT_US;
        self.predict();
    }

    fn depth(&self) -> DepthFix {
        DepthFix {
            t_us: self.t_us,
            depth_m: 2.0,
            std_m: 0.005,
        }
    }

    fn heading(&self) -> HeadingFix {
        HeadingFix {
            t_us: self.t_us,
            yaw_rad: truth(self.t_us).1,
            std_rad: 0.02,
        }
    }

    fn dvl(&self) -> DvlFix {
        DvlFix {
            t_us: self.t_us,
            velocity_m_s: [SPEED_M_S, 0.0],
            std_m_s: 0.01,
        }
    }

    fn usbl(&self) -> PositionFix {
        let t = self.t_us.saturating_sub(500_000);
        let (p, _, _) = truth(t);
        PositionFix {
            t_us: t,
            north_m: p[0],
            east_m: p[1],
            std_m: 0.3,
        }
    }
}

/// Time the estimator's items.
pub fn run_nav<P: Platform>(b: &Bench<'_, P>, p: &P) {
    let start = NavState {
        z_m: 2.0,
        ..NavState::default()
    };
    let (Ok(est), Ok(ctl)) = (
        Estimator::new(Vehicle::observer(), NavConfig::default(), &start, 0),
        Controller::new(Vehicle::observer(), Gains::default()),
    ) else {
        p.print(format_args!(
            "mcu-bench: Estimator::new or Controller::new failed"
        ));
        return;
    };
    let reference = Reference::Circle {
        center_m: [0.0, RADIUS_M, 2.0],
        radius_m: RADIUS_M,
        speed_m_s: SPEED_M_S,
    };
    let mut c = Cruise {
        est,
        ctl,
        reference,
        t_us: 0,
    };
    // Three seconds of cruise first, so the history is full enough for a late fix.
    for _ in 0..300 {
        c.advance();
    }

    b.run_state(
        "nav.predict",
        CALLS,
        &mut c,
        |c, _| c.t_us += DT_US,
        |c| c.predict(),
        |_| {},
    );
    let updates: [(&str, Update); 4] = [
        ("nav.fuse_depth", |c| {
            let m = c.depth();
            let _ = c.est.fuse_depth(&m);
        }),
        ("nav.fuse_heading", |c| {
            let m = c.heading();
            let _ = c.est.fuse_heading(&m);
        }),
        ("nav.fuse_dvl", |c| {
            let m = c.dvl();
            let _ = c.est.fuse_dvl(&m);
        }),
        ("nav.fuse_position", |c| {
            let m = c.usbl();
            let _ = c.est.fuse_position(&m);
        }),
    ];
    // Each update after a predict (untimed).
    for (name, update) in updates {
        b.run_state(name, CALLS, &mut c, |c, _| c.advance(), update, |_| {});
    }
    b.run_state(
        "nav.step_worst",
        CALLS,
        &mut c,
        |c, _| c.t_us += DT_US,
        |c| {
            c.predict();
            let (d, h, v, u) = (c.depth(), c.heading(), c.dvl(), c.usbl());
            let _ = c.est.fuse_depth(&d);
            let _ = c.est.fuse_heading(&h);
            let _ = c.est.fuse_dvl(&v);
            let _ = c.est.fuse_position(&u);
            let nav = c.est.state();
            let r = c.reference.sample(c.t_us as f32 * 1e-6);
            let out = c.ctl.step(ControlMode::Tracking3d, &nav, &r, 0.01);
            let _ = core::hint::black_box(out);
        },
        |_| {},
    );
    let h = c.est.health();
    p.print(format_args!(
        "NAVHEALTH imu={} depth={} heading={} dvl={} position={} outliers={}/{} invalid={} resets={}",
        h.imu_samples,
        h.depth_fused,
        h.heading_fused,
        h.dvl_fused,
        h.position_fused,
        h.position_outliers,
        h.other_outliers,
        h.invalid,
        h.resets
    ));
}
