//! Configuration: raw TOML in, one validated [`Config`] out, written into every version's
//! manifest.
//!
//! Precedence: built-in defaults < `--config FILE` < command-line flags. `config/default.toml`
//! documents every key with its default and unit; a test keeps it equal to the built-in defaults,
//! so the reference cannot drift. Every table is `deny_unknown_fields`: a typo is an error that
//! names the key, never a silent fallback to a default.

use std::path::Path;

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use tirebase_core::fit::mf61::{CollapseConfig, Mf61Config};
use tirebase_core::fit::pac2002::{FitConfig, MxForm};
use tirebase_core::fit::relaxation::RelaxationConfig;
use tirebase_core::fit::spring_rate::SpringRateConfig;
use tirebase_core::fit::thermal::ThermalConfig;
use tirebase_core::numerics::nonlinear_least_squares::RobustLoss;
use tirebase_core::segment::SegmentConfig;
use tirebase_core::synth::round::SynthConfig;

/// Reading a TOML input file failed: the two ways shared by every TOML file the pipeline reads
/// (this configuration, the run catalog, the car of `compare`). Each message names the file.
#[derive(Debug, thiserror::Error)]
pub enum TomlFileError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// OS error.
        source: std::io::Error,
    },
    /// Invalid TOML, an unknown or missing key or a wrong type (toml names the key and line).
    #[error("{path}: {message}")]
    Parse {
        /// The file (or what the text is).
        path: String,
        /// What is wrong, on one line.
        message: String,
    },
}

impl TomlFileError {
    /// A parse error of the text `path` names, toml's message on one line.
    pub fn parse(path: &str, error: impl std::fmt::Display) -> TomlFileError {
        TomlFileError::Parse {
            path: path.to_string(),
            message: error.to_string().trim().replace('\n', " "),
        }
    }
}

/// The text of the file at `path`, and its name for messages.
pub fn read_toml_text(path: &Path) -> Result<(String, String), TomlFileError> {
    let name = path.display().to_string();
    match std::fs::read_to_string(path) {
        Ok(text) => Ok((text, name)),
        Err(source) => Err(TomlFileError::Io { path: name, source }),
    }
}

/// TOML `text` deserialized (`path` names it in errors).
pub fn parse_toml<T: DeserializeOwned>(text: &str, path: &str) -> Result<T, TomlFileError> {
    toml::from_str(text).map_err(|e| TomlFileError::parse(path, e))
}

/// Configuration errors.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read or parsed.
    #[error(transparent)]
    File(#[from] TomlFileError),
    /// A value out of range.
    #[error("config key {key}: {reason}")]
    Invalid {
        /// Dotted key.
        key: String,
        /// Why.
        reason: String,
    },
}

/// Everything configurable, one table per stage.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// `[synth]`: the virtual test machine.
    pub synth: SynthConfig,
    /// `[segment]`: segmentation thresholds.
    pub segment: SegmentConfig,
    /// `[fit]`: the fitting stages.
    pub fit: FitSettings,
}

/// Robust loss of the PAC2002 refinements.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LossKind {
    /// Plain least squares.
    None,
    /// Huber.
    Huber,
    /// Cauchy.
    Cauchy,
}

/// Form of the overturning moment fit.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MxFormSetting {
    /// PAC2002 core form (QSX1..QSX3).
    Core,
    /// Core form, then QSX4..QSX11 when it lowers the Mx RMSE by 10 % or more.
    Auto,
}

/// A model `tirebase fit` writes.
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FitModel {
    /// PAC2002 (Magic Formula 5.2), one per tire, rim and tested pressure.
    Pac2002,
    /// Magic Formula 6.1, one per tire and rim across every tested pressure.
    Mf61,
}

impl FitModel {
    /// The name in `[fit] models` and in the tables' `model` column.
    pub const fn as_str(self) -> &'static str {
        match self {
            FitModel::Pac2002 => "pac2002",
            FitModel::Mf61 => "mf61",
        }
    }
}

