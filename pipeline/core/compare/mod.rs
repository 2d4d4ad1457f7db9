//! Tire selection: the figures that decide a choice between tires, evaluated from a steady-state
//! tire model at a car's conditions, and a ranking that shows ties instead of hiding them.
//!
//! In: a model behind [`SteadyStateTire`] (a fitted PAC2002 `.tir` today; a pressure-dependent
//! MF 6.1 model plugs in through the same trait and [`pressure`]) and the car's [`Conditions`]
//! (corner loads, nominal load, speed, static camber range). Out: [`Figures`]: per load the
//! peak lateral and longitudinal force and friction coefficient and the cornering stiffness;
//! the load sensitivity of both friction coefficients; the camber that maximises the peak
//! lateral force at the nominal load and the gain from it; the longitudinal slip stiffness; the
//! friction-envelope area; relaxation lengths and vertical stiffness where the model has them.
//!
//! Definitions (ISO-W axes, SI units; every search stays inside the model's valid ranges
//! `ALPMIN..ALPMAX`, `KPUMIN..KPUMAX`, `CAMMIN..CAMMAX`, so no figure comes from outside the
//! tested envelope, except loads, see below):
//! - camber `gamma*`: the inclination in the car's range (magnitudes, the loaded tire leaning
//!   into the turn) that maximises the peak lateral force at the nominal load. Every other
//!   figure is evaluated at `gamma*`: it is the static camber the car would run on that tire.
//! - peak lateral force at a load: `max |Fy|` over the slip angle (pure side slip, both
//!   directions: with camber, the direction camber thrust helps); `mu_y = |Fy|peak / Fz`.
//! - peak longitudinal force: `max |Fx|` over the slip ratio (pure longitudinal slip, drive and
//!   brake); `mu_x = |Fx|peak / Fz`.
//! - cornering stiffness `|dFy/dalpha|` and longitudinal slip stiffness `|dFx/dkappa|` at zero
//!   slip (central differences of the model, so a shifted curve is measured where it is).
//! - load sensitivity: the secant `(mu(Fz_max) - mu(Fz_min)) / (Fz_max - Fz_min)` over the car's
//!   loads (one load: a +-10 % central difference), 1/N.
//! - friction-envelope area: area of the convex outline of `(Fx, Fy)` over the slip-angle x
//!   slip-ratio grid of the valid ranges at the nominal load (combined slip), N^2; only for a
//!   model with a fitted combined-slip part.
//! - lateral and longitudinal capacity (the ranking objectives): `sum |F|peak / sum Fz` over the
//!   car's loads: the friction coefficient of a set of tires at those corner loads.
//!
//! A model without a lateral or a longitudinal part (`USE_MODE` 1: Fx only, 2: Fy and Mz only)
//! has NaN for every figure of the missing direction, never a number from evaluating an absent
//! family.
//!
//! Loads above the model's `FZMAX` are evaluated by the model's own load law (the Magic Formula
//! extrapolates smoothly in load) instead of clipped, and reported in
//! [`Figures::extrapolated_loads_n`], so a figure never silently belongs to another load.
//!
//! Deliberately not here: reading files, tables, the thermal window (measured, not modelled:
//! see the `tirebase` crate's `compare`), the cross-round spread.

pub mod envelope;
pub mod pressure;
pub mod rank;

use crate::fit::scalar::{self, ScalarOptions};
use crate::tire_model::{Coef, Evaluation, Mode, Pac2002, SlipInput};

/// Step of the numerical slip derivatives (rad for slip angle, - for slip ratio).
const SLIP_STEP: f64 = 1e-5;
/// Grid points of a peak search before Brent polishes it.
const PEAK_GRID: usize = 61;
/// Grid points of the camber search.
const CAMBER_GRID: usize = 17;
/// Grid points per axis of the friction-envelope outline.
const ENVELOPE_GRID: usize = 81;

/// The car's conditions the figures are evaluated at (SI; validated by [`Conditions::validate`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Conditions {
    /// Corner loads, N (> 0, ascending, at least one).
    pub loads_n: Vec<f64>,
    /// Nominal (static) corner load, N: stiffness, camber, envelope and relaxation figures.
    pub nominal_load_n: f64,
    /// Road speed, m/s.
    pub speed_mps: f64,
    /// Static camber range as inclination magnitudes `(lo, hi)`, rad, `0 <= lo <= hi`.
    pub camber_rad: (f64, f64),
}

