//! The joint refinement of one coefficient family as a bounded least-squares problem.
//!
//! In: the current coefficient vector (every family fitted so far), the family's free
//! coefficients, weighted data points of its channel and penalty terms. Out: residuals and their
//! exact Jacobian (forward-mode [`Dual`] numbers through the generic PAC2002 equations) for
//! [`crate::numerics::nonlinear_least_squares::minimize`].
//!
//! Residuals, in order: data `w_i (model_i - measured_i)` (`model_i` the mean of the model at the
//! point's branch operating points, [`super::collapse::BranchInputs`]), then penalties: priors
//! `w (c - centre)` and one-sided constraints `w max(0, q(c) - limit)` for the physical rules
//! (curvature factors `E <= 1` before clamping, `Gxa, Gyk > 0`, `Bt > 0` over the tested
//! envelope). The model is evaluated without input limiting (`Mode::Raw`): inside the tested
//! envelope with `E <= 1` that is what MFeval's limited mode evaluates too, and the derivatives
//! never vanish on a clamp.
//!
//! Deliberately not here: choosing weights, bounds or penalties (the stage does), the solver.

use crate::numerics::nonlinear_least_squares::LeastSquaresProblem;
use crate::tire_model::jacobian::{self, moment_from_forces};
use crate::tire_model::pac2002::{
    Load, Mode, PureFy, TrailPeak, combined_fx, combined_fy, gxa, gyk, load, load_with,
    overturning_mx, pure_fx0, pure_fy0,
};
use crate::tire_model::{Coef, Coef::*, Coefs, Dual, MomentForces, Real, SlipInput, Version};

use super::collapse::BranchInputs;
use super::family::Family;

/// Evaluation mode of every fit.
pub const FIT_MODE: Mode = Mode::Raw;

/// The channel a family is fitted against; NaN for `My` (never fitted).
pub fn channel_value<T: Real>(c: &Coefs<T>, input: &SlipInput, family: Family) -> T {
    match family {
        Family::My => T::cst(f64::NAN),
        _ => jacobian::channel_value(c, input, FIT_MODE, TrailPeak::Standard, family.channel()),
    }
}

/// One measured point of the family's channel.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DataPoint {
    /// Operating point (the mean of `branches`).
    pub input: SlipInput,
    /// The operating points whose values the measured value averages.
    pub branches: BranchInputs,
    /// Measured (collapsed) value, N or N m.
    pub value: f64,
    /// Residual weight (1 / (sweep peak * sqrt(points in sweep * sweeps))).
    pub weight: f64,
    /// Index of the point's sweep among the family's sweeps: the cluster of its residual
    /// (errors along a sweep are correlated, between sweeps independent).
    pub sweep: usize,
}

/// A quantity of the model that a constraint bounds from above. Where PAC2002 and MF 6.x
/// compute a quantity differently, it carries the [`Version`] whose equations it follows
/// (`Ex`, `Et`, `Bt`, `Exa` and `Eyk` have one form in both: MFeval's `Solver.m` evaluates
/// MF 6.x's `Bt` by the paper's (A58), with `QBZ4`, not the book's (4.E40) with `QBZ6`).
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum ConstrainedQuantity {
    /// `Ey` at a relative load change, inclination and sign of `alpha_y`: PAC2002
    /// `(PEY1 + PEY2 dfz)(1 - (PEY3 + PEY4 gamma_y) sgn) LEY`, MF 6.x
    /// `(PEY1 + PEY2 dfz)(1 + PEY5 gamma^2 - (PEY3 + PEY4 gamma) sgn) LEY`.
    Ey {
        dfz: f64,
        gamma: f64,
        sign: f64,
        version: Version,
    },
    /// `Ex` at a relative load change and sign of `kappa_x`.
    Ex { dfz: f64, sign: f64 },
    /// `Ex` of a sign of `kappa_x` at the interior maximum of its quadratic in `dfz` within
    /// `(lo, hi)`, wherever the coefficients put it; `-inf` (inactive) when the quadratic has no
    /// interior maximum there. The [`Self::Ex`] rows on a load grid miss a maximum between
    /// their points.
    ExPeak { lo: f64, hi: f64, sign: f64 },
    /// `Et` at a relative load change, inclination and value `a` of `(2/pi) atan(Bt Ct alpha_t)`.
    Et { dfz: f64, gamma: f64, a: f64 },
    /// `Exa` at a relative load change.
    Exa { dfz: f64 },
    /// `Eyk` at a relative load change.
    Eyk { dfz: f64 },
    /// `-Gxa` at an operating point (MF 6.x: `RBX3 gamma^2` in `Bxa`).
    NegGxa { input: SlipInput, version: Version },
    /// `-Gyk` at an operating point (MF 6.x: `RBY4 gamma^2` in `Byk`).
    NegGyk { input: SlipInput, version: Version },
    /// `-Bt` at a relative load change and inclination.
    NegBt { dfz: f64, gamma: f64 },
}

