//! Nonlinear least squares, the one solver of the crate: a projected Levenberg-Marquardt with an
//! active set, Moré's diagonal scaling and Nielsen's damping update, optional box bounds, and an
//! optional robust loss by iteratively reweighted least squares (IRLS).
//!
//! In: a [`LeastSquaresProblem`] (residuals, and residuals with their Jacobian written into
//! caller-owned slices), a start point, box [`Bounds`] ([`Bounds::unbounded`] for none) and
//! [`Options`]. Out: a [`FitOutcome`] with the parameters, their covariance and standard errors,
//! which parameters ended on a bound, the iteration and evaluation counts, why the solver
//! stopped, the cost and the data RMSE. Not converging is reported in
//! [`FitOutcome::termination`], never raised: the caller decides what a `MaxIterations` fit is
//! worth. The problem (residuals + Jacobian) and the solver are separate, as in the
//! `levenberg-marquardt` and `argmin` crates; every stage's nonlinear fit goes through
//! [`minimize`] (the PAC2002 and MF 6.1 fits bounded and robust, the thermal `mu(T)` curve and
//! the rig-inertia models with plain squared loss). Linear least squares is
//! [`super::least_squares`].
//!
//! Why not a crate: neither `levenberg-marquardt` nor `argmin` takes bounds, and the tire fits
//! need them (shape factors `C > 0`, combined-slip shifts kept small, sign conventions of
//! symmetric parameters). The method is the textbook one (Moré 1978 for the scaling and the
//! stopping tests, Nielsen 1999 for the damping update, Kanzow et al. 2004 for the projection):
//! a step solves `(J_F^T J_F + lambda D_F^2) d_F = -g_F` over the free set `F` (parameters not
//! held on a bound by a gradient pushing outward), the trial point is clipped into the box, and
//! it is accepted when it lowers the cost.
//!
//! Robust loss: the problem declares its first [`LeastSquaresProblem::n_data`] residuals as data
//! (the rest are penalties and priors, never down-weighted). With [`RobustLoss::Huber`] or
//! [`RobustLoss::Cauchy`] the solver fits, re-weights each data residual from its size relative
//! to a robust scale (1.4826 x the median absolute data residual, floored at
//! [`Options::scale_floor`]), and refits from the previous solution, [`Options::irls_rounds`]
//! times.
//!
//! Deliberately not here: constraints other than boxes (callers add penalty residuals), global
//! search, and anything about tires.

use nalgebra::{DMatrix, DVector};

/// A nonlinear least-squares problem: minimise `0.5 |r(p)|^2` over the box.
///
/// The Jacobian is row-major: `jac[i * n_params + j] = d r_i / d p_j`.
pub trait LeastSquaresProblem {
    /// Number of parameters.
    fn n_params(&self) -> usize;
    /// Number of residuals (data and penalties).
    fn n_residuals(&self) -> usize;
    /// The first `n_data()` residuals are data (subject to the robust loss); the rest are
    /// penalties. Default: all residuals are data.
    fn n_data(&self) -> usize {
        self.n_residuals()
    }
    /// The cluster (e.g. the sweep) of each data residual, `n_data()` labels, when the data
    /// residuals are correlated within clusters and independent between them; `None` (the
    /// default) treats every data residual as independent. With clusters the covariance is the
    /// cluster-robust sandwich (see [`FitOutcome::covariance`]).
    fn data_clusters(&self) -> Option<&[usize]> {
        None
    }
    /// Residuals at `p` into `r` (`r.len() == n_residuals()`).
    fn residuals(&self, p: &[f64], r: &mut [f64]);
    /// Residuals and Jacobian at `p` (`jac.len() == n_residuals() * n_params()`).
    fn residuals_and_jacobian(&self, p: &[f64], r: &mut [f64], jac: &mut [f64]);
}

/// Box bounds, one `[lower, upper]` pair per parameter (infinite for unbounded).
#[derive(Clone, Debug, PartialEq)]
pub struct Bounds {
    /// Lower bounds.
    pub lower: Vec<f64>,
    /// Upper bounds.
    pub upper: Vec<f64>,
}

impl Bounds {
    /// No bounds on `n` parameters.
    pub fn unbounded(n: usize) -> Self {
        Bounds {
            lower: vec![f64::NEG_INFINITY; n],
            upper: vec![f64::INFINITY; n],
        }
    }

    fn clamp(&self, j: usize, v: f64) -> f64 {
        v.max(self.lower[j]).min(self.upper[j])
    }
}

/// Robust loss on the data residuals (applied by IRLS).
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum RobustLoss {
    /// Plain least squares.
    None,
    /// Huber: quadratic within `k` robust scales, linear beyond (weight `min(1, k s / |r|)`).
    Huber {
        /// Threshold in robust scales (1.345 to 2.5 are usual).
        k: f64,
    },
    /// Cauchy: weight `1 / (1 + (r / (k s))^2)`; rejects gross outliers more firmly than Huber.
    Cauchy {
        /// Scale multiplier (2.385 is the usual 95 %-efficiency choice).
        k: f64,
    },
}

/// Stopping rules and the robust loss.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Options {
    /// Maximum number of trial steps (each solves one damped system) per IRLS round.
    pub max_iterations: usize,
    /// Stop when the scaled step `|D d|` is below `xtol (|D p| + xtol)`.
    pub xtol: f64,
    /// Stop when an accepted step lowers the cost by less than `ftol` relative.
    pub ftol: f64,
    /// Stop when every free scaled gradient component `|g_j| / (D_j |r|)` is below `gtol`.
    pub gtol: f64,
    /// Robust loss on the data residuals.
    pub loss: RobustLoss,
    /// Number of re-weighting rounds when `loss` is not `None`.
    pub irls_rounds: usize,
    /// Smallest robust scale, in residual units (keeps a near-exact fit from re-weighting
    /// round-off).
    pub scale_floor: f64,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            max_iterations: 200,
            xtol: 1e-10,
            ftol: 1e-12,
            gtol: 1e-10,
            loss: RobustLoss::None,
            irls_rounds: 3,
            scale_floor: 1e-12,
        }
    }
}

impl Options {
    /// Options of a warm-started refit (a cross-validation fold started from the full fit):
    /// looser tolerances, one re-weighting round, `max_iterations` trial steps.
    pub fn warm_refit(max_iterations: usize, loss: RobustLoss) -> Self {
        Options {
            max_iterations,
            xtol: 1e-8,
            ftol: 1e-6,
            gtol: 1e-8,
            loss,
            irls_rounds: 1,
            ..Options::default()
        }
    }
}

