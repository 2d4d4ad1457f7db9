//! One family's joint refinement across every tested pressure as a bounded least-squares
//! problem.
//!
//! In: the current MF 6.1 model, the family's free coefficients, its channel and the collapsed
//! points of every pressure (each evaluated at its own measured pressure). Out: residuals
//! `w_i (model_i - measured_i)` and their exact Jacobian, through
//! [`MagicFormula::jacobian_into_at`] (forward-mode dual numbers, one pressure per point), for
//! [`crate::numerics::nonlinear_least_squares::minimize`]. The model is evaluated without input
//! limiting (`Mode::Raw`), as the PAC2002 stage does. After the data rows: penalty rows for
//! the physical rules the MF 6.1 equations share with PAC2002 ([`physical_penalties`]).
//!
//! Deliberately not here: which points and coefficients a family uses (`mod.rs`).

use super::data::Point;
use crate::fit::output::Output;
use crate::fit::pac2002::{ConstrainedQuantity, Penalty, penalty_rows};
use crate::numerics::nonlinear_least_squares::LeastSquaresProblem;
use crate::tire_model::{
    Channel, Coef, Coef::*, MagicFormula, Mode, MomentForces, Pressures, SlipInput, moment_split,
};

/// Evaluation mode of the fit.
pub const FIT_MODE: Mode = Mode::Raw;

/// A family's data: operating points, their pressures, measured values and weights.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FamilyData {
    /// Operating points.
    pub inputs: Vec<SlipInput>,
    /// Inflation pressure of each point, Pa.
    pub pressures: Vec<f64>,
    /// Measured values (N or N m).
    pub measured: Vec<f64>,
    /// Residual weights.
    pub weights: Vec<f64>,
    /// Sweep index of each point (across every tested pressure).
    pub sweeps: Vec<usize>,
    /// Tested-pressure group of each point.
    pub groups: Vec<usize>,
}

impl FamilyData {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.inputs.len()
    }

    /// No points?
    pub fn is_empty(&self) -> bool {
        self.inputs.is_empty()
    }

    /// Add `p`'s measured `out` with residual weight `weight`, when it is measured (finite)
    /// with a positive weight of its own.
    pub fn push_output(&mut self, p: &Point, out: Output, weight: f64) {
        let k = out as usize;
        if !p.values[k].is_finite() || p.weights[k] <= 0.0 {
            return;
        }
        self.inputs.push(p.input);
        self.pressures.push(p.p_pa);
        self.measured.push(p.values[k]);
        self.weights.push(weight);
        self.sweeps.push(p.sweep);
        self.groups.push(p.group);
    }
}

/// The problem: `base` with `free` replaced by the parameters.
pub struct Mf61FamilyProblem<'a> {
    /// The model with every other coefficient fixed.
    pub base: &'a MagicFormula,
    /// Free coefficients, in parameter order.
    pub free: &'a [Coef],
    /// The channel the data measure.
    pub channel: Channel,
    /// The data.
    pub data: &'a FamilyData,
    /// The forces an aligning-moment channel reads, computed once from `base` when no free
    /// coefficient changes them ([`moment_split`]).
    forces: Option<Vec<MomentForces>>,
    /// Penalty rows after the data rows ([`physical_penalties`]).
    penalties: Vec<Penalty>,
}

/// Weight of a physical rule's penalty per unit of violation, per sweep of data: as the PAC2002
/// stage's `constraint_weight` (10), scaled by the square root of the sweeps because each
/// sweep's weighted squared errors here sum to its own relative mean square error (PAC2002
/// normalises the whole family to one).
const CONSTRAINT_WEIGHT: f64 = 10.0;

