//! Unit cross-checks after conversion: never trust a declared (or assumed) unit blindly.
//!
//! In: a converted [`RunTable`] (SI, ISO-W). Out: the same table with the channels that fail
//! their checks rescaled or withheld, and one [`UnitNote`] per finding (also one warning line
//! each in [`super::RunMeta::warnings`]).
//!
//! Checks, on the samples where they mean something (rolling: V > 5 km/h; loaded: Fz > 100 N;
//! the wheel-speed and radius checks need 5 s of such samples as evidence; a run with less
//! rolling than that, such as spring-rate holds at standstill, has its RL checked against a
//! tire's radius range on 5 s of loaded samples):
//! - **Wheel speed N** against the road speed: the kinematic radius `V / (2 pi N / 60)` must lie
//!   within 0.1..0.6 m on most rolling samples; otherwise N is withheld (an obfuscated or dead
//!   channel), and nothing can be checked against it.
//! - **Radii RE and RL** against that kinematic radius: the median ratio must be within
//!   0.9..1.1 (RE) or 0.8..1.05 (RL, the loaded radius is shorter). A ratio that one length-unit
//!   confusion explains (the values are in m, mm, in or ft while read as the declared unit) is
//!   rescaled by that exact factor, with a note naming channel, factor and evidence. Without a
//!   usable N, the median must be a tire radius (0.15..0.45 m). A channel with no consistent
//!   reading (ratio or median off, or less than 80 % of its samples within 20 % of its median)
//!   is withheld: the stages that need it then see none.
//! - **Range checks** of pressure (20..400 kPa, [`crate::physical`]), load (|Fz| <= 15 kN), road speed (<= 300 km/h)
//!   and temperatures (-40..200 degC): a note, the values are kept (QC decides).
//!
//! Deliberately not here: the declared units themselves (readers), and SL (see `slip.rs`).

use std::fmt;

use super::{RunTable, TtcChannel};
use crate::numerics::stats::finite_median_high;

/// Road speed above which the wheel rolls for these checks, km/h.
const ROLLING_MIN_KPH: f64 = 5.0;
/// Load above which the tire is loaded, N.
const LOADED_MIN_N: f64 = 100.0;
/// Kinematic radii outside this range say the wheel speed is not a wheel speed, m.
const KINEMATIC_RANGE_M: (f64, f64) = (0.1, 0.6);
/// Fraction of rolling samples whose kinematic radius must be in range for N to count.
const CONSISTENT_FRAC: f64 = 0.8;
/// Radius of a tire the consortium tests (without kinematic evidence), m.
const TIRE_RADIUS_M: (f64, f64) = (0.15, 0.45);
/// Accepted RE / (V / omega) median ratios.
const RE_BAND: (f64, f64) = (0.9, 1.1);
/// Accepted RL / (V / omega) median ratios.
const RL_BAND: (f64, f64) = (0.8, 1.05);
/// A radius sample within this fraction of the channel's median is consistent with it.
const SPREAD_FRAC: f64 = 0.2;
/// Least rolling, loaded time a check needs as evidence, s (a run has minutes of it; a snippet
/// of a few rows is not checked).
const MIN_EVIDENCE_S: f64 = 5.0;
/// Length units a radius may really be in, metres per unit.
const LENGTH_UNITS: [(&str, f64); 5] = [
    ("m", 1.0),
    ("cm", 0.01),
    ("mm", 0.001),
    ("in", 0.0254),
    ("ft", 0.3048),
];

/// What a check did.
#[derive(Clone, Debug, PartialEq)]
pub enum UnitAction {
    /// Values multiplied by `factor`: they are in `actual_unit`, not in the unit read.
    Rescaled {
        factor: f64,
        actual_unit: &'static str,
    },
    /// No consistent reading: the channel is removed from the run.
    Withheld,
    /// Outside its physical range; values kept.
    OutOfRange,
}

/// One finding of the cross-check.
#[derive(Clone, Debug, PartialEq)]
pub struct UnitNote {
    pub channel: TtcChannel,
    pub action: UnitAction,
    /// What was measured (one line).
    pub evidence: String,
}

impl fmt::Display for UnitNote {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = self.channel.name();
        match &self.action {
            UnitAction::Rescaled {
                factor,
                actual_unit,
            } => write!(
                f,
                "{name}: rescaled x{} (the values are in {actual_unit}): {}",
                // Six significant digits: 2.54, 0.393701 (1 / 2.54), 100.
                format!("{factor:.5e}").parse::<f64>().unwrap_or(*factor),
                self.evidence
            ),
            UnitAction::Withheld => write!(
                f,
                "{name}: no consistent reading, withheld: {}",
                self.evidence
            ),
            UnitAction::OutOfRange => {
                write!(f, "{name}: outside its physical range: {}", self.evidence)
            }
        }
    }
}

