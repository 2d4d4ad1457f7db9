//! A small Levenberg-Marquardt solver for models with a handful of parameters.
//!
//! In: a [`LeastSquaresModel`] (residuals and Jacobian at a parameter vector) and a start point.
//! Out: a [`FitOutcome`] with the parameters, their covariance `s^2 (J^T J)^-1`, the cost, the
//! iteration count and whether the stopping test was met; non-convergence is reported, not
//! raised. Deliberately tiny (dense normal equations with Marquardt's diagonal scaling): the
//! rig models have 2 to 6 parameters. No bounds beyond the model's own `project` hook.

use nalgebra::{DMatrix, DVector};

/// A nonlinear least-squares problem: minimise `0.5 |r(p)|^2`.
pub trait LeastSquaresModel {
    /// Residual vector at `p`.
    fn residuals(&self, p: &DVector<f64>) -> DVector<f64>;
    /// Jacobian `dr/dp` at `p` (rows: residuals, columns: parameters).
    fn jacobian(&self, p: &DVector<f64>) -> DMatrix<f64>;
    /// Maps a trial point back into the feasible set (default: identity).
    fn project(&self, p: DVector<f64>) -> DVector<f64> {
        p
    }
}

/// Stopping rules.
#[derive(Debug, Clone, Copy)]
pub struct LmOptions {
    /// Maximum number of Jacobian evaluations.
    pub max_iterations: usize,
    /// Stop when a step changes every parameter by less than `xtol` relative to its size.
    pub xtol: f64,
    /// Stop when an accepted step lowers the cost by less than `ftol` relative.
    pub ftol: f64,
}

impl Default for LmOptions {
    fn default() -> Self {
        Self {
            max_iterations: 200,
            xtol: 1e-12,
            ftol: 1e-15,
        }
    }
}

/// Why the solver stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Termination {
    /// Parameter steps became negligible.
    SmallStep,
    /// Cost reduction became negligible.
    SmallCostChange,
    /// The gradient vanished (exact fit).
    ZeroGradient,
    /// The iteration budget ran out.
    MaxIterations,
    /// No downhill step could be found.
    Stalled,
}

/// Outcome of a fit. `converged` is false for `MaxIterations` and `Stalled`.
#[derive(Debug, Clone)]
pub struct FitOutcome {
    /// Final parameters.
    pub params: DVector<f64>,
    /// Parameter covariance `s^2 (J^T J)^-1`, `s^2 = |r|^2 / (n - p)`.
    pub covariance: DMatrix<f64>,
    /// Final cost `0.5 |r|^2`.
    pub cost: f64,
    /// Root-mean-square residual.
    pub rmse: f64,
    /// Jacobian evaluations used.
    pub iterations: usize,
    /// Why it stopped.
    pub termination: Termination,
}

impl FitOutcome {
    /// True when a stopping test (not the budget) ended the iteration.
    pub fn converged(&self) -> bool {
        !matches!(
            self.termination,
            Termination::MaxIterations | Termination::Stalled
        )
    }

    /// Standard uncertainty of parameter `i`.
    pub fn std_err(&self, i: usize) -> f64 {
        self.covariance[(i, i)].max(0.0).sqrt()
    }
}