/// Why the solver stopped.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Termination {
    /// The projected gradient vanished (first-order optimality within `gtol`).
    SmallGradient,
    /// Steps became negligible (`xtol`).
    SmallStep,
    /// The cost stopped decreasing (`ftol`).
    SmallCostChange,
    /// The iteration budget ran out.
    MaxIterations,
    /// No downhill step could be found even with very strong damping.
    Stalled,
    /// The residuals were not finite at the start point.
    NonFiniteStart,
}

impl Termination {
    /// True for the three stopping tests, false for budget, stall and bad start.
    pub fn converged(self) -> bool {
        matches!(
            self,
            Termination::SmallGradient | Termination::SmallStep | Termination::SmallCostChange
        )
    }

    /// Short snake-case name (for tables).
    pub const fn as_str(self) -> &'static str {
        match self {
            Termination::SmallGradient => "small_gradient",
            Termination::SmallStep => "small_step",
            Termination::SmallCostChange => "small_cost_change",
            Termination::MaxIterations => "max_iterations",
            Termination::Stalled => "stalled",
            Termination::NonFiniteStart => "non_finite_start",
        }
    }
}

/// The result of [`minimize`].
#[derive(Clone, Debug, PartialEq)]
pub struct FitOutcome {
    /// Final parameters (inside the bounds).
    pub params: Vec<f64>,
    /// Parameter covariance over the parameters not on a bound, `n_params x n_params`, from the
    /// weighted residuals `r` and Jacobian `J` at the solution (robust weights applied; penalty
    /// rows in `J^T J` but not in the residual spread), `n` data residuals, `k` free parameters:
    /// - without [`LeastSquaresProblem::data_clusters`]: the classical `s^2 (J^T J)^-1`,
    ///   `s^2 = |r_data|^2 / (n - k)`;
    /// - with `G` clusters: the cluster-robust sandwich
    ///   `G/(G-1) (n-1)/(n-k) (J^T J)^-1 (sum_g J_g^T r_g r_g^T J_g) (J^T J)^-1` (CR1), which
    ///   stays honest when the residuals within a cluster are correlated (smooth model error
    ///   along a sweep) and equals the classical figure in expectation when they are white.
    ///
    /// Rows and columns of a parameter on a bound are NaN; all of it is NaN when the normal
    /// matrix is singular, there are no spare degrees of freedom or fewer than two clusters.
    pub covariance: DMatrix<f64>,
    /// Standard error of each parameter, the square root of the covariance's diagonal; `None`
    /// where that is not a finite, non-negative number (on a bound, singular normal matrix, no
    /// spare degrees of freedom).
    pub std_errors: Vec<Option<f64>>,
    /// The classical `s^2 (J^T J)^-1` (equal to `covariance` without clusters): the curvature
    /// of the cost, which predicts how much the residual sum of squares grows when parameters
    /// are moved or held (a Wald statistic), whatever the residuals' correlation.
    pub classical_covariance: DMatrix<f64>,
    /// The classical standard errors, from `classical_covariance` (equal to `std_errors`
    /// without clusters): their ratio to `std_errors` shows how much the within-cluster
    /// correlation matters.
    pub classical_std_errors: Vec<Option<f64>>,
    /// Which parameters ended on (within 1e-12 relative of) a bound.
    pub at_bounds: Vec<bool>,
    /// How well the data determine the parameters off their bounds (see [`Identifiability`]).
    pub identifiability: Identifiability,
    /// Trial steps taken, over all IRLS rounds.
    pub iterations: usize,
    /// Residual evaluations plus Jacobian evaluations.
    pub evaluations: usize,
    /// Jacobian evaluations alone (each also yields the residuals).
    pub jacobian_evaluations: usize,
    /// Why the last round stopped.
    pub termination: Termination,
    /// Final cost `0.5 |r|^2` with the final robust weights, penalties included.
    pub cost: f64,
    /// Root mean square of the data residuals, without robust weights.
    pub rmse: f64,
    /// Final robust weight of each data residual (all 1 without a robust loss).
    pub robust_weights: Vec<f64>,
}

/// Identifiability of the parameters off their bounds from the data rows of the weighted
/// Jacobian at the solution (penalty rows excluded), each column scaled to unit length so that
/// units do not matter: its singular values say how many directions the data fix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Identifiability {
    /// Parameters off their bounds (the Jacobian's columns).
    pub n_free: usize,
    /// Numerical rank: singular values above `1e-10` of the largest (0 when the Jacobian is
    /// not finite).
    pub rank: usize,
    /// Ratio of the largest to the smallest singular value (infinite when rank-deficient, 1 with
    /// no free parameter).
    pub condition: f64,
}

impl Identifiability {
    /// From a row-major Jacobian of `n` columns: its first `n_data` rows, columns `free`.
    pub fn of(jac: &[f64], n: usize, n_data: usize, free: &[usize]) -> Identifiability {
        let k = free.len();
        // A non-finite Jacobian (a non-finite start) determines nothing; the SVD would not
        // converge on it.
        let finite = jac
            .chunks_exact(n)
            .take(n_data)
            .all(|row| free.iter().all(|&j| row[j].is_finite()));
        if k == 0 || n_data == 0 || !finite {
            return Identifiability {
                n_free: k,
                rank: 0,
                condition: if k == 0 { 1.0 } else { f64::INFINITY },
            };
        }
        let mut a = DMatrix::<f64>::zeros(n_data, k);
        for (i, row) in jac.chunks_exact(n).take(n_data).enumerate() {
            for (x, &j) in free.iter().enumerate() {
                a[(i, x)] = row[j];
            }
        }
        for mut col in a.column_iter_mut() {
            let norm = col.norm();
            if norm > 0.0 && norm.is_finite() {
                col /= norm;
            }
        }
        let sv = a.singular_values();
        let largest = sv.iter().copied().fold(0.0, f64::max);
        let smallest = sv.iter().copied().fold(f64::INFINITY, f64::min);
        let rank = sv.iter().filter(|v| **v > 1e-10 * largest).count();
        Identifiability {
            n_free: k,
            rank,
            condition: if rank < k || smallest <= 0.0 {
                f64::INFINITY
            } else {
                largest / smallest
            },
        }
    }
}

