//! The cubic-spline kernel of SPH (Monaghan 1992), support 2h.

use std::f32::consts::PI;

/// Cubic-spline kernel (Monaghan 1992) of smoothing length `h`, support `2h`, in 3D.
#[derive(Clone, Copy, Debug)]
pub struct CubicSpline {
    pub h: f32,
    pub(super) inv_h: f32,
    pub(super) sigma: f32,
}

impl CubicSpline {
    pub fn new(h: f32) -> Self {
        Self {
            h,
            inv_h: 1.0 / h,
            sigma: 1.0 / (PI * h * h * h),
        }
    }

    /// Support radius `2h` (m).
    #[inline]
    pub fn support(&self) -> f32 {
        2.0 * self.h
    }

    /// `W(r)` (1/m³) from the squared distance.
    #[inline]
    pub fn w(&self, r2: f32) -> f32 {
        let q = r2.sqrt() * self.inv_h;
        if q < 1.0 {
            self.sigma * (1.0 - 1.5 * q * q + 0.75 * q * q * q)
        } else if q < 2.0 {
            let t = 2.0 - q;
            self.sigma * 0.25 * t * t * t
        } else {
            0.0
        }
    }

    /// `W'(r)/r` (1/m⁵): `∇_i W(x_i − x_j) = (x_i − x_j) · W'(r)/r`.
    #[inline]
    pub fn grad_over_r(&self, r2: f32) -> f32 {
        let r = r2.sqrt();
        let q = r * self.inv_h;
        if q <= 0.0 || q >= 2.0 {
            return 0.0;
        }
        let dw = if q < 1.0 {
            self.sigma * self.inv_h * (-3.0 * q + 2.25 * q * q)
        } else {
            let t = 2.0 - q;
            -0.75 * self.sigma * self.inv_h * t * t
        };
        dw / r
    }
}