/// A condition that cannot be evaluated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConditionsError {
    /// A value is out of range; the message names it.
    #[error("{0}")]
    Invalid(String),
}

impl Conditions {
    /// Check every value.
    pub fn validate(&self) -> Result<(), ConditionsError> {
        let bad = |m: String| Err(ConditionsError::Invalid(m));
        if self.loads_n.is_empty() {
            return bad("no corner load given".into());
        }
        if self.loads_n.iter().any(|f| !(f.is_finite() && *f > 0.0)) {
            return bad(format!("corner loads must be > 0 N: {:?}", self.loads_n));
        }
        if self.loads_n.windows(2).any(|w| w[1] <= w[0]) {
            return bad(format!(
                "corner loads must be strictly ascending: {:?}",
                self.loads_n
            ));
        }
        if !(self.nominal_load_n.is_finite() && self.nominal_load_n > 0.0) {
            return bad(format!(
                "nominal load must be > 0 N: {}",
                self.nominal_load_n
            ));
        }
        if !(self.speed_mps.is_finite() && self.speed_mps > 0.0) {
            return bad(format!("speed must be > 0: {} m/s", self.speed_mps));
        }
        let (lo, hi) = self.camber_rad;
        if !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo <= hi && hi < 0.35) {
            return bad(format!(
                "camber range must satisfy 0 <= min <= max < 20 deg: {:.3}..{:.3} deg",
                lo.to_degrees(),
                hi.to_degrees()
            ));
        }
        Ok(())
    }
}

/// The model's valid (tested) ranges.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ValidRanges {
    /// Slip angle, rad.
    pub alpha_rad: (f64, f64),
    /// Slip ratio.
    pub kappa: (f64, f64),
    /// Inclination, rad.
    pub gamma_rad: (f64, f64),
    /// Vertical load, N.
    pub fz_n: (f64, f64),
}

/// What the figures need from a tire model: steady-state forces and its valid ranges.
pub trait SteadyStateTire {
    /// Forces at one point (ISO-W, SI), slip inputs limited to the valid ranges; loads are not
    /// clipped at the top of the tested range (see the module docs).
    fn eval(&self, input: &SlipInput) -> Evaluation<f64>;
    /// The valid ranges.
    fn ranges(&self) -> ValidRanges;
    /// Does the model carry a fitted combined-slip part (friction envelope)?
    fn has_combined_slip(&self) -> bool;
    /// Does the model carry a lateral part (Fy)? Without it every lateral figure is NaN.
    fn has_lateral(&self) -> bool {
        true
    }
    /// Does the model carry a longitudinal part (Fx)? Without it every longitudinal figure is
    /// NaN.
    fn has_longitudinal(&self) -> bool {
        true
    }
    /// Relaxation lengths `(sigma_kappa, sigma_alpha)`, m, when the model carries fitted ones.
    fn relaxation_lengths(&self, fz_n: f64, gamma_rad: f64) -> Option<(f64, f64)>;
    /// Vertical stiffness, N/m, when known.
    fn vertical_stiffness_n_per_m(&self) -> Option<f64>;
}

/// A PAC2002 model with what its `.tir` declares about itself.
#[derive(Clone, Debug)]
pub struct Pac2002Tire {
    model: Pac2002,
    ranges: ValidRanges,
    combined: bool,
    relaxation: bool,
    lateral: bool,
    longitudinal: bool,
}

