//! Segmentation thresholds: every number the segmenter uses, with its unit, in one TOML-readable
//! struct.
//!
//! In: a `[segment]` TOML table (or nothing: [`SegmentConfig::default`] is the tuned default).
//! Out: a validated [`SegmentConfig`]. Deliberately not here: reading files (the command layer
//! does that) and any per-round schedule (the segmenter must not need one).
//!
//! Tolerances called "half-band" allow a value to stay within `±tol` of a level: a plateau of a
//! set-point holds while the spread (max - min) of the smoothed channel is at most `2 * tol`.
//! Angles are in degrees (ISO-W sign for slip angle), loads in N (positive = compression),
//! pressures in kPa, speeds in km/h, slips dimensionless, durations in seconds.

use serde::{Deserialize, Serialize};

use super::SegmentError;

/// A tolerance that grows with the level: `max(abs, frac * |level|)`.
#[derive(Copy, Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tolerance {
    /// Absolute floor, in the channel's unit.
    pub abs: f64,
    /// Fraction of the level's magnitude (0.1 = 10 %).
    pub frac: f64,
}

impl Tolerance {
    /// Tolerance at `level`: `max(abs, frac * |level|)`.
    pub fn at(&self, level: f64) -> f64 {
        self.abs.max(self.frac * level.abs())
    }

    /// A tolerance independent of the level.
    pub const fn fixed(abs: f64) -> Self {
        Tolerance { abs, frac: 0.0 }
    }
}

/// Every threshold of the segmenter. Sections follow the passes.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SegmentConfig {
    /// Pass 1: ET gaps ("run" files drop the dwells, so ET jumps).
    pub gaps: GapConfig,
    /// Signal preparation: smoothing and rate windows.
    pub smoothing: SmoothingConfig,
    /// Pass 3a: what counts as slip activity (SA or SL away from zero).
    pub activity: ActivityConfig,
    /// Pass 2: set-point plateaus of P, IA, V inside slip activity (FZ for IA sweeps).
    pub plateau: PlateauConfig,
    /// Pass 3b: slip sweeps and their cycles.
    pub sweep: SweepConfig,
    /// Pass 3c: step steers (fast SA steps held at a level).
    pub step_steer: StepSteerConfig,
    /// Pass 3d: spring-rate load staircases (SA and SL quiet).
    pub spring_rate: SpringRateHoldConfig,
    /// Pass 3e: inclination-angle sweeps at SA ~ 0.
    pub ia_sweep: IaSweepConfig,
    /// Pass 4: cold-to-warm / conditioning / matrix rules.
    pub classify: ClassifyConfig,
    /// Pass 5: tolerances of the levels each run learns (clustering and labels).
    pub levels: LevelConfig,
    /// Pass 6: QC flag thresholds.
    pub qc: QcConfig,
}

/// ET gap detection. A gap is `dt > max(min_gap_s, gap_factor * sample_period)`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GapConfig {
    /// Smallest ET jump that splits a run, s.
    pub min_gap_s: f64,
    /// A jump must also exceed this many median sample periods, -.
    pub gap_factor: f64,
}

/// Smoothing applied (per gap-free block, never across a gap) before any threshold.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SmoothingConfig {
    /// Centred moving-average width for every channel, s.
    pub window_s: f64,
    /// Centred difference width for rates (dSA/dt, dSL/dt), s.
    pub rate_window_s: f64,
    /// Centred difference width for the slow inclination rate (dIA/dt), s.
    pub ia_rate_window_s: f64,
}

/// Slip activity: a sample is active when the slip angle or the longitudinal slip is away from
/// zero or moving. Activity episodes are the unit sweeps and step steers are found in.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ActivityConfig {
    /// |SA| above this is active, deg.
    pub sa_active_deg: f64,
    /// |SL - SL at free rolling| above this is active, -.
    pub sl_active: f64,
    /// |dSA/dt| above this is active too (a sweep passing through zero), deg/s.
    pub sa_rate_active_deg_s: f64,
    /// |dSL/dt| above this is active too, 1/s.
    pub sl_rate_active_per_s: f64,
    /// SL is only looked at above this road speed (SL/SR are meaningless at V ~ 0), km/h.
    pub rolling_min_kph: f64,
    /// Quiet stretches shorter than this inside activity are bridged (a sweep crossing zero), s.
    pub quiet_min_s: f64,
    /// Active stretches shorter than this are ignored (left to `other`), s.
    pub active_min_s: f64,
}

