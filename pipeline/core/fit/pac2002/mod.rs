//! The PAC2002 fitting stage: the sweeps of one (tire, rim, nominal pressure) in, a fitted
//! PAC2002 model and per-family fit facts out.
//!
//! In: a [`FitInput`]: cornering, drive/brake and combined-slip sweeps ([`Sweep`], samples in
//! ISO-W SI, nominal levels) and a [`FitContext`] (test speed, optional vertical stiffness,
//! unloaded radius and relaxation lengths from the other stages). Out: a [`Pac2002Fit`]: the
//! model (every family fitted in the order of issue 5: `Fy0 -> Mz0 -> Fx0 -> Fx, Fy -> Mz -> Mx`,
//! `My` a documented placeholder), the implied `USE_MODE`, ranges and scalars from the data,
//! per-family quality ([`FamilyFit`]) and per-coefficient standard errors and bound flags
//! ([`FittedCoefficient`]).
//!
//! Method, per family (details in the sub-modules):
//! 1. `collapse`: per sweep, despike (running median + MAD test), optionally de-lag with the
//!    relaxation length (`F_ss = F + sigma/V dF/dt`), then collapse the up/down hysteresis by
//!    averaging the up-branch and down-branch means on a slip grid. The joint fits run on these
//!    collapsed curves, not on the raw samples: each slip region of each sweep counts once
//!    whatever the sweep rate and the number of passes, the lag hysteresis cancels to first
//!    order, and a fit costs ~20x fewer model evaluations (the whole tire fits in well under a
//!    second). Quality is also reported against the raw samples.
//! 2. `initial`: starting values the way the thesis did by hand (seed section 8.2): per sweep a
//!    single Magic Formula curve (`B C D E SH SV K`) or trail curve, then linear least squares
//!    (and 1-D scans for the few nonlinear load laws) for their load and camber dependence.
//! 3. `problem`: joint refinement of the family's coefficients with the bounded
//!    Levenberg-Marquardt of [`crate::numerics::nonlinear_least_squares`] on the collapsed points,
//!    residuals normalised by each sweep's peak (every sweep counts the same), optional
//!    Huber/Cauchy loss by IRLS, penalties for `E <= 1` (before clamping) and `Gxa, Gyk > 0` over
//!    the tested envelope, bounds for `C > 0`, and a small prior pulling the asymmetric
//!    combined-slip shifts (`RHX1`, `RBY3`) to zero (combined data exist for one sign of slip
//!    angle only).
//! 4. [`select`]: a short table of term groups (camber and load-curvature terms, combined-slip
//!    shape terms) that, when free and weakly identified, are held at their neutral values if
//!    that lowers the family's k-fold-by-sweep prediction error by a clear margin at no
//!    material in-sample cost.
//!
//! Conventions: ISO-W. Signs are never assumed: the cornering stiffness takes the sign the data
//! has. The Magic Formula is unchanged when `B` and `D` flip sign together, so the sign of the
//! peak factors (`PDY1`, `PDX1`) is a convention: it is chosen equal to the sign of the slip
//! stiffness (`B > 0`), which gives `PDY1 < 0, PKY1 < 0` for a normal tire in ISO-W (the
//! Stackpole/TTC and `fsae-demo` convention). Likewise `RVY6 >= 0`, `RBX2, RBY2, RVY4 >= 0`.
//!
//! Deliberately not here: reading the store, segmentation and QC (the caller passes the sweeps to
//! fit and has already dropped cold-to-warm, conditioning and QC-flagged segments; a sweep marked
//! `qc_ok = false` is skipped again defensively), writing `.tir` files or tables, relaxation
//! lengths and transient coefficients (`PTX*`, `PTY*`: the relaxation stage).

mod collapse;
mod family;
pub mod grip;
mod initial;
mod linear;
mod problem;
mod quality;
mod select;
mod stage;

#[cfg(test)]
mod synthetic;
#[cfg(test)]
mod tests;

use super::output::Output;
use super::segment_data::{MeasuredSegment, SegmentKind};
use super::sweep_folds::OutOfSampleQuality;
use crate::numerics::nonlinear_least_squares::{RobustLoss, Termination};
use crate::tire_model::{Coef, Pac2002, SlipInput};

