//! Fixed-step classical Runge-Kutta (RK4) for small autonomous or time-dependent ODE systems.
//!
//! In: a right-hand side `f(t, y) -> dy/dt` over fixed-size state arrays, a step and a span.
//! Out: the state after each step. Deliberately no adaptive stepping or event detection: the
//! synthetic rig generators need a known, fixed truncation error (h <= 1 ms).

/// One RK4 step of size `h` from `(t, y)`.
pub fn rk4_step<const N: usize>(
    f: &impl Fn(f64, &[f64; N]) -> [f64; N],
    t: f64,
    y: &[f64; N],
    h: f64,
) -> [f64; N] {
    let add = |a: &[f64; N], b: &[f64; N], s: f64| -> [f64; N] {
        let mut out = *a;
        for (o, bi) in out.iter_mut().zip(b) {
            *o += s * bi;
        }
        out
    };
    let k1 = f(t, y);
    let k2 = f(t + 0.5 * h, &add(y, &k1, 0.5 * h));
    let k3 = f(t + 0.5 * h, &add(y, &k2, 0.5 * h));
    let k4 = f(t + h, &add(y, &k3, h));
    let mut out = *y;
    for i in 0..N {
        out[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    out
}

/// Integrates from `t0` and samples the state at `t0 + k * dt_sample`, `k = 0..n_samples`, using
/// `substeps` RK4 steps per sample interval.
pub fn integrate_sampled<const N: usize>(
    f: impl Fn(f64, &[f64; N]) -> [f64; N],
    t0: f64,
    y0: [f64; N],
    dt_sample: f64,
    n_samples: usize,
    substeps: usize,
) -> Vec<[f64; N]> {
    let h = dt_sample / substeps.max(1) as f64;
    let mut out = Vec::with_capacity(n_samples);
    let mut y = y0;
    for k in 0..n_samples {
        out.push(y);
        let t_start = t0 + k as f64 * dt_sample;
        for s in 0..substeps.max(1) {
            y = rk4_step(&f, t_start + s as f64 * h, &y, h);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn harmonic_oscillator_keeps_phase() {
        let w = 2.0;
        let states = integrate_sampled(
            |_, y: &[f64; 2]| [y[1], -w * w * y[0]],
            0.0,
            [1.0, 0.0],
            0.01,
            1001,
            10,
        );
        let last = states[1000];
        assert!((last[0] - (w * 10.0_f64).cos()).abs() < 1e-9, "{}", last[0]);
    }
}
