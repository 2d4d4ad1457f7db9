//! Linear least squares with parameter covariance, and centred polynomial fits built on it.
//!
//! In: a design matrix and observations (or abscissae and ordinates for a polynomial). Out: the
//! parameters, their covariance `s^2 (X^T X)^-1` with `s^2` the residual variance, the residual
//! sum of squares and the degrees of freedom. Solved by SVD on column-scaled designs, so centred
//! quadratics reproduce noise-free data to ~1e-13 relative. Deliberately no weighting schemes
//! beyond an optional per-row weight, and no robust (outlier-rejecting) loss.

use nalgebra::{DMatrix, DVector};

use super::{NumericsError, check_finite};

/// Result of a linear least-squares solve.
#[derive(Debug, Clone)]
pub struct LinearFit {
    /// Fitted parameters, one per design column.
    pub params: DVector<f64>,
    /// Covariance of the parameters, `s^2 (X^T X)^-1`; zero when there are no spare degrees of
    /// freedom.
    pub covariance: DMatrix<f64>,
    /// Residual sum of squares.
    pub rss: f64,
    /// Degrees of freedom, rows minus columns.
    pub dof: usize,
}

impl LinearFit {
    /// Standard uncertainty of parameter `i`.
    pub fn std_err(&self, i: usize) -> f64 {
        self.covariance[(i, i)].max(0.0).sqrt()
    }

    /// Root-mean-square residual.
    pub fn rms(&self) -> f64 {
        let n = self.dof + self.params.len();
        if n == 0 {
            0.0
        } else {
            (self.rss / n as f64).sqrt()
        }
    }
}

/// Solves `min |X p - y|^2`. Errors on too few rows, non-finite input or a rank-deficient design.
pub fn solve(design: &DMatrix<f64>, y: &DVector<f64>) -> Result<LinearFit, NumericsError> {
    let (rows, cols) = design.shape();
    if y.len() != rows {
        return Err(NumericsError::LengthMismatch {
            what: "least squares",
            left: rows,
            right: y.len(),
        });
    }
    if rows < cols {
        return Err(NumericsError::TooFewPoints {
            what: "least squares",
            needed: cols,
            found: rows,
        });
    }
    check_finite("least squares design", design.as_slice())?;
    check_finite("least squares observations", y.as_slice())?;
    let scale: Vec<f64> = (0..cols)
        .map(|j| {
            let n = design.column(j).norm();
            if n > 0.0 { n } else { 1.0 }
        })
        .collect();
    let mut scaled = design.clone();
    for (j, s) in scale.iter().enumerate() {
        scaled.column_mut(j).scale_mut(1.0 / s);
    }
    let svd = scaled.clone().svd(true, true);
    let s_max = svd.singular_values.max();
    let s_min = svd.singular_values.min();
    if s_max <= 0.0 || s_min <= s_max * 1e-13 {
        return Err(NumericsError::Degenerate {
            what: "least squares",
            reason: format!("design is rank deficient (condition number > 1e13, {cols} columns)"),
        });
    }
    let solution = svd.solve(y, 0.0).map_err(|e| NumericsError::Degenerate {
        what: "least squares",
        reason: e.to_string(),
    })?;
    let residual = &scaled * &solution - y;
    let rss = residual.norm_squared();
    let dof = rows - cols;
    let s2 = if dof > 0 { rss / dof as f64 } else { 0.0 };
    let v_t = svd.v_t.as_ref().expect("SVD computed with V");
    let mut inv = DMatrix::<f64>::zeros(cols, cols);
    for k in 0..cols {
        let sk = svd.singular_values[k];
        let vk = v_t.row(k).transpose();
        inv += (&vk * vk.transpose()) / (sk * sk);
    }
    let mut params = solution;
    let mut covariance = inv * s2;
    for i in 0..cols {
        params[i] /= scale[i];
        for j in 0..cols {
            covariance[(i, j)] /= scale[i] * scale[j];
        }
    }
    Ok(LinearFit {
        params,
        covariance,
        rss,
        dof,
    })
}