/// Set-point plateaus inside slip activity (half-band tolerances, see the module doc).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlateauConfig {
    /// Pressure half-band, kPa.
    pub pressure_kpa: Tolerance,
    /// Inclination half-band, deg.
    pub ia_deg: Tolerance,
    /// Load half-band of an IA sweep, N (sweeps are not cut where FZ moves: load control wanders
    /// with the tire force, and a load set-point changes only between sweeps).
    pub fz_n: Tolerance,
    /// Road speed half-band, km/h.
    pub speed_kph: Tolerance,
    /// Adjacent sweep cycles whose mean loads agree within this are read as one load level
    /// (their pooled mean): loose load control swings FZ by about +-20 % within and between the
    /// cycles of one set-point, N.
    pub fz_swing: Tolerance,
    /// A plateau must last at least this long, s.
    pub hold_min_s: f64,
    /// Excursions shorter than this between two plateaus at the same level are absorbed, s.
    pub blip_max_s: f64,
}

/// Slip sweeps and their cycles. A cycle is one positive and one negative big excursion of the
/// swept slip (SA: -4 -> +12 -> -12 -> +3 or 0 -> +12 -> -12 -> 0; SL: +0.2 -> -0.2 -> +0.2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SweepConfig {
    /// Minimum SA span (max - min) of a slip-angle sweep, deg.
    pub sa_min_span_deg: f64,
    /// Minimum SL span of a longitudinal slip sweep, -.
    pub sl_min_span: f64,
    /// An excursion is "big" beyond this fraction of the piece's largest |slip|, -.
    pub peak_frac: f64,
    /// ... and beyond this absolute SA, deg.
    pub sa_peak_min_deg: f64,
    /// ... and beyond this absolute SL, -.
    pub sl_peak_min: f64,
    /// Rates below this are treated as holds when measuring a sweep's slip rate, deg/s.
    pub sa_rate_floor_deg_s: f64,
    /// Same for SL, 1/s.
    pub sl_rate_floor_per_s: f64,
    /// Slip-angle half-band for the SA set-point of a combined SL sweep, deg.
    pub combined_sa_tol_deg: f64,
}

/// Step steers: SA jumps fast to a level and holds it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StepSteerConfig {
    /// SA half-band of a hold, deg.
    pub hold_tol_deg: f64,
    /// A hold lasts at least this long, s.
    pub hold_min_s: f64,
    /// The jump into a hold takes at most this long, s.
    pub max_rise_s: f64,
    /// A step holds at least this |SA|, deg.
    pub min_level_deg: f64,
    /// Holds must cover at least this fraction of the active piece (else it is a sweep), -.
    pub min_hold_fraction: f64,
}

/// Spring-rate holds: FZ stepped through levels with SA and SL at zero.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SpringRateHoldConfig {
    /// Load half-band of one step (fine: FZ is clean at zero slip), N.
    pub fz_n: Tolerance,
    /// Shortest step, s.
    pub step_min_s: f64,
    /// Longest step (a longer hold is a dwell, not a step), s.
    pub step_max_s: f64,
    /// Smallest load change between consecutive steps, N.
    pub step_min_n: f64,
    /// Longest transition between consecutive steps, s.
    pub transition_max_s: f64,
    /// Fewest steps in a staircase, -.
    pub min_steps: usize,
    /// Steps carry at least this load (an unloaded hold is not a step), N.
    pub loaded_min_n: f64,
    /// Below this mean road speed a staircase is static, above it dynamic, km/h.
    pub static_max_kph: f64,
}

/// Inclination sweeps: IA ramps through a wide span at SA ~ 0, rolling, loaded, at a held load
/// (spread within the plateau load band) and not too quickly.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IaSweepConfig {
    /// Minimum IA span of one monotonic ramp (set-point changes of a matrix are <= 4 deg), deg.
    pub min_span_deg: f64,
    /// IA is moving above this rate, deg/s.
    pub rate_min_deg_s: f64,
    /// Pauses shorter than this inside a ramp are bridged, s.
    pub pause_max_s: f64,
    /// The tire must carry at least this load, N.
    pub loaded_min_n: f64,
    /// A sweep lasts at least this long (a quick IA repositioning is no sweep), s.
    pub min_duration_s: f64,
}