/// The metres per unit of the unit a channel was read in (cm when unknown).
fn read_unit(t: &RunTable, channel: TtcChannel) -> (String, f64) {
    let info = t.meta.columns.iter().find(|c| c.channel == Some(channel));
    let raw = info.map_or("cm".to_string(), |c| c.unit_raw.clone());
    let per = info
        .and_then(|c| c.unit)
        .map_or(0.01, |u| u.to_canonical(1.0));
    (raw, per)
}

/// Run every check; returns the findings (the table's warnings get one line each).
pub(crate) fn cross_check(t: &mut RunTable) -> Vec<UnitNote> {
    let n = t.len();
    let rolling: Vec<bool> = (0..n)
        .map(|i| t.speed_kph[i] > ROLLING_MIN_KPH && t.tire.fz_n[i] > LOADED_MIN_N)
        .collect();
    let mut notes = Vec::new();
    let rate_hz = t.meta.sample_rate_hz.unwrap_or(100.0);
    let evidence = rolling.iter().filter(|r| **r).count() as f64 / rate_hz;
    if evidence >= MIN_EVIDENCE_S {
        let kinematic = check_wheel_speed(t, &rolling, &mut notes);
        for channel in [TtcChannel::Re, TtcChannel::Rl] {
            check_radius(t, channel, &rolling, kinematic, &mut notes);
        }
    } else {
        // A run that hardly rolls (spring-rate holds at standstill): the loaded radius against
        // a tire's radius range on the loaded samples (RE means nothing at standstill).
        let loaded: Vec<bool> = t.tire.fz_n.iter().map(|f| *f > LOADED_MIN_N).collect();
        if loaded.iter().filter(|l| **l).count() as f64 / rate_hz >= MIN_EVIDENCE_S {
            check_radius(t, TtcChannel::Rl, &loaded, None, &mut notes);
        }
    }
    range_checks(t, &mut notes);
    for note in &notes {
        t.meta.warnings.push(note.to_string());
    }
    notes
}

/// N against V; returns the median kinematic radius when N is usable (else withholds N).
fn check_wheel_speed(
    t: &mut RunTable,
    rolling: &[bool],
    notes: &mut Vec<UnitNote>,
) -> Option<(f64, usize)> {
    let n_rpm = t.wheel_speed_rpm.as_ref()?;
    let radius = |i: usize| (t.speed_kph[i] / 3.6) / (n_rpm[i] * std::f64::consts::TAU / 60.0);
    let samples: Vec<usize> = (0..t.len()).filter(|&i| rolling[i]).collect();
    if samples.is_empty() {
        return None;
    }
    let in_range: Vec<f64> = samples
        .iter()
        .map(|&i| radius(i))
        .filter(|r| (KINEMATIC_RANGE_M.0..=KINEMATIC_RANGE_M.1).contains(r))
        .collect();
    let frac = in_range.len() as f64 / samples.len() as f64;
    if frac >= CONSISTENT_FRAC {
        return finite_median_high(in_range).map(|r| (r, samples.len()));
    }
    let rpm = finite_median_high(samples.iter().map(|&i| n_rpm[i])).unwrap_or(f64::NAN);
    let v = finite_median_high(samples.iter().map(|&i| t.speed_kph[i])).unwrap_or(f64::NAN);
    notes.push(UnitNote {
        channel: TtcChannel::N,
        action: UnitAction::Withheld,
        evidence: format!(
            "V / (2 pi N / 60) within {}..{} m on {:.0} % of {} rolling samples (median N {rpm:.2} rpm at V {v:.1} km/h)",
            KINEMATIC_RANGE_M.0,
            KINEMATIC_RANGE_M.1,
            100.0 * frac,
            samples.len()
        ),
    });
    t.wheel_speed_rpm = None;
    None
}

