//! The tracking laws' gains: what each does, its default, and its validation (finite,
//! positive, and within the range its law stays stable in: [`crate::law::gain_bounds`]).

use crate::error::{positive, Error};
use serde::{Deserialize, Serialize};

/// Gains of the tracking laws. Every value must be finite and positive.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TrackingGains {
    /// XY: distance `eps` of the hand point ahead of the origin (m). The yaw dynamics are
    /// stable for `eps > (m11 - m22) U / Y_v` (0.28 U for the Observer, `U` relative to the
    /// water); smaller `eps` shrinks the origin error a heading error causes. 0.2 m covers
    /// about 1 m/s (measured).
    pub hand_m: f32,
    /// XY: hand position gain (1/s^2).
    pub xy_kp: f32,
    /// XY: hand velocity gain (1/s).
    pub xy_kd: f32,
    /// XY: integral gain on the origin error (1/s^3).
    pub xy_ki: f32,
    /// XZ: position gain of the x1 loop (1/s^2).
    pub xz_kp: f32,
    /// XZ: velocity gain of the x1 loop (1/s).
    pub xz_kd: f32,
    /// XZ: integral gain of the x1 loop (1/s^3).
    pub xz_ki: f32,
    /// XZ: pitch gain (1/s^2).
    pub pitch_kp: f32,
    /// XZ: pitch-rate gain (1/s).
    pub pitch_kd: f32,
    /// XZ: largest pitch demand (rad, < 0.7).
    pub pitch_max_rad: f32,
    /// Depth: position gain (1/s^2).
    pub depth_kp: f32,
    /// Depth: velocity gain (1/s).
    pub depth_kd: f32,
    /// Depth: integral gain (1/s^3).
    pub depth_ki: f32,
    /// XZ on the 6-DOF plant: yaw-hold gain (1/s^2).
    pub yaw_kp: f32,
    /// XZ on the 6-DOF plant: yaw-rate gain (1/s).
    pub yaw_kd: f32,
    /// Largest position error fed to the PD terms (m); bounds the virtual controls.
    pub error_limit_m: f32,
    /// Largest acceleration an integrator may contribute (m/s^2).
    pub integral_limit_m_s2: f32,
    /// XY: bandwidth of the disturbance observer read as a current (rad/s); 0 turns it off.
    /// Must be >= 0. Measured effect in `docs/tracking.md`.
    pub current_observer_rad_s: f32,
}

impl TrackingGains {
    /// The documented defaults (`docs/tracking.md`).
    pub const DEFAULT: Self = Self {
        hand_m: 0.2,
        xy_kp: 1.0,
        xy_kd: 2.0,
        xy_ki: 0.15,
        xz_kp: 3.0,
        xz_kd: 3.0,
        xz_ki: 1.0,
        pitch_kp: 9.0,
        pitch_kd: 6.0,
        pitch_max_rad: 0.35,
        depth_kp: 3.0,
        depth_kd: 3.0,
        depth_ki: 1.0,
        yaw_kp: 4.0,
        yaw_kd: 4.0,
        error_limit_m: 0.5,
        integral_limit_m_s2: 1.0,
        current_observer_rad_s: 1.0,
    };

    /// Refuse non-finite or non-positive gains, and a pitch limit at or beyond 0.7 rad (the
    /// inverse of `sin(2 theta)` needs `|theta| < pi / 4`).
    pub fn validate(&self) -> Result<(), Error> {
        for (n, v) in [
            ("hand_m", self.hand_m),
            ("xy_kp", self.xy_kp),
            ("xy_kd", self.xy_kd),
            ("xy_ki", self.xy_ki),
            ("xz_kp", self.xz_kp),
            ("xz_kd", self.xz_kd),
            ("xz_ki", self.xz_ki),
            ("pitch_kp", self.pitch_kp),
            ("pitch_kd", self.pitch_kd),
            ("pitch_max_rad", self.pitch_max_rad),
            ("depth_kp", self.depth_kp),
            ("depth_kd", self.depth_kd),
            ("depth_ki", self.depth_ki),
            ("yaw_kp", self.yaw_kp),
            ("yaw_kd", self.yaw_kd),
            ("error_limit_m", self.error_limit_m),
            ("integral_limit_m_s2", self.integral_limit_m_s2),
        ] {
            positive(n, v)?;
        }
        crate::error::non_negative("current_observer_rad_s", self.current_observer_rad_s)?;
        if self.pitch_max_rad >= 0.7 {
            return Err(Error::OutOfRange("pitch_max_rad"));
        }
        Ok(())
    }
}

