//! The simulated world: the plants (rigid body, thrusters, water), the frames, the sensors and
//! their noise. Depends on nothing of the simulation above it.

pub mod battery;
pub mod frames;
pub mod noise;
pub mod plant;
pub mod sensor_sim;
pub mod sensors;
pub mod tether_wire;