pub use crate::numerics::nonlinear_least_squares::Identifiability;
pub use family::Family;
pub(crate) use family::{Levels, unidentifiable};
pub(crate) use problem::{ConstrainedQuantity, Penalty, ey_rules, penalty_rows, trail_rules};
pub use quality::{OutOfSample, TREND_SUBDIVISIONS, TrendDeviation};
pub(crate) use stage::{bound_note, combined_slip_box};
pub use stage::{fit, middle_nominal_load};

/// A sweep's samples as this stage fits them: finite, in time order, despiked and, with
/// `relaxation`, de-lagged (the MF 6.1 stage reads the same cleaned samples).
pub fn cleaned_samples(
    sweep: &Sweep,
    despike_sigmas: f64,
    relaxation: Option<&RelaxationLengths>,
) -> Vec<Sample> {
    let settings = collapse::CollapseSettings {
        bin: match sweep.kind {
            SweepKind::Cornering => 0.25_f64.to_radians(),
            _ => 0.0025,
        },
        despike_sigmas,
        relaxation,
    };
    collapse::collapse(sweep, &settings).samples
}

/// What a sweep holds fixed and what it sweeps.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum SweepKind {
    /// Slip-angle sweep at fixed load and inclination, free rolling (`kappa ~ 0`).
    Cornering,
    /// Longitudinal-slip sweep at slip angle ~ 0.
    DriveBrake,
    /// Longitudinal-slip sweep at a fixed non-zero slip angle.
    Combined,
}

impl SweepKind {
    /// The segment kind name used by the store (`cornering`, `drive_brake`, `combined`).
    pub const fn as_str(self) -> &'static str {
        match self {
            SweepKind::Cornering => "cornering",
            SweepKind::DriveBrake => "drive_brake",
            SweepKind::Combined => "combined",
        }
    }
}

/// The nominal (commanded) levels of a sweep, ISO-W, SI.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SweepNominal {
    /// Nominal vertical load, N (> 0).
    pub fz_n: f64,
    /// Nominal inclination angle, rad.
    pub gamma_rad: f64,
    /// Nominal slip angle, rad, ISO-W sign (0 for drive/brake; the held angle for combined;
    /// ignored for cornering sweeps).
    pub alpha_rad: f64,
}

/// One measured sample, ISO-W axes, SI units.
///
/// Output channels the test did not record may be NaN: the sample then does not count for the
/// families that need that channel. A sample with a non-finite input is dropped.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Sample {
    /// Elapsed time, s.
    pub et_s: f64,
    /// Vertical load, N, positive in compression.
    pub fz_n: f64,
    /// Longitudinal slip (SL: 0 gives `Fx ~ 0`).
    pub kappa: f64,
    /// Slip angle, rad (ISO-W).
    pub alpha_rad: f64,
    /// Inclination angle, rad.
    pub gamma_rad: f64,
    /// Road speed, m/s.
    pub vx_mps: f64,
    /// Longitudinal force, N.
    pub fx_n: f64,
    /// Lateral force, N (ISO-W).
    pub fy_n: f64,
    /// Aligning moment, N m (ISO-W).
    pub mz_nm: f64,
    /// Overturning moment, N m.
    pub mx_nm: f64,
    /// Loaded radius, m (only used when the context has no unloaded radius / stiffness).
    pub loaded_radius_m: Option<f64>,
    /// Centre tread surface temperature as the IR sensor reads it (no phase-lag correction),
    /// degC; NaN when not recorded. Only the grip-temperature correction ([`grip`]) reads it.
    pub tread_c: f64,
}

impl Sample {
    /// The sample's operating point, as the tire model takes it.
    pub fn slip_input(&self) -> SlipInput {
        SlipInput {
            fz_n: self.fz_n,
            kappa: self.kappa,
            alpha_rad: self.alpha_rad,
            gamma_rad: self.gamma_rad,
            vx_mps: self.vx_mps,
        }
    }

    /// The value of one output channel.
    pub fn output(&self, o: Output) -> f64 {
        match o {
            Output::Fx => self.fx_n,
            Output::Fy => self.fy_n,
            Output::Mz => self.mz_nm,
            Output::Mx => self.mx_nm,
        }
    }

    fn set_output(&mut self, o: Output, v: f64) {
        match o {
            Output::Fx => self.fx_n = v,
            Output::Fy => self.fy_n = v,
            Output::Mz => self.mz_nm = v,
            Output::Mx => self.mx_nm = v,
        }
    }
}