/// Minimises `0.5 |w . r(p)|^2` over the box from `start` (clipped into the box first).
///
/// # Panics
/// If `start` or the bounds do not have `problem.n_params()` entries, or a lower bound exceeds
/// its upper bound.
pub fn minimize(
    problem: &impl LeastSquaresProblem,
    start: &[f64],
    bounds: &Bounds,
    options: &Options,
) -> FitOutcome {
    let (state, p, termination) = solve(problem, start, bounds, options, None);
    let n_data = problem.n_data().min(problem.n_residuals());
    state.finish(p, termination, n_data)
}

/// The unweighted residuals and Jacobian at a point, as
/// [`LeastSquaresProblem::residuals_and_jacobian`] writes them, evaluated by the caller.
pub struct Evaluated {
    /// Where.
    pub at: Vec<f64>,
    /// Residuals.
    pub r: Vec<f64>,
    /// Jacobian, row-major.
    pub jac: Vec<f64>,
}

/// The parameters of a [`refit`] and what they cost.
#[derive(Clone, Debug, PartialEq)]
pub struct Refit {
    /// Final parameters (inside the bounds), the same as [`minimize`]'s.
    pub params: Vec<f64>,
    /// Residual evaluations plus Jacobian evaluations.
    pub evaluations: usize,
    /// Why the last round stopped.
    pub termination: Termination,
}

/// [`minimize`] for a caller that needs only the parameters (a cross-validation refit): the
/// same steps and parameters, without the statistics at the solution (covariance,
/// identifiability, RMSE). `at_start`, when the caller has evaluated the problem at `start`
/// already, stands in for the solver's first Jacobian if `start` lies inside the box (it must
/// be this problem's evaluation there).
///
/// # Panics
/// As [`minimize`].
pub fn refit(
    problem: &impl LeastSquaresProblem,
    start: &[f64],
    bounds: &Bounds,
    options: &Options,
    at_start: Option<Evaluated>,
) -> Refit {
    let (state, params, termination) = solve(problem, start, bounds, options, at_start);
    Refit {
        params,
        evaluations: state.evaluations,
        termination,
    }
}

/// The Levenberg-Marquardt runs and IRLS rounds of [`minimize`]: the solver state, the final
/// parameters and why the last round stopped.
fn solve<'a, P: LeastSquaresProblem>(
    problem: &'a P,
    start: &[f64],
    bounds: &'a Bounds,
    options: &'a Options,
    at_start: Option<Evaluated>,
) -> (Solver<'a, P>, Vec<f64>, Termination) {
    let n = problem.n_params();
    assert_eq!(start.len(), n, "minimize: start length");
    assert_eq!(bounds.lower.len(), n, "minimize: lower bounds length");
    assert_eq!(bounds.upper.len(), n, "minimize: upper bounds length");
    for j in 0..n {
        assert!(
            bounds.lower[j] <= bounds.upper[j],
            "minimize: bound {j} is empty"
        );
    }
    let m = problem.n_residuals();
    let n_data = problem.n_data().min(m);
    let mut state = Solver {
        problem,
        bounds,
        options,
        n,
        m,
        weights: vec![1.0; m],
        evaluations: 0,
        jacobian_evaluations: 0,
        iterations: 0,
        last_jacobian: at_start.filter(|e| e.r.len() == m && e.jac.len() == m * n),
    };
    let mut p: Vec<f64> = (0..n).map(|j| bounds.clamp(j, start[j])).collect();
    let rounds = match options.loss {
        RobustLoss::None => 0,
        _ => options.irls_rounds,
    };
    let mut termination = state.levenberg_marquardt(&mut p);
    for _ in 0..rounds {
        if termination == Termination::NonFiniteStart {
            break;
        }
        let mut r = vec![0.0; m];
        problem.residuals(&p, &mut r);
        state.evaluations += 1;
        state.weights[..n_data].copy_from_slice(&robust_weights(
            &r[..n_data],
            options.loss,
            options.scale_floor,
        ));
        termination = state.levenberg_marquardt(&mut p);
    }
    (state, p, termination)
}

/// Square roots of the IRLS weights of `r` (they multiply residuals and Jacobian rows).
fn robust_weights(r: &[f64], loss: RobustLoss, floor: f64) -> Vec<f64> {
    let mut abs: Vec<f64> = r.iter().map(|x| x.abs()).collect();
    let median = super::stats::median(&mut abs).unwrap_or(0.0);
    let s = (1.4826 * median).max(floor);
    r.iter()
        .map(|x| {
            let u = x.abs() / s;
            let w = match loss {
                RobustLoss::None => 1.0,
                RobustLoss::Huber { k } => {
                    if u <= k {
                        1.0
                    } else {
                        k / u
                    }
                }
                RobustLoss::Cauchy { k } => 1.0 / (1.0 + (u / k) * (u / k)),
            };
            w.sqrt()
        })
        .collect()
}

/// Mutable solver state shared by the IRLS rounds.
struct Solver<'a, P: LeastSquaresProblem> {
    problem: &'a P,
    bounds: &'a Bounds,
    options: &'a Options,
    n: usize,
    m: usize,
    /// Square-root robust weight per residual (1 for penalties).
    weights: Vec<f64>,
    evaluations: usize,
    jacobian_evaluations: usize,
    iterations: usize,
    /// The last unweighted residuals and Jacobian and where they were evaluated: a round stops
    /// on the point it evaluated them at, and the next IRLS round and the final statistics
    /// start there (only the weights change), so they reuse them instead of evaluating again.
    last_jacobian: Option<Evaluated>,
}

impl Evaluated {
    /// True when evaluated at exactly `p` (bit for bit: the same point gives the same values).
    fn is_at(&self, p: &[f64]) -> bool {
        self.at.len() == p.len()
            && self
                .at
                .iter()
                .zip(p)
                .all(|(a, b)| a.to_bits() == b.to_bits())
    }
}

