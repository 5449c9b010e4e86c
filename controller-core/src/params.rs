//! Vehicle parameters (Table I of the paper plus the values it does not give) and the
//! coefficients derived from them.
//!
//! Conventions (Fossen / SNAME): body x forward, y starboard, z down; body origin at the centre
//! of buoyancy; centre of gravity at `(0, 0, z_g)` with `z_g > 0`. Table I drag coefficients are
//! magnitudes (the force is `-(X_u + X_uu |u|) u`). Added-mass derivatives keep the paper's sign
//! (negative). Table I misprints `Z_wdot` as "-0.3 .848"; it is `-0.3848`.
//!
//! Values the paper needs but does not give are marked *assumed* below and in `docs/derivation.md`.
//! Everything the laws use is derived here from the raw set, never typed in twice.

use crate::error::{finite, non_negative, positive, Error};
use serde::{Deserialize, Serialize};

/// Raw physical parameters of the vehicle, SI units. Build a [`Vehicle`] from it with
/// [`VehicleParams::validate`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VehicleParams {
    /// Dry mass `m` (Table I).
    pub mass_kg: f32,
    /// Added mass in surge `X_udot` (Table I, negative).
    pub x_udot_kg: f32,
    /// Added mass in sway `Y_vdot` (Table I, negative).
    pub y_vdot_kg: f32,
    /// Added mass in heave `Z_wdot` (Table I, negative; misprinted there).
    pub z_wdot_kg: f32,
    /// Added inertia in pitch `M_qdot` (Table I, negative).
    pub m_qdot_kg_m2: f32,
    /// Added inertia in yaw `N_rdot` (Table I, negative).
    pub n_rdot_kg_m2: f32,
    /// Linear surge drag `X_u` (magnitude).
    pub x_u: f32,
    /// Linear sway drag `Y_v`.
    pub y_v: f32,
    /// Linear heave drag `Z_w`.
    pub z_w: f32,
    /// Linear pitch drag `M_q` (Table I labels it "surge").
    pub m_q: f32,
    /// Linear yaw drag `N_r`.
    pub n_r: f32,
    /// Quadratic surge drag `X_uu`.
    pub x_uu: f32,
    /// Quadratic sway drag `Y_vv`.
    pub y_vv: f32,
    /// Quadratic heave drag `Z_ww`.
    pub z_ww: f32,
    /// Quadratic pitch drag `M_qq`.
    pub m_qq: f32,
    /// Quadratic yaw drag `N_rr`.
    pub n_rr: f32,
    /// Roll inertia `I_x` (assumed).
    pub i_x_kg_m2: f32,
    /// Pitch inertia `I_y` (assumed).
    pub i_y_kg_m2: f32,
    /// Yaw inertia `I_z` (assumed).
    pub i_z_kg_m2: f32,
    /// Depth of the CG below the CB `z_g` (assumed, > 0).
    pub z_g_m: f32,
    /// Gravity.
    pub gravity_m_s2: f32,
    /// Net buoyancy `B - W`; positive means the vehicle floats up (assumed 0 = neutral).
    pub buoyancy_offset_n: f32,
    /// Lateral lever arm `l` of the horizontal thrusters (at `y = -l` and `y = +l`, assumed).
    pub thruster_lever_arm_m: f32,
    /// Largest forward thrust of one thruster (assumed).
    pub thrust_max_forward_n: f32,
    /// Largest reverse thrust of one thruster, as a magnitude (assumed).
    pub thrust_max_reverse_n: f32,
    /// First-order spin-up time constant of a thruster (assumed; plant only).
    pub thruster_time_constant_s: f32,
    /// The ESCs' pulse widths and the thrust curve between them.
    pub pulse: PulseCurve,
}

/// Neutral pulse of the thrusters' ESCs, microseconds: a constant of the ESC (its arming and
/// stop point), not of a vehicle description. The firmware writes it at boot, when disarmed
/// and on every failsafe, whatever description it holds; a description whose pulse curve
/// names another neutral is refused (`Vehicle::check_flyable`).
pub const ESC_NEUTRAL_US: f32 = 1500.0;
/// Shortest pulse the ESCs take (full reverse), microseconds.
pub const ESC_MIN_US: f32 = 1100.0;
/// Longest pulse the ESCs take (full forward), microseconds.
pub const ESC_MAX_US: f32 = 1900.0;

