//! The 6-DOF plant (being written).