impl<P: LeastSquaresProblem> Solver<'_, P> {
    fn weighted_residuals(&mut self, p: &[f64], r: &mut [f64]) -> f64 {
        self.problem.residuals(p, r);
        self.evaluations += 1;
        for (x, w) in r.iter_mut().zip(&self.weights) {
            *x *= w;
        }
        0.5 * r.iter().map(|x| x * x).sum::<f64>()
    }

    fn weighted_jacobian(&mut self, p: &[f64], r: &mut [f64], jac: &mut [f64]) -> f64 {
        match self.last_jacobian.as_ref().filter(|last| last.is_at(p)) {
            Some(last) => {
                r.copy_from_slice(&last.r);
                jac.copy_from_slice(&last.jac);
            }
            None => {
                self.problem.residuals_and_jacobian(p, r, jac);
                self.evaluations += 1;
                self.jacobian_evaluations += 1;
                self.last_jacobian = Some(Evaluated {
                    at: p.to_vec(),
                    r: r.to_vec(),
                    jac: jac.to_vec(),
                });
            }
        }
        let n = self.n;
        for (i, (x, w)) in r.iter_mut().zip(&self.weights).enumerate() {
            *x *= w;
            jac[i * n..(i + 1) * n].iter_mut().for_each(|v| *v *= w);
        }
        0.5 * r.iter().map(|x| x * x).sum::<f64>()
    }

    /// One Levenberg-Marquardt run from `p` (updated in place) with the current weights.
    fn levenberg_marquardt(&mut self, p: &mut [f64]) -> Termination {
        let (n, m) = (self.n, self.m);
        let mut r = vec![0.0; m];
        let mut jac = vec![0.0; m * n];
        let mut cost = self.weighted_jacobian(p, &mut r, &mut jac);
        if !cost.is_finite() {
            return Termination::NonFiniteStart;
        }
        let mut normal = normal_equations(&jac, &r, n);
        let mut scale: Vec<f64> = (0..n).map(|j| normal.a[j * n + j].sqrt()).collect();
        floor_scale(&mut scale);
        let mut lambda = 1e-3;
        let mut nu = 2.0;
        let mut r_trial = vec![0.0; m];
        let mut trial = vec![0.0; n];
        let mut steps = 0;
        loop {
            if cost <= 0.0 {
                return Termination::SmallGradient;
            }
            let free = self.free_set(p, &normal.g);
            let r_norm = (2.0 * cost).sqrt();
            let gmax = free
                .iter()
                .map(|&j| normal.g[j].abs() / (scale[j] * r_norm))
                .fold(0.0, f64::max);
            if gmax <= self.options.gtol {
                return Termination::SmallGradient;
            }
            if steps >= self.options.max_iterations {
                return Termination::MaxIterations;
            }
            steps += 1;
            self.iterations += 1;
            let Some(step) = damped_step(&normal, &free, &scale, lambda, n) else {
                lambda *= nu;
                nu *= 2.0;
                if lambda > 1e30 {
                    return Termination::Stalled;
                }
                continue;
            };
            for j in 0..n {
                trial[j] = self.bounds.clamp(j, p[j] + step[j]);
            }
            let s: Vec<f64> = (0..n).map(|j| trial[j] - p[j]).collect();
            let cost_trial = self.weighted_residuals(&trial, &mut r_trial);
            let predicted = -(dot(&normal.g, &s) + 0.5 * quad(&normal.a, &s, n));
            if cost_trial.is_finite() && cost_trial < cost {
                let rho = if predicted > 0.0 {
                    (cost - cost_trial) / predicted
                } else {
                    0.5
                };
                lambda *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
                nu = 2.0;
                let step_norm = s
                    .iter()
                    .zip(&scale)
                    .map(|(a, d)| (a * d).powi(2))
                    .sum::<f64>()
                    .sqrt();
                let p_norm = p
                    .iter()
                    .zip(&scale)
                    .map(|(a, d)| (a * d).powi(2))
                    .sum::<f64>()
                    .sqrt();
                let small_step = step_norm <= self.options.xtol * (p_norm + self.options.xtol);
                let small_cost = cost - cost_trial <= self.options.ftol * cost;
                p.copy_from_slice(&trial);
                cost = self.weighted_jacobian(p, &mut r, &mut jac);
                normal = normal_equations(&jac, &r, n);
                for (j, d) in scale.iter_mut().enumerate() {
                    *d = d.max(normal.a[j * n + j].sqrt());
                }
                floor_scale(&mut scale);
                if small_step {
                    return Termination::SmallStep;
                }
                if small_cost {
                    return Termination::SmallCostChange;
                }
            } else {
                // A step the local model says cannot gain more than `ftol` is a converged fit
                // (round-off decides the sign of the actual change), not a stall.
                if predicted >= 0.0 && predicted <= self.options.ftol * cost {
                    return Termination::SmallCostChange;
                }
                lambda *= nu;
                nu *= 2.0;
                let all_clipped = s.iter().all(|x| *x == 0.0);
                if lambda > 1e30 || all_clipped {
                    return Termination::Stalled;
                }
            }
        }
    }

    /// Parameters not held on a bound by a gradient pointing out of the box.
    fn free_set(&self, p: &[f64], g: &[f64]) -> Vec<usize> {
        (0..self.n)
            .filter(|&j| {
                let at_lower = p[j] <= self.bounds.lower[j] && g[j] > 0.0;
                let at_upper = p[j] >= self.bounds.upper[j] && g[j] < 0.0;
                !(at_lower || at_upper)
            })
            .collect()
    }

    fn finish(mut self, p: Vec<f64>, termination: Termination, n_data: usize) -> FitOutcome {
        let (n, m) = (self.n, self.m);
        let mut r = vec![0.0; m];
        let mut jac = vec![0.0; m * n];
        let cost = self.weighted_jacobian(&p, &mut r, &mut jac);
        let at_bounds: Vec<bool> = (0..n)
            .map(|j| {
                let tol = 1e-12 * (1.0 + p[j].abs());
                p[j] - self.bounds.lower[j] <= tol || self.bounds.upper[j] - p[j] <= tol
            })
            .collect();
        let free: Vec<usize> = (0..n).filter(|&j| !at_bounds[j]).collect();
        let normal = ScaledNormal::of(&jac, n, &free);
        let classical = normal
            .as_ref()
            .map(|b| b.classical(&r, n_data))
            .unwrap_or_else(|| nan_covariance(n));
        let clusters = self.problem.data_clusters().filter(|c| c.len() == n_data);
        let covariance = match (clusters, normal.as_ref()) {
            (None, _) => classical.clone(),
            (Some(labels), Some(b)) => b.clustered(&jac, &r, n_data, labels),
            (Some(_), None) => nan_covariance(n),
        };
        let std_errors = std_errors_of(&covariance);
        let classical_std_errors = std_errors_of(&classical);
        let identifiability = Identifiability::of(&jac, n, n_data, &free);
        let mut raw = vec![0.0; m];
        self.problem.residuals(&p, &mut raw);
        self.evaluations += 1;
        let rmse = if n_data == 0 {
            0.0
        } else {
            (raw[..n_data].iter().map(|x| x * x).sum::<f64>() / n_data as f64).sqrt()
        };
        let robust_weights = self.weights[..n_data].iter().map(|w| w * w).collect();
        FitOutcome {
            params: p,
            covariance,
            std_errors,
            classical_std_errors,
            classical_covariance: classical,
            at_bounds,
            identifiability,
            iterations: self.iterations,
            evaluations: self.evaluations,
            jacobian_evaluations: self.jacobian_evaluations,
            termination,
            cost,
            rmse,
            robust_weights,
        }
    }
}