/// `[fit]`: the PAC2002 fitting stage's knobs; the other stages' knobs in its sub-tables.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FitSettings {
    /// Models written: pac2002 (one per tire, rim and tested pressure), mf61 (one per tire and rim across every tested pressure, built on the PAC2002 fits, which run either way).
    pub models: Vec<FitModel>,
    /// Slip-angle grid for collapsing up/down cornering sweeps, deg.
    pub alpha_bin_deg: f64,
    /// Longitudinal-slip grid for collapsing drive/brake and combined sweeps, -.
    pub kappa_bin: f64,
    /// Collapsed points per sweep used by the joint refinements.
    pub max_points_per_sweep: usize,
    /// Spike rejection threshold, robust standard deviations.
    pub despike_sigmas: f64,
    /// Remove the first-order lag with the relaxation stage's sigma before collapsing.
    pub delag: bool,
    /// Robust loss: none, huber or cauchy.
    pub loss: LossKind,
    /// Threshold of the robust loss, robust scales.
    pub loss_k: f64,
    /// Iteration budget per refinement.
    pub max_iterations: usize,
    /// Prior weight pulling the asymmetric combined terms RHX1, RBY3 to zero.
    pub asymmetry_weight: f64,
    /// Prior weight pulling weakly identified terms (residual torque, trail curvature, load-curvature and combined-slip shape terms; camber terms only through residual torque and trail curvature) to neutral values.
    pub regularisation_weight: f64,
    /// Weight of the physical-constraint penalties.
    pub constraint_weight: f64,
    /// Overturning moment form: core or auto.
    pub mx_form: MxFormSetting,
    /// QSY1 written as the rolling-resistance placeholder (TTC records no My; 0: the model claims no rolling resistance moment; 0.0165 is the thesis's constant), -.
    pub rolling_resistance_placeholder: f64,
    /// Folds of the out-of-sample check (k-fold by sweep, every sweep predicted by a refit that did not see it); below 2 skips it.
    pub kfold: usize,
    /// Iteration budget of each fold's refit (warm-started from the full fit, one robust-loss round).
    pub kfold_iterations: usize,
    /// Collapsed points per sweep in each fold's refit (the held-out sweeps are predicted at all of theirs).
    pub kfold_points_per_sweep: usize,
    /// Flag a family whose out-of-sample RMSE exceeds this multiple of its in-sample RMSE (plus 0.1 % of the channel's peak), -.
    pub oos_ratio_limit: f64,
    /// Bring the PAC2002 sweeps to a reference tread temperature with the thermal stage's mu(T) law of the same tire, rim and pressure and each sample's IR temperature before the fit, when that law exists (cold-to-warm runs, IR channels, thermal stage on); fit_quality grip_t_ref_c says the temperature.
    pub grip_correction: bool,
    /// Smallest rise of peak grip from cold to optimum (thermal_fit gain_peak_over_cold) the correction acts on: a flatter mu(T) is taken as no temperature effect, -.
    pub grip_min_gain: f64,
    /// `[fit.spring_rate]`: vertical stiffness, unloaded radius, effective rolling radius.
    pub spring_rate: SpringRateConfig,
    /// `[fit.thermal]`: cold-to-warm peaks and the mu(T) curve.
    pub thermal: ThermalConfig,
    /// `[fit.relaxation]`: relaxation lengths, contact length, PTY/PTX laws.
    pub relaxation: RelaxationConfig,
    /// `[fit.mf61]`: the MF 6.1 stage's solver and its leave-one-pressure-out check (its sweep grid, robust loss and k-fold check are `[fit]`'s).
    pub mf61: Mf61Settings,
}

/// `[fit.mf61]`: the MF 6.1 stage's solver and its leave-one-pressure-out check (its sweep grid, robust loss and k-fold check are `[fit]`'s).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Mf61Settings {
    /// Iteration budget per family refinement and robust-loss round.
    pub max_iterations: usize,
    /// A family refinement stops when an accepted step lowers its cost by less than this fraction, -.
    pub ftol: f64,
    /// With three or more tested pressures, also rerun the whole fit with each pressure left out and score that pressure (fit_quality lopo_rmse, lopo_ratio): one more whole fit per tested pressure, stopping at ftol 1e-5 (or ftol if larger): a check, not the model.
    pub leave_one_pressure_out: bool,
}

impl Default for Mf61Settings {
    fn default() -> Self {
        let core = Mf61Config::default();
        Mf61Settings {
            max_iterations: core.max_iterations,
            ftol: core.ftol,
            leave_one_pressure_out: core.leave_one_pressure_out,
        }
    }
}

