//! Uncertainty propagation from declared input uncertainties to results (methods section 6).
//!
//! In: the inputs as [`Measured`] values and a deterministic function from input values to one
//! or more outputs (the whole rig-level computation, so correlations such as the same `g` in tare
//! and vehicle runs are handled by construction). Out: each output's value at the nominal inputs
//! and its standard uncertainty, either linearised (central differences, GUM) or by seeded Monte
//! Carlo (JCGM 101). Deliberately no expanded uncertainty or coverage intervals.

use super::Measured;
use crate::numerics::random::SplitMix64;

/// A deterministic computation from input values to output values.
pub type Computation<'a, E> = &'a dyn Fn(&[f64]) -> Result<Vec<f64>, E>;

/// A deterministic computation from input values to a fixed number of output values.
pub type FixedComputation<'a, const N: usize, E> = &'a dyn Fn(&[f64]) -> Result<[f64; N], E>;

/// Propagation method.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Propagation {
    /// First order, central finite differences with step `u_i / 100`.
    Linear,
    /// Monte Carlo with Gaussian inputs, `samples` draws from a SplitMix64 seeded with `seed`.
    MonteCarlo { samples: usize, seed: u64 },
}

/// The inputs of one propagated computation, in the order [`propagate`] perturbs and draws
/// them. Each value added gets an [`Input`] handle by which the computation reads it back, so a
/// computation names its inputs instead of counting positions.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Inputs(Vec<Measured>);

/// One input of an [`Inputs`] list.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Input(usize);

impl Inputs {
    /// No inputs.
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends an input; the handle reads its value in every evaluation.
    pub fn add(&mut self, value: Measured) -> Input {
        self.0.push(value);
        Input(self.0.len() - 1)
    }

    /// The inputs in order, for [`propagate`].
    pub fn values(&self) -> &[Measured] {
        &self.0
    }
}

impl Input {
    /// This input's value among the values of one evaluation.
    pub fn of(self, x: &[f64]) -> f64 {
        x[self.0]
    }
}

/// Value and standard uncertainty of each output of `f`. Evaluations that fail inside the Monte
/// Carlo loop are skipped; if more than 10 % fail the uncertainty is NaN.
pub fn propagate<E>(
    inputs: &[Measured],
    f: Computation<'_, E>,
    how: Propagation,
) -> Result<Vec<(f64, f64)>, E> {
    let nominal: Vec<f64> = inputs.iter().map(|m| m.value).collect();
    let y0 = f(&nominal)?;
    let mut var = vec![0.0; y0.len()];
    match how {
        Propagation::Linear => {
            for (i, m) in inputs.iter().enumerate() {
                if m.u <= 0.0 {
                    continue;
                }
                let h = m.u * 0.01;
                let mut x = nominal.clone();
                x[i] = m.value + h;
                let plus = f(&x);
                x[i] = m.value - h;
                let minus = f(&x);
                match (plus, minus) {
                    (Ok(p), Ok(q)) => {
                        for k in 0..y0.len() {
                            let d = (p[k] - q[k]) / (2.0 * h);
                            var[k] += (d * m.u).powi(2);
                        }
                    }
                    _ => var.iter_mut().for_each(|v| *v = f64::NAN),
                }
            }
        }
        Propagation::MonteCarlo { samples, seed } => {
            let mut rng = SplitMix64::new(seed);
            let (mut sum, mut sum2, mut ok) = (vec![0.0; y0.len()], vec![0.0; y0.len()], 0usize);
            for _ in 0..samples {
                let x: Vec<f64> = inputs.iter().map(|m| m.value + rng.normal(m.u)).collect();
                if let Ok(y) = f(&x) {
                    ok += 1;
                    for k in 0..y.len() {
                        let d = y[k] - y0[k];
                        sum[k] += d;
                        sum2[k] += d * d;
                    }
                }
            }
            for k in 0..y0.len() {
                var[k] = if ok >= 2 && ok * 10 >= samples * 9 {
                    let n = ok as f64;
                    (sum2[k] - sum[k] * sum[k] / n) / (n - 1.0)
                } else {
                    f64::NAN
                };
            }
        }
    }
    Ok(y0
        .into_iter()
        .zip(var)
        .map(|(v, s2)| (v, s2.max(0.0).sqrt()))
        .collect())
}

/// [`propagate`] over named [`Inputs`] for a computation with a fixed number of outputs, read
/// back by destructuring (`let [x, z] = propagate_each(..)?`).
pub fn propagate_each<const N: usize, E>(
    inputs: &Inputs,
    f: FixedComputation<'_, N, E>,
    how: Propagation,
) -> Result<[(f64, f64); N], E> {
    let out = propagate(inputs.values(), &|x| f(x).map(Vec::from), how)?;
    Ok(std::array::from_fn(|k| out[k]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_and_monte_carlo_agree_on_a_product() {
        let inputs = [Measured::new(2.0, 0.01), Measured::new(3.0, 0.02)];
        let f = |x: &[f64]| -> Result<Vec<f64>, ()> { Ok(vec![x[0] * x[1]]) };
        let lin = propagate(&inputs, &f, Propagation::Linear).unwrap();
        let expected = (3.0f64 * 0.01).hypot(2.0 * 0.02);
        assert!((lin[0].1 - expected).abs() < 1e-9);
        let mc = propagate(
            &inputs,
            &f,
            Propagation::MonteCarlo {
                samples: 20_000,
                seed: 7,
            },
        )
        .unwrap();
        assert!((mc[0].1 / expected - 1.0).abs() < 0.03, "{}", mc[0].1);
        assert_eq!(mc[0].0, 6.0);
    }

    #[test]
    fn named_inputs_propagate_as_the_positional_vector() {
        // The same computation through handles and through positions: identical bits.
        let mut inputs = Inputs::new();
        let a = inputs.add(Measured::new(2.0, 0.01));
        let b = inputs.add(Measured::new(3.0, 0.02));
        let named =
            |x: &[f64]| -> Result<[f64; 2], ()> { Ok([a.of(x) * b.of(x), a.of(x) / b.of(x)]) };
        let positional = |x: &[f64]| -> Result<Vec<f64>, ()> { Ok(vec![x[0] * x[1], x[0] / x[1]]) };
        for how in [
            Propagation::Linear,
            Propagation::MonteCarlo {
                samples: 500,
                seed: 3,
            },
        ] {
            let [product, ratio] = propagate_each(&inputs, &named, how).unwrap();
            let expected = propagate(inputs.values(), &positional, how).unwrap();
            assert_eq!(
                [product, ratio].map(|(v, u)| (v.to_bits(), u.to_bits())),
                [expected[0], expected[1]].map(|(v, u)| (v.to_bits(), u.to_bits()))
            );
        }
    }
}