/// Keeps every scale positive: a parameter with no effect at the current point (a zero
/// Jacobian column, e.g. a factor multiplied by a term that is zero there) gets a scale of 1e-8
/// of the largest, so the damped system stays positive definite and its step is zero.
fn floor_scale(scale: &mut [f64]) {
    let largest = scale.iter().copied().fold(0.0, f64::max);
    let floor = if largest > 0.0 { 1e-8 * largest } else { 1.0 };
    for d in scale.iter_mut() {
        if d.is_nan() || *d < floor {
            *d = floor;
        }
    }
}

/// `J^T J` (row-major `n x n`) and `J^T r`.
struct Normal {
    a: Vec<f64>,
    g: Vec<f64>,
}

fn normal_equations(jac: &[f64], r: &[f64], n: usize) -> Normal {
    let mut a = vec![0.0; n * n];
    let mut g = vec![0.0; n];
    for (row, ri) in jac.chunks_exact(n).zip(r) {
        for j in 0..n {
            let rj = row[j];
            if rj == 0.0 {
                continue;
            }
            g[j] += rj * ri;
            // Slices rather than indices: the loop compiles to vector code without bounds
            // checks (each element's sum runs in the same order, so the values do not change).
            let upper = &mut a[j * n + j..(j + 1) * n];
            for (x, r) in upper.iter_mut().zip(&row[j..]) {
                *x += rj * r;
            }
        }
    }
    for j in 0..n {
        for k in 0..j {
            a[j * n + k] = a[k * n + j];
        }
    }
    Normal { a, g }
}

/// Solves `(A_FF + lambda D_F^2) d_F = -g_F`; zero outside `free`. `None` if not positive
/// definite.
fn damped_step(
    normal: &Normal,
    free: &[usize],
    scale: &[f64],
    lambda: f64,
    n: usize,
) -> Option<Vec<f64>> {
    let k = free.len();
    let mut step = vec![0.0; n];
    if k == 0 {
        return Some(step);
    }
    let mut m = DMatrix::<f64>::zeros(k, k);
    let mut rhs = DVector::<f64>::zeros(k);
    for (a, &ja) in free.iter().enumerate() {
        for (b, &jb) in free.iter().enumerate() {
            m[(a, b)] = normal.a[ja * n + jb];
        }
        m[(a, a)] += lambda * scale[ja] * scale[ja];
        rhs[a] = -normal.g[ja];
    }
    let chol = m.cholesky()?;
    let d = chol.solve(&rhs);
    if d.iter().any(|x| !x.is_finite()) {
        return None;
    }
    for (a, &ja) in free.iter().enumerate() {
        step[ja] = d[a];
    }
    Some(step)
}

/// An all-NaN `n x n` covariance (nothing estimated).
fn nan_covariance(n: usize) -> DMatrix<f64> {
    DMatrix::from_element(n, n, f64::NAN)
}

/// Standard errors from a covariance's diagonal (`None` where not finite and non-negative).
fn std_errors_of(cov: &DMatrix<f64>) -> Vec<Option<f64>> {
    (0..cov.nrows())
        .map(|j| {
            let var = cov[(j, j)];
            (var.is_finite() && var >= 0.0).then(|| var.sqrt())
        })
        .collect()
}

/// The inverse normal matrix over the free parameters, computed on the unit-diagonal scaling
/// `D^-1 J^T J D^-1` (the coefficients differ by orders of magnitude): `inv` is that scaled
/// matrix's inverse, `d` the column norms.
struct ScaledNormal<'a> {
    n: usize,
    free: &'a [usize],
    d: Vec<f64>,
    inv: DMatrix<f64>,
}

impl<'a> ScaledNormal<'a> {
    /// `None` when there is no free parameter, a column is zero or not finite, or the normal
    /// matrix is singular.
    fn of(jac: &[f64], n: usize, free: &'a [usize]) -> Option<Self> {
        let k = free.len();
        if k == 0 {
            return None;
        }
        let mut a = DMatrix::<f64>::zeros(k, k);
        for row in jac.chunks_exact(n) {
            for (x, &jx) in free.iter().enumerate() {
                let v = row[jx];
                if v == 0.0 {
                    continue;
                }
                for (y, &jy) in free.iter().enumerate() {
                    a[(x, y)] += v * row[jy];
                }
            }
        }
        let d: Vec<f64> = (0..k).map(|x| a[(x, x)].sqrt()).collect();
        if d.iter().any(|v| *v <= 0.0 || !v.is_finite()) {
            return None;
        }
        for x in 0..k {
            for y in 0..k {
                a[(x, y)] /= d[x] * d[y];
            }
        }
        let inv = a.cholesky()?.inverse();
        Some(ScaledNormal { n, free, d, inv })
    }

    /// The full `n x n` covariance from a scaled `k x k` one (NaN off the free set).
    fn unscale(&self, scaled: &DMatrix<f64>) -> DMatrix<f64> {
        let mut cov = nan_covariance(self.n);
        for (x, &jx) in self.free.iter().enumerate() {
            for (y, &jy) in self.free.iter().enumerate() {
                cov[(jx, jy)] = scaled[(x, y)] / (self.d[x] * self.d[y]);
            }
        }
        cov
    }

    /// `s^2 (J^T J)^-1` (see [`FitOutcome::covariance`]).
    fn classical(&self, r: &[f64], n_data: usize) -> DMatrix<f64> {
        let k = self.free.len();
        if n_data <= k {
            return nan_covariance(self.n);
        }
        let s2 = r[..n_data].iter().map(|x| x * x).sum::<f64>() / (n_data - k) as f64;
        self.unscale(&(&self.inv * s2))
    }

