//! Pass 5, binning: a sample range -> measured means/spreads of the set-point channels, and the
//! nominal (commanded) level each mean is nearest to, within a tolerance.
//!
//! In: the raw [`RunSignals`], the dropout stretches found by preparation, [`LevelConfig`].
//! Out: [`MeasuredLevels`] (dropout samples excluded) and [`NominalLevels`]; which levels a
//! segment keeps depends on its kind ([`nominal_for`]): a swept level is `None`. Classification
//! (pass 4) uses the bins as set-point keys, so binning is computed for candidates first.
//! Deliberately not here: choosing tolerances per round (they come from the config).

use std::ops::Range;

use super::config::{LevelConfig, Tolerance};
use super::output::{
    ChannelStats, Level, MeasuredLevels, NominalLevels, SegmentKind, SweepVariable,
};
use super::prepare::Dropouts;
use super::signals::RunSignals;

/// Raw set-point channels in segment units, with dropout samples masked out.
pub(crate) struct StatsSource {
    pressure_kpa: Vec<f64>,
    ia_deg: Vec<f64>,
    fz_n: Vec<f64>,
    speed_kph: Vec<f64>,
    alpha_deg: Vec<f64>,
    /// Per channel (same order), true where the sample is a dropout.
    masked: [Vec<bool>; 5],
}

fn mask(n: usize, runs: &[Range<usize>]) -> Vec<bool> {
    let mut m = vec![false; n];
    for r in runs {
        m[r.clone()].iter_mut().for_each(|v| *v = true);
    }
    m
}

impl StatsSource {
    pub fn new(signals: &RunSignals, dropouts: &Dropouts) -> Self {
        let n = signals.len();
        StatsSource {
            pressure_kpa: signals.pressure_kpa.to_vec(),
            ia_deg: signals.gamma_rad.iter().map(|r| r.to_degrees()).collect(),
            fz_n: signals.fz_n.to_vec(),
            speed_kph: signals.speed_kph.to_vec(),
            alpha_deg: signals.alpha_rad.iter().map(|r| r.to_degrees()).collect(),
            masked: [
                mask(n, &dropouts.p),
                mask(n, &dropouts.ia),
                mask(n, &dropouts.fz),
                mask(n, &dropouts.v),
                mask(n, &dropouts.sa),
            ],
        }
    }

    /// Measured levels over `range`.
    pub fn measure(&self, range: Range<usize>) -> MeasuredLevels {
        let stats = |x: &[f64], m: &[bool]| channel_stats(&x[range.clone()], &m[range.clone()]);
        MeasuredLevels {
            pressure_kpa: stats(&self.pressure_kpa, &self.masked[0]),
            ia_deg: stats(&self.ia_deg, &self.masked[1]),
            fz_n: stats(&self.fz_n, &self.masked[2]),
            speed_kph: stats(&self.speed_kph, &self.masked[3]),
            alpha_deg: stats(&self.alpha_deg, &self.masked[4]),
        }
    }
}

/// Mean and population std of the unmasked samples (zeros when every sample is masked).
fn channel_stats(x: &[f64], masked: &[bool]) -> ChannelStats {
    let (mut n, mut sum) = (0usize, 0.0);
    for (v, m) in x.iter().zip(masked) {
        if !m {
            n += 1;
            sum += v;
        }
    }
    if n == 0 {
        return ChannelStats::default();
    }
    let mean = sum / n as f64;
    let var = x
        .iter()
        .zip(masked)
        .filter(|(_, m)| !**m)
        .map(|(v, _)| (v - mean).powi(2))
        .sum::<f64>()
        / n as f64;
    ChannelStats {
        mean,
        std: var.sqrt(),
    }
}

/// The nominal level nearest to `value`, if within `tol` of it (ties go to the first listed).
pub(crate) fn nearest(value: f64, levels: &[f64], tol: Tolerance) -> Option<i32> {
    let best = levels
        .iter()
        .copied()
        .min_by(|a, b| (a - value).abs().total_cmp(&(b - value).abs()))?;
    ((best - value).abs() <= tol.at(best)).then(|| best.round() as i32)
}

/// Every level binned, whether or not the kind will keep it.
pub(crate) fn bin_all(m: &MeasuredLevels, cfg: &LevelConfig) -> NominalLevels {
    NominalLevels {
        pressure_kpa: nearest(m.pressure_kpa.mean, &cfg.pressure_kpa, cfg.pressure_tol),
        ia_deg: nearest(m.ia_deg.mean, &cfg.ia_deg, cfg.ia_tol),
        fz_n: nearest(m.fz_n.mean, &cfg.fz_n, cfg.fz_tol),
        alpha_deg: nearest(m.alpha_deg.mean, &cfg.alpha_deg, cfg.alpha_tol),
        speed_kph: nearest(m.speed_kph.mean, &cfg.speed_kph, cfg.speed_tol),
    }
}