/// The ESC pulse-width curve of the thrusters (all three alike): pulse widths from `min_us`
/// to `max_us`, `neutral_us` at rest, no thrust within `deadband_us` of neutral, and beyond
/// it thrust `F_max (k x + (1 - k) x^2)` of the normalized travel `x`, `k = linear_fraction`
/// (see [`crate::alloc::PwmMap`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PulseCurve {
    /// Shortest pulse (full reverse), microseconds.
    pub min_us: f32,
    /// Neutral pulse, microseconds.
    pub neutral_us: f32,
    /// Longest pulse (full forward), microseconds.
    pub max_us: f32,
    /// Half-width of the deadband around neutral, microseconds.
    pub deadband_us: f32,
    /// Linear share `k` of the thrust curve, in [0, 1].
    pub linear_fraction: f32,
}

impl PulseCurve {
    /// 1100-1900 us, 1500 neutral, +-25 us deadband, a quarter linear (common hobby ESCs
    /// driving small ROV thrusters; assumed).
    pub const STANDARD: Self = Self {
        min_us: 1100.0,
        neutral_us: 1500.0,
        max_us: 1900.0,
        deadband_us: 25.0,
        linear_fraction: 0.25,
    };

    /// Within the servo-pulse range 500-2500 us, `min < neutral - deadband` and
    /// `neutral + deadband < max`, `k` in [0, 1].
    pub fn validate(&self) -> Result<(), Error> {
        for (name, v) in [
            ("pulse.min_us", self.min_us),
            ("pulse.neutral_us", self.neutral_us),
            ("pulse.max_us", self.max_us),
        ] {
            if !(500.0..=2500.0).contains(&finite(name, v)?) {
                return Err(Error::OutOfRange(name));
            }
        }
        non_negative("pulse.deadband_us", self.deadband_us)?;
        if !(0.0..=1.0).contains(&finite("pulse.linear_fraction", self.linear_fraction)?) {
            return Err(Error::OutOfRange("pulse.linear_fraction"));
        }
        if self.min_us >= self.neutral_us - self.deadband_us
            || self.neutral_us + self.deadband_us >= self.max_us
        {
            return Err(Error::NonPhysical(
                "pulse: min_us < neutral_us - deadband_us < neutral_us + deadband_us < max_us",
            ));
        }
        Ok(())
    }
}

impl VehicleParams {
    /// The ROV "Observer": Table I of the paper plus the documented assumptions.
    pub const OBSERVER: Self = Self {
        mass_kg: 10.84,
        x_udot_kg: -1.0810,
        y_vdot_kg: -0.3848,
        z_wdot_kg: -0.3848,
        m_qdot_kg_m2: -0.0075,
        n_rdot_kg_m2: -0.0075,
        x_u: 0.9613,
        y_v: 2.4674,
        z_w: 2.4674,
        m_q: 5.3014e-6,
        n_r: 5.3014e-6,
        x_uu: 4.4674,
        y_vv: 5.989,
        z_ww: 5.989,
        m_qq: 0.1011,
        n_rr: 0.1011,
        i_x_kg_m2: 0.15,
        i_y_kg_m2: 0.2,
        i_z_kg_m2: 0.2,
        z_g_m: 0.03,
        gravity_m_s2: 9.81,
        buoyancy_offset_n: 0.0,
        thruster_lever_arm_m: 0.12,
        thrust_max_forward_n: 20.0,
        thrust_max_reverse_n: 15.0,
        thruster_time_constant_s: 0.1,
        pulse: PulseCurve::STANDARD,
    };