/// One sweep of one segment.
#[derive(Clone, Debug, PartialEq)]
pub struct Sweep {
    /// Identifier used in reports (e.g. the segment id).
    pub id: String,
    /// What is swept.
    pub kind: SweepKind,
    /// Nominal levels.
    pub nominal: SweepNominal,
    /// False if the segment carries QC flags (it is then skipped and reported).
    pub qc_ok: bool,
    /// Samples in time order.
    pub samples: Vec<Sample>,
}

impl Sweep {
    /// The sweep of a cornering, drive/brake or combined segment (`None` for other kinds or
    /// without nominal load and inclination). `mx_nm`: the overturning moment per sample, which
    /// [`MeasuredSegment`] does not carry (NaN when absent).
    pub fn from_segment(
        seg: &MeasuredSegment,
        mx_nm: Option<&[f64]>,
        qc_ok: bool,
    ) -> Option<Sweep> {
        let kind = match seg.kind {
            SegmentKind::Cornering => SweepKind::Cornering,
            SegmentKind::DriveBrake => SweepKind::DriveBrake,
            SegmentKind::Combined => SweepKind::Combined,
            _ => return None,
        };
        let c = &seg.channels;
        Some(Sweep {
            id: seg.segment_id.clone(),
            kind,
            nominal: SweepNominal {
                fz_n: seg.nominal.fz_n? as f64,
                gamma_rad: (seg.nominal.ia_cdeg? as f64 / 100.0).to_radians(),
                alpha_rad: (seg.nominal.alpha_deg.unwrap_or(0) as f64).to_radians(),
            },
            qc_ok,
            samples: (0..c.len())
                .map(|i| Sample {
                    et_s: c.et_s[i],
                    fz_n: c.fz_n[i],
                    kappa: c.kappa[i],
                    alpha_rad: c.alpha_rad[i],
                    gamma_rad: c.gamma_rad[i],
                    vx_mps: c.speed_mps(i),
                    fx_n: c.fx_n[i],
                    fy_n: c.fy_n[i],
                    mz_nm: c.mz_nm[i],
                    mx_nm: mx_nm.map_or(f64::NAN, |m| m[i]),
                    loaded_radius_m: c.loaded_radius_m.as_ref().map(|v| v[i]),
                    tread_c: c.tread_centre_c.as_ref().map_or(f64::NAN, |v| v[i]),
                })
                .collect(),
        })
    }
}

/// A relaxation length as a function of load: `(fz_n, sigma_m)` pairs, linearly interpolated,
/// held constant outside the first and last load.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RelaxationTable {
    /// `(load N, relaxation length m)`, sorted by load.
    pub by_load: Vec<(f64, f64)>,
}

impl RelaxationTable {
    /// Relaxation length at `fz_n`, m (`None` for an empty law).
    pub fn at(&self, fz_n: f64) -> Option<f64> {
        let pts = &self.by_load;
        let (first, last) = (pts.first()?, pts.last()?);
        if fz_n <= first.0 {
            return Some(first.1);
        }
        if fz_n >= last.0 {
            return Some(last.1);
        }
        let k = pts.partition_point(|p| p.0 <= fz_n);
        let (a, b) = (pts[k - 1], pts[k]);
        let f = (fz_n - a.0) / (b.0 - a.0);
        Some(a.1 + f * (b.1 - a.1))
    }
}

/// Relaxation lengths from the relaxation stage, used to de-lag the sweeps.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RelaxationLengths {
    /// Lateral relaxation length `sigma_alpha(Fz)`: de-lags `Fy`, `Mz`, `Mx`.
    pub sigma_alpha: RelaxationTable,
    /// Longitudinal relaxation length `sigma_kappa(Fz)`: de-lags `Fx`.
    pub sigma_kappa: RelaxationTable,
    /// The rig's measurement lag in time (every force and moment channel), s: de-lagging
    /// removes `sigma/V + measurement_lag_s` of lag.
    pub measurement_lag_s: f64,
}

