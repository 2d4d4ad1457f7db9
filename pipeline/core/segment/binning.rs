//! Pass 5b, binning: a sample range -> measured means/spreads of the set-point channels, and
//! which of the run's learned levels ([`super::levels`]) a segment of a kind keeps.
//!
//! In: the raw [`RunSignals`], the dropout stretches found by preparation; the levels of every
//! channel binned by [`super::levels::RunLevels::bin_all`]. Out: [`MeasuredLevels`] (dropout
//! samples excluded) and [`NominalLevels`]; which levels a segment keeps depends on its kind
//! ([`nominal_for`]): a swept level is `None`. Classification (pass 4) uses the bins as
//! set-point keys, so binning is computed for candidates first. Deliberately not here: learning
//! the levels (`levels.rs`).

use std::ops::Range;

use super::output::{
    ChannelStats, Level, MeasuredLevels, NominalLevels, SegmentKind, SweepVariable,
};
use super::prepare::Dropouts;
use super::signals::RunSignals;

/// Raw set-point channels with their dropout stretches (borrowed, nothing copied).
pub(crate) struct StatsSource<'a> {
    signals: &'a RunSignals<'a>,
    dropouts: &'a Dropouts,
}

impl<'a> StatsSource<'a> {
    pub fn new(signals: &'a RunSignals<'a>, dropouts: &'a Dropouts) -> Self {
        StatsSource { signals, dropouts }
    }

    /// Measured levels over `range` (angles converted to degrees).
    pub fn measure(&self, range: Range<usize>) -> MeasuredLevels {
        let (s, d) = (self.signals, self.dropouts);
        let stats = |x: &[f64], skip: &[Range<usize>], scale: f64| {
            let st = channel_stats(x, range.clone(), skip);
            ChannelStats {
                mean: st.mean * scale,
                std: st.std * scale,
            }
        };
        let deg = 1f64.to_degrees();
        MeasuredLevels {
            pressure_kpa: stats(s.pressure_kpa, &d.p, 1.0),
            ia_deg: stats(s.gamma_rad, &d.ia, deg),
            fz_n: stats(s.fz_n, &d.fz, 1.0),
            speed_kph: stats(s.speed_kph, &d.v, 1.0),
            alpha_deg: stats(s.alpha_rad, &d.sa, deg),
        }
    }
}

/// The parts of `range` outside the sorted, disjoint `skip` ranges.
fn kept_parts(range: Range<usize>, skip: &[Range<usize>]) -> Vec<Range<usize>> {
    let first = skip.partition_point(|r| r.end <= range.start);
    let mut out = Vec::new();
    let mut cursor = range.start;
    for r in skip[first..].iter().take_while(|r| r.start < range.end) {
        if r.start > cursor {
            out.push(cursor..r.start);
        }
        cursor = cursor.max(r.end);
    }
    if cursor < range.end {
        out.push(cursor..range.end);
    }
    out
}

/// Mean and population std of `x[range]` outside `skip` (zeros when nothing is left).
fn channel_stats(x: &[f64], range: Range<usize>, skip: &[Range<usize>]) -> ChannelStats {
    let parts = kept_parts(range, skip);
    let n: usize = parts.iter().map(|r| r.len()).sum();
    if n == 0 {
        return ChannelStats::default();
    }
    let values = || parts.iter().flat_map(|r| x[r.clone()].iter());
    let mean = values().sum::<f64>() / n as f64;
    let var = values().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64;
    ChannelStats {
        mean,
        std: var.sqrt(),
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
    held_alpha: Option<Option<i64>>,
) -> (NominalLevels, Vec<Level>) {
    let [p, ia, fz, alpha, v] = applicable(kind, sweep);
    let alpha_bin = held_alpha.unwrap_or(bins.alpha_deg);
    let keep = |on: bool, value: Option<i64>| if on { value } else { None };
    let nominal = NominalLevels {
        pressure_kpa: keep(p, bins.pressure_kpa),
        ia_cdeg: keep(ia, bins.ia_cdeg),
        fz_n: keep(fz, bins.fz_n),
        alpha_deg: keep(alpha, alpha_bin),
        speed_kph: keep(v, bins.speed_kph),
    };
    let off = [
        (p, nominal.pressure_kpa, Level::Pressure),
        (ia, nominal.ia_cdeg, Level::Inclination),
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
    fn stats_skip_dropouts() {
        let skip: Vec<Range<usize>> = std::iter::once(1..3).collect();
        let s = channel_stats(&[10.0, 0.0, 0.0, 12.0], 0..4, &skip);
        assert!((s.mean - 11.0).abs() < 1e-12 && (s.std - 1.0).abs() < 1e-12);
        let all: Vec<Range<usize>> = std::iter::once(0..1).collect();
        assert_eq!(channel_stats(&[0.0], 0..1, &all), ChannelStats::default());
        assert_eq!(
            kept_parts(5..20, &[0..2, 4..7, 10..12, 19..30]),
            vec![7..10, 12..19]
        );
    }

    #[test]
    fn swept_levels_are_dropped_and_missing_ones_reported() {
        let bins = NominalLevels {
            pressure_kpa: Some(83),
            ia_cdeg: Some(200),
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
        assert_eq!((n.fz_n, n.ia_cdeg), (None, Some(200)));
        assert!(off.is_empty());
    }
}