    /// Check every value once and derive the model coefficients.
    pub fn validate(self) -> Result<Vehicle, Error> {
        let p = self;
        positive("mass_kg", p.mass_kg)?;
        for (name, v) in [
            ("x_udot_kg", p.x_udot_kg),
            ("y_vdot_kg", p.y_vdot_kg),
            ("z_wdot_kg", p.z_wdot_kg),
            ("m_qdot_kg_m2", p.m_qdot_kg_m2),
            ("n_rdot_kg_m2", p.n_rdot_kg_m2),
            ("buoyancy_offset_n", p.buoyancy_offset_n),
        ] {
            finite(name, v)?;
        }
        for (name, v) in [
            ("x_u", p.x_u),
            ("y_v", p.y_v),
            ("z_w", p.z_w),
            ("m_q", p.m_q),
            ("n_r", p.n_r),
            ("x_uu", p.x_uu),
            ("y_vv", p.y_vv),
            ("z_ww", p.z_ww),
            ("m_qq", p.m_qq),
            ("n_rr", p.n_rr),
            ("thruster_time_constant_s", p.thruster_time_constant_s),
        ] {
            non_negative(name, v)?;
        }
        for (name, v) in [
            ("i_x_kg_m2", p.i_x_kg_m2),
            ("i_y_kg_m2", p.i_y_kg_m2),
            ("i_z_kg_m2", p.i_z_kg_m2),
            ("z_g_m", p.z_g_m),
            ("gravity_m_s2", p.gravity_m_s2),
            ("thruster_lever_arm_m", p.thruster_lever_arm_m),
            ("thrust_max_forward_n", p.thrust_max_forward_n),
            ("thrust_max_reverse_n", p.thrust_max_reverse_n),
        ] {
            positive(name, v)?;
        }
        p.pulse.validate()?;
        let weight = p.mass_kg * p.gravity_m_s2;
        if p.buoyancy_offset_n.abs() >= weight {
            return Err(Error::OutOfRange("buoyancy_offset_n"));
        }
        let xz = XzCoeffs::derive(&p)?;
        let xy = XyCoeffs::derive(&p)?;
        Ok(Vehicle { params: p, xz, xy })
    }
}

impl Vehicle {
    /// What the firmware takes from the surface: a valid vehicle on which the laws stay safe.
    /// Beyond [`VehicleParams::validate`], the vertical thruster must hold the net buoyancy
    /// with half its smaller limit to spare (else depth hold saturates and a disturbance
    /// wins), and the horizontal thrust limits must be within 10x of each other (the yaw
    /// allocation splits between them).
    pub fn check_flyable(&self) -> Result<(), Error> {
        let p = &self.params;
        let vertical = p.thrust_max_forward_n.min(p.thrust_max_reverse_n);
        if p.buoyancy_offset_n.abs() > 0.5 * vertical {
            return Err(Error::OutOfRange(
                "buoyancy_offset_n: more than half the vertical thrust",
            ));
        }
        if p.thrust_max_forward_n > 10.0 * p.thrust_max_reverse_n
            || p.thrust_max_reverse_n > 10.0 * p.thrust_max_forward_n
        {
            return Err(Error::NonPhysical(
                "thrust_max_forward_n and thrust_max_reverse_n more than 10x apart",
            ));
        }
        self.check_bounds()
    }
}