impl ConstrainedQuantity {
    /// The quantity at coefficients `c`.
    pub(crate) fn value<T: Real>(&self, c: &Coefs<T>) -> T {
        match *self {
            ConstrainedQuantity::Ey {
                dfz,
                gamma,
                sign,
                version,
            } => {
                let camber = if version.is_mf6() {
                    c[PEY5] * (gamma * gamma) + 1.0 - (c[PEY3] + c[PEY4] * gamma) * sign
                } else {
                    -((c[PEY3] + c[PEY4] * (c[LGAY] * gamma)) * sign) + 1.0
                };
                (c[PEY1] + c[PEY2] * dfz) * camber * c[LEY]
            }
            ConstrainedQuantity::Ex { dfz, sign } => ex_at(c, T::cst(dfz), sign),
            ConstrainedQuantity::ExPeak { lo, hi, sign } => {
                let factor = (-(c[PEX4] * sign) + 1.0) * c[LEX];
                let vertex = -c[PEX2] / (c[PEX3] * 2.0);
                let concave = (c[PEX3] * factor).value() < 0.0;
                if concave && vertex.value() > lo && vertex.value() < hi {
                    ex_at(c, vertex, sign)
                } else {
                    T::cst(f64::NEG_INFINITY)
                }
            }
            ConstrainedQuantity::Et { dfz, gamma, a } => {
                let gz = c[LGAZ] * gamma;
                (c[QEZ1] + c[QEZ2] * dfz + c[QEZ3] * (dfz * dfz))
                    * ((c[QEZ4] + c[QEZ5] * gz) * a + 1.0)
            }
            ConstrainedQuantity::Exa { dfz } => c[REX1] + c[REX2] * dfz,
            ConstrainedQuantity::Eyk { dfz } => c[REY1] + c[REY2] * dfz,
            ConstrainedQuantity::NegGxa { input, version } => {
                -gxa(c, &weight_load(c, &input, version))
            }
            ConstrainedQuantity::NegGyk { input, version } => {
                -gyk(c, &weight_load(c, &input, version))
            }
            ConstrainedQuantity::NegBt { dfz, gamma } => {
                let gz = c[LGAZ] * gamma;
                -((c[QBZ1] + c[QBZ2] * dfz + c[QBZ3] * (dfz * dfz))
                    * (c[QBZ4] * gz + c[QBZ5] * gz.abs() + 1.0))
            }
        }
    }
}

/// The lateral curvature rules `Ey <= 1`, as (quantity, limit): at every load change of `dfzs`,
/// inclination of `gammas` and both signs of `alpha_y`, in `version`'s equations.
pub(crate) fn ey_rules(
    dfzs: &[f64],
    gammas: &[f64],
    version: Version,
) -> Vec<(ConstrainedQuantity, f64)> {
    let mut out = Vec::new();
    for &dfz in dfzs {
        for &gamma in gammas {
            for sign in [-1.0, 1.0] {
                let q = ConstrainedQuantity::Ey {
                    dfz,
                    gamma,
                    sign,
                    version,
                };
                out.push((q, 1.0));
            }
        }
    }
    out
}