impl Pac2002Tire {
    /// `use_mode` is the file's `USE_MODE` (Adams: 1 Fx, 2 Fy+Mz, 3 uncombined, 4 combined, +10
    /// transient): combined slip when its last digit is 4, relaxation when it is >= 10, a
    /// lateral part unless the last digit is 0 or 1, a longitudinal part unless it is 0 or 2.
    /// `None` (no `USE_MODE`) takes every part as present. `max_load_n`: the highest load to be evaluated;
    /// `FZMAX` is raised to it so loads above the tested range extrapolate instead of clipping.
    pub fn new(model: &Pac2002, use_mode: Option<i64>, max_load_n: f64) -> Pac2002Tire {
        let c = &model.coefs;
        let ranges = ValidRanges {
            alpha_rad: (c[Coef::ALPMIN], c[Coef::ALPMAX]),
            kappa: (c[Coef::KPUMIN], c[Coef::KPUMAX]),
            gamma_rad: (c[Coef::CAMMIN], c[Coef::CAMMAX]),
            fz_n: (c[Coef::FZMIN], c[Coef::FZMAX]),
        };
        let mut model = model.clone();
        if max_load_n.is_finite() && max_load_n > model.coefs[Coef::FZMAX] {
            model.coefs[Coef::FZMAX] = max_load_n;
        }
        let (combined, relaxation, lateral, longitudinal) = match use_mode {
            Some(m) => {
                let d = m.rem_euclid(10);
                (d == 4, m >= 10, !matches!(d, 0 | 1), !matches!(d, 0 | 2))
            }
            None => (true, true, true, true),
        };
        Pac2002Tire {
            model,
            ranges,
            combined,
            relaxation,
            lateral,
            longitudinal,
        }
    }
}

impl SteadyStateTire for Pac2002Tire {
    fn eval(&self, input: &SlipInput) -> Evaluation<f64> {
        self.model.eval(input, Mode::Limits)
    }

    fn ranges(&self) -> ValidRanges {
        self.ranges
    }

    fn has_combined_slip(&self) -> bool {
        self.combined
    }

    fn has_lateral(&self) -> bool {
        self.lateral
    }

    fn has_longitudinal(&self) -> bool {
        self.longitudinal
    }

    fn relaxation_lengths(&self, fz_n: f64, gamma_rad: f64) -> Option<(f64, f64)> {
        self.relaxation
            .then(|| self.model.relaxation_lengths(fz_n, gamma_rad))
            .filter(|(k, a)| k.is_finite() && a.is_finite() && *k > 0.0 && *a > 0.0)
    }

    fn vertical_stiffness_n_per_m(&self) -> Option<f64> {
        let cz = self.model.coefs[Coef::VERTICAL_STIFFNESS];
        (cz.is_finite() && cz > 0.0).then_some(cz)
    }
}

/// What a ranking maximises.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Objective {
    /// Lateral capacity [`Figures::lateral_mu`].
    Lateral,
    /// Longitudinal capacity [`Figures::longitudinal_mu`].
    Longitudinal,
    /// Friction-envelope area at the nominal load [`Figures::envelope_area_n2`].
    Envelope,
}

impl Objective {
    /// Every objective, in the order they are documented.
    pub const ALL: [Objective; 3] = [
        Objective::Lateral,
        Objective::Longitudinal,
        Objective::Envelope,
    ];

    /// Its name on the command line and in tables.
    pub fn name(self) -> &'static str {
        match self {
            Objective::Lateral => "lateral",
            Objective::Longitudinal => "longitudinal",
            Objective::Envelope => "envelope",
        }
    }

    /// Its value in `figures` (NaN when the model lacks it).
    pub fn of(self, figures: &Figures) -> f64 {
        match self {
            Objective::Lateral => figures.lateral_mu,
            Objective::Longitudinal => figures.longitudinal_mu,
            Objective::Envelope => figures.envelope_area_n2.unwrap_or(f64::NAN),
        }
    }

    /// Its value for `tire` at `cond`, computing only what it needs (same number as
    /// `self.of(&evaluate(tire, cond))`).
    pub fn value_of(self, tire: &dyn SteadyStateTire, cond: &Conditions) -> f64 {
        let (gamma, _) = design_camber(tire, cond);
        let fz_sum: f64 = cond.loads_n.iter().sum();
        match self {
            Objective::Lateral => {
                cond.loads_n
                    .iter()
                    .map(|&f| peak_fy(tire, cond, f, gamma))
                    .sum::<f64>()
                    / fz_sum
            }
            Objective::Longitudinal => {
                cond.loads_n
                    .iter()
                    .map(|&f| peak_fx(tire, cond, f, gamma))
                    .sum::<f64>()
                    / fz_sum
            }
            Objective::Envelope => match tire.has_combined_slip() {
                true => envelope::polygon_area(&envelope_outline(
                    tire,
                    cond,
                    cond.nominal_load_n,
                    gamma,
                )),
                false => f64::NAN,
            },
        }
    }
}