/// Minimises the model's cost from `p0`.
pub fn minimize(model: &impl LeastSquaresModel, p0: DVector<f64>, opts: LmOptions) -> FitOutcome {
    let mut p = model.project(p0);
    let mut r = model.residuals(&p);
    let mut cost = 0.5 * r.norm_squared();
    let mut lambda = 1e-3;
    let mut termination = Termination::MaxIterations;
    let mut iterations = 0;
    while iterations < opts.max_iterations {
        iterations += 1;
        let j = model.jacobian(&p);
        let g = j.transpose() * &r;
        let a = j.transpose() * &j;
        if g.amax() <= 1e-300 || cost == 0.0 {
            termination = Termination::ZeroGradient;
            break;
        }
        let diag: Vec<f64> = (0..a.nrows()).map(|i| a[(i, i)].max(1e-300)).collect();
        let mut accepted = false;
        while lambda < 1e16 {
            let mut damped = a.clone();
            for (i, d) in diag.iter().enumerate() {
                damped[(i, i)] += lambda * d;
            }
            let Some(step) = damped.cholesky().map(|c| c.solve(&(-&g))) else {
                lambda *= 10.0;
                continue;
            };
            let trial = model.project(&p + &step);
            let r_trial = model.residuals(&trial);
            let cost_trial = 0.5 * r_trial.norm_squared();
            if cost_trial.is_finite() && cost_trial <= cost {
                let rel_step = (&trial - &p)
                    .iter()
                    .zip(trial.iter())
                    .map(|(d, x)| d.abs() / (x.abs() + 1e-30))
                    .fold(0.0, f64::max);
                let rel_cost = (cost - cost_trial) / cost.max(1e-300);
                p = trial;
                r = r_trial;
                cost = cost_trial;
                lambda = (lambda * 0.3).max(1e-15);
                accepted = true;
                if rel_step < opts.xtol {
                    termination = Termination::SmallStep;
                } else if rel_cost < opts.ftol {
                    termination = Termination::SmallCostChange;
                }
                break;
            }
            lambda *= 4.0;
        }
        if !accepted {
            termination = Termination::Stalled;
            break;
        }
        if termination != Termination::MaxIterations {
            break;
        }
    }
    let j = model.jacobian(&p);
    let n = r.len();
    let k = p.len();
    let s2 = if n > k {
        2.0 * cost / (n - k) as f64
    } else {
        0.0
    };
    let covariance = (j.transpose() * &j)
        .try_inverse()
        .map(|inv| inv * s2)
        .unwrap_or_else(|| DMatrix::from_element(k, k, f64::NAN));
    // A stalled solver at an exact fit is a converged one.
    if termination == Termination::Stalled && cost <= 1e-28 * n as f64 {
        termination = Termination::ZeroGradient;
    }
    FitOutcome {
        params: p,
        covariance,
        cost,
        rmse: (2.0 * cost / n.max(1) as f64).sqrt(),
        iterations,
        termination,
    }
}

/// Central finite-difference Jacobian of `residuals`, for testing analytic Jacobians.
pub fn finite_difference_jacobian(
    model: &impl LeastSquaresModel,
    p: &DVector<f64>,
    rel_step: f64,
) -> DMatrix<f64> {
    let r0 = model.residuals(p);
    let mut jac = DMatrix::zeros(r0.len(), p.len());
    for k in 0..p.len() {
        let h = rel_step * p[k].abs().max(1e-3);
        let mut plus = p.clone();
        plus[k] += h;
        let mut minus = p.clone();
        minus[k] -= h;
        let d = (model.residuals(&plus) - model.residuals(&minus)) / (2.0 * h);
        jac.set_column(k, &d);
    }
    jac
}

#[cfg(test)]
mod tests {
    use super::*;

    /// y = a exp(b x)
    struct Exp {
        x: Vec<f64>,
        y: Vec<f64>,
    }

    impl LeastSquaresModel for Exp {
        fn residuals(&self, p: &DVector<f64>) -> DVector<f64> {
            DVector::from_iterator(
                self.x.len(),
                self.x
                    .iter()
                    .zip(&self.y)
                    .map(|(x, y)| p[0] * (p[1] * x).exp() - y),
            )
        }
        fn jacobian(&self, p: &DVector<f64>) -> DMatrix<f64> {
            DMatrix::from_fn(self.x.len(), 2, |i, k| {
                let e = (p[1] * self.x[i]).exp();
                if k == 0 { e } else { p[0] * self.x[i] * e }
            })
        }
    }

    #[test]
    fn recovers_exponential() {
        let x: Vec<f64> = (0..30).map(|i| i as f64 * 0.1).collect();
        let y = x.iter().map(|x| 2.5 * (-0.7 * x).exp()).collect();
        let model = Exp { x, y };
        let out = minimize(
            &model,
            DVector::from_vec(vec![1.0, 0.0]),
            LmOptions::default(),
        );
        assert!(out.converged(), "{:?}", out.termination);
        assert!(
            (out.params[0] - 2.5).abs() < 1e-10 && (out.params[1] + 0.7).abs() < 1e-10,
            "{}",
            out.params
        );
        let fd = finite_difference_jacobian(&model, &out.params, 1e-6);
        assert!((fd - model.jacobian(&out.params)).amax() < 1e-7);
    }
}
