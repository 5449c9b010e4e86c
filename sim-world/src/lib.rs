//! The simulated world: the plants (rigid body, thrusters, water), the frames, the sensors and
//! their noise, the battery and the tether's wires, plus the number checks its keys go
//! through and simulated time as microsecond stamps. Depends on no simulator code above it.

pub mod battery;
pub mod checks;
pub mod clock;
pub mod frames;
pub mod noise;
pub mod plant;
pub mod sensor_sim;
pub mod sensors;
pub mod tether_wire;
