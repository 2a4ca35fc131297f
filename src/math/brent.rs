//! Brent's root finder (Brent 1973; Numerical Recipes §9.3): bisection safety with
//! inverse quadratic interpolation speed, for the contact-surface root `F = 0`.

/// A root of `f` in `[a, b]` where `f(a)` and `f(b)` have opposite signs (or one is 0),
/// to `tol` in the argument, with at most `max_iter` evaluations; `None` without a sign
/// change or when `f` returns `None`.
pub fn brent(
    mut f: impl FnMut(f32) -> Option<f32>,
    mut a: f32,
    mut b: f32,
    tol: f32,
    max_iter: u32,
) -> Option<f32> {
    let mut fa = f(a)?;
    let mut fb = f(b)?;
    if fa == 0.0 {
        return Some(a);
    }
    if fb == 0.0 {
        return Some(b);
    }
    if fa.signum() == fb.signum() {
        return None;
    }
    let (mut c, mut fc) = (a, fa);
    let mut d = b - a;
    let mut e = d;
    for _ in 0..max_iter {
        if fb.signum() == fc.signum() {
            c = a;
            fc = fa;
            d = b - a;
            e = d;
        }
        if fc.abs() < fb.abs() {
            a = b;
            b = c;
            c = a;
            fa = fb;
            fb = fc;
            fc = fa;
        }
        let tol1 = 2.0 * f32::EPSILON * b.abs() + 0.5 * tol;
        let m = 0.5 * (c - b);
        if m.abs() <= tol1 || fb == 0.0 {
            return Some(b);
        }
        if e.abs() >= tol1 && fa.abs() > fb.abs() {
            // Inverse quadratic interpolation (secant when a == c).
            let s = fb / fa;
            let (mut p, mut q);
            if a == c {
                p = 2.0 * m * s;
                q = 1.0 - s;
            } else {
                let qa = fa / fc;
                let r = fb / fc;
                p = s * (2.0 * m * qa * (qa - r) - (b - a) * (r - 1.0));
                q = (qa - 1.0) * (r - 1.0) * (s - 1.0);
            }
            if p > 0.0 {
                q = -q;
            } else {
                p = -p;
            }
            if 2.0 * p < (3.0 * m * q - (tol1 * q).abs()).min((e * q).abs()) {
                e = d;
                d = p / q;
            } else {
                d = m;
                e = d;
            }
        } else {
            d = m;
            e = d;
        }
        a = b;
        fa = fb;
        b += if d.abs() > tol1 { d } else { tol1.copysign(m) };
        fb = f(b)?;
    }
    Some(b)
}

#[cfg(test)]
mod tests {
    use super::brent;

    /// Roots of smooth functions to the requested tolerance: cos x on [0, 2] (π/2),
    /// x³ − 2x − 5 on [2, 3] (2.0945515, the classic Wallis example), and a step-like
    /// tanh(50 (x − 0.3)) on [0, 1].
    #[test]
    fn finds_known_roots() {
        let r = brent(|x| Some(x.cos()), 0.0, 2.0, 1e-6, 60).unwrap();
        assert!((r - std::f32::consts::FRAC_PI_2).abs() < 2e-6);
        let r = brent(|x| Some(x * x * x - 2.0 * x - 5.0), 2.0, 3.0, 1e-6, 60).unwrap();
        assert!((r - 2.094_551_5).abs() < 2e-6);
        let r = brent(|x| Some((50.0 * (x - 0.3)).tanh()), 0.0, 1.0, 1e-6, 60).unwrap();
        assert!((r - 0.3).abs() < 2e-6);
        assert!(brent(|x| Some(x + 1.0), 0.0, 1.0, 1e-6, 60).is_none());
    }
}