impl Default for FitSettings {
    fn default() -> Self {
        let core = FitConfig::default();
        let (loss, loss_k) = match core.loss {
            RobustLoss::None => (LossKind::None, 0.0),
            RobustLoss::Huber { k } => (LossKind::Huber, k),
            RobustLoss::Cauchy { k } => (LossKind::Cauchy, k),
        };
        FitSettings {
            models: vec![FitModel::Pac2002, FitModel::Mf61],
            alpha_bin_deg: core.alpha_bin_rad.to_degrees(),
            kappa_bin: core.kappa_bin,
            max_points_per_sweep: core.max_points_per_sweep,
            despike_sigmas: core.despike_sigmas,
            delag: core.delag,
            loss,
            loss_k,
            max_iterations: core.max_iterations,
            asymmetry_weight: core.asymmetry_weight,
            regularisation_weight: core.regularisation_weight,
            constraint_weight: core.constraint_weight,
            mx_form: match core.mx_form {
                MxForm::Core => MxFormSetting::Core,
                MxForm::Auto => MxFormSetting::Auto,
            },
            rolling_resistance_placeholder: core.rolling_resistance_placeholder,
            kfold: core.kfold,
            kfold_iterations: core.kfold_iterations,
            kfold_points_per_sweep: core.kfold_points_per_sweep,
            oos_ratio_limit: core.oos_ratio_limit,
            grip_correction: core.grip_correction,
            grip_min_gain: core.grip_min_gain,
            spring_rate: SpringRateConfig::default(),
            thermal: ThermalConfig::default(),
            relaxation: RelaxationConfig::default(),
            mf61: Mf61Settings::default(),
        }
    }
}

impl FitSettings {
    /// `model` is in `[fit] models`.
    pub fn writes(&self, model: FitModel) -> bool {
        self.models.contains(&model)
    }

    /// The MF 6.1 stage's configuration: the sweep grid, robust loss and k-fold check of `[fit]`.
    pub fn mf61(&self) -> Mf61Config {
        let pac = self.pac2002();
        Mf61Config {
            collapse: CollapseConfig {
                alpha_bin_rad: pac.alpha_bin_rad,
                kappa_bin: pac.kappa_bin,
                max_points_per_sweep: pac.max_points_per_sweep,
            },
            max_iterations: self.mf61.max_iterations,
            ftol: self.mf61.ftol,
            loss: pac.loss,
            kfold: pac.kfold,
            kfold_iterations: pac.kfold_iterations,
            oos_ratio_limit: pac.oos_ratio_limit,
            leave_one_pressure_out: self.mf61.leave_one_pressure_out,
        }
    }

    /// The core stage's configuration.
    pub fn pac2002(&self) -> FitConfig {
        FitConfig {
            alpha_bin_rad: self.alpha_bin_deg.to_radians(),
            kappa_bin: self.kappa_bin,
            max_points_per_sweep: self.max_points_per_sweep,
            despike_sigmas: self.despike_sigmas,
            delag: self.delag,
            loss: match self.loss {
                LossKind::None => RobustLoss::None,
                LossKind::Huber => RobustLoss::Huber { k: self.loss_k },
                LossKind::Cauchy => RobustLoss::Cauchy { k: self.loss_k },
            },
            max_iterations: self.max_iterations,
            asymmetry_weight: self.asymmetry_weight,
            regularisation_weight: self.regularisation_weight,
            constraint_weight: self.constraint_weight,
            mx_form: match self.mx_form {
                MxFormSetting::Core => MxForm::Core,
                MxFormSetting::Auto => MxForm::Auto,
            },
            rolling_resistance_placeholder: self.rolling_resistance_placeholder,
            kfold: self.kfold,
            kfold_iterations: self.kfold_iterations,
            kfold_points_per_sweep: self.kfold_points_per_sweep,
            oos_ratio_limit: self.oos_ratio_limit,
            grip_correction: self.grip_correction,
            grip_min_gain: self.grip_min_gain,
        }
    }