/// A radius channel against the kinematic radius (or, without one, a tire's radius range).
fn check_radius(
    t: &mut RunTable,
    channel: TtcChannel,
    rolling: &[bool],
    kinematic: Option<(f64, usize)>,
    notes: &mut Vec<UnitNote>,
) {
    let values = match channel {
        TtcChannel::Re => t.effective_radius_m.as_ref(),
        _ => t.loaded_radius_m.as_ref(),
    };
    let Some(values) = values else {
        return;
    };
    let samples: Vec<f64> = (0..t.len())
        .filter(|&i| rolling[i])
        .map(|i| values[i])
        .collect();
    let Some(mid) = finite_median_high(samples.iter().copied()) else {
        return;
    };
    let consistent = samples
        .iter()
        .filter(|v| (*v - mid).abs() <= SPREAD_FRAC * mid.abs())
        .count() as f64
        >= CONSISTENT_FRAC * samples.len() as f64;
    let (unit_raw, per_unit) = read_unit(t, channel);
    let band = if channel == TtcChannel::Re {
        RE_BAND
    } else {
        RL_BAND
    };
    let inside = |x: f64, (lo, hi): (f64, f64)| (lo..=hi).contains(&x);
    let decision = match kinematic {
        Some((r_kin, count)) => {
            let ratio = mid / r_kin;
            let evidence = format!(
                "V / (2 pi N / 60) = {r_kin:.4} m (median of {count} rolling samples), median {} as read {mid:.4} m (ratio {ratio:.4}, unit read {unit_raw})",
                channel.name()
            );
            if !consistent {
                Some((UnitAction::Withheld, evidence))
            } else if inside(ratio, band) {
                None
            } else {
                let fix = LENGTH_UNITS
                    .iter()
                    .filter(|(_, m)| (m - per_unit).abs() > 1e-12)
                    .find(|(_, m)| inside(ratio * m / per_unit, band));
                Some(match fix {
                    Some((unit, m)) => (
                        UnitAction::Rescaled {
                            factor: m / per_unit,
                            actual_unit: unit,
                        },
                        evidence,
                    ),
                    None => (UnitAction::Withheld, evidence),
                })
            }
        }
        None => {
            let evidence = format!(
                "no usable wheel speed to compare with, median {} as read {mid:.4} m (unit read {unit_raw}), {} of a tire's radius range {}..{} m",
                channel.name(),
                if inside(mid, TIRE_RADIUS_M) {
                    "inside"
                } else {
                    "outside"
                },
                TIRE_RADIUS_M.0,
                TIRE_RADIUS_M.1
            );
            (!(consistent && inside(mid, TIRE_RADIUS_M)))
                .then_some((UnitAction::Withheld, evidence))
        }
    };
    let Some((action, evidence)) = decision else {
        return;
    };
    let slot = match channel {
        TtcChannel::Re => &mut t.effective_radius_m,
        _ => &mut t.loaded_radius_m,
    };
    match &action {
        UnitAction::Rescaled { factor, .. } => {
            if let Some(v) = slot.as_mut() {
                v.iter_mut().for_each(|x| *x *= factor);
            }
        }
        _ => *slot = None,
    }
    notes.push(UnitNote {
        channel,
        action,
        evidence,
    });
}

