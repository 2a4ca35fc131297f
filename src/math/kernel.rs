//! Smoothing kernels shared by the MLS estimate, surfel advection and force distribution.

use std::f32::consts::PI;

/// Poly6 kernel of Müller et al. (2003): `315/(64π h⁹)(h² − r²)³` for `r < h`, else 0.
/// Zero with vanishing derivative at `h`, so weights fade in and out smoothly.
/// Takes the squared distance to avoid a square root.
#[inline]
pub fn poly6(r2: f32, h: f32) -> f32 {
    let h2 = h * h;
    if r2 >= h2 {
        return 0.0;
    }
    let d = h2 - r2;
    315.0 / (64.0 * PI * h2 * h2 * h2 * h2 * h) * d * d * d
}

/// Unnormalised poly6 shape `(1 − r²/h²)³`: for weights that are normalised afterwards.
#[inline]
pub fn poly6_shape(r2: f32, h: f32) -> f32 {
    let q = 1.0 - r2 / (h * h);
    if q <= 0.0 { 0.0 } else { q * q * q }
}