/// The figures at one corner load (at the design camber).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct LoadFigures {
    /// The load, N.
    pub fz_n: f64,
    /// Peak `|Fy|`, pure side slip, N.
    pub fy_peak_n: f64,
    /// `fy_peak_n / fz_n`.
    pub mu_y_peak: f64,
    /// Peak `|Fx|`, pure longitudinal slip, N.
    pub fx_peak_n: f64,
    /// `fx_peak_n / fz_n`.
    pub mu_x_peak: f64,
    /// `|dFy/dalpha|` at zero slip, N/rad.
    pub cornering_stiffness_n_per_rad: f64,
}

/// Everything [`evaluate`] computes for one model (see the module docs for the definitions).
#[derive(Clone, Debug, PartialEq)]
pub struct Figures {
    /// Design camber `gamma*` (inclination magnitude), rad.
    pub camber_rad: f64,
    /// `gamma*` is an end of the searched range (the car's range within the model's).
    pub camber_at_bound: bool,
    /// Peak `|Fy|` at `gamma*` over the peak at zero inclination, minus 1 (nominal load).
    pub camber_gain: f64,
    /// Per corner load, in the order of [`Conditions::loads_n`].
    pub loads: Vec<LoadFigures>,
    /// Loads above the model's tested range (`FZMAX`), N.
    pub extrapolated_loads_n: Vec<f64>,
    /// Lateral capacity: `sum |Fy|peak / sum Fz` over the loads.
    pub lateral_mu: f64,
    /// Longitudinal capacity: `sum |Fx|peak / sum Fz` over the loads.
    pub longitudinal_mu: f64,
    /// `d mu_y / d Fz`, 1/N.
    pub mu_y_load_sensitivity_per_n: f64,
    /// `d mu_x / d Fz`, 1/N.
    pub mu_x_load_sensitivity_per_n: f64,
    /// Cornering stiffness at the nominal load, N/rad.
    pub cornering_stiffness_n_per_rad: f64,
    /// Longitudinal slip stiffness at the nominal load, N.
    pub longitudinal_stiffness_n: f64,
    /// Peak `|Fy|` at the nominal load (and `gamma*`), N.
    pub fy_peak_nominal_n: f64,
    /// Friction-envelope area at the nominal load, N^2 (combined-slip models only).
    pub envelope_area_n2: Option<f64>,
    /// Lateral relaxation length at the nominal load, m.
    pub relaxation_lateral_m: Option<f64>,
    /// Longitudinal relaxation length at the nominal load, m.
    pub relaxation_longitudinal_m: Option<f64>,
    /// Vertical stiffness, N/m.
    pub vertical_stiffness_n_per_m: Option<f64>,
}

/// One operating point at the car's speed.
fn point(cond: &Conditions, fz_n: f64, alpha_rad: f64, kappa: f64, gamma_rad: f64) -> SlipInput {
    SlipInput {
        fz_n,
        kappa,
        alpha_rad,
        gamma_rad,
        vx_mps: cond.speed_mps,
    }
}

/// `max f` over `[lo, hi]` (grid, then Brent between the best grid point's neighbours); `(x,
/// f(x), at_bound)`. A degenerate interval gives its one point.
fn maximise(f: &dyn Fn(f64) -> f64, lo: f64, hi: f64, grid: usize) -> (f64, f64, bool) {
    if lo.is_nan() || hi.is_nan() || hi <= lo {
        let x = if lo.is_finite() { lo } else { 0.0 };
        return (x, f(x), true);
    }
    let opts = ScalarOptions {
        grid,
        log_grid: false,
        rel_tol: 1e-10,
        abs_tol: 1e-12 * (hi - lo).max(1e-3),
        max_iters: 200,
    };
    match scalar::minimize(&|x| -f(x), lo, hi, &opts) {
        Ok(m) => (m.x, -m.cost, m.at_bound),
        Err(_) => (lo, f(lo), true),
    }
}