/// The ranges a description must lie in to be flown (docs/safety.md gives each
/// reason). The laws' gains were tuned on the Observer (10.84 kg, Table I); these ranges allow
/// vehicles of its class, about 5x lighter to 10x heavier, and refuse the values that made
/// the laws fail in the probes (thrust 1e-3 N: saturated every step, 4.1 m off; drag 1e5: 138
/// m off; mass 1e-3 kg: 23 m off).
pub mod flyable {
    /// Mass (kg): a hand-launched ROV of the Observer's class.
    pub const MASS_KG: (f32, f32) = (2.0, 100.0);
    /// Added mass and inertia magnitude, as a multiple of the mass (kg per kg) or of the
    /// rigid inertia: added mass above 2x the body's is not a submerged rigid body of this
    /// shape.
    pub const ADDED_MASS_RATIO: f32 = 2.0;
    /// Rigid inertia about each axis (kg m^2).
    pub const INERTIA_KG_M2: (f32, f32) = (0.005, 20.0);
    /// Linear drag coefficients (N s/m, N m s/rad): 0 to 50x the Observer's largest (2.47).
    pub const LINEAR_DRAG: f32 = 100.0;
    /// Quadratic drag coefficients (N s^2/m^2, N m s^2/rad^2): 0 to ~80x the Observer's
    /// largest (5.99). The published BlueROV2 Heavy (von Benzon et al. 2022) has
    /// `Y_vv = 217` and `Z_ww = 190`; 500 keeps twice its largest and stays far below the
    /// probe's failing 1e5 (the laws cancel the drag through the model, so a larger one
    /// only asks for more thrust at speed, which the allocation limits).
    pub const QUADRATIC_DRAG: f32 = 500.0;
    /// Each thruster's largest thrust either way (N): below 2 N the laws saturate on any
    /// disturbance; above 200 N the pulse steps are coarser than the laws' resolution.
    pub const THRUST_N: (f32, f32) = (2.0, 200.0);
    /// Thruster time constant (s): the laws assume a thruster faster than the 0.5-1 s of the
    /// vehicle's motion.
    pub const THRUSTER_TIME_CONSTANT_S: f32 = 0.5;
    /// Lever arm of the horizontal thrusters (m).
    pub const LEVER_ARM_M: (f32, f32) = (0.03, 1.0);
    /// Metacentric height `z_g` (m): positive (self-righting), at most half a metre.
    pub const Z_G_M: (f32, f32) = (0.001, 0.5);
    /// Gravity (m/s^2): the Earth's, anywhere on it.
    pub const GRAVITY_M_S2: (f32, f32) = (9.7, 9.9);
    /// Pulse range of the curve: within the ESC's 1100-1900 us, each end at least 100 us
    /// from neutral (else the full thrust is within a few pulse steps).
    pub const PULSE_END_FROM_NEUTRAL_US: f32 = 100.0;
    /// Deadband half-width (us): at most 100 us (a quarter of the ESC's travel).
    pub const DEADBAND_US: f32 = 100.0;
}

impl Vehicle {
    /// Every mass, drag, thrust and pulse value within [`flyable`], and the neutral pulse
    /// the ESC's ([`ESC_NEUTRAL_US`]).
    fn check_bounds(&self) -> Result<(), Error> {
        use flyable::*;
        let p = &self.params;
        let within = |name: &'static str, v: f32, (lo, hi): (f32, f32)| {
            if (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(Error::OutOfRange(name))
            }
        };
        within("mass_kg", p.mass_kg, MASS_KG)?;
        let added = ADDED_MASS_RATIO * p.mass_kg;
        for (name, v) in [
            ("x_udot_kg", p.x_udot_kg),
            ("y_vdot_kg", p.y_vdot_kg),
            ("z_wdot_kg", p.z_wdot_kg),
        ] {
            within(name, v.abs(), (0.0, added))?;
        }
        for (name, v) in [
            ("i_x_kg_m2", p.i_x_kg_m2),
            ("i_y_kg_m2", p.i_y_kg_m2),
            ("i_z_kg_m2", p.i_z_kg_m2),
        ] {
            within(name, v, INERTIA_KG_M2)?;
        }
        let inertia = ADDED_MASS_RATIO * p.i_y_kg_m2.max(p.i_z_kg_m2);
        for (name, v) in [
            ("m_qdot_kg_m2", p.m_qdot_kg_m2),
            ("n_rdot_kg_m2", p.n_rdot_kg_m2),
        ] {
            within(name, v.abs(), (0.0, inertia))?;
        }
        for (name, v) in [
            ("x_u", p.x_u),
            ("y_v", p.y_v),
            ("z_w", p.z_w),
            ("m_q", p.m_q),
            ("n_r", p.n_r),
        ] {
            within(name, v, (0.0, LINEAR_DRAG))?;
        }
        for (name, v) in [
            ("x_uu", p.x_uu),
            ("y_vv", p.y_vv),
            ("z_ww", p.z_ww),
            ("m_qq", p.m_qq),
            ("n_rr", p.n_rr),
        ] {
            within(name, v, (0.0, QUADRATIC_DRAG))?;
        }
        within("thrust_max_forward_n", p.thrust_max_forward_n, THRUST_N)?;
        within("thrust_max_reverse_n", p.thrust_max_reverse_n, THRUST_N)?;
        within(
            "thruster_time_constant_s",
            p.thruster_time_constant_s,
            (0.0, THRUSTER_TIME_CONSTANT_S),
        )?;
        within("thruster_lever_arm_m", p.thruster_lever_arm_m, LEVER_ARM_M)?;
        within("z_g_m", p.z_g_m, Z_G_M)?;
        within("gravity_m_s2", p.gravity_m_s2, GRAVITY_M_S2)?;
        let c = &p.pulse;
        if c.neutral_us != ESC_NEUTRAL_US {
            return Err(Error::OutOfRange("pulse.neutral_us: the ESC's 1500 us"));
        }
        let end = PULSE_END_FROM_NEUTRAL_US;
        within("pulse.min_us", c.min_us, (ESC_MIN_US, ESC_NEUTRAL_US - end))?;
        within("pulse.max_us", c.max_us, (ESC_NEUTRAL_US + end, ESC_MAX_US))?;
        within("pulse.deadband_us", c.deadband_us, (0.0, DEADBAND_US))?;
        Ok(())
    }
}

