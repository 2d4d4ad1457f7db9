//! One family's joint refinement across every tested pressure as a bounded least-squares
//! problem.
//!
//! In: the current MF 6.1 model, the family's free coefficients, its channel and the collapsed
//! points of every pressure (each evaluated at its own measured pressure). Out: residuals
//! `w_i (model_i - measured_i)` and their exact Jacobian, through
//! [`MagicFormula::jacobian_into_at`] (forward-mode dual numbers, one pressure per point), for
//! [`crate::numerics::nonlinear_least_squares::minimize`]. The model is evaluated without input
//! limiting (`Mode::Raw`), as the PAC2002 stage does. After the data rows: penalty rows for
//! the PAC2002 stage's physical rules in MF 6.1's equations ([`physical_penalties`]) over the
//! data's envelope ([`Span`]).
//!
//! Deliberately not here: which points and coefficients a family uses (`mod.rs`).

use super::data::Point;
use crate::fit::output::Output;
use crate::fit::pac2002::{ConstrainedQuantity, Penalty, ey_rules, penalty_rows, trail_rules};
use crate::numerics::nonlinear_least_squares::LeastSquaresProblem;
use std::f64::consts::PI;

use crate::tire_model::tir::units::PLACEHOLDER;
use crate::tire_model::{
    Channel, Coef, Coef::*, MagicFormula, Mode, MomentForces, Pressures, SlipInput, Version,
    moment_split,
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

/// The operating envelope of a family's data: their loads, inclinations, slips and measured
/// pressures, each widened to the range the model declares where it is set, with the lint's
/// caps (loads within `[0.05, 4] FNOMIN`, `|kappa| <= 1`, `|alpha| <= 45 deg`, `|gamma| <= 15
/// deg`): the envelope `tir lint` samples the written file over, so a rule held here is held
/// where the lint checks it.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Span {
    /// Loads, N.
    pub fz: (f64, f64),
    /// Inclinations, rad.
    pub gamma: (f64, f64),
    /// Longitudinal slips.
    pub kappa: (f64, f64),
    /// Slip angles, rad.
    pub alpha: (f64, f64),
    /// Inflation pressures, Pa.
    pub p: (f64, f64),
    /// Speed of the first point, m/s.
    pub vx: f64,
}

impl Span {
    /// The span of `data` for `model` (`None` without data).
    pub fn of(model: &MagicFormula, data: &FamilyData) -> Option<Span> {
        let first = data.inputs.first()?;
        let range = |v: &mut dyn Iterator<Item = f64>| {
            v.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                (lo.min(x), hi.max(x))
            })
        };
        let c = &model.coefs;
        let widen = |r: (f64, f64), lo: f64, hi: f64| {
            if lo.is_finite() && hi.is_finite() && lo < hi && hi.abs() < PLACEHOLDER {
                (r.0.min(lo), r.1.max(hi))
            } else {
                r
            }
        };
        let of = |f: fn(&SlipInput) -> f64, lo: Coef, hi: Coef, cap: f64| {
            let r = range(&mut data.inputs.iter().map(f));
            widen(r, c[lo].max(-cap), c[hi].min(cap))
        };
        Some(Span {
            fz: widen(
                range(&mut data.inputs.iter().map(|p| p.fz_n)),
                c[FZMIN].max(0.05 * c[FNOMIN]),
                c[FZMAX].min(4.0 * c[FNOMIN]),
            ),
            gamma: of(|p| p.gamma_rad, CAMMIN, CAMMAX, PI / 12.0),
            kappa: of(|p| p.kappa, KPUMIN, KPUMAX, 1.0),
            alpha: of(|p| p.alpha_rad, ALPMIN, ALPMAX, PI / 4.0),
            p: widen(
                range(&mut data.pressures.iter().copied()),
                c[PRESMIN],
                c[PRESMAX],
            ),
            vx: first.vx_mps,
        })
    }

    /// Relative load changes `dfz` of five loads spanning the span, ends included.
    fn dfz_grid(&self, fz0: f64) -> [f64; 5] {
        let (lo, hi) = ((self.fz.0 - fz0) / fz0, (self.fz.1 - fz0) / fz0);
        [0.0, 0.25, 0.5, 0.75, 1.0].map(|t| lo + (hi - lo) * t)
    }

    /// The inclinations a rule linear in the inclination on either side of 0 takes its extremes
    /// at: the ends, and 0 between them (`|gamma|` terms kink there).
    fn gammas(&self) -> Vec<f64> {
        let (lo, hi) = self.gamma;
        let mut out = vec![lo];
        if lo < 0.0 && hi > 0.0 {
            out.push(0.0);
        }
        if hi > lo {
            out.push(hi);
        }
        out
    }

    /// Operating points over the span for the combined-slip weights: both end loads, every
    /// inclination of [`Self::gammas`], 9 slip angles x 5 longitudinal slips (the PAC2002
    /// stage's grid).
    fn combined_grid(&self) -> Vec<SlipInput> {
        let at = |r: (f64, f64), i: usize, n: usize| r.0 + (r.1 - r.0) * i as f64 / (n - 1) as f64;
        let mut out = Vec::new();
        for fz_n in [self.fz.0, self.fz.1] {
            for gamma_rad in self.gammas() {
                for i in 0..9 {
                    for j in 0..5 {
                        out.push(SlipInput {
                            fz_n,
                            kappa: at(self.kappa, j, 5),
                            alpha_rad: at(self.alpha, i, 9),
                            gamma_rad,
                            vx_mps: self.vx,
                        });
                    }
                }
            }
        }
        out
    }
}

