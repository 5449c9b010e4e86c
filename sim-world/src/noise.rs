//! The one Gaussian draw of the simulated world (sensors and navigation noise).

use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// Standard normal draw (Box-Muller; one of the pair is dropped, simplicity over speed).
pub fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}