/// Thrust authority of a vehicle: the acceleration its weaker thrust direction gives in
/// surge (both horizontal thrusters), in heave (the vertical one) and in yaw (the pair in
/// opposition), `[m/s^2, m/s^2, rad/s^2]`.
pub fn authority(v: &crate::params::Vehicle) -> [f32; 3] {
    let p = v.params();
    let weaker = p.thrust_max_forward_n.min(p.thrust_max_reverse_n);
    [
        2.0 * weaker / v.xy.m11,
        weaker / v.xz.m_z,
        2.0 * p.thruster_lever_arm_m * weaker / v.xy.m33,
    ]
}

impl TrackingGains {
    /// The defaults fitted to a vehicle: each loop slowed by the share `s` of the
    /// Observer's thrust authority the vehicle has on its axis (`s <= 1`; a vehicle with
    /// more authority keeps the defaults). A position gain scales with `s`, a rate gain with
    /// `sqrt(s)` (the loop's damping ratio is kept), an integral gain with `s^1.5` and the
    /// integral's limit with `s`: the force a given error asks for shrinks with the thrust
    /// the vehicle has. The laws cancel the model (mass, drag), so nothing else of the
    /// vehicle enters. Every scaled gain stays within [`crate::law::gain_bounds`]: the
    /// bounds' lower side `k_d >= 2 k_p T + 4 k_i / k_p` scales at most with `sqrt(s)`, as
    /// `k_d` does, and the floors are below the defaults times `s = 0.05` (the smallest
    /// share used).
    pub fn for_vehicle(v: &crate::params::Vehicle) -> Self {
        let mine = authority(v);
        let observer = crate::params::Vehicle::observer();
        let reference = authority(&observer);
        let share = |i: usize| {
            let (a, r) = (
                mine.get(i).copied().unwrap_or(1.0),
                reference.get(i).copied().unwrap_or(1.0),
            );
            if a.is_finite() && r > 0.0 {
                (a / r).clamp(0.05, 1.0)
            } else {
                1.0
            }
        };
        let (sx, sz, sy) = (share(0), share(1), share(2));
        let d = Self::DEFAULT;
        let rate = crate::math::sqrt;
        let horizontal = sx.min(sy);
        Self {
            xy_kp: d.xy_kp * horizontal,
            xy_kd: d.xy_kd * rate(horizontal),
            xy_ki: d.xy_ki * horizontal * rate(horizontal),
            xz_kp: d.xz_kp * sx,
            xz_kd: d.xz_kd * rate(sx),
            xz_ki: d.xz_ki * sx * rate(sx),
            depth_kp: d.depth_kp * sz,
            depth_kd: d.depth_kd * rate(sz),
            depth_ki: d.depth_ki * sz * rate(sz),
            yaw_kp: d.yaw_kp * sy,
            yaw_kd: d.yaw_kd * rate(sy),
            integral_limit_m_s2: d.integral_limit_m_s2 * sx.min(sz),
            ..d
        }
    }
}

impl Default for TrackingGains {
    fn default() -> Self {
        Self::DEFAULT
    }
}

#[cfg(test)]
mod for_vehicle_tests {
    use super::*;
    use crate::law::gain_bounds::check_tracking;
    use crate::params::VehicleParams;

    #[test]
    fn the_observer_keeps_the_defaults() {
        let g = TrackingGains::for_vehicle(&crate::params::Vehicle::observer());
        assert_eq!(g, TrackingGains::DEFAULT);
    }

    #[test]
    fn a_weaker_vehicle_gets_slower_gains_within_the_bounds() {
        for scale in [0.65, 0.3, 0.1, 0.01] {
            let p = VehicleParams {
                mass_kg: 15.18,
                thrust_max_forward_n: 20.0 * scale,
                thrust_max_reverse_n: 15.0 * scale,
                ..VehicleParams::OBSERVER
            };
            let p = VehicleParams {
                thrust_max_forward_n: p.thrust_max_forward_n.max(2.0),
                thrust_max_reverse_n: p.thrust_max_reverse_n.max(2.0),
                ..p
            };
            let g = TrackingGains::for_vehicle(&p.validate().unwrap());
            g.validate().unwrap();
            check_tracking(&g).unwrap_or_else(|e| panic!("scale {scale}: {e}"));
            assert!(g.depth_kp < TrackingGains::DEFAULT.depth_kp, "{scale}");
            assert!(g.xy_kp < TrackingGains::DEFAULT.xy_kp, "{scale}");
        }
    }
}