/// A polynomial `sum_k coeffs[k] * (t - t_center)^k` fitted by least squares.
#[derive(Debug, Clone)]
pub struct PolyFit {
    /// Coefficients in increasing power of `(t - t_center)`.
    pub coeffs: Vec<f64>,
    /// The centring abscissa (mean of the input `t`).
    pub t_center: f64,
    /// The underlying linear fit (covariance of `coeffs`).
    pub fit: LinearFit,
}

impl PolyFit {
    /// Value at `t`.
    pub fn eval(&self, t: f64) -> f64 {
        let tau = t - self.t_center;
        self.coeffs.iter().rev().fold(0.0, |acc, c| acc * tau + c)
    }

    /// First derivative at `t`.
    pub fn derivative(&self, t: f64) -> f64 {
        let tau = t - self.t_center;
        self.coeffs
            .iter()
            .enumerate()
            .skip(1)
            .rev()
            .fold(0.0, |acc, (k, c)| acc * tau + k as f64 * c)
    }
}

/// Fits a polynomial of `degree` to `(t, y)` with `t` centred on its mean for conditioning.
pub fn polyfit_centered(t: &[f64], y: &[f64], degree: usize) -> Result<PolyFit, NumericsError> {
    if t.len() != y.len() {
        return Err(NumericsError::LengthMismatch {
            what: "polynomial fit",
            left: t.len(),
            right: y.len(),
        });
    }
    if t.len() < degree + 1 {
        return Err(NumericsError::TooFewPoints {
            what: "polynomial fit",
            needed: degree + 1,
            found: t.len(),
        });
    }
    let t_center = t.iter().sum::<f64>() / t.len() as f64;
    let design = DMatrix::from_fn(t.len(), degree + 1, |i, k| (t[i] - t_center).powi(k as i32));
    let fit = solve(&design, &DVector::from_column_slice(y))?;
    Ok(PolyFit {
        coeffs: fit.params.iter().copied().collect(),
        t_center,
        fit,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quadratic_recovered_exactly_and_shift_invariant() {
        let t: Vec<f64> = (0..144)
            .map(|k| 0.35 + (2.0 * (0.013 + k as f64 * 0.0698) / 0.0744).sqrt())
            .collect();
        let y: Vec<f64> = t
            .iter()
            .map(|ti| 0.0372 * (ti - 0.35) * (ti - 0.35) + 0.013)
            .collect();
        let fit = polyfit_centered(&t, &y, 2).unwrap();
        assert!((fit.coeffs[2] - 0.0372).abs() < 1e-14, "{}", fit.coeffs[2]);
        let shifted: Vec<f64> = t.iter().map(|ti| ti + 7.3).collect();
        let fit2 = polyfit_centered(&shifted, &y, 2).unwrap();
        assert!((fit2.coeffs[2] - fit.coeffs[2]).abs() < 1e-14);
    }

    #[test]
    fn covariance_matches_textbook_line_fit() {
        // y = 1 + 2 x + e with alternating residuals +-0.1 on x = 0..9.
        let x: Vec<f64> = (0..10).map(f64::from).collect();
        let y: Vec<f64> = x
            .iter()
            .enumerate()
            .map(|(i, xi)| 1.0 + 2.0 * xi + if i % 2 == 0 { 0.1 } else { -0.1 })
            .collect();
        let design = DMatrix::from_fn(10, 2, |i, j| if j == 0 { 1.0 } else { x[i] });
        let fit = solve(&design, &DVector::from_vec(y)).unwrap();
        let sxx: f64 = x.iter().map(|xi| (xi - 4.5).powi(2)).sum();
        let s2 = fit.rss / 8.0;
        assert!((fit.covariance[(1, 1)] - s2 / sxx).abs() < 1e-15);
    }

    #[test]
    fn rank_deficient_design_is_an_error() {
        let design = DMatrix::from_fn(5, 2, |i, _| i as f64);
        assert!(matches!(
            solve(&design, &DVector::zeros(5)),
            Err(NumericsError::Degenerate { .. })
        ));
    }
}