/// What the other stages and the catalogue know about the tire and the test.
#[derive(Clone, Debug, PartialEq)]
pub struct FitContext {
    /// Tire name.
    pub tire: String,
    /// Rim width, in.
    pub rim_in: f64,
    /// Nominal inflation pressure, kPa.
    pub pressure_kpa_nom: f64,
    /// Test (road) speed, m/s: becomes `LONGVL`.
    pub test_speed_mps: f64,
    /// Vertical stiffness from the spring-rate stage, N/m.
    pub vertical_stiffness_n_per_m: Option<f64>,
    /// Unloaded radius from the spring-rate stage, m.
    pub unloaded_radius_m: Option<f64>,
    /// Relaxation lengths (enables de-lagging when [`FitConfig::delag`] is on).
    pub relaxation: Option<RelaxationLengths>,
}

/// Everything one fit needs.
#[derive(Clone, Debug, PartialEq)]
pub struct FitInput {
    /// Tire, test and other stages' results.
    pub context: FitContext,
    /// The sweeps (any order; the stage sorts by kind, nominal levels and id).
    pub sweeps: Vec<Sweep>,
}

/// How `Mx` is modelled.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum MxForm {
    /// PAC2002 core form: `QSX1..QSX3` (the others keep MFeval's defaults, under which the extra
    /// terms vanish).
    Core,
    /// Core form, then `QSX4..QSX11` too; kept only if it lowers the `Mx` RMSE by 10 % or more.
    Auto,
}

/// Knobs of the stage (defaults are what the validation tests use).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FitConfig {
    /// Slip-angle grid for collapsing cornering sweeps, rad.
    pub alpha_bin_rad: f64,
    /// Longitudinal-slip grid for collapsing drive/brake and combined sweeps.
    pub kappa_bin: f64,
    /// Largest number of collapsed points per sweep used by the joint refinements (evenly spaced
    /// along the curve); quality is always reported on all of them.
    pub max_points_per_sweep: usize,
    /// Spike test: a sample deviating from its running median by more than this many robust
    /// standard deviations (and by 1 % of the sweep's peak) is replaced by the median.
    pub despike_sigmas: f64,
    /// De-lag the sweeps when the context carries relaxation lengths.
    pub delag: bool,
    /// Robust loss of the joint refinements.
    pub loss: RobustLoss,
    /// Iteration budget per refinement (per IRLS round).
    pub max_iterations: usize,
    /// Weight of the prior pulling `RHX1` and `RBY3` to zero: a shift of 0.01 rad costs as much
    /// as this relative RMS error of the fit.
    pub asymmetry_weight: f64,
    /// Weight of the priors pulling weakly identified terms (residual torque, trail curvature,
    /// load-curvature and combined-slip shape terms) to their neutral values: one
    /// typical departure costs as much as this relative RMS error of the fit.
    pub regularisation_weight: f64,
    /// Weight of the physical-constraint penalties (per unit of violation, relative to a
    /// normalised residual of 1 = 100 % of a sweep's peak).
    pub constraint_weight: f64,
    /// Form of the overturning moment.
    pub mx_form: MxForm,
    /// Rolling-resistance coefficient written as the `QSY1` placeholder (TTC records no `My`):
    /// 0 by default, so the model claims no rolling resistance moment it was not fitted to.
    pub rolling_resistance_placeholder: f64,
    /// Folds of the out-of-sample check (k-fold by sweep); below 2 the check is skipped.
    pub kfold: usize,
    /// Iteration budget of each fold's refit (warm-started from the full fit, one robust-loss
    /// round).
    pub kfold_iterations: usize,
    /// Collapsed points per sweep in each fold's refit (evenly spaced, as
    /// [`FitConfig::max_points_per_sweep`]); the held-out sweeps are predicted at all of theirs.
    /// The default equals `max_points_per_sweep`: a coarser fold refit solves another problem
    /// than the full fit (a refit on every sweep would not reproduce the in-sample error), and
    /// that difference would be charged to out of sample.
    pub kfold_points_per_sweep: usize,
    /// A family whose out-of-sample RMSE exceeds this multiple of its in-sample RMSE (plus
    /// 0.1 % of the channel's peak) is flagged.
    pub oos_ratio_limit: f64,
    /// Bring the sweeps to a reference tread temperature with the thermal stage's `mu(T)` law
    /// before fitting ([`grip::correct`]), when that law exists. The caller applies it: the
    /// stage fits the input it is given.
    pub grip_correction: bool,
    /// Smallest rise of peak grip from the cold tire to the optimum (the thermal fit's
    /// `gain_peak_over_cold`) that counts as a temperature effect to correct: a flatter law is
    /// the fit of noise (a grip independent of temperature gives gains of ~0.002).
    pub grip_min_gain: f64,
}

