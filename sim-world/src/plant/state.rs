//! The plant's state ([`PlantState`]) and the state as the plant holds it ([`RawState`]):
//! the 6-DOF plant keeps its attitude as a quaternion, and the ZYX Euler angles of
//! [`PlantState`] cost two `atan2` and an `asin`. A reader that keeps many states and looks at few (a delay line) stores these and
//! converts only the one it reads.

use super::lanes::Lane;

/// Pose and body velocities of the plant, `f64`, SI units.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PlantState {
    /// `[x, y, z, roll, pitch, yaw]` of the body origin (the CB), inertial, z down.
    pub eta: [f64; 6],
    /// `[u, v, w, p, q, r]` in the body frame.
    pub nu: [f64; 6],
}

impl PlantState {
    /// True when every component is finite.
    pub fn is_finite(&self) -> bool {
        self.eta.iter().chain(self.nu.iter()).all(|v| v.is_finite())
    }
}

/// A plant's state before the conversion to [`PlantState`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RawState {
    /// Already a [`PlantState`] (planar plants, initial states).
    Euler(PlantState),
    /// Position `[x, y, z]`, the unit quaternion `[e0, e1, e2, e3]` (`e0` scalar) of the
    /// body-to-NED rotation, and the body velocities `[u, v, w, p, q, r]`.
    Quaternion {
        /// Position of the body origin, inertial, z down (m).
        pos_m: [f64; 3],
        /// Attitude quaternion.
        quat: [f64; 4],
        /// Body velocities.
        nu: [f64; 6],
    },
}

impl From<PlantState> for RawState {
    fn from(s: PlantState) -> Self {
        RawState::Euler(s)
    }
}

impl RawState {
    /// The state with ZYX Euler angles.
    pub fn state(&self) -> PlantState {
        match *self {
            RawState::Euler(s) => s,
            RawState::Quaternion { pos_m, quat, nu } => {
                let [x, y, z] = pos_m;
                let [r0, r1, r2] = rot(quat);
                let roll = r2[1].atan2(r2[2]);
                let pitch = -r2[0].clamp(-1.0, 1.0).asin();
                let yaw = r1[0].atan2(r0[0]);
                PlantState {
                    eta: [x, y, z, roll, pitch, yaw],
                    nu,
                }
            }
        }
    }
}

/// Body -> NED rotation matrix rows of a unit quaternion `[e0, e1, e2, e3]` (`e0` scalar),
/// for one plant (`f64`) or several ([`super::lanes::Lanes`]).
#[inline(always)]
pub(crate) fn rot<T: Lane>(q: [T; 4]) -> [[T; 3]; 3] {
    let [e0, e1, e2, e3] = q;
    let (one, two) = (T::splat(1.0), T::splat(2.0));
    [
        [
            one - two * (e2 * e2 + e3 * e3),
            two * (e1 * e2 - e0 * e3),
            two * (e1 * e3 + e0 * e2),
        ],
        [
            two * (e1 * e2 + e0 * e3),
            one - two * (e1 * e1 + e3 * e3),
            two * (e2 * e3 - e0 * e1),
        ],
        [
            two * (e1 * e3 - e0 * e2),
            two * (e2 * e3 + e0 * e1),
            one - two * (e1 * e1 + e2 * e2),
        ],
    ]
}