/// The coefficients the physical rules of `channel` read ([`physical_penalties`]).
fn rule_coefficients(channel: Channel) -> &'static [Coef] {
    match channel {
        Channel::Fy0 => &[PEY1, PEY2, PEY3, PEY4, PEY5],
        Channel::Fx0 => &[PEX1, PEX2, PEX3, PEX4],
        Channel::Mz0 | Channel::Mz => &[QBZ1, QBZ2, QBZ3, QBZ4, QBZ5, QEZ1, QEZ2, QEZ3, QEZ4, QEZ5],
        Channel::Fx => &[RBX1, RBX2, RBX3, RCX1, REX1, REX2, RHX1],
        Channel::Fy => &[RBY1, RBY2, RBY3, RBY4, RCY1, REY1, REY2, RHY1, RHY2],
        Channel::Mx | Channel::My => &[],
    }
}

/// The physical rules of the PAC2002 stage (`pac2002::stage::penalties_of`), each in MF 6.1's
/// own equations, over the [`Span`] of `data`, when one of the coefficients a rule reads is
/// free: without them the joint refinement over pressures is free to leave physical shape
/// where the data are thin (a trail curvature above 1 between the tested loads ruins `Mz`
/// there; MFeval clamps every `E` at 1 and the lint warns).
/// - `Fy0`: `Ey <= 1` (MF 6.1's law, with `PEY5`) at five loads, the inclinations of
///   [`Span::gammas`] and both signs of `alpha_y`.
/// - `Fx0`: `Ex <= 1` at five loads and at the interior maximum of its quadratic in load.
/// - `Mz0`, `Mz`: `Et <= 1` at `(2/pi) atan(Bt Ct alpha_t) = +-1` and `Bt >= 0.1`, at five
///   loads and the inclinations of [`Span::gammas`].
/// - combined `Fx`, `Fy`: `Exa <= 1`, `Eyk <= 1` at five loads; `Gxa`, `Gyk >= 0.01` over
///   [`Span::combined_grid`] (MF 6.1's `RBX3`, `RBY4` camber terms).
///
/// No pressure term enters any of these quantities, so the pressures need no grid.
pub fn physical_penalties(
    base: &MagicFormula,
    free: &[Coef],
    channel: Channel,
    data: &FamilyData,
) -> Vec<Penalty> {
    let read = rule_coefficients(channel);
    let Some(span) = Span::of(base, data) else {
        return Vec::new();
    };
    if !free.iter().any(|c| read.contains(c)) {
        return Vec::new();
    }
    let fz0 = base.coefs[FNOMIN] * base.coefs[LFZO];
    let sweeps = data
        .sweeps
        .iter()
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    let weight = CONSTRAINT_WEIGHT * (sweeps as f64).sqrt();
    let at_most = |quantity, limit| Penalty::AtMost {
        quantity,
        limit,
        weight,
    };
    let version = Version::Mf61;
    let dfzs = span.dfz_grid(fz0);
    let mut out = Vec::new();
    match channel {
        Channel::Fy0 => {
            let rules = ey_rules(&dfzs, &span.gammas(), version);
            out.extend(rules.into_iter().map(|(q, limit)| at_most(q, limit)));
        }
        Channel::Fx0 => {
            let (lo, hi) = (dfzs[0], dfzs[4]);
            for sign in [-1.0, 1.0] {
                for dfz in dfzs {
                    out.push(at_most(ConstrainedQuantity::Ex { dfz, sign }, 1.0));
                }
                out.push(at_most(ConstrainedQuantity::ExPeak { lo, hi, sign }, 1.0));
            }
        }
        Channel::Mz0 | Channel::Mz => {
            let rules = trail_rules(&dfzs, &span.gammas());
            out.extend(rules.into_iter().map(|(q, limit)| at_most(q, limit)));
        }
        Channel::Fx | Channel::Fy => {
            for dfz in dfzs {
                let q = if channel == Channel::Fx {
                    ConstrainedQuantity::Exa { dfz }
                } else {
                    ConstrainedQuantity::Eyk { dfz }
                };
                out.push(at_most(q, 1.0));
            }
            for input in span.combined_grid() {
                let q = if channel == Channel::Fx {
                    ConstrainedQuantity::NegGxa { input, version }
                } else {
                    ConstrainedQuantity::NegGyk { input, version }
                };
                out.push(at_most(q, -0.01));
            }
        }
        Channel::Mx | Channel::My => {}
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