impl Default for FitConfig {
    fn default() -> Self {
        FitConfig {
            alpha_bin_rad: 0.25_f64.to_radians(),
            kappa_bin: 0.0025,
            max_points_per_sweep: 40,
            despike_sigmas: 6.0,
            delag: true,
            loss: RobustLoss::Huber { k: 2.0 },
            max_iterations: 300,
            asymmetry_weight: 1e-3,
            regularisation_weight: 1e-3,
            constraint_weight: 10.0,
            mx_form: MxForm::Auto,
            rolling_resistance_placeholder: 0.0,
            kfold: 5,
            kfold_iterations: 20,
            kfold_points_per_sweep: 40,
            oos_ratio_limit: 1.2,
            grip_correction: true,
            grip_min_gain: 0.02,
        }
    }
}

/// Outcome class of one family.
#[derive(Clone, Debug, PartialEq)]
pub enum FamilyStatus {
    /// Fitted (see the quality for convergence).
    Fitted,
    /// Not fitted, coefficients set to a documented placeholder.
    Placeholder {
        /// Why and what was set.
        reason: String,
    },
    /// No data for this family: its coefficients are left at zero and `USE_MODE` excludes it.
    NoData {
        /// What was missing.
        reason: String,
    },
    /// The fit could not be done (its coefficients are left at zero).
    Failed {
        /// What went wrong.
        reason: String,
    },
}

impl FamilyStatus {
    /// `fitted`, `placeholder`, `no_data` or `failed`.
    pub const fn as_str(&self) -> &'static str {
        match self {
            FamilyStatus::Fitted => "fitted",
            FamilyStatus::Placeholder { .. } => "placeholder",
            FamilyStatus::NoData { .. } => "no_data",
            FamilyStatus::Failed { .. } => "failed",
        }
    }
}

/// Quality of one family's fit (units of its channel: N or N m).
#[derive(Clone, Debug, PartialEq)]
pub struct FitQuality {
    /// Collapsed points the quality is computed on (all of them; the refinement may use a
    /// thinned subset, see [`FitConfig::max_points_per_sweep`]).
    pub n: usize,
    /// Root-mean-square error on the collapsed points.
    pub rmse: f64,
    /// `rmse` relative to the largest `|value|` among the collapsed points, %.
    pub rmse_pct_of_peak: f64,
    /// Coefficient of determination on the collapsed points.
    pub r2: f64,
    /// Raw samples of the fitted sweeps (after despiking, before collapsing).
    pub n_samples: usize,
    /// RMSE against those raw samples (includes noise and hysteresis).
    pub sample_rmse: f64,
    /// RMSE of the starting values on the collapsed points.
    pub initial_rmse: f64,
    /// Solver trial steps (all IRLS rounds).
    pub iterations: usize,
    /// Why the solver stopped.
    pub termination: Termination,
    /// Model evaluations: residual vectors plus Jacobians of the joint refinement.
    pub evaluations: usize,
    /// Wall-clock time of the family (initial values + refinement), s. The only
    /// non-deterministic number of the stage.
    pub seconds: f64,
    /// Rank and condition of the data Jacobian over the free coefficients off their bounds.
    pub identifiability: Identifiability,
    /// k-fold-by-sweep prediction error (`None` with fewer than two sweeps or `kfold < 2`).
    pub out_of_sample: Option<OutOfSample>,
    /// Largest deviation from the data's local trend between the collapsed points.
    pub trend: Option<TrendDeviation>,
}

impl OutOfSampleQuality for FitQuality {
    fn rmse(&self) -> f64 {
        self.rmse
    }
    fn rmse_pct_of_peak(&self) -> f64 {
        self.rmse_pct_of_peak
    }
    fn oos_rmse(&self) -> Option<f64> {
        self.out_of_sample.as_ref().map(|o| o.rmse)
    }
    fn oos_folds(&self) -> usize {
        self.out_of_sample.as_ref().map_or(0, |o| o.folds)
    }
    fn oos_deficient_folds(&self) -> usize {
        self.out_of_sample.as_ref().map_or(0, |o| o.deficient_folds)
    }
}