/// The aligning-moment trail rules, as (quantity, limit): `Et <= 1` at both ends of
/// `(2/pi) atan(Bt Ct alpha_t)` and `Bt >= 0.1`, at every load change of `dfzs` and inclination
/// of `gammas` (one form in PAC2002 and MF 6.x).
pub(crate) fn trail_rules(dfzs: &[f64], gammas: &[f64]) -> Vec<(ConstrainedQuantity, f64)> {
    let mut out = Vec::new();
    for &dfz in dfzs {
        for &gamma in gammas {
            for a in [-1.0, 1.0] {
                out.push((ConstrainedQuantity::Et { dfz, gamma, a }, 1.0));
            }
            out.push((ConstrainedQuantity::NegBt { dfz, gamma }, -0.1));
        }
    }
    out
}

/// The load quantities of the combined-slip weights `Gxa`, `Gyk` at `input` for `version`: no
/// pressure term enters them, so MF 6.x's are taken at `NOMPRES`.
fn weight_load<T: Real>(c: &Coefs<T>, input: &SlipInput, version: Version) -> Load<T> {
    load_with(c, input, FIT_MODE, version, c[NOMPRES].value())
}

/// PAC2002's longitudinal curvature `Ex` before clamping at relative load change `dfz` and
/// sign `sign` of `kappa_x`.
fn ex_at<T: Real>(c: &Coefs<T>, dfz: T, sign: f64) -> T {
    (c[PEX1] + c[PEX2] * dfz + c[PEX3] * (dfz * dfz)) * (-(c[PEX4] * sign) + 1.0) * c[LEX]
}

/// A penalty residual.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Penalty {
    /// `weight (c[coef] - centre)`.
    Prior {
        coef: Coef,
        centre: f64,
        weight: f64,
    },
    /// `weight max(0, quantity - limit)`.
    AtMost {
        quantity: ConstrainedQuantity,
        limit: f64,
        weight: f64,
    },
}

impl Penalty {
    fn residual<T: Real>(&self, c: &Coefs<T>) -> T {
        match *self {
            Penalty::Prior {
                coef,
                centre,
                weight,
            } => (c[coef] - centre) * weight,
            Penalty::AtMost {
                quantity,
                limit,
                weight,
            } => {
                let q = quantity.value(c) - limit;
                if q.value() > 0.0 {
                    q * weight
                } else {
                    T::cst(0.0)
                }
            }
        }
    }
}

/// `penalties` at `c` into `r` and, when given, their derivatives with respect to `free` into
/// `jac` (row-major, `free.len()` per row): one forward-mode pass per free coefficient, which
/// is cheap for a few penalties and needs no dual width chosen by the number of coefficients.
pub fn penalty_rows(
    penalties: &[Penalty],
    c: &Coefs<f64>,
    free: &[Coef],
    r: &mut [f64],
    jac: Option<&mut [f64]>,
) {
    for (ri, pen) in r.iter_mut().zip(penalties) {
        *ri = pen.residual(c);
    }
    let Some(jac) = jac else {
        return;
    };
    let n = free.len();
    let mut dual: Coefs<Dual<1>> = Coefs(c.0.map(Dual::cst));
    for (k, coef) in free.iter().enumerate() {
        dual[*coef] = Dual::var(c[*coef], 0);
        for (i, pen) in penalties.iter().enumerate() {
            jac[i * n + k] = pen.residual(&dual).d[0];
        }
        dual[*coef] = Dual::cst(c[*coef]);
    }
}

/// What the families held fixed contribute at one point (computed once per problem).
#[derive(Copy, Clone, Debug)]
struct Fixed {
    /// Pure lateral force factors (`Fy0` family), read by `Fy`.
    py: PureFy<f64>,
    /// Pure longitudinal force (`Fx0` family), read by `Fx`.
    fx0: f64,
    /// Combined lateral force (`Fy` family), read by `Mx`.
    fy: f64,
    /// The forces `Mz0` or `Mz` reads (`Fy0`, `Fx0`, `Fx`, `Fy` families); `None` for the
    /// other families.
    moment: Option<MomentForces>,
}