    fn validate(&self) -> Result<(), ConfigError> {
        let bad = |key: &str, reason: &str| {
            Err(ConfigError::Invalid {
                key: format!("fit.{key}"),
                reason: reason.to_string(),
            })
        };
        if self.models.is_empty() {
            return bad("models", "must name at least one model (pac2002, mf61)");
        }
        if (1..self.models.len()).any(|i| self.models[..i].contains(&self.models[i])) {
            return bad("models", "names a model twice");
        }
        if !(self.alpha_bin_deg > 0.0 && self.alpha_bin_deg < 5.0) {
            return bad("alpha_bin_deg", "must be in (0, 5) deg");
        }
        if !(self.kappa_bin > 0.0 && self.kappa_bin < 0.05) {
            return bad("kappa_bin", "must be in (0, 0.05)");
        }
        if self.max_points_per_sweep < 8 {
            return bad("max_points_per_sweep", "must be at least 8");
        }
        if self.loss != LossKind::None && self.loss_k <= 0.0 {
            return bad("loss_k", "must be positive for a robust loss");
        }
        if self.max_iterations == 0 {
            return bad("max_iterations", "must be positive");
        }
        if self.mf61.max_iterations == 0 {
            return bad("mf61.max_iterations", "must be positive");
        }
        if !(self.mf61.ftol > 0.0 && self.mf61.ftol < 1.0) {
            return bad("mf61.ftol", "must be in (0, 1)");
        }
        if self.kfold >= 2 && self.kfold_iterations == 0 {
            return bad("kfold_iterations", "must be positive when kfold >= 2");
        }
        if self.kfold >= 2 && self.kfold_points_per_sweep < 8 {
            return bad("kfold_points_per_sweep", "must be at least 8");
        }
        if self.regularisation_weight.is_nan() || self.regularisation_weight < 0.0 {
            return bad("regularisation_weight", "must be >= 0");
        }
        if !(self.grip_min_gain >= 0.0 && self.grip_min_gain.is_finite()) {
            return bad("grip_min_gain", "must be a finite number >= 0");
        }
        if self.oos_ratio_limit.is_nan() || self.oos_ratio_limit < 1.0 {
            return bad("oos_ratio_limit", "must be at least 1");
        }
        let ordered = |r: (f64, f64)| r.0.is_finite() && r.1.is_finite() && r.0 < r.1;
        if !ordered(self.spring_rate.breff_range) || self.spring_rate.breff_range.0 <= 0.0 {
            return bad(
                "spring_rate.breff_range",
                "must be [low, high] with 0 < low < high",
            );
        }
        if !ordered(self.relaxation.sigma_range_m) || self.relaxation.sigma_range_m.0 <= 0.0 {
            return bad(
                "relaxation.sigma_range_m",
                "must be [low, high] with 0 < low < high, m",
            );
        }
        let shift = self.relaxation.apparent_lag_max_s;
        if !(shift.is_finite() && shift > 0.0) {
            return bad("relaxation.apparent_lag_max_s", "must be > 0, s");
        }
        if !ordered(self.relaxation.pty2_range) || self.relaxation.pty2_range.0 <= 0.0 {
            return bad(
                "relaxation.pty2_range",
                "must be [low, high] with 0 < low < high",
            );
        }
        if !ordered(self.relaxation.ptx3_range) {
            return bad(
                "relaxation.ptx3_range",
                "must be [low, high] with low < high",
            );
        }
        let lag = self.relaxation.measurement_lag_range_s;
        if !ordered(lag) || lag.0 < 0.0 {
            return bad(
                "relaxation.measurement_lag_range_s",
                "must be [low, high] with 0 <= low < high, s",
            );
        }
        if !(self.relaxation.measurement_lag_s.is_finite()
            && self.relaxation.measurement_lag_s >= 0.0)
        {
            return bad("relaxation.measurement_lag_s", "must be >= 0, s");
        }
        if !(self.relaxation.linear_fraction > 0.0 && self.relaxation.linear_fraction <= 1.0) {
            return bad("relaxation.linear_fraction", "must be in (0, 1]");
        }
        if self.thermal.min_peaks < 3 {
            return bad("thermal.min_peaks", "must be at least 3");
        }
        Ok(())
    }
}

/// Numeric keys that may be negative (every other number must be >= 0): temperatures, a
/// threshold whose negative value disables its check, a search interval that straddles zero,
/// model coefficients.
const MAY_BE_NEGATIVE: [&str; 6] = [
    "synth.realism.ambient_c",
    "synth.realism.road_c",
    "segment.classify.cold_to_warm_min_temp_rise_c",
    "fit.relaxation.ptx3_range",
    "fit.relaxation.contact.q_a1",
    "fit.relaxation.contact.q_a2",
];

/// Numeric keys that must be strictly positive (zero leaves a division or a window empty).
const MUST_BE_POSITIVE: [&str; 11] = [
    "synth.quirks.sa_scale",
    "synth.quirks.load_scale",
    "segment.smoothing.window_s",
    "segment.smoothing.rate_window_s",
    "segment.smoothing.ia_rate_window_s",
    "segment.gaps.gap_factor",
    "segment.classify.main_speed_kph",
    "fit.despike_sigmas",
    "fit.thermal.peak_fit_half_s",
    "fit.thermal.stiffness_half_window_rad",
    "fit.thermal.ir_phase_revolutions",
];