/// Which levels apply to a kind: (pressure, ia, fz, alpha, speed).
fn applicable(kind: SegmentKind, sweep: Option<SweepVariable>) -> [bool; 5] {
    let sl = sweep == Some(SweepVariable::LongitudinalSlip);
    match kind {
        SegmentKind::Other => [true, false, false, false, false],
        SegmentKind::SpringRateStatic | SegmentKind::SpringRateDynamic => {
            [true, true, false, true, true]
        }
        SegmentKind::IaSweep => [true, false, true, true, true],
        SegmentKind::DriveBrake | SegmentKind::Combined | SegmentKind::StepSteer => {
            [true, true, true, true, true]
        }
        SegmentKind::ColdToWarm
        | SegmentKind::Conditioning
        | SegmentKind::Cornering
        | SegmentKind::SpeedSweep => [true, true, true, sl, true],
    }
}

/// The nominal levels a segment of `kind` keeps, and the applicable ones that binned to `None`.
/// `held_alpha` (a step steer's held slip angle, deg) replaces the segment mean for alpha.
pub(crate) fn nominal_for(
    kind: SegmentKind,
    sweep: Option<SweepVariable>,
    bins: &NominalLevels,
    held_alpha: Option<Option<i32>>,
) -> (NominalLevels, Vec<Level>) {
    let [p, ia, fz, alpha, v] = applicable(kind, sweep);
    let alpha_bin = held_alpha.unwrap_or(bins.alpha_deg);
    let keep = |on: bool, value: Option<i32>| if on { value } else { None };
    let nominal = NominalLevels {
        pressure_kpa: keep(p, bins.pressure_kpa),
        ia_deg: keep(ia, bins.ia_deg),
        fz_n: keep(fz, bins.fz_n),
        alpha_deg: keep(alpha, alpha_bin),
        speed_kph: keep(v, bins.speed_kph),
    };
    let off = [
        (p, nominal.pressure_kpa, Level::Pressure),
        (ia, nominal.ia_deg, Level::Inclination),
        (fz, nominal.fz_n, Level::Load),
        (alpha, nominal.alpha_deg, Level::SlipAngle),
        (v, nominal.speed_kph, Level::Speed),
    ]
    .into_iter()
    .filter(|(on, value, _)| *on && value.is_none())
    .map(|(_, _, level)| level)
    .collect();
    (nominal, off)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_level_within_tolerance_or_none() {
        let cfg = LevelConfig::default();
        assert_eq!(nearest(1101.0, &cfg.fz_n, cfg.fz_tol), Some(1112));
        assert_eq!(
            nearest(1334.0, &cfg.fz_n, cfg.fz_tol),
            None,
            "300 lb is no nominal"
        );
        assert_eq!(nearest(85.9, &cfg.pressure_kpa, cfg.pressure_tol), Some(83));
        assert_eq!(nearest(-2.96, &cfg.alpha_deg, cfg.alpha_tol), Some(-3));
        assert_eq!(nearest(40.2, &cfg.speed_kph, cfg.speed_tol), Some(40));
    }

    #[test]
    fn stats_skip_dropouts() {
        let s = channel_stats(&[10.0, 0.0, 0.0, 12.0], &[false, true, true, false]);
        assert!((s.mean - 11.0).abs() < 1e-12 && (s.std - 1.0).abs() < 1e-12);
        assert_eq!(channel_stats(&[0.0], &[true]), ChannelStats::default());
    }

    #[test]
    fn swept_levels_are_dropped_and_missing_ones_reported() {
        let bins = NominalLevels {
            pressure_kpa: Some(83),
            ia_deg: Some(2),
            fz_n: None,
            alpha_deg: Some(0),
            speed_kph: Some(40),
        };
        let (n, off) = nominal_for(
            SegmentKind::Cornering,
            Some(SweepVariable::SlipAngle),
            &bins,
            None,
        );
        assert_eq!(n.alpha_deg, None);
        assert_eq!(off, vec![Level::Load]);
        let (n, off) = nominal_for(
            SegmentKind::SpringRateStatic,
            Some(SweepVariable::Load),
            &bins,
            None,
        );
        assert_eq!((n.fz_n, n.ia_deg), (None, Some(2)));
        assert!(off.is_empty());
    }
}