/// Peak `|Fy|` over the slip angle at load `fz_n` and inclination `gamma_rad` (pure side slip):
/// the larger of the peaks in the two directions.
pub fn peak_fy(tire: &dyn SteadyStateTire, cond: &Conditions, fz_n: f64, gamma_rad: f64) -> f64 {
    if !tire.has_lateral() {
        return f64::NAN;
    }
    let (lo, hi) = tire.ranges().alpha_rad;
    let fy = |a: f64| tire.eval(&point(cond, fz_n, a, 0.0, gamma_rad)).fy_n;
    let up = maximise(&|a| fy(a), lo, hi, PEAK_GRID).1;
    let down = maximise(&|a| -fy(a), lo, hi, PEAK_GRID).1;
    up.max(down)
}

/// Peak `|Fx|` over the slip ratio at load `fz_n` and inclination `gamma_rad` (pure
/// longitudinal slip): the larger of the drive and brake peaks.
pub fn peak_fx(tire: &dyn SteadyStateTire, cond: &Conditions, fz_n: f64, gamma_rad: f64) -> f64 {
    if !tire.has_longitudinal() {
        return f64::NAN;
    }
    let (lo, hi) = tire.ranges().kappa;
    let fx = |k: f64| tire.eval(&point(cond, fz_n, 0.0, k, gamma_rad)).fx_n;
    let drive = maximise(&|k| fx(k), lo, hi, PEAK_GRID).1;
    let brake = maximise(&|k| -fx(k), lo, hi, PEAK_GRID).1;
    drive.max(brake)
}

/// `|dFy/dalpha|` at zero slip, N/rad.
pub fn cornering_stiffness(
    tire: &dyn SteadyStateTire,
    cond: &Conditions,
    fz_n: f64,
    gamma_rad: f64,
) -> f64 {
    if !tire.has_lateral() {
        return f64::NAN;
    }
    let fy = |a: f64| tire.eval(&point(cond, fz_n, a, 0.0, gamma_rad)).fy_n;
    ((fy(SLIP_STEP) - fy(-SLIP_STEP)) / (2.0 * SLIP_STEP)).abs()
}

/// `|dFx/dkappa|` at zero slip, N.
pub fn longitudinal_stiffness(
    tire: &dyn SteadyStateTire,
    cond: &Conditions,
    fz_n: f64,
    gamma_rad: f64,
) -> f64 {
    if !tire.has_longitudinal() {
        return f64::NAN;
    }
    let fx = |k: f64| tire.eval(&point(cond, fz_n, 0.0, k, gamma_rad)).fx_n;
    ((fx(SLIP_STEP) - fx(-SLIP_STEP)) / (2.0 * SLIP_STEP)).abs()
}

/// The inclination in the car's range (clipped to the model's) maximising the peak `|Fy|` at
/// the nominal load: `(gamma*, at an end of the searched range)`. A model without a lateral
/// part has nothing to maximise: the low end of that range, flagged as a bound.
pub fn design_camber(tire: &dyn SteadyStateTire, cond: &Conditions) -> (f64, bool) {
    let (m_lo, m_hi) = tire.ranges().gamma_rad;
    let (c_lo, c_hi) = cond.camber_rad;
    let lo = c_lo.clamp(m_lo.min(m_hi), m_hi.max(m_lo));
    let hi = c_hi.clamp(m_lo.min(m_hi), m_hi.max(m_lo));
    if !tire.has_lateral() {
        return (lo, true);
    }
    let (g, _, at_bound) = maximise(
        &|g| peak_fy(tire, cond, cond.nominal_load_n, g),
        lo,
        hi,
        CAMBER_GRID,
    );
    (g, at_bound)
}

/// The `(Fx, Fy)` outline of the model at load `fz_n`, inclination `gamma_rad` over the grid
/// of the valid slip ranges (combined slip), closed (first point repeated).
pub fn envelope_outline(
    tire: &dyn SteadyStateTire,
    cond: &Conditions,
    fz_n: f64,
    gamma_rad: f64,
) -> Vec<(f64, f64)> {
    let r = tire.ranges();
    let lin =
        |(lo, hi): (f64, f64), i: usize| lo + (hi - lo) * i as f64 / (ENVELOPE_GRID - 1) as f64;
    let mut points = Vec::with_capacity(ENVELOPE_GRID * ENVELOPE_GRID);
    for i in 0..ENVELOPE_GRID {
        for j in 0..ENVELOPE_GRID {
            let e = tire.eval(&point(
                cond,
                fz_n,
                lin(r.alpha_rad, i),
                lin(r.kappa, j),
                gamma_rad,
            ));
            if e.fx_n.is_finite() && e.fy_n.is_finite() {
                points.push((e.fx_n, e.fy_n));
            }
        }
    }
    let mut hull = envelope::convex_hull(points);
    if let Some(&first) = hull.first() {
        hull.push(first);
    }
    hull
}