/// One family's result.
#[derive(Clone, Debug, PartialEq)]
pub struct FamilyFit {
    /// Which family.
    pub family: Family,
    /// Fitted, placeholder, no data or failed.
    pub status: FamilyStatus,
    /// Quality when fitted.
    pub quality: Option<FitQuality>,
}

/// Where a coefficient's value comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum CoefficientOrigin {
    /// Fitted (free in the joint refinement).
    Fitted,
    /// Held fixed because the data cannot determine it (the reason says why).
    Fixed {
        /// E.g. "one camber sign: not separable from QBZ4".
        reason: String,
    },
    /// A documented placeholder (e.g. `QSY1`).
    Placeholder,
    /// Derived from the data directly (ranges, `FNOMIN`, radius from `RL`).
    Data,
    /// Taken from the context (spring-rate stage, test speed).
    Context,
}

impl CoefficientOrigin {
    /// `fitted`, `fixed`, `placeholder`, `data` or `context`.
    pub const fn as_str(&self) -> &'static str {
        match self {
            CoefficientOrigin::Fitted => "fitted",
            CoefficientOrigin::Fixed { .. } => "fixed",
            CoefficientOrigin::Placeholder => "placeholder",
            CoefficientOrigin::Data => "data",
            CoefficientOrigin::Context => "context",
        }
    }
}

/// One coefficient the stage set.
#[derive(Clone, Debug, PartialEq)]
pub struct FittedCoefficient {
    /// The coefficient.
    pub coef: Coef,
    /// Its family (`None` for ranges, dimensions and other scalars).
    pub family: Option<Family>,
    /// Value, SI.
    pub value: f64,
    /// Standard error from the joint refinement (`None` unless fitted and off its bounds).
    pub std_error: Option<f64>,
    /// True if the fitted value sits on a bound.
    pub at_bound: bool,
    /// Where the value comes from.
    pub origin: CoefficientOrigin,
    /// Why it is held, or why it sits on a bound and what that bound means (`None` otherwise):
    /// no coefficient is left on a bound without saying why.
    pub note: Option<String>,
}

/// A sweep the stage did not use, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct SkippedSweep {
    /// [`Sweep::id`].
    pub id: String,
    /// Why it was skipped.
    pub reason: String,
}

/// The stage's result for one (tire, rim, pressure).
#[derive(Clone, Debug, PartialEq)]
pub struct Pac2002Fit {
    /// The fitted model (standard PAC2002 trail peak), coefficients in SI.
    pub model: Pac2002,
    /// Adams `USE_MODE` implied by the families fitted: 1 Fx only, 2 Fy+Mz only, 3 pure Fx and Fy,
    /// 4 combined.
    pub use_mode: u8,
    /// Every family in fit order.
    pub families: Vec<FamilyFit>,
    /// Every coefficient the stage set, in [`Coef::ALL`] order.
    pub coefficients: Vec<FittedCoefficient>,
    /// Sweeps not used.
    pub skipped_sweeps: Vec<SkippedSweep>,
    /// Human-readable notes (placeholders, where the radius came from, ...), in a fixed order.
    pub notes: Vec<String>,
    /// Model evaluations over all families.
    pub evaluations: usize,
    /// Wall-clock time of the whole fit, s (not deterministic).
    pub seconds: f64,
}

/// Bad input (a failed family is not an error: see [`FamilyStatus::Failed`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Pac2002Error {
    /// Nothing to fit.
    #[error("{tire}: no usable cornering, drive/brake or combined sweep ({skipped} skipped)")]
    NoUsableSweeps {
        /// Tire name.
        tire: String,
        /// Sweeps skipped.
        skipped: usize,
    },
    /// No unloaded radius in the context and no loaded radius in the samples.
    #[error(
        "{tire}: no unloaded radius: the context has none and no sample carries a loaded radius"
    )]
    NoUnloadedRadius {
        /// Tire name.
        tire: String,
    },
    /// The context is unusable.
    #[error("{tire}: bad context: {field} = {value} ({expected})")]
    BadContext {
        /// Tire name.
        tire: String,
        /// The context field.
        field: &'static str,
        /// Its value.
        value: f64,
        /// What was expected.
        expected: &'static str,
    },
}
