//! Small solvers for the starting-value stage: linear least squares (minimum-norm, by SVD of a
//! column-scaled design) and one-dimensional curve fits through the bounded Levenberg-Marquardt
//! with dual-number Jacobians.
//!
//! In: designs and observations, or a [`CurveModel`] with `(x, y)` points. Out: coefficients, or
//! the solver's outcome. Deliberately small: these fit a handful of per-sweep numbers; the joint
//! refinement of a family lives in `problem`.

use nalgebra::{DMatrix, DVector};

use crate::numerics::nonlinear_least_squares::{
    Bounds, FitOutcome, LeastSquaresProblem, Options, minimize,
};
use crate::tire_model::{Dual, Real};

/// Minimum-norm solution of `min |X b - y|^2` (`design` row-major, `ncols` columns); columns
/// that the data cannot separate get the minimum-norm share (often 0). `None` if there are no
/// rows or the input is not finite.
pub fn lstsq(design: &[f64], ncols: usize, y: &[f64]) -> Option<Vec<f64>> {
    let nrows = y.len();
    if nrows == 0 || ncols == 0 || design.len() != nrows * ncols {
        return None;
    }
    if design.iter().chain(y).any(|v| !v.is_finite()) {
        return None;
    }
    let mut x = DMatrix::from_row_slice(nrows, ncols, design);
    let scale: Vec<f64> = (0..ncols)
        .map(|j| {
            let n = x.column(j).norm();
            if n > 0.0 { n } else { 1.0 }
        })
        .collect();
    for (j, s) in scale.iter().enumerate() {
        x.column_mut(j).scale_mut(1.0 / s);
    }
    let svd = x.svd(true, true);
    let eps = svd.singular_values.max() * 1e-10;
    let b = svd.solve(&DVector::from_column_slice(y), eps).ok()?;
    Some(b.iter().zip(&scale).map(|(v, s)| v / s).collect())
}

/// A one-dimensional model `y = f(p; x)` with at most 8 parameters.
pub trait CurveModel {
    /// Number of parameters (<= 8).
    fn n_params(&self) -> usize;
    /// Model value at `x`.
    fn eval<T: Real>(&self, p: &[T], x: f64) -> T;
}

struct CurveProblem<'a, M: CurveModel> {
    model: &'a M,
    x: &'a [f64],
    y: &'a [f64],
}

impl<M: CurveModel> LeastSquaresProblem for CurveProblem<'_, M> {
    fn n_params(&self) -> usize {
        self.model.n_params()
    }
    fn n_residuals(&self) -> usize {
        self.x.len()
    }
    fn residuals(&self, p: &[f64], r: &mut [f64]) {
        for ((ri, x), y) in r.iter_mut().zip(self.x).zip(self.y) {
            *ri = self.model.eval(p, *x) - y;
        }
    }
    fn residuals_and_jacobian(&self, p: &[f64], r: &mut [f64], jac: &mut [f64]) {
        let n = p.len();
        let pd: Vec<Dual<8>> = p
            .iter()
            .enumerate()
            .map(|(j, v)| Dual::var(*v, j))
            .collect();
        for (i, (x, y)) in self.x.iter().zip(self.y).enumerate() {
            let v = self.model.eval(&pd, *x);
            r[i] = v.v - y;
            jac[i * n..(i + 1) * n].copy_from_slice(&v.d[..n]);
        }
    }
}

/// Fits `model` to `(x, y)` from `start` within `bounds`.
///
/// # Panics
/// If the model has more than 8 parameters or the lengths disagree.
pub fn fit_curve<M: CurveModel>(
    model: &M,
    x: &[f64],
    y: &[f64],
    start: &[f64],
    bounds: &Bounds,
) -> FitOutcome {
    assert!(model.n_params() <= 8, "fit_curve: at most 8 parameters");
    assert_eq!(x.len(), y.len(), "fit_curve: x and y lengths");
    let problem = CurveProblem { model, x, y };
    minimize(
        &problem,
        start,
        bounds,
        &Options {
            max_iterations: 200,
            xtol: 1e-10,
            ftol: 1e-12,
            gtol: 1e-10,
            ..Options::default()
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lstsq_recovers_plane_and_handles_collinear_columns() {
        let rows: Vec<[f64; 3]> = (0..12).map(|i| [1.0, i as f64, (i % 3) as f64]).collect();
        let design: Vec<f64> = rows.iter().flatten().copied().collect();
        let y: Vec<f64> = rows.iter().map(|r| 2.0 + 0.5 * r[1] - 3.0 * r[2]).collect();
        let b = lstsq(&design, 3, &y).unwrap();
        assert!(
            (b[0] - 2.0).abs() < 1e-9 && (b[1] - 0.5).abs() < 1e-9 && (b[2] + 3.0).abs() < 1e-9
        );
        // Two identical columns: the minimum-norm answer splits the effect.
        let design2: Vec<f64> = (0..5).flat_map(|i| [i as f64, i as f64]).collect();
        let y2: Vec<f64> = (0..5).map(|i| 4.0 * i as f64).collect();
        let b2 = lstsq(&design2, 2, &y2).unwrap();
        assert!(
            (b2[0] - 2.0).abs() < 1e-9 && (b2[1] - 2.0).abs() < 1e-9,
            "{b2:?}"
        );
    }
}