/// Evaluate every figure of `tire` at `cond` (assumed validated).
pub fn evaluate(tire: &dyn SteadyStateTire, cond: &Conditions) -> Figures {
    let fz_nom = cond.nominal_load_n;
    let (gamma, camber_at_bound) = design_camber(tire, cond);
    let fy_nom = peak_fy(tire, cond, fz_nom, gamma);
    let fy_flat = peak_fy(tire, cond, fz_nom, 0.0);
    let loads: Vec<LoadFigures> = cond
        .loads_n
        .iter()
        .map(|&fz| {
            let fy = peak_fy(tire, cond, fz, gamma);
            let fx = peak_fx(tire, cond, fz, gamma);
            LoadFigures {
                fz_n: fz,
                fy_peak_n: fy,
                mu_y_peak: fy / fz,
                fx_peak_n: fx,
                mu_x_peak: fx / fz,
                cornering_stiffness_n_per_rad: cornering_stiffness(tire, cond, fz, gamma),
            }
        })
        .collect();
    let fz_sum: f64 = loads.iter().map(|l| l.fz_n).sum();
    let (sens_y, sens_x) = load_sensitivity(tire, cond, &loads, gamma);
    let fz_max_tested = tire.ranges().fz_n.1;
    let relaxation = tire.relaxation_lengths(fz_nom, gamma);
    Figures {
        camber_rad: gamma,
        camber_at_bound,
        camber_gain: fy_nom / fy_flat - 1.0,
        extrapolated_loads_n: cond
            .loads_n
            .iter()
            .chain(std::iter::once(&cond.nominal_load_n))
            .copied()
            .filter(|&f| f > fz_max_tested * (1.0 + 1e-9))
            .collect(),
        lateral_mu: loads.iter().map(|l| l.fy_peak_n).sum::<f64>() / fz_sum,
        longitudinal_mu: loads.iter().map(|l| l.fx_peak_n).sum::<f64>() / fz_sum,
        mu_y_load_sensitivity_per_n: sens_y,
        mu_x_load_sensitivity_per_n: sens_x,
        cornering_stiffness_n_per_rad: cornering_stiffness(tire, cond, fz_nom, gamma),
        longitudinal_stiffness_n: longitudinal_stiffness(tire, cond, fz_nom, gamma),
        fy_peak_nominal_n: fy_nom,
        envelope_area_n2: tire
            .has_combined_slip()
            .then(|| envelope::polygon_area(&envelope_outline(tire, cond, fz_nom, gamma))),
        relaxation_lateral_m: relaxation.map(|r| r.1),
        relaxation_longitudinal_m: relaxation.map(|r| r.0),
        vertical_stiffness_n_per_m: tire.vertical_stiffness_n_per_m(),
        loads,
    }
}

/// `(d mu_y/d Fz, d mu_x/d Fz)`, 1/N: the secant over the loads, or a +-10 % central
/// difference at a single load.
fn load_sensitivity(
    tire: &dyn SteadyStateTire,
    cond: &Conditions,
    loads: &[LoadFigures],
    gamma: f64,
) -> (f64, f64) {
    match (loads.first(), loads.last()) {
        (Some(a), Some(b)) if b.fz_n > a.fz_n => (
            (b.mu_y_peak - a.mu_y_peak) / (b.fz_n - a.fz_n),
            (b.mu_x_peak - a.mu_x_peak) / (b.fz_n - a.fz_n),
        ),
        (Some(a), _) => {
            let (lo, hi) = (0.9 * a.fz_n, 1.1 * a.fz_n);
            let mu_y = |f: f64| peak_fy(tire, cond, f, gamma) / f;
            let mu_x = |f: f64| peak_fx(tire, cond, f, gamma) / f;
            (
                (mu_y(hi) - mu_y(lo)) / (hi - lo),
                (mu_x(hi) - mu_x(lo)) / (hi - lo),
            )
        }
        _ => (f64::NAN, f64::NAN),
    }
}

#[cfg(test)]
mod tests;
