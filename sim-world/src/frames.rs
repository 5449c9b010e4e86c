//! Body and inertial (NED) frames: a vector rotated by the attitude `eta[3..6]`.

/// Rotation body -> inertial (ZYX Euler), applied to a body vector.
pub fn body_to_inertial(eta: &[f64; 6], v: [f64; 3]) -> [f64; 3] {
    let (sf, cf) = eta[3].sin_cos();
    let (st, ct) = eta[4].sin_cos();
    let (sp, cp) = eta[5].sin_cos();
    [
        cp * ct * v[0] + (cp * st * sf - sp * cf) * v[1] + (cp * st * cf + sp * sf) * v[2],
        sp * ct * v[0] + (sp * st * sf + cp * cf) * v[1] + (sp * st * cf - cp * sf) * v[2],
        -st * v[0] + ct * sf * v[1] + ct * cf * v[2],
    ]
}

/// Rotation inertial -> body (the transpose of [`body_to_inertial`]).
pub fn inertial_to_body(eta: &[f64; 6], v: [f64; 3]) -> [f64; 3] {
    let (sf, cf) = eta[3].sin_cos();
    let (st, ct) = eta[4].sin_cos();
    let (sp, cp) = eta[5].sin_cos();
    [
        cp * ct * v[0] + sp * ct * v[1] - st * v[2],
        (cp * st * sf - sp * cf) * v[0] + (sp * st * sf + cp * cf) * v[1] + ct * sf * v[2],
        (cp * st * cf + sp * sf) * v[0] + (sp * st * cf - cp * sf) * v[1] + ct * cf * v[2],
    ]
}