impl Default for VehicleParams {
    fn default() -> Self {
        Self::OBSERVER
    }
}

/// A validated parameter set with its derived coefficients. Only [`VehicleParams::validate`]
/// makes one, so holding a `Vehicle` means every number in it is finite and physical.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vehicle {
    params: VehicleParams,
    /// Vertical-plane coefficients.
    pub xz: XzCoeffs,
    /// Horizontal-plane coefficients.
    pub xy: XyCoeffs,
}

impl Vehicle {
    /// The raw parameters this vehicle was built from.
    pub fn params(&self) -> &VehicleParams {
        &self.params
    }

    /// The Observer with the paper's Table I and the documented assumptions.
    pub fn observer() -> Self {
        // The constant set is checked by a unit test; fall back field-by-field is impossible,
        // so derive without the Result (the derivation cannot fail for these values).
        match VehicleParams::OBSERVER.validate() {
            Ok(v) => v,
            // Unreachable for the constant set (tested); keep the control path panic-free.
            Err(_) => Vehicle {
                params: VehicleParams::OBSERVER,
                xz: XzCoeffs::ZERO,
                xy: XyCoeffs::ZERO,
            },
        }
    }
}

/// Vertical-plane (XZ) coefficients, corrected model of `MODEL_NOTES` section 3 / paper eqs
/// (2)-(3).
///
/// Physical model (`u` surge, `w` heave, `q` pitch rate, `theta` pitch):
/// ```text
/// [m_x  a_uq] [u_dot]   [F_u]   F_u = -(X_u + X_uu|u|)u - m_z w q - (W - B) sin(theta) + tau_1
/// [a_uq J_y ] [q_dot] = [F_q]   F_q = -(M_q + M_qq|q|)q - a_uq w q - (Z_wdot - X_udot) u w
///                                     - z_g W sin(theta)
/// m_z w_dot = -(Z_w + Z_ww|w|)w + (W - B) cos(theta) + m_x u q + a_uq q^2 + tau_3
/// ```
/// Transformed model, eq. (3) corrected, with `u1 = u + alpha q`, `alpha = J_y / a_uq`:
/// ```text
/// u1_dot = a3 q + a4 q|q| + a5 sin(theta) + a6 w q + a7 w u1          (a1 = a2 = 0)
/// w_dot  = b1 w + b2 |w| w + b3 cos(theta) + b4 u q + b5 q^2 + tau_3 / m_z
/// q_dot  = d1 u + d2 |u| u + d3 q + d4 q|q| + d5 sin(theta) + d6 w q + d7 w u + d_tau tau_1
/// ```
/// where the `d_i` multiply the physical surge speed `u = u1 - alpha q`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct XzCoeffs {
    /// `m_x = m - X_udot`.
    pub m_x: f32,
    /// `m_z = m - Z_wdot`.
    pub m_z: f32,
    /// `J_y = I_y - M_qdot`.
    pub j_y: f32,
    /// `a_uq = m z_g`, the surge-pitch inertia coupling.
    pub a_uq: f32,
    /// `delta = m_x J_y - a_uq^2`, the mass-matrix determinant.
    pub delta: f32,
    /// `alpha = J_y / a_uq`, distance of the transformed point below the CB along body z.
    pub alpha: f32,
    /// Weight `W = m g`.
    pub weight_n: f32,
    /// Buoyancy `B = W + offset`.
    pub buoyancy_n: f32,
    /// `a1` (zero: surge drag acts at the origin with the thrust and cancels).
    pub a1: f32,
    /// `a2` (zero for the same reason).
    pub a2: f32,
    /// `a3 = -M_q / a_uq`.
    pub a3: f32,
    /// `a4 = -M_qq / a_uq`.
    pub a4: f32,
    /// `a5 = -z_g W / a_uq = -g`.
    pub a5: f32,
    /// `a6 = -1 + (Z_wdot - X_udot) alpha / a_uq`.
    pub a6: f32,
    /// `a7 = -(Z_wdot - X_udot) / a_uq`.
    pub a7: f32,
    /// `b1 = -Z_w / m_z`.
    pub b1: f32,
    /// `b2 = -Z_ww / m_z`.
    pub b2: f32,
    /// `b3 = (W - B) / m_z`.
    pub b3: f32,
    /// `b4 = m_x / m_z` (multiplies the physical `u q`).
    pub b4: f32,
    /// `b5 = a_uq / m_z`.
    pub b5: f32,
    /// `d1 = a_uq X_u / delta`.
    pub d1: f32,
    /// `d2 = a_uq X_uu / delta`.
    pub d2: f32,
    /// `d3 = -m_x M_q / delta`.
    pub d3: f32,
    /// `d4 = -m_x M_qq / delta`.
    pub d4: f32,
    /// `d5 = (a_uq (W - B) - m_x z_g W) / delta`.
    pub d5: f32,
    /// `d6 = a_uq (m_z - m_x) / delta`.
    pub d6: f32,
    /// `d7 = -m_x (Z_wdot - X_udot) / delta`.
    pub d7: f32,
    /// Gain from `tau_1` to `q_dot`: `-a_uq / delta` (the paper prints `1/(delta alpha)`).
    pub d_tau: f32,
}