/// Range checks that keep the values: pressure, load, speed, temperatures.
fn range_checks(t: &RunTable, notes: &mut Vec<UnitNote>) {
    let mut check =
        |channel: TtcChannel, values: Option<&Vec<f64>>, lo: f64, hi: f64, unit: &str| {
            let Some(values) = values else {
                return;
            };
            let Some(mid) = finite_median_high(values.iter().copied().filter(|v| v.abs() > 1.0))
            else {
                return;
            };
            if !(lo..=hi).contains(&mid) {
                notes.push(UnitNote {
                    channel,
                    action: UnitAction::OutOfRange,
                    evidence: format!("median {mid:.4} {unit}, expected {lo}..{hi} {unit}"),
                });
            }
        };
    let (p_lo, p_hi) = crate::physical::PRESSURE_KPA;
    check(TtcChannel::P, Some(&t.pressure_kpa), p_lo, p_hi, "kPa");
    check(TtcChannel::Fz, Some(&t.tire.fz_n), -15_000.0, 15_000.0, "N");
    check(TtcChannel::V, Some(&t.speed_kph), 0.0, 300.0, "km/h");
    for (channel, values) in [
        (TtcChannel::Rst, t.road_temp_c.as_ref()),
        (TtcChannel::Tsti, t.tread_inner_temp_c.as_ref()),
        (TtcChannel::Tstc, t.tread_centre_temp_c.as_ref()),
        (TtcChannel::Tsto, t.tread_outer_temp_c.as_ref()),
        (TtcChannel::Ambtmp, t.ambient_temp_c.as_ref()),
    ] {
        check(channel, values, -40.0, 200.0, "degC");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ttc::example::example_mat;
    use crate::ttc::mat::Compression;
    use crate::ttc::read_mat;

    /// A consistent 20 s example run (RE 0.21 m, RL 0.20 m, N from V and RE), checks not yet run.
    fn example() -> RunTable {
        let mut t = read_mat(&example_mat(2000, Compression::None), "B1320run15.mat").unwrap();
        assert!(t.meta.unit_notes.is_empty(), "{:?}", t.meta.unit_notes);
        t.meta.warnings.clear();
        t
    }

    #[test]
    fn a_radius_in_inches_read_as_cm_is_rescaled_with_its_evidence() {
        let mut t = example();
        let truth = t.effective_radius_m.clone().unwrap();
        for v in t.effective_radius_m.as_mut().unwrap() {
            *v *= 0.01 / 0.0254;
        }
        let notes = cross_check(&mut t);
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert_eq!(notes[0].channel, TtcChannel::Re);
        let UnitAction::Rescaled {
            factor,
            actual_unit,
        } = notes[0].action
        else {
            panic!("{:?}", notes[0]);
        };
        assert!((factor - 2.54).abs() < 1e-12 && actual_unit == "in");
        assert!(notes[0].evidence.contains("V / (2 pi N / 60) = 0.21"));
        for (a, b) in t.effective_radius_m.unwrap().iter().zip(&truth) {
            assert!((a - b).abs() < 1e-12);
        }
        assert_eq!(t.meta.warnings.len(), 1);
        assert!(
            t.meta.warnings[0].starts_with("RE: rescaled x2.54 (the values are in in): "),
            "{}",
            t.meta.warnings[0]
        );
        let inverse = UnitNote {
            action: UnitAction::Rescaled {
                factor: 1.0 / 2.54,
                actual_unit: "cm",
            },
            ..notes[0].clone()
        };
        assert!(inverse.to_string().starts_with("RE: rescaled x0.393701 "));
    }

    #[test]
    fn a_loaded_radius_in_metres_read_as_cm_is_rescaled_x100() {
        let mut t = example();
        for v in t.loaded_radius_m.as_mut().unwrap() {
            *v *= 0.01;
        }
        let notes = cross_check(&mut t);
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(
            matches!(notes[0].action, UnitAction::Rescaled { factor, actual_unit: "m" } if (factor - 100.0).abs() < 1e-9)
        );
    }

    #[test]
    fn garbage_is_withheld_and_a_dead_wheel_speed_leaves_the_range_check() {
        let mut t = example();
        for (i, v) in t
            .effective_radius_m
            .as_mut()
            .unwrap()
            .iter_mut()
            .enumerate()
        {
            *v = 3000.0 * ((i * 7919) % 200) as f64 - 2.7e5;
        }
        for (i, v) in t.wheel_speed_rpm.as_mut().unwrap().iter_mut().enumerate() {
            *v = 0.3 * ((i % 7) as f64 - 3.0);
        }
        let notes = cross_check(&mut t);
        let actions: Vec<(TtcChannel, &UnitAction)> =
            notes.iter().map(|n| (n.channel, &n.action)).collect();
        assert_eq!(
            actions,
            [
                (TtcChannel::N, &UnitAction::Withheld),
                (TtcChannel::Re, &UnitAction::Withheld)
            ]
        );
        assert!(t.effective_radius_m.is_none() && t.wheel_speed_rpm.is_none());
        assert!(t.loaded_radius_m.is_some(), "RL 0.20 m is a tire radius");
        assert_eq!(t.meta.warnings.len(), 2, "one line per channel");
        // Stored warnings are joined with "; " and split on it again for stderr: a note must
        // not contain the separator, or it prints as two lines.
        assert!(
            t.meta.warnings.iter().all(|w| !w.contains("; ")),
            "{:?}",
            t.meta.warnings
        );
    }

    /// Spring-rate holds at standstill give no kinematic radius: RL in inches read as cm is
    /// still caught (outside a tire's radius range) and withheld; a right one is kept.
    #[test]
    fn a_standstill_run_has_its_loaded_radius_checked_on_loaded_samples() {
        let mut t = example();
        t.speed_kph.iter_mut().for_each(|v| *v = 0.0);
        let mut good = t.clone();
        assert!(cross_check(&mut good).is_empty());
        assert!(good.loaded_radius_m.is_some());
        for v in t.loaded_radius_m.as_mut().unwrap() {
            *v *= 0.01 / 0.0254;
        }
        let notes = cross_check(&mut t);
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert_eq!(
            (notes[0].channel, &notes[0].action),
            (TtcChannel::Rl, &UnitAction::Withheld)
        );
        assert!(notes[0].evidence.contains("no usable wheel speed"));
        assert!(t.loaded_radius_m.is_none());
    }

    #[test]
    fn a_pressure_in_psi_read_as_kpa_is_noted_and_kept() {
        let mut t = example();
        for v in &mut t.pressure_kpa {
            *v /= 6.894_757;
        }
        let notes = cross_check(&mut t);
        assert_eq!(notes.len(), 1);
        assert_eq!(
            (notes[0].channel, &notes[0].action),
            (TtcChannel::P, &UnitAction::OutOfRange)
        );
        assert!((t.pressure_kpa[0] - 12.0).abs() < 0.5);
    }
}
