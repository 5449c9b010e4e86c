//! host-sim (being written).
fn main() {}