/// Classification of sweep cycles (see `classify.rs` for the rules these feed).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ClassifyConfig {
    /// A cold-to-warm block has at least this many consecutive cycles at one set-point, -.
    pub cold_to_warm_min_cycles: usize,
    /// ... swept at least this fast, deg/s.
    pub cold_to_warm_min_rate_deg_s: f64,
    /// ... and, when tread temperatures are given, the centre tread warms by at least this much
    /// from its first to its last cycle, degC. Negative disables the check.
    pub cold_to_warm_min_temp_rise_c: f64,
    /// Cycles whose slip rate is within this fraction of the matrix rate are at "matrix rate", -.
    pub rate_tol_frac: f64,
    /// Consecutive cycles belong to one train when their spans agree within this fraction, -.
    pub span_tol_frac: f64,
    /// The standard test speed; sweeps at another nominal speed are `speed_sweep`, km/h.
    pub main_speed_kph: f64,
}

/// Set-point levels: each run learns its own nominal levels by clustering the measured means of
/// its held stretches (`levels.rs`); these are the clustering and labelling tolerances. The means
/// of one level span at most twice the tolerance, with no gap wider than it; a level whose centre
/// is within the label tolerance of a consortium standard level (8-16 psi; 50-350 lb;
/// 0/15/25/45 mph) is labelled with it, else with its rounded centre.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LevelConfig {
    /// Pressure clustering tolerance, kPa.
    pub pressure_tol: Tolerance,
    /// A pressure level within this of a standard pressure takes its label, kPa.
    pub pressure_label_tol: Tolerance,
    /// Load clustering tolerance, N.
    pub fz_tol: Tolerance,
    /// A load level within this of a standard load takes its label, N.
    pub fz_label_tol: Tolerance,
    /// Inclination clustering tolerance, deg. No label tolerance: there is no standard list of
    /// inclinations, a level's label is its centre rounded to 0.1 deg
    /// ([`super::ia_cdeg_label`]).
    pub ia_tol: Tolerance,
    /// Road speed clustering tolerance, km/h.
    pub speed_tol: Tolerance,
    /// A speed level within this of a standard speed takes its label, km/h.
    pub speed_label_tol: Tolerance,
    /// Held slip angle clustering tolerance (combined sweeps, step steers), deg; a level is
    /// labelled by its centre rounded to whole degrees (there is no standard list to snap to).
    pub alpha_tol: Tolerance,
}

/// QC flag thresholds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct QcConfig {
    /// A stretch of exact zeros (or of P below `zero_pressure_max_kpa`) lasts at least this, s.
    pub zero_min_s: f64,
    /// Pressure at or below this is "zero pressure", kPa.
    pub zero_pressure_max_kpa: f64,
    /// Exact zeros are a zeroed channel only when the channel's neighbours exceed this fraction
    /// of the channel's typical magnitude (its 95th percentile of |x| over the run), -.
    pub zeroed_neighbour_frac: f64,
    /// A channel pinned at its run extreme for at least this long is saturated, s.
    pub saturation_min_s: f64,
    /// A sweep shorter than this fraction of the median duration of its kind in the run is too
    /// short, -.
    pub too_short_frac: f64,
    /// Any classified segment shorter than this is too short, s.
    pub too_short_min_s: f64,
    /// Load drift: FZ trend over a held-load segment beyond this tolerance, N. Loose load control
    /// of older rounds swings FZ by about +-20 % within a sweep, and over part of a swing period
    /// the least-squares change reaches 2.6 times the swing amplitude: that is not a drift.
    pub load_drift: Tolerance,
}

impl Default for GapConfig {
    fn default() -> Self {
        GapConfig {
            min_gap_s: 0.5,
            gap_factor: 5.0,
        }
    }
}

impl Default for SmoothingConfig {
    fn default() -> Self {
        SmoothingConfig {
            window_s: 0.1,
            rate_window_s: 0.3,
            ia_rate_window_s: 1.0,
        }
    }
}

impl Default for ActivityConfig {
    fn default() -> Self {
        ActivityConfig {
            sa_active_deg: 0.5,
            sl_active: 0.03,
            sa_rate_active_deg_s: 1.0,
            sl_rate_active_per_s: 0.01,
            rolling_min_kph: 2.0,
            quiet_min_s: 1.0,
            active_min_s: 0.5,
        }
    }
}