/// A fraction (at most 1): keys named `frac`, `*_frac` or `*_fraction`.
fn is_fraction(key: &str) -> bool {
    let last = key.rsplit('.').next().unwrap_or(key);
    last == "frac" || last.ends_with("_frac") || last.ends_with("_fraction")
}

/// Check every number of a resolved configuration: finite, non-negative unless in
/// [`MAY_BE_NEGATIVE`], positive where [`MUST_BE_POSITIVE`], at most 1 for fractions. The
/// error names the dotted key.
fn check_numbers(table: &toml::Table, prefix: &str) -> Result<(), ConfigError> {
    for (name, value) in table {
        let key = if prefix.is_empty() {
            name.clone()
        } else {
            format!("{prefix}.{name}")
        };
        let numbers: Vec<f64> = match value {
            toml::Value::Table(t) => {
                check_numbers(t, &key)?;
                continue;
            }
            toml::Value::Float(v) => vec![*v],
            toml::Value::Integer(v) => vec![*v as f64],
            toml::Value::Array(items) => items
                .iter()
                .filter_map(|v| match v {
                    toml::Value::Float(f) => Some(*f),
                    toml::Value::Integer(i) => Some(*i as f64),
                    _ => None,
                })
                .collect(),
            _ => continue,
        };
        let bad = |reason: String| {
            Err(ConfigError::Invalid {
                key: key.clone(),
                reason,
            })
        };
        for v in numbers {
            if !v.is_finite() {
                return bad(format!("{v} is not a finite number"));
            }
            if v < 0.0 && !MAY_BE_NEGATIVE.contains(&key.as_str()) {
                return bad(format!("{v} is negative; it must be 0 or more"));
            }
            if v <= 0.0 && MUST_BE_POSITIVE.contains(&key.as_str()) {
                return bad(format!("{v} must be positive"));
            }
            if v > 1.0 && is_fraction(&key) {
                return bad(format!("{v} is a fraction; it must be at most 1"));
            }
        }
    }
    Ok(())
}