impl XzCoeffs {
    const ZERO: Self = Self {
        m_x: 0.0,
        m_z: 0.0,
        j_y: 0.0,
        a_uq: 0.0,
        delta: 0.0,
        alpha: 0.0,
        weight_n: 0.0,
        buoyancy_n: 0.0,
        a1: 0.0,
        a2: 0.0,
        a3: 0.0,
        a4: 0.0,
        a5: 0.0,
        a6: 0.0,
        a7: 0.0,
        b1: 0.0,
        b2: 0.0,
        b3: 0.0,
        b4: 0.0,
        b5: 0.0,
        d1: 0.0,
        d2: 0.0,
        d3: 0.0,
        d4: 0.0,
        d5: 0.0,
        d6: 0.0,
        d7: 0.0,
        d_tau: 0.0,
    };

    fn derive(p: &VehicleParams) -> Result<Self, Error> {
        let m_x = p.mass_kg - p.x_udot_kg;
        let m_z = p.mass_kg - p.z_wdot_kg;
        let j_y = p.i_y_kg_m2 - p.m_qdot_kg_m2;
        if m_x <= 0.0 || m_z <= 0.0 || j_y <= 0.0 {
            return Err(Error::NonPhysical("XZ mass matrix not positive"));
        }
        let a_uq = p.mass_kg * p.z_g_m;
        let delta = m_x * j_y - a_uq * a_uq;
        if delta <= 1e-6 * m_x * j_y {
            return Err(Error::NonPhysical("XZ mass matrix singular (delta <= 0)"));
        }
        let alpha = j_y / a_uq;
        let weight = p.mass_kg * p.gravity_m_s2;
        let buoyancy = weight + p.buoyancy_offset_n;
        let w_minus_b = weight - buoyancy;
        let zx = p.z_wdot_kg - p.x_udot_kg;
        let c = Self {
            m_x,
            m_z,
            j_y,
            a_uq,
            delta,
            alpha,
            weight_n: weight,
            buoyancy_n: buoyancy,
            a1: 0.0,
            a2: 0.0,
            a3: -p.m_q / a_uq,
            a4: -p.m_qq / a_uq,
            a5: -p.z_g_m * weight / a_uq,
            a6: -1.0 + zx * alpha / a_uq,
            a7: -zx / a_uq,
            b1: -p.z_w / m_z,
            b2: -p.z_ww / m_z,
            b3: w_minus_b / m_z,
            b4: m_x / m_z,
            b5: a_uq / m_z,
            d1: a_uq * p.x_u / delta,
            d2: a_uq * p.x_uu / delta,
            d3: -m_x * p.m_q / delta,
            d4: -m_x * p.m_qq / delta,
            d5: (a_uq * w_minus_b - m_x * p.z_g_m * weight) / delta,
            d6: a_uq * (m_z - m_x) / delta,
            d7: -m_x * zx / delta,
            d_tau: -a_uq / delta,
        };
        Ok(c)
    }
}