    /// The CR1 cluster-robust sandwich (see [`FitOutcome::covariance`]); `labels` has one
    /// cluster label per data residual.
    fn clustered(&self, jac: &[f64], r: &[f64], n_data: usize, labels: &[usize]) -> DMatrix<f64> {
        let k = self.free.len();
        // Each cluster's score `D^-1 J_g^T r_g` (ordered by label: deterministic sums).
        let mut scores: std::collections::BTreeMap<usize, DVector<f64>> = Default::default();
        for ((row, ri), g) in jac.chunks_exact(self.n).zip(r).take(n_data).zip(labels) {
            let u = scores.entry(*g).or_insert_with(|| DVector::zeros(k));
            for (x, &jx) in self.free.iter().enumerate() {
                u[x] += row[jx] * ri / self.d[x];
            }
        }
        let g = scores.len();
        if g < 2 || n_data <= k {
            return nan_covariance(self.n);
        }
        let mut meat = DMatrix::<f64>::zeros(k, k);
        for u in scores.values() {
            meat += u * u.transpose();
        }
        let factor = g as f64 / (g - 1) as f64 * (n_data - 1) as f64 / (n_data - k) as f64;
        self.unscale(&(&self.inv * meat * &self.inv * factor))
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// `s^T A s` for row-major `A`.
fn quad(a: &[f64], s: &[f64], n: usize) -> f64 {
    let mut acc = 0.0;
    for j in 0..n {
        if s[j] == 0.0 {
            continue;
        }
        acc += s[j] * dot(&a[j * n..(j + 1) * n], s);
    }
    acc
}

/// Central finite-difference Jacobian (row-major), for checking analytic Jacobians in tests.
pub fn finite_difference_jacobian(
    problem: &impl LeastSquaresProblem,
    p: &[f64],
    rel_step: f64,
) -> Vec<f64> {
    let (n, m) = (problem.n_params(), problem.n_residuals());
    let mut jac = vec![0.0; m * n];
    let mut plus = vec![0.0; m];
    let mut minus = vec![0.0; m];
    let mut q = p.to_vec();
    for j in 0..n {
        let h = rel_step * p[j].abs().max(1e-3);
        q[j] = p[j] + h;
        problem.residuals(&q, &mut plus);
        q[j] = p[j] - h;
        problem.residuals(&q, &mut minus);
        q[j] = p[j];
        for i in 0..m {
            jac[i * n + j] = (plus[i] - minus[i]) / (2.0 * h);
        }
    }
    jac
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `y = a exp(b x) + c` on a grid, with optional outliers.
    struct Exp {
        x: Vec<f64>,
        y: Vec<f64>,
    }

    impl LeastSquaresProblem for Exp {
        fn n_params(&self) -> usize {
            3
        }
        fn n_residuals(&self) -> usize {
            self.x.len()
        }
        fn residuals(&self, p: &[f64], r: &mut [f64]) {
            for ((ri, x), y) in r.iter_mut().zip(&self.x).zip(&self.y) {
                *ri = p[0] * (p[1] * x).exp() + p[2] - y;
            }
        }
        fn residuals_and_jacobian(&self, p: &[f64], r: &mut [f64], jac: &mut [f64]) {
            self.residuals(p, r);
            for (i, x) in self.x.iter().enumerate() {
                let e = (p[1] * x).exp();
                jac[i * 3] = e;
                jac[i * 3 + 1] = p[0] * x * e;
                jac[i * 3 + 2] = 1.0;
            }
        }
    }

    fn exp_data(outliers: bool) -> Exp {
        let x: Vec<f64> = (0..60).map(|i| i as f64 * 0.05).collect();
        let mut y: Vec<f64> = x.iter().map(|x| 2.5 * (-0.7 * x).exp() + 0.3).collect();
        // Deterministic small "noise" so the robust scale is not zero.
        for (i, v) in y.iter_mut().enumerate() {
            *v += 1e-3 * ((i * 37 % 11) as f64 - 5.0) / 5.0;
        }
        if outliers {
            y[7] += 1.0;
            y[31] -= 0.8;
        }
        Exp { x, y }
    }

    /// The fit of `problem` from `[1, 0, 0]`, unbounded, with `options`.
    fn fit_exp(problem: &Exp, options: &Options) -> FitOutcome {
        minimize(problem, &[1.0, 0.0, 0.0], &Bounds::unbounded(3), options)
    }

    /// Residuals and row-major Jacobian of `problem` at `p`.
    fn residuals_and_jacobian_at(problem: &Exp, p: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let m = problem.n_residuals();
        let mut r = vec![0.0; m];
        let mut jac = vec![0.0; m * problem.n_params()];
        problem.residuals_and_jacobian(p, &mut r, &mut jac);
        (r, jac)
    }

    #[test]
    fn recovers_exponential_unbounded() {
        let problem = exp_data(false);
        let out = fit_exp(&problem, &Options::default());
        assert!(out.termination.converged(), "{:?}", out.termination);
        assert!((out.params[0] - 2.5).abs() < 5e-3, "{:?}", out.params);
        assert!((out.params[1] + 0.7).abs() < 5e-3, "{:?}", out.params);
        assert!(out.std_errors.iter().all(|s| s.is_some()));
        let fd = finite_difference_jacobian(&problem, &out.params, 1e-6);
        let (_, jac) = residuals_and_jacobian_at(&problem, &out.params);
        let worst = fd
            .iter()
            .zip(&jac)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-7, "jacobian vs finite differences: {worst}");
    }

    /// `refit` takes the same steps as `minimize` (bit for bit, with a robust loss and a bound
    /// on the path), and an evaluation supplied at the start saves exactly the solver's first
    /// Jacobian; one at another point is not used.
    #[test]
    fn refit_gives_minimizes_parameters_and_reuses_a_start_evaluation() {
        let problem = exp_data(true);
        let bounds = Bounds {
            lower: vec![0.0, -0.69, -1.0],
            upper: vec![10.0, 1.0, 1.0],
        };
        let options = Options::warm_refit(20, RobustLoss::Huber { k: 1.345 });
        let start = [2.0, -0.5, 0.2];
        let full = minimize(&problem, &start, &bounds, &options);
        let plain = refit(&problem, &start, &bounds, &options, None);
        assert_eq!(plain.params, full.params);
        assert_eq!(plain.termination, full.termination);
        // `minimize` also evaluates the residuals once more for the RMSE.
        assert_eq!(plain.evaluations + 1, full.evaluations);
        let evaluated_at = |p: &[f64]| {
            let (r, jac) = residuals_and_jacobian_at(&problem, p);
            Evaluated {
                at: p.to_vec(),
                r,
                jac,
            }
        };
        let seeded = refit(
            &problem,
            &start,
            &bounds,
            &options,
            Some(evaluated_at(&start)),
        );
        assert_eq!(seeded.params, full.params);
        assert_eq!(seeded.evaluations + 1, plain.evaluations);
        let elsewhere = [2.1, -0.5, 0.2];
        let unused = refit(
            &problem,
            &start,
            &bounds,
            &options,
            Some(evaluated_at(&elsewhere)),
        );
        assert_eq!(unused, plain);
    }

    #[test]
    fn covariance_is_s2_times_the_inverse_normal_matrix() {
        let problem = exp_data(false);
        let out = fit_exp(&problem, &Options::default());
        let m = problem.n_residuals();
        let (r, jac) = residuals_and_jacobian_at(&problem, &out.params);
        let j = DMatrix::from_row_slice(m, 3, &jac);
        let s2 = r.iter().map(|x| x * x).sum::<f64>() / (m - 3) as f64;
        let expected = (j.transpose() * &j).try_inverse().unwrap() * s2;
        for a in 0..3 {
            for b in 0..3 {
                let (got, want) = (out.covariance[(a, b)], expected[(a, b)]);
                assert!(
                    (got - want).abs() <= 1e-9 * want.abs().max(1e-300),
                    "({a}, {b}): {got} vs {want}"
                );
            }
            assert_eq!(out.std_errors[a], Some(out.covariance[(a, a)].sqrt()));
            assert_eq!(out.std_errors[a], out.classical_std_errors[a]);
        }
        // A parameter on a bound has no covariance; the others keep theirs.
        let bounded = minimize(
            &problem,
            &[1.0, 0.0, 0.9],
            &Bounds {
                lower: vec![f64::NEG_INFINITY, f64::NEG_INFINITY, 0.4],
                upper: vec![f64::INFINITY; 3],
            },
            &Options::default(),
        );
        assert!(bounded.at_bounds[2]);
        assert!((0..3).all(|k| bounded.covariance[(2, k)].is_nan()));
        assert!(bounded.covariance[(0, 1)].is_finite() && bounded.covariance[(0, 0)] > 0.0);
    }

    /// `y = a exp(b x) + c` measured in `labels.len() / per` sweeps of `per` points each, the
    /// sweeps' residuals declared as clusters.
    struct SweptExp {
        exp: Exp,
        labels: Vec<usize>,
    }

    impl LeastSquaresProblem for SweptExp {
        fn n_params(&self) -> usize {
            3
        }
        fn n_residuals(&self) -> usize {
            self.exp.n_residuals()
        }
        fn data_clusters(&self) -> Option<&[usize]> {
            Some(&self.labels)
        }
        fn residuals(&self, p: &[f64], r: &mut [f64]) {
            self.exp.residuals(p, r);
        }
        fn residuals_and_jacobian(&self, p: &[f64], r: &mut [f64], jac: &mut [f64]) {
            self.exp.residuals_and_jacobian(p, r, jac);
        }
    }

    /// Monte Carlo over `replicates` data sets of `sweeps x 20` points of the known truth
    /// `2.5 exp(-0.7 x) + 0.3` with white noise of `white` and, per sweep, a smooth error
    /// `e_s sin(2 x)` with `e_s` of standard deviation `per_sweep`. Per parameter: the
    /// estimates' standard deviation, the mean cluster-robust and the mean classical standard
    /// error.
    fn monte_carlo(sweeps: usize, white: f64, per_sweep: f64) -> [(f64, f64, f64); 3] {
        let replicates = 300;
        let per = 20;
        let mut rng = crate::numerics::random::SplitMix64::new(18);
        let (mut sum, mut sum2) = ([0.0; 3], [0.0; 3]);
        let (mut robust, mut classical) = ([0.0; 3], [0.0; 3]);
        for _ in 0..replicates {
            let (mut x, mut y, mut labels) = (Vec::new(), Vec::new(), Vec::new());
            for s in 0..sweeps {
                let e = rng.normal(per_sweep);
                for i in 0..per {
                    let xi = 3.0 * i as f64 / (per - 1) as f64;
                    x.push(xi);
                    y.push(
                        2.5 * (-0.7 * xi).exp() + 0.3 + e * (2.0 * xi).sin() + rng.normal(white),
                    );
                    labels.push(s);
                }
            }
            let problem = SweptExp {
                exp: Exp { x, y },
                labels,
            };
            let out = minimize(
                &problem,
                &[2.0, -0.5, 0.0],
                &Bounds::unbounded(3),
                &Options::default(),
            );
            assert!(out.termination.converged(), "{:?}", out.termination);
            for j in 0..3 {
                sum[j] += out.params[j];
                sum2[j] += out.params[j] * out.params[j];
                robust[j] += out.std_errors[j].unwrap();
                classical[j] += out.classical_std_errors[j].unwrap();
            }
        }
        let r = replicates as f64;
        let out: [(f64, f64, f64); 3] = std::array::from_fn(|j| {
            let sd = ((sum2[j] - sum[j] * sum[j] / r) / (r - 1.0)).sqrt();
            (sd, robust[j] / r, classical[j] / r)
        });
        eprintln!("white {white} per-sweep {per_sweep}: (spread, clustered, classical) {out:?}");
        out
    }

    /// White noise: the cluster-robust standard errors agree with the classical ones and with
    /// the spread of the estimates over repeated data sets.
    #[test]
    fn clustered_std_errors_match_classical_on_white_noise() {
        for (j, (sd, robust, classical)) in monte_carlo(30, 0.05, 0.0).into_iter().enumerate() {
            assert!(
                (robust / classical - 1.0).abs() < 0.1,
                "parameter {j}: robust {robust:.3e} classical {classical:.3e}"
            );
            assert!(
                (robust / sd - 1.0).abs() < 0.15,
                "parameter {j}: robust {robust:.3e} vs spread {sd:.3e}"
            );
        }
    }

    /// Smooth error shared along each sweep: the classical standard errors are far below the
    /// spread of the estimates, the cluster-robust ones follow it.
    #[test]
    fn clustered_std_errors_see_correlated_sweep_error() {
        for (j, (sd, robust, classical)) in monte_carlo(30, 0.01, 0.05).into_iter().enumerate() {
            assert!(
                classical < 0.5 * sd,
                "parameter {j}: the case is not correlated: classical {classical:.3e} spread {sd:.3e}"
            );
            assert!(
                (robust / sd - 1.0).abs() < 0.2,
                "parameter {j}: robust {robust:.3e} vs spread {sd:.3e}"
            );
        }
    }

    /// Fewer than two clusters estimate nothing; the classical figure is still reported.
    #[test]
    fn one_cluster_has_no_clustered_std_errors() {
        let exp = exp_data(false);
        let labels = vec![0; exp.x.len()];
        let out = minimize(
            &SweptExp { exp, labels },
            &[1.0, 0.0, 0.0],
            &Bounds::unbounded(3),
            &Options::default(),
        );
        assert!(out.std_errors.iter().all(|s| s.is_none()));
        assert!(out.classical_std_errors.iter().all(|s| s.is_some()));
    }

    #[test]
    fn identifiability_sees_collinear_columns() {
        // Columns 0 and 1 orthogonal, column 2 = 3 x column 0 (only their product is determined).
        let jac = [1.0, 0.0, 3.0, 0.0, 2.0, 0.0, 1.0, 0.0, 3.0, 0.0, 5.0, 0.0];
        let all = Identifiability::of(&jac, 3, 4, &[0, 1, 2]);
        assert_eq!((all.n_free, all.rank), (3, 2));
        assert!(all.condition.is_infinite());
        let two = Identifiability::of(&jac, 3, 4, &[0, 1]);
        assert_eq!(two.rank, 2);
        assert!((two.condition - 1.0).abs() < 1e-12, "{two:?}");
        // Penalty rows (after n_data) do not count.
        assert_eq!(Identifiability::of(&jac, 3, 1, &[0, 1]).rank, 1);
        let out = fit_exp(&exp_data(false), &Options::default());
        assert_eq!(out.identifiability.rank, 3);
        assert!(out.identifiability.condition.is_finite() && out.identifiability.condition > 1.0);
    }

    #[test]
    fn active_bound_is_respected_and_reported() {
        let problem = exp_data(false);
        let bounds = Bounds {
            lower: vec![f64::NEG_INFINITY, f64::NEG_INFINITY, 0.4],
            upper: vec![f64::INFINITY, f64::INFINITY, 1.0],
        };
        let out = minimize(&problem, &[1.0, 0.0, 0.9], &bounds, &Options::default());
        assert!((out.params[2] - 0.4).abs() < 1e-15, "{:?}", out.params);
        assert_eq!(out.at_bounds, vec![false, false, true]);
        assert!(out.std_errors[2].is_none());
        assert!(out.termination.converged(), "{:?}", out.termination);
    }

    #[test]
    fn huber_irls_resists_outliers() {
        let problem = exp_data(true);
        let plain = fit_exp(&problem, &Options::default());
        let robust = fit_exp(
            &problem,
            &Options {
                loss: RobustLoss::Huber { k: 1.5 },
                irls_rounds: 6,
                ..Options::default()
            },
        );
        let err = |p: &[f64]| (p[0] - 2.5).abs() + (p[1] + 0.7).abs() + (p[2] - 0.3).abs();
        assert!(
            err(&robust.params) < 0.2 * err(&plain.params),
            "robust {:?} vs plain {:?}",
            robust.params,
            plain.params
        );
        assert!(robust.robust_weights[7] < 0.1 && robust.robust_weights[31] < 0.1);
    }

    /// Records where its Jacobian is evaluated.
    struct Recording {
        inner: Exp,
        at: std::cell::RefCell<Vec<Vec<f64>>>,
    }

    impl LeastSquaresProblem for Recording {
        fn n_params(&self) -> usize {
            self.inner.n_params()
        }
        fn n_residuals(&self) -> usize {
            self.inner.n_residuals()
        }
        fn residuals(&self, p: &[f64], r: &mut [f64]) {
            self.inner.residuals(p, r)
        }
        fn residuals_and_jacobian(&self, p: &[f64], r: &mut [f64], jac: &mut [f64]) {
            self.at.borrow_mut().push(p.to_vec());
            self.inner.residuals_and_jacobian(p, r, jac)
        }
    }

    /// The IRLS rounds and the final statistics start where the previous round stopped: they
    /// reuse its Jacobian instead of evaluating it at the same point again.
    #[test]
    fn irls_rounds_evaluate_each_jacobian_once() {
        let problem = Recording {
            inner: exp_data(true),
            at: Default::default(),
        };
        let options = Options {
            loss: RobustLoss::Huber { k: 1.5 },
            irls_rounds: 4,
            ..Options::default()
        };
        let out = minimize(&problem, &[1.0, 0.0, 0.0], &Bounds::unbounded(3), &options);
        let at = problem.at.borrow();
        assert_eq!(out.jacobian_evaluations, at.len());
        // Bit-identical points are what the reuse looks for.
        let same = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(at.windows(2).all(|w| !same(&w[0], &w[1])), "{at:?}");
        assert!(out.termination.converged(), "{:?}", out.termination);
    }

    /// A parameter without effect at the start (zero Jacobian column) does not stall the solver.
    struct Product;

    impl LeastSquaresProblem for Product {
        fn n_params(&self) -> usize {
            2
        }
        fn n_residuals(&self) -> usize {
            20
        }
        fn residuals(&self, p: &[f64], r: &mut [f64]) {
            // y = p0 + p1 * x with a zero-effect third... here p1 multiplies x^2 * p0^0.
            for (i, ri) in r.iter_mut().enumerate() {
                let x = i as f64 / 10.0;
                *ri = p[0] * x + p[0] * p[1] * x * x - (0.5 * x + 0.5 * 0.4 * x * x);
            }
        }
        fn residuals_and_jacobian(&self, p: &[f64], r: &mut [f64], jac: &mut [f64]) {
            self.residuals(p, r);
            for i in 0..20 {
                let x = i as f64 / 10.0;
                jac[2 * i] = x + p[1] * x * x;
                jac[2 * i + 1] = p[0] * x * x;
            }
        }
    }

    #[test]
    fn zero_jacobian_column_does_not_stall() {
        let out = minimize(
            &Product,
            &[0.0, 1.0],
            &Bounds::unbounded(2),
            &Options::default(),
        );
        assert!(out.termination.converged(), "{:?}", out.termination);
        assert!((out.params[0] - 0.5).abs() < 1e-8 && (out.params[1] - 0.4).abs() < 1e-8);
    }

    #[test]
    fn non_finite_start_is_reported_not_raised() {
        let problem = exp_data(false);
        let out = minimize(
            &problem,
            &[1.0, 1e6, 0.0],
            &Bounds::unbounded(3),
            &Options::default(),
        );
        assert_eq!(out.termination, Termination::NonFiniteStart);
        assert_eq!(out.identifiability.rank, 0);
        assert!(out.identifiability.condition.is_infinite());
    }
}
