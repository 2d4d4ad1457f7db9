//! One-dimensional minimisation for the stages' single nonlinear parameters (a relaxation
//! length, `BREFF`, `PTY2`, `PTX3`): a coarse grid finds the basin, argmin's Brent method
//! (golden section + parabolic interpolation) polishes it.
//!
//! In: a cost `f(x)` and an interval. Out: [`ScalarMinimum`] (argument, cost, evaluations,
//! whether Brent met its tolerance). Non-convergence is data, not an error; only a bad interval
//! is an `Err`. Deliberately not here: multi-dimensional solvers (see [`crate::numerics`]).

use argmin::core::{CostFunction, Executor, State, TerminationReason, TerminationStatus};
use argmin::solver::brent::BrentOpt;

/// How the interval is searched.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ScalarOptions {
    /// Grid points over the interval before Brent (>= 3).
    pub grid: usize,
    /// Space the grid logarithmically (the interval must then be positive).
    pub log_grid: bool,
    /// Relative tolerance of Brent's argument.
    pub rel_tol: f64,
    /// Absolute tolerance of Brent's argument.
    pub abs_tol: f64,
    /// Brent iteration budget.
    pub max_iters: u64,
}

impl Default for ScalarOptions {
    fn default() -> Self {
        ScalarOptions {
            grid: 25,
            log_grid: true,
            rel_tol: 1e-8,
            abs_tol: 1e-12,
            max_iters: 200,
        }
    }
}

/// Result of a 1-D minimisation.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ScalarMinimum {
    /// Minimising argument.
    pub x: f64,
    /// Cost there.
    pub cost: f64,
    /// Cost evaluations (grid + Brent).
    pub evaluations: usize,
    /// Brent met its tolerance (false: budget ran out or the cost was not finite).
    pub converged: bool,
    /// The minimum sits on an end of the interval (the true minimum may lie outside).
    pub at_bound: bool,
}

/// A bad search interval.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScalarError {
    /// `lo >= hi`, a non-finite end, or a non-positive end with a log grid.
    #[error("1-D minimisation: bad interval [{lo}, {hi}] (log grid: {log})")]
    BadInterval { lo: f64, hi: f64, log: bool },
}

struct Cost<'a>(&'a dyn Fn(f64) -> f64);

impl CostFunction for Cost<'_> {
    type Param = f64;
    type Output = f64;
    fn cost(&self, x: &f64) -> Result<f64, argmin::core::Error> {
        let c = (self.0)(*x);
        Ok(if c.is_finite() { c } else { f64::MAX })
    }
}

/// The grid [`minimize`] evaluates first over `[lo, hi]` (`opts.grid` points, at least 3, ends
/// included), bit for bit: a caller whose cost has an expensive part that depends only on `x`
/// can compute that part once at these points and reuse it over many minimisations.
pub fn grid(lo: f64, hi: f64, opts: &ScalarOptions) -> Vec<f64> {
    let n = opts.grid.max(3);
    (0..n)
        .map(|i| {
            let u = i as f64 / (n - 1) as f64;
            if opts.log_grid {
                (lo.ln() + u * (hi.ln() - lo.ln())).exp()
            } else {
                lo + u * (hi - lo)
            }
        })
        .collect()
}

/// Minimise `f` over `[lo, hi]`: grid, then Brent between the best grid point's neighbours.
pub fn minimize(
    f: &dyn Fn(f64) -> f64,
    lo: f64,
    hi: f64,
    opts: &ScalarOptions,
) -> Result<ScalarMinimum, ScalarError> {
    let bad = !(lo.is_finite() && hi.is_finite() && lo < hi) || (opts.log_grid && lo <= 0.0);
    if bad {
        return Err(ScalarError::BadInterval {
            lo,
            hi,
            log: opts.log_grid,
        });
    }
    let grid = grid(lo, hi, opts);
    let n = grid.len();
    let point = |i: usize| grid[i];
    let guard = |x: f64| {
        let c = f(x);
        if c.is_finite() { c } else { f64::MAX }
    };
    let (mut best_i, mut best_c) = (0, f64::MAX);
    for i in 0..n {
        let c = guard(point(i));
        if c < best_c {
            best_i = i;
            best_c = c;
        }
    }
    let a = point(best_i.saturating_sub(1));
    let b = point((best_i + 1).min(n - 1));
    let solver = BrentOpt::new(a, b).set_tolerance(opts.rel_tol, opts.abs_tol);
    let run = Executor::new(Cost(f), solver)
        .configure(|s| s.max_iters(opts.max_iters))
        .run();
    let (mut x, mut cost, mut evaluations, mut converged) = (point(best_i), best_c, n, false);
    if let Ok(res) = run {
        let state = res.state();
        evaluations += state.get_func_counts().values().sum::<u64>() as usize;
        converged = matches!(
            state.get_termination_status(),
            TerminationStatus::Terminated(TerminationReason::SolverConverged)
        );
        if let Some(&bx) = state.get_best_param() {
            let bc = state.get_best_cost();
            if bc <= cost {
                x = bx;
                cost = bc;
            }
        }
    }
    let span = hi - lo;
    let at_bound = (x - lo).abs() <= 1e-6 * span || (hi - x).abs() <= 1e-6 * span;
    Ok(ScalarMinimum {
        x,
        cost,
        evaluations,
        converged,
        at_bound,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_minimum_of_a_shifted_quartic_to_tolerance() {
        let f = |x: f64| (x - 0.3137).powi(2) * (1.0 + (x - 0.3137).powi(2)) + 2.0;
        let m = minimize(&f, 0.01, 3.0, &ScalarOptions::default()).unwrap();
        assert!((m.x - 0.3137).abs() < 1e-6, "{m:?}");
        assert!(m.converged && !m.at_bound, "{m:?}");
    }

    #[test]
    fn grid_escapes_a_local_minimum() {
        // Local minimum near 0.2, global near 2.0.
        let f = |x: f64| {
            -(-((x - 0.2) / 0.05).powi(2)).exp() - 2.0 * (-((x - 2.0) / 0.3).powi(2)).exp()
        };
        let m = minimize(&f, 0.05, 5.0, &ScalarOptions::default()).unwrap();
        assert!((m.x - 2.0).abs() < 1e-5, "{m:?}");
    }

    #[test]
    fn minimum_on_the_edge_is_flagged_and_bad_intervals_are_errors() {
        let m = minimize(&|x: f64| x, 1.0, 2.0, &ScalarOptions::default()).unwrap();
        assert!(m.at_bound && (m.x - 1.0).abs() < 1e-6, "{m:?}");
        assert!(minimize(&|x: f64| x, 0.0, 1.0, &ScalarOptions::default()).is_err());
        assert!(minimize(&|x: f64| x, 2.0, 1.0, &ScalarOptions::default()).is_err());
    }
}