/// Horizontal-plane (XY) coefficients, model of `MODEL_NOTES` section 4 (paper eq. (34)
/// reduced, roll not modelled):
/// ```text
/// m_11 u_dot = m_22 v r - (X_u + X_uu|u|) u + tau_1
/// m_22 v_dot = -m_11 u r - (Y_v + Y_vv|v|) v
/// m_33 r_dot = (m_11 - m_22) u v - (N_r + N_rr|r|) r + tau_2
/// ```
/// In the paper's notation (eq. (36)): `u_dot = alpha1 u - alpha2 |u| u - alpha3 v r + tau_1/m_11`,
/// `v_dot = -beta1 v - beta2 |v| v - beta3 u r`, `r_dot = -gamma1 r - gamma2 |r| r - gamma3 u v + tau_2/m_33`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct XyCoeffs {
    /// `m_11 = m - X_udot`.
    pub m11: f32,
    /// `m_22 = m - Y_vdot`.
    pub m22: f32,
    /// `m_33 = I_z - N_rdot`.
    pub m33: f32,
    /// `alpha1 = -X_u / m_11`.
    pub alpha1: f32,
    /// `alpha2 = X_uu / m_11`.
    pub alpha2: f32,
    /// `alpha3 = -m_22 / m_11`.
    pub alpha3: f32,
    /// `beta1 = Y_v / m_22`.
    pub beta1: f32,
    /// `beta2 = Y_vv / m_22`.
    pub beta2: f32,
    /// `beta3 = m_11 / m_22`.
    pub beta3: f32,
    /// `gamma1 = N_r / m_33`.
    pub gamma1: f32,
    /// `gamma2 = N_rr / m_33`.
    pub gamma2: f32,
    /// `gamma3 = (m_22 - m_11) / m_33`.
    pub gamma3: f32,
}

impl XyCoeffs {
    const ZERO: Self = Self {
        m11: 0.0,
        m22: 0.0,
        m33: 0.0,
        alpha1: 0.0,
        alpha2: 0.0,
        alpha3: 0.0,
        beta1: 0.0,
        beta2: 0.0,
        beta3: 0.0,
        gamma1: 0.0,
        gamma2: 0.0,
        gamma3: 0.0,
    };

    fn derive(p: &VehicleParams) -> Result<Self, Error> {
        let m11 = p.mass_kg - p.x_udot_kg;
        let m22 = p.mass_kg - p.y_vdot_kg;
        let m33 = p.i_z_kg_m2 - p.n_rdot_kg_m2;
        if m11 <= 0.0 || m22 <= 0.0 || m33 <= 0.0 {
            return Err(Error::NonPhysical("XY mass matrix not positive"));
        }
        Ok(Self {
            m11,
            m22,
            m33,
            alpha1: -p.x_u / m11,
            alpha2: p.x_uu / m11,
            alpha3: -m22 / m11,
            beta1: p.y_v / m22,
            beta2: p.y_vv / m22,
            beta3: m11 / m22,
            gamma1: p.n_r / m33,
            gamma2: p.n_rr / m33,
            gamma3: (m22 - m11) / m33,
        })
    }
}

#[cfg(test)]
mod tests;