impl Default for PlateauConfig {
    fn default() -> Self {
        PlateauConfig {
            pressure_kpa: Tolerance::fixed(4.0),
            ia_deg: Tolerance::fixed(0.4),
            fz_n: Tolerance {
                abs: 60.0,
                frac: 0.10,
            },
            speed_kph: Tolerance::fixed(2.5),
            fz_swing: Tolerance {
                abs: 100.0,
                frac: 0.3,
            },
            hold_min_s: 0.5,
            blip_max_s: 1.0,
        }
    }
}

impl Default for SweepConfig {
    fn default() -> Self {
        SweepConfig {
            sa_min_span_deg: 4.0,
            sl_min_span: 0.08,
            peak_frac: 0.5,
            sa_peak_min_deg: 2.0,
            sl_peak_min: 0.03,
            sa_rate_floor_deg_s: 0.5,
            sl_rate_floor_per_s: 0.005,
            combined_sa_tol_deg: 0.5,
        }
    }
}

impl Default for StepSteerConfig {
    fn default() -> Self {
        StepSteerConfig {
            hold_tol_deg: 0.25,
            hold_min_s: 0.5,
            max_rise_s: 0.5,
            min_level_deg: 0.5,
            min_hold_fraction: 0.5,
        }
    }
}

impl Default for SpringRateHoldConfig {
    fn default() -> Self {
        SpringRateHoldConfig {
            fz_n: Tolerance {
                abs: 30.0,
                frac: 0.04,
            },
            step_min_s: 0.15,
            step_max_s: 4.0,
            step_min_n: 100.0,
            transition_max_s: 1.5,
            min_steps: 3,
            loaded_min_n: 100.0,
            static_max_kph: 2.0,
        }
    }
}

impl Default for IaSweepConfig {
    fn default() -> Self {
        IaSweepConfig {
            min_span_deg: 6.0,
            rate_min_deg_s: 0.2,
            pause_max_s: 0.5,
            loaded_min_n: 100.0,
            min_duration_s: 3.0,
        }
    }
}

impl Default for ClassifyConfig {
    fn default() -> Self {
        ClassifyConfig {
            cold_to_warm_min_cycles: 3,
            cold_to_warm_min_rate_deg_s: 6.0,
            cold_to_warm_min_temp_rise_c: 2.0,
            rate_tol_frac: 0.3,
            span_tol_frac: 0.2,
            main_speed_kph: 40.0,
        }
    }
}

impl Default for LevelConfig {
    fn default() -> Self {
        LevelConfig {
            pressure_tol: Tolerance::fixed(3.0),
            pressure_label_tol: Tolerance::fixed(3.0),
            fz_tol: Tolerance {
                abs: 40.0,
                frac: 0.05,
            },
            fz_label_tol: Tolerance {
                abs: 30.0,
                frac: 0.03,
            },
            ia_tol: Tolerance::fixed(0.5),
            speed_tol: Tolerance::fixed(4.0),
            speed_label_tol: Tolerance::fixed(2.0),
            alpha_tol: Tolerance::fixed(0.5),
        }
    }
}

impl Default for QcConfig {
    fn default() -> Self {
        QcConfig {
            zero_min_s: 0.25,
            zero_pressure_max_kpa: 1.0,
            zeroed_neighbour_frac: 0.05,
            saturation_min_s: 0.25,
            too_short_frac: 0.5,
            too_short_min_s: 1.0,
            load_drift: Tolerance {
                abs: 100.0,
                frac: 0.6,
            },
        }
    }
}