/// Merge `over` into `base`: tables key by key (so a file may give any subset of any table, a
/// tolerance's `abs` without its `frac`), every other value replaced.
fn merge(base: &mut toml::Table, over: toml::Table) {
    for (key, value) in over {
        match (base.get_mut(&key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (_, value) => {
                base.insert(key, value);
            }
        }
    }
}

impl Config {
    /// Parse TOML text layered over the defaults (any subset of any table, down to one field
    /// of a tolerance); `path` names it in errors.
    pub fn parse(text: &str, path: &str) -> Result<Config, ConfigError> {
        let user: toml::Table = parse_toml(text, path)?;
        let mut merged = toml::Table::try_from(Config::default())
            .map_err(|e| TomlFileError::parse("built-in defaults", e))?;
        merge(&mut merged, user);
        let cfg: Config = match merged.try_into() {
            Ok(cfg) => cfg,
            // The text's own error names the key and its line.
            Err(merged_error) => {
                return Err(match parse_toml::<Config>(text, path) {
                    Err(e) => e.into(),
                    Ok(_) => TomlFileError::parse(path, merged_error).into(),
                });
            }
        };
        cfg.validate()?;
        Ok(cfg)
    }

    /// The defaults, or the defaults overridden by `path`.
    pub fn load(path: Option<&Path>) -> Result<Config, ConfigError> {
        match path {
            None => Ok(Config::default()),
            Some(p) => {
                let (text, name) = read_toml_text(p)?;
                Config::parse(&text, &name)
            }
        }
    }

    /// Check values serde cannot: every number (see `check_numbers`), then each stage's
    /// own rules.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let table = toml::Table::try_from(self)
            .map_err(|e| TomlFileError::parse("resolved configuration", e))?;
        check_numbers(&table, "")?;
        self.segment.validate().map_err(|e| ConfigError::Invalid {
            key: "segment".into(),
            reason: e.to_string(),
        })?;
        self.fit.validate()
    }

    /// The resolved configuration as TOML (written into manifests).
    pub fn to_toml(&self) -> String {
        toml::to_string(self).unwrap_or_else(|e| format!("# could not render config: {e}\n"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_toml_documents_exactly_the_defaults() {
        let text = include_str!("../config/default.toml");
        let parsed = Config::parse(text, "config/default.toml").unwrap();
        assert_eq!(
            parsed,
            Config::default(),
            "config/default.toml drifted from the defaults"
        );
    }

    #[test]
    fn partial_files_override_only_their_keys() {
        let cfg = Config::parse("[fit]\nkappa_bin = 0.005\n", "x.toml").unwrap();
        assert_eq!(cfg.fit.kappa_bin, 0.005);
        assert_eq!(cfg.segment, SegmentConfig::default());
    }

    #[test]
    fn unknown_keys_and_bad_values_are_named() {
        let err = Config::parse("[fit]\nkapa_bin = 0.005\n", "x.toml")
            .unwrap_err()
            .to_string();
        assert!(err.contains("kapa_bin"), "{err}");
        let err = Config::parse("[fit]\nkappa_bin = -1.0\n", "x.toml")
            .unwrap_err()
            .to_string();
        assert!(err.contains("fit.kappa_bin"), "{err}");
    }

    #[test]
    fn stage_tables_are_nested_under_fit() {
        let cfg = Config::parse(
            "[fit.relaxation]\nnuisance = \"offset\"\n[fit.thermal]\nmin_peaks = 5\n",
            "x.toml",
        )
        .unwrap();
        assert_eq!(
            cfg.fit.relaxation.nuisance,
            tirebase_core::fit::relaxation::Nuisance::Offset
        );
        assert_eq!(cfg.fit.thermal.min_peaks, 5);
        let err = Config::parse("[fit.relaxation]\nsigma_range_m = [1.0, 0.5]\n", "x.toml")
            .unwrap_err()
            .to_string();
        assert!(err.contains("fit.relaxation.sigma_range_m"), "{err}");
    }

    #[test]
    fn issue20_nonsense_numbers_are_refused_at_load_naming_the_key() {
        for (text, key, why) in [
            (
                "[fit]\nasymmetry_weight = nan\n",
                "fit.asymmetry_weight",
                "not a finite",
            ),
            (
                "[fit]\nconstraint_weight = -1.0\n",
                "fit.constraint_weight",
                "negative",
            ),
            ("[fit]\nloss_k = inf\n", "fit.loss_k", "not a finite"),
            (
                "[segment.activity]\nsa_active_deg = -0.5\n",
                "segment.activity.sa_active_deg",
                "negative",
            ),
            (
                "[segment.plateau.fz_n]\nfrac = 1.5\n",
                "segment.plateau.fz_n.frac",
                "at most 1",
            ),
            (
                "[segment.smoothing]\nwindow_s = 0.0\n",
                "segment.smoothing.window_s",
                "positive",
            ),
            (
                "[fit.thermal]\ndelineation_n = -100.0\n",
                "fit.thermal.delineation_n",
                "negative",
            ),
            (
                "[fit.spring_rate]\nbreff_range = [0.05, nan]\n",
                "fit.spring_rate.breff_range",
                "not a finite",
            ),
            (
                "[synth.quirks]\nload_scale = 0.0\n",
                "synth.quirks.load_scale",
                "positive",
            ),
        ] {
            let err = Config::parse(text, "x.toml").unwrap_err().to_string();
            assert!(err.contains(key) && err.contains(why), "{text}: {err}");
        }
        // Negative where it means something.
        let cfg = Config::parse(
            "[segment.classify]\ncold_to_warm_min_temp_rise_c = -1.0\n[synth.realism]\nambient_c = -5.0\n",
            "x.toml",
        )
        .unwrap();
        assert_eq!(cfg.synth.realism.ambient_c, -5.0);
    }

    #[test]
    fn issue20_a_tolerance_table_may_be_overridden_in_part() {
        let cfg = Config::parse("[segment.plateau.fz_n]\nabs = 50.0\n", "x.toml").unwrap();
        let default = SegmentConfig::default();
        assert_eq!(cfg.segment.plateau.fz_n.abs, 50.0);
        assert_eq!(cfg.segment.plateau.fz_n.frac, default.plateau.fz_n.frac);
        assert_eq!(cfg.segment.plateau.ia_deg, default.plateau.ia_deg);
        // Unknown keys are still refused, by name and line.
        let err = Config::parse("[segment.plateau.fz_n]\nabz = 50.0\n", "x.toml")
            .unwrap_err()
            .to_string();
        assert!(err.contains("abz") && err.contains("line 2"), "{err}");
    }

    #[test]
    fn resolved_config_round_trips() {
        let cfg = Config::default();
        assert_eq!(Config::parse(&cfg.to_toml(), "resolved").unwrap(), cfg);
    }
}

/// Prints the defaults as TOML, the input of `config/gen_default_toml.py`.
#[cfg(test)]
#[test]
#[ignore]
fn print_default_config() {
    println!("{}", Config::default().to_toml());
}
