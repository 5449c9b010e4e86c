//! `controller-core`: models, references, control laws and thrust allocation for the
//! underactuated ROV "Observer" (10.84 kg; two horizontal thrusters for surge and yaw, one
//! vertical thruster for heave, no sway actuation).
//!
//! `no_std`, `f32`, no allocation: the same code runs on the Cortex-M4F and on the desktop.
//! Nothing here knows about hardware, time sources or I/O.
//!
//! - [`params`]: Table I of the paper plus the documented assumptions, validated once;
//!   derived coefficients of eqs. (2), (3), (34), (36).
//! - [`model`]: the vertical-plane model in physical and transformed coordinates (eqs. (1)-(3),
//!   corrected) and the horizontal-plane model (eq. (34), reduced).
//! - [`reference`](mod@reference): reference trajectories with analytic derivatives.
//! - [`law`]: the paper's laws and the tracking laws.
//! - [`alloc`]: thrust allocation, saturation and the PWM map.
//! - [`controller`]: one validated entry point over all of them.
//! - [`math`]: all float maths, in `f32` (own sine/cosine; no `f64` on the target).
//!
//! The derivation and the paper's errata are in `docs/derivation.md`.
#![cfg_attr(not(any(test, feature = "std")), no_std)]

pub mod alloc;
pub mod controller;
pub mod error;
pub mod law;
pub mod math;
pub mod model;
pub mod nav;
pub mod params;
pub mod reference;
pub mod state;

pub use error::Error;