impl SegmentConfig {
    /// Check every value for sign and range; the error names the key.
    pub fn validate(&self) -> Result<(), SegmentError> {
        let positive = [
            ("gaps.min_gap_s", self.gaps.min_gap_s),
            ("gaps.gap_factor", self.gaps.gap_factor),
            ("smoothing.window_s", self.smoothing.window_s),
            ("smoothing.rate_window_s", self.smoothing.rate_window_s),
            (
                "smoothing.ia_rate_window_s",
                self.smoothing.ia_rate_window_s,
            ),
            ("activity.sa_active_deg", self.activity.sa_active_deg),
            ("activity.sl_active", self.activity.sl_active),
            ("activity.quiet_min_s", self.activity.quiet_min_s),
            ("plateau.hold_min_s", self.plateau.hold_min_s),
            ("sweep.sa_min_span_deg", self.sweep.sa_min_span_deg),
            ("sweep.sl_min_span", self.sweep.sl_min_span),
            ("sweep.peak_frac", self.sweep.peak_frac),
            ("sweep.combined_sa_tol_deg", self.sweep.combined_sa_tol_deg),
            ("step_steer.hold_tol_deg", self.step_steer.hold_tol_deg),
            ("step_steer.hold_min_s", self.step_steer.hold_min_s),
            ("step_steer.max_rise_s", self.step_steer.max_rise_s),
            ("spring_rate.step_min_s", self.spring_rate.step_min_s),
            ("spring_rate.step_max_s", self.spring_rate.step_max_s),
            ("spring_rate.step_min_n", self.spring_rate.step_min_n),
            ("ia_sweep.min_span_deg", self.ia_sweep.min_span_deg),
            ("ia_sweep.rate_min_deg_s", self.ia_sweep.rate_min_deg_s),
            ("classify.rate_tol_frac", self.classify.rate_tol_frac),
            ("classify.span_tol_frac", self.classify.span_tol_frac),
            ("qc.zero_min_s", self.qc.zero_min_s),
            ("qc.saturation_min_s", self.qc.saturation_min_s),
        ];
        for (key, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(SegmentError::Config {
                    key,
                    reason: format!("must be a finite number > 0, got {value}"),
                });
            }
        }
        let tolerances = [
            ("plateau.pressure_kpa", self.plateau.pressure_kpa),
            ("plateau.ia_deg", self.plateau.ia_deg),
            ("plateau.fz_n", self.plateau.fz_n),
            ("plateau.speed_kph", self.plateau.speed_kph),
            ("plateau.fz_swing", self.plateau.fz_swing),
            ("spring_rate.fz_n", self.spring_rate.fz_n),
            ("levels.pressure_tol", self.levels.pressure_tol),
            ("levels.pressure_label_tol", self.levels.pressure_label_tol),
            ("levels.fz_tol", self.levels.fz_tol),
            ("levels.fz_label_tol", self.levels.fz_label_tol),
            ("levels.ia_tol", self.levels.ia_tol),
            ("levels.speed_tol", self.levels.speed_tol),
            ("levels.speed_label_tol", self.levels.speed_label_tol),
            ("levels.alpha_tol", self.levels.alpha_tol),
            ("qc.load_drift", self.qc.load_drift),
        ];
        for (key, tol) in tolerances {
            if !(tol.abs.is_finite() && tol.abs > 0.0 && tol.frac.is_finite() && tol.frac >= 0.0) {
                return Err(SegmentError::Config {
                    key,
                    reason: format!("needs abs > 0 and frac >= 0, got {tol:?}"),
                });
            }
        }
        if self.spring_rate.min_steps < 2 {
            return Err(SegmentError::Config {
                key: "spring_rate.min_steps",
                reason: format!("must be >= 2, got {}", self.spring_rate.min_steps),
            });
        }
        if self.classify.cold_to_warm_min_cycles < 2 {
            return Err(SegmentError::Config {
                key: "classify.cold_to_warm_min_cycles",
                reason: format!(
                    "must be >= 2, got {}",
                    self.classify.cold_to_warm_min_cycles
                ),
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_validate_and_old_level_lists_are_refused_by_name() {
        assert!(SegmentConfig::default().validate().is_ok());
        let err = toml::from_str::<SegmentConfig>("[levels]\nfz_n = [222.0]\n").unwrap_err();
        assert!(err.to_string().contains("fz_n"), "{err}");
    }

    #[test]
    fn toml_overrides_one_key_and_rejects_unknown_keys() {
        let cfg: SegmentConfig = toml::from_str("[gaps]\nmin_gap_s = 1.5\n").unwrap();
        assert_eq!(cfg.gaps.min_gap_s, 1.5);
        assert_eq!(cfg.gaps.gap_factor, GapConfig::default().gap_factor);
        assert!(toml::from_str::<SegmentConfig>("[gaps]\nmin_gap = 1.5\n").is_err());
        assert!(toml::from_str::<SegmentConfig>("bogus = 1\n").is_err());
    }

    #[test]
    fn validation_names_the_key() {
        let mut cfg = SegmentConfig::default();
        cfg.plateau.hold_min_s = 0.0;
        let err = cfg.validate().unwrap_err().to_string();
        assert!(err.contains("plateau.hold_min_s"), "{err}");
    }
}