/// The physical rules of the PAC2002 stage whose quantity the MF 6.1 equations compute the same
/// way, over the loads of `data`: the longitudinal curvature `Ex <= 1` before clamping (on a
/// grid of five loads and at the interior maximum of its quadratic in load), when one of its
/// coefficients is free: the joint refinement over pressures is otherwise free to move `Ex`
/// above 1 between the tested loads, where MFeval clamps it and the lint warns. Other channels
/// have no rule here: their curvature laws differ from PAC2002's (`PEY5`) or no fit was seen to
/// break them.
pub fn physical_penalties(
    base: &MagicFormula,
    free: &[Coef],
    channel: Channel,
    data: &FamilyData,
) -> Vec<Penalty> {
    let curvature = [PEX1, PEX2, PEX3, PEX4];
    if channel != Channel::Fx0 || !free.iter().any(|c| curvature.contains(c)) || data.is_empty() {
        return Vec::new();
    }
    let fz0 = base.coefs[FNOMIN] * base.coefs[LFZO];
    let (fz_lo, fz_hi) = data
        .inputs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.fz_n), hi.max(p.fz_n))
        });
    let (lo, hi) = ((fz_lo - fz0) / fz0, (fz_hi - fz0) / fz0);
    let sweeps = data
        .sweeps
        .iter()
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    let weight = CONSTRAINT_WEIGHT * (sweeps as f64).sqrt();
    let at_most = |quantity| Penalty::AtMost {
        quantity,
        limit: 1.0,
        weight,
    };
    let mut out = Vec::new();
    for sign in [-1.0, 1.0] {
        for i in 0..5 {
            let dfz = lo + (hi - lo) * i as f64 / 4.0;
            out.push(at_most(ConstrainedQuantity::Ex { dfz, sign }));
        }
        out.push(at_most(ConstrainedQuantity::ExPeak { lo, hi, sign }));
    }
    out
}

impl<'a> Mf61FamilyProblem<'a> {
    /// The problem of fitting `free` of `base` to `data` on `channel`.
    pub fn new(
        base: &'a MagicFormula,
        free: &'a [Coef],
        channel: Channel,
        data: &'a FamilyData,
    ) -> Self {
        let forces = moment_split(channel, free).then(|| {
            base.moment_forces(
                channel,
                &data.inputs,
                Pressures::PerPoint(&data.pressures),
                FIT_MODE,
            )
        });
        Mf61FamilyProblem {
            base,
            free,
            channel,
            data,
            forces,
            penalties: physical_penalties(base, free, channel, data),
        }
    }

    /// The model at parameters `p`.
    pub fn model_at(&self, p: &[f64]) -> MagicFormula {
        let mut m = self.base.clone();
        for (c, v) in self.free.iter().zip(p) {
            m.coefs[*c] = *v;
        }
        m
    }
}

impl LeastSquaresProblem for Mf61FamilyProblem<'_> {
    fn n_params(&self) -> usize {
        self.free.len()
    }

    fn n_residuals(&self) -> usize {
        self.data.len() + self.penalties.len()
    }

    fn n_data(&self) -> usize {
        self.data.len()
    }

    /// Errors along a sweep are correlated (smooth model error), between sweeps independent.
    fn data_clusters(&self) -> Option<&[usize]> {
        Some(&self.data.sweeps)
    }

    fn residuals(&self, p: &[f64], r: &mut [f64]) {
        let m = self.model_at(p);
        let (r, penalties) = r.split_at_mut(self.data.len());
        penalty_rows(&self.penalties, &m.coefs, self.free, penalties, None);
        m.channel_into_at(
            self.channel,
            &self.data.inputs,
            Pressures::PerPoint(&self.data.pressures),
            FIT_MODE,
            r,
        );
        for ((x, y), w) in r
            .iter_mut()
            .zip(&self.data.measured)
            .zip(&self.data.weights)
        {
            *x = w * (*x - y);
        }
    }

    fn residuals_and_jacobian(&self, p: &[f64], r: &mut [f64], jac: &mut [f64]) {
        let m = self.model_at(p);
        let n = self.free.len();
        let (r, penalties) = r.split_at_mut(self.data.len());
        let (jac, penalty_jac) = jac.split_at_mut(self.data.len() * n);
        penalty_rows(
            &self.penalties,
            &m.coefs,
            self.free,
            penalties,
            Some(penalty_jac),
        );
        m.jacobian_into_with(
            self.channel,
            self.free,
            &self.data.inputs,
            Pressures::PerPoint(&self.data.pressures),
            FIT_MODE,
            self.forces.as_deref(),
            r,
            jac,
        );
        for (i, ((x, y), w)) in r
            .iter_mut()
            .zip(&self.data.measured)
            .zip(&self.data.weights)
            .enumerate()
        {
            *x = w * (*x - y);
            jac[i * n..(i + 1) * n].iter_mut().for_each(|v| *v *= w);
        }
    }
}