/// The families whose values a family's problem caches (their coefficients must not be free).
fn cached_families(family: Family) -> &'static [Family] {
    match family {
        Family::Fy0 | Family::Fx0 | Family::My => &[],
        Family::Mz0 | Family::Fy => &[Family::Fy0],
        Family::Fx => &[Family::Fx0],
        Family::Mz => &[Family::Fy0, Family::Fx0, Family::Fx, Family::Fy],
        Family::Mx => &[Family::Fy0, Family::Fy],
    }
}

/// One family's refinement problem. The channel is evaluated with the contributions of the
/// families held fixed computed once ([`FamilyProblem::new`]), so a Jacobian runs the dual
/// numbers only through the family's own equations.
pub struct FamilyProblem<'a> {
    /// Every coefficient; the free ones are overwritten by the parameter vector.
    pub base: &'a Coefs<f64>,
    /// Free coefficients (at most 32), in parameter order.
    pub free: &'a [Coef],
    /// The family (selects the channel).
    pub family: Family,
    /// Data.
    pub points: &'a [DataPoint],
    /// Penalties.
    pub penalties: &'a [Penalty],
    /// The fixed families at every branch operating point of every point, in point order.
    fixed: Vec<Fixed>,
    /// Index in `fixed` of each point's first branch.
    first_fixed: Vec<usize>,
    /// Each point's sweep ([`DataPoint::sweep`]): the clusters of the data residuals.
    clusters: Vec<usize>,
}

impl<'a> FamilyProblem<'a> {
    /// A problem; caches the fixed families' values at every point.
    ///
    /// # Panics
    /// If a free coefficient belongs to a family the channel caches.
    pub fn new(
        base: &'a Coefs<f64>,
        free: &'a [Coef],
        family: Family,
        points: &'a [DataPoint],
        penalties: &'a [Penalty],
    ) -> Self {
        for f in cached_families(family) {
            assert!(
                !free.iter().any(|c| f.coefficients().contains(c)),
                "FamilyProblem: {family:?} caches {f:?} but one of its coefficients is free"
            );
        }
        let moment_channel = matches!(family, Family::Mz0 | Family::Mz).then(|| family.channel());
        let mut first_fixed = Vec::with_capacity(points.len());
        let mut fixed = Vec::with_capacity(2 * points.len());
        for pt in points {
            first_fixed.push(fixed.len());
            fixed.extend(pt.branches.as_slice().iter().map(|input| {
                let l = load(base, input, FIT_MODE);
                let px = pure_fx0(base, &l);
                let py = pure_fy0(base, &l);
                Fixed {
                    py,
                    fx0: px.fx0,
                    fy: combined_fy(base, &l, &py).fy,
                    moment: moment_channel.map(|ch| MomentForces::at(base, &l, ch)),
                }
            }));
        }
        FamilyProblem {
            base,
            free,
            family,
            points,
            penalties,
            fixed,
            first_fixed,
            clusters: points.iter().map(|p| p.sweep).collect(),
        }
    }

    /// The coefficient vector at parameters `p`.
    pub fn coefs_at(&self, p: &[f64]) -> Coefs<f64> {
        let mut c = self.base.clone();
        for (coef, v) in self.free.iter().zip(p) {
            c[*coef] = *v;
        }
        c
    }

    /// The channel's prediction of point `i`: its mean over the point's branch operating points.
    fn value<T: Real>(&self, c: &Coefs<T>, i: usize) -> T {
        let mut k = self.first_fixed[i];
        self.points[i].branches.mean_of(|input| {
            let v = self.value_at(c, input, &self.fixed[k]);
            k += 1;
            v
        })
    }

    /// The channel at one operating point with the fixed families taken from the cache.
    fn value_at<T: Real>(&self, c: &Coefs<T>, input: &SlipInput, fixed: &Fixed) -> T {
        let l = load(c, input, FIT_MODE);
        match self.family {
            Family::Fy0 => pure_fy0(c, &l).fy0,
            Family::Fx0 => pure_fx0(c, &l).fx0,
            Family::Mz0 | Family::Mz => {
                let forces = fixed
                    .moment
                    .expect("FamilyProblem::new caches the moment's forces")
                    .map(T::cst);
                moment_from_forces(c, &l, &forces, TrailPeak::Standard, self.family.channel())
            }
            Family::Fx => combined_fx(c, &l, T::cst(fixed.fx0)),
            Family::Fy => combined_fy(c, &l, &fixed.py.map(T::cst)).fy,
            Family::Mx => overturning_mx(c, &l, T::cst(fixed.fy)),
            Family::My => T::cst(f64::NAN),
        }
    }

    /// The residual vector at coefficients `c`: one weighted error per data point, then one row
    /// per penalty. The value path (`f64`) and the Jacobian path (dual numbers) both read it.
    fn residual_rows<'s, T: Real>(&'s self, c: &'s Coefs<T>) -> impl Iterator<Item = T> + 's {
        let rows = self
            .points
            .iter()
            .enumerate()
            .map(move |(i, pt)| (self.value(c, i) - pt.value) * pt.weight);
        let pen = self.penalties.iter().map(move |pen| pen.residual(c));
        rows.chain(pen)
    }

    fn jacobian_block<const N: usize>(&self, p: &[f64], r: &mut [f64], jac: &mut [f64]) {
        let n = self.free.len();
        debug_assert!(n <= N);
        let mut c: Coefs<Dual<N>> = Coefs(self.base.0.map(Dual::cst));
        for (k, (coef, v)) in self.free.iter().zip(p).enumerate() {
            c[*coef] = Dual::var(*v, k);
        }
        for (i, v) in self.residual_rows(&c).enumerate() {
            r[i] = v.v;
            jac[i * n..(i + 1) * n].copy_from_slice(&v.d[..n]);
        }
    }
}

impl LeastSquaresProblem for FamilyProblem<'_> {
    fn n_params(&self) -> usize {
        self.free.len()
    }
    fn n_residuals(&self) -> usize {
        self.points.len() + self.penalties.len()
    }
    fn n_data(&self) -> usize {
        self.points.len()
    }
    fn data_clusters(&self) -> Option<&[usize]> {
        Some(&self.clusters)
    }
    fn residuals(&self, p: &[f64], r: &mut [f64]) {
        let c = self.coefs_at(p);
        for (ri, v) in r.iter_mut().zip(self.residual_rows(&c)) {
            *ri = v;
        }
    }
    fn residuals_and_jacobian(&self, p: &[f64], r: &mut [f64], jac: &mut [f64]) {
        // Each width compiles the family equations once more: four keep the build short.
        match self.free.len() {
            0..=8 => self.jacobian_block::<8>(p, r, jac),
            9..=16 => self.jacobian_block::<16>(p, r, jac),
            17..=24 => self.jacobian_block::<24>(p, r, jac),
            25..=32 => self.jacobian_block::<32>(p, r, jac),
            n => panic!("FamilyProblem: {n} free coefficients, at most 32"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::nonlinear_least_squares::finite_difference_jacobian;
    use crate::tire_model::Coef;

    /// The dual-number Jacobian of every family matches central differences.
    #[test]
    fn jacobian_matches_finite_differences() {
        let truth = super::super::synthetic::fsae_demo();
        let inputs: Vec<SlipInput> = (0..9)
            .map(|i| SlipInput {
                fz_n: 300.0 + 150.0 * i as f64,
                kappa: -0.12 + 0.03 * i as f64,
                alpha_rad: (-0.15 + 0.037 * i as f64),
                gamma_rad: 0.01 * (i % 4) as f64,
                vx_mps: 11.176,
            })
            .collect();
        for family in Family::MEASURED {
            let free: Vec<Coef> = family.coefficients().to_vec();
            let points: Vec<DataPoint> = inputs
                .iter()
                .map(|input| DataPoint {
                    input: *input,
                    branches: BranchInputs::one(*input),
                    value: 1.0,
                    weight: 0.01,
                    sweep: 0,
                })
                .collect();
            let penalties = [Penalty::Prior {
                coef: free[0],
                centre: 0.0,
                weight: 0.5,
            }];
            let problem = FamilyProblem::new(&truth, &free, family, &points, &penalties);
            // The cached evaluation equals the full one.
            for (i, pt) in points.iter().enumerate() {
                let full = channel_value(&truth, &pt.input, family);
                let cached = problem.value(&truth, i);
                assert!(
                    (full - cached).abs() <= 1e-9 * full.abs().max(1.0),
                    "{family:?}"
                );
            }
            let p: Vec<f64> = free.iter().map(|c| truth[*c]).collect();
            let fd = finite_difference_jacobian(&problem, &p, 1e-6);
            let mut r = vec![0.0; problem.n_residuals()];
            let mut jac = vec![0.0; fd.len()];
            problem.residuals_and_jacobian(&p, &mut r, &mut jac);
            for (k, (a, b)) in jac.iter().zip(&fd).enumerate() {
                let tol = 1e-5 * (1.0 + a.abs().max(b.abs()));
                assert!(
                    (a - b).abs() <= tol,
                    "{family:?} residual {} coef {}: dual {a} vs fd {b}",
                    k / free.len(),
                    free[k % free.len()].name()
                );
            }
        }
    }
    /// `ExPeak` is the largest `Ex` over its load interval where the quadratic peaks inside it
    /// (above every point of the five-load grid), inactive otherwise; its penalty rows'
    /// derivatives ([`penalty_rows`]) match central differences.
    #[test]
    fn ex_peak_is_the_maximum_between_grid_loads() {
        let mut c = super::super::synthetic::fsae_demo();
        // Concave in load with its vertex at dfz = -0.45, between grid loads -0.6 and -0.3.
        c[PEX1] = 0.71625;
        c[PEX2] = -1.35;
        c[PEX3] = -1.5;
        c[PEX4] = -0.005;
        c[LEX] = 1.0;
        let (lo, hi) = (-0.6, 0.6);
        for sign in [-1.0, 1.0] {
            let dense = (0..=12_000)
                .map(|i| lo + (hi - lo) * i as f64 / 12_000.0)
                .map(|dfz| ConstrainedQuantity::Ex { dfz, sign }.value(&c))
                .fold(f64::NEG_INFINITY, f64::max);
            let grid = (0..=4)
                .map(|i| lo + (hi - lo) * i as f64 / 4.0)
                .map(|dfz| ConstrainedQuantity::Ex { dfz, sign }.value(&c))
                .fold(f64::NEG_INFINITY, f64::max);
            let peak = ConstrainedQuantity::ExPeak { lo, hi, sign }.value(&c);
            assert!((peak - dense).abs() < 1e-6, "peak {peak} vs dense {dense}");
            assert!(peak > 1.0 && grid < 1.0, "peak {peak}, grid {grid}");
        }
        let inactive = |c: &Coefs<f64>, lo, hi| {
            ConstrainedQuantity::ExPeak { lo, hi, sign: 1.0 }.value(c) == f64::NEG_INFINITY
        };
        assert!(inactive(&c, 0.0, 0.6), "vertex below the interval");
        let mut convex = c.clone();
        convex[PEX3] = 1.5;
        assert!(inactive(&convex, lo, hi), "convex quadratic");

        let free = [PEX1, PEX2, PEX3, PEX4];
        let penalties: Vec<Penalty> = [-1.0, 1.0]
            .into_iter()
            .map(|sign| Penalty::AtMost {
                quantity: ConstrainedQuantity::ExPeak { lo, hi, sign },
                limit: 1.0,
                weight: 7.0,
            })
            .collect();
        let mut r = vec![0.0; penalties.len()];
        let mut jac = vec![0.0; penalties.len() * free.len()];
        penalty_rows(&penalties, &c, &free, &mut r, Some(&mut jac));
        assert!(r.iter().all(|v| *v > 0.0), "{r:?}");
        for (k, coef) in free.iter().enumerate() {
            let h = 1e-6;
            let at = |d: f64| {
                let mut cc = c.clone();
                cc[*coef] += d;
                let mut rr = vec![0.0; penalties.len()];
                penalty_rows(&penalties, &cc, &free, &mut rr, None);
                rr
            };
            let (up, down) = (at(h), at(-h));
            for i in 0..penalties.len() {
                let fd = (up[i] - down[i]) / (2.0 * h);
                let dual = jac[i * free.len() + k];
                assert!(
                    (fd - dual).abs() < 1e-5,
                    "{}: dual {dual} fd {fd}",
                    coef.name()
                );
            }
        }
    }
}
