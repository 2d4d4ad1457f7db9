//! Pass 2, set-point plateaus: a smoothed channel -> stretches where it holds a level.
//!
//! In: smoothed channel slices and half-band [`Tolerance`]s. Out: [`LevelRun`]s (greedy: a run
//! grows while its spread stays within `2 * tol(mean)`), held runs (long runs, with short
//! excursions between two runs at the same level absorbed) and held pieces (where every one of
//! several channels holds). A ramp becomes a chain of short runs, hence "not held"; a slow drift
//! within the band is one run. Deliberately not here: what the levels mean (binning does that).

use std::ops::Range;

use super::config::Tolerance;

/// A stretch `[start, end)` of a slice and the mean of the channel over it.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct LevelRun {
    pub start: usize,
    pub end: usize,
    pub mean: f64,
}

impl LevelRun {
    pub fn len(&self) -> usize {
        self.end - self.start
    }

    pub fn range(&self) -> Range<usize> {
        self.start..self.end
    }
}

/// Greedy level runs: extend the current run while `max - min <= 2 * tol(mean)`.
pub(crate) fn level_runs(x: &[f64], tol: Tolerance) -> Vec<LevelRun> {
    let mut runs = Vec::new();
    let Some(&first) = x.first() else {
        return runs;
    };
    let (mut start, mut lo, mut hi, mut sum) = (0, first, first, first);
    for (i, &v) in x.iter().enumerate().skip(1) {
        let (nlo, nhi, nsum) = (lo.min(v), hi.max(v), sum + v);
        let mean = nsum / (i - start + 1) as f64;
        if nhi - nlo <= 2.0 * tol.at(mean) {
            (lo, hi, sum) = (nlo, nhi, nsum);
        } else {
            runs.push(LevelRun {
                start,
                end: i,
                mean: sum / (i - start) as f64,
            });
            (start, lo, hi, sum) = (i, v, v, v);
        }
    }
    runs.push(LevelRun {
        start,
        end: x.len(),
        mean: sum / (x.len() - start) as f64,
    });
    runs
}

/// Runs of at least `min_len` samples; two of them at the same level (within `tol`) separated
/// by at most `blip_max` samples of shorter runs are merged, the excursion included.
pub(crate) fn held_runs(
    x: &[f64],
    tol: Tolerance,
    min_len: usize,
    blip_max: usize,
) -> Vec<LevelRun> {
    let mut held: Vec<LevelRun> = Vec::new();
    for run in level_runs(x, tol)
        .into_iter()
        .filter(|r| r.len() >= min_len)
    {
        if let Some(last) = held.last_mut() {
            let gap = run.start - last.end;
            if gap <= blip_max && (run.mean - last.mean).abs() <= tol.at(last.mean) {
                let (a, b) = (last.len() as f64, run.len() as f64);
                last.mean = (last.mean * a + run.mean * b) / (a + b);
                last.end = run.end;
                continue;
            }
        }
        held.push(run);
    }
    held
}

/// Least-squares change across `x` (fitted slope times the span), 0 for fewer than 2 samples.
pub(crate) fn linear_change(x: &[f64]) -> f64 {
    let n = x.len();
    if n < 2 {
        return 0.0;
    }
    let mt = (n - 1) as f64 / 2.0;
    let mx = x.iter().sum::<f64>() / n as f64;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (i, v) in x.iter().enumerate() {
        let dt = i as f64 - mt;
        sxy += dt * (v - mx);
        sxx += dt * dt;
    }
    sxy / sxx * (n - 1) as f64
}

/// Stretches where every channel is inside one of its held runs, cut at every run boundary
/// of any channel, at least `min_len` long.
pub(crate) fn held_pieces(
    len: usize,
    channels: &[Vec<LevelRun>],
    min_len: usize,
) -> Vec<Range<usize>> {
    let mut cuts: Vec<usize> = vec![0, len];
    for runs in channels {
        for r in runs {
            cuts.push(r.start);
            cuts.push(r.end);
        }
    }
    cuts.sort_unstable();
    cuts.dedup();
    let mut cursor = vec![0usize; channels.len()];
    let mut pieces = Vec::new();
    for w in cuts.windows(2) {
        let (a, b) = (w[0], w[1]);
        let all_held = channels.iter().zip(cursor.iter_mut()).all(|(runs, k)| {
            while *k < runs.len() && runs[*k].end <= a {
                *k += 1;
            }
            *k < runs.len() && runs[*k].start <= a && b <= runs[*k].end
        });
        if all_held && b - a >= min_len {
            pieces.push(a..b);
        }
    }
    pieces
}

#[cfg(test)]
mod tests {
    use super::*;

    fn steps(levels: &[(f64, usize)]) -> Vec<f64> {
        levels
            .iter()
            .flat_map(|&(v, n)| std::iter::repeat_n(v, n))
            .collect()
    }

    #[test]
    fn steps_become_runs_and_a_ramp_is_not_held() {
        let mut x = steps(&[(100.0, 50), (400.0, 50)]);
        x.extend((0..50).map(|i| 400.0 + 20.0 * i as f64));
        let held = held_runs(&x, Tolerance::fixed(30.0), 20, 10);
        assert_eq!(held.len(), 2);
        assert_eq!((held[0].start, held[0].end), (0, 50));
        assert_eq!(
            (held[1].start, held[1].end),
            (50, 104),
            "the ramp's first 60 N join the level"
        );
        assert!((held[0].mean - 100.0).abs() < 1e-9);
    }

    #[test]
    fn a_short_spike_between_equal_levels_is_absorbed() {
        let x = steps(&[(100.0, 50), (300.0, 3), (102.0, 50)]);
        let held = held_runs(&x, Tolerance::fixed(30.0), 20, 10);
        assert_eq!(held.len(), 1);
        assert_eq!((held[0].start, held[0].end), (0, 103));
        let no_absorb = held_runs(&x, Tolerance::fixed(30.0), 20, 2);
        assert_eq!(no_absorb.len(), 2);
    }

    #[test]
    fn relative_tolerance_scales_with_level() {
        let tol = Tolerance {
            abs: 10.0,
            frac: 0.1,
        };
        let x = steps(&[(1500.0, 30), (1600.0, 30)]);
        assert_eq!(
            level_runs(&x, tol).len(),
            1,
            "100 N apart at 1550 N is within +-155 N"
        );
        let y = steps(&[(150.0, 30), (250.0, 30)]);
        assert_eq!(level_runs(&y, tol).len(), 2);
    }

    #[test]
    fn linear_change_of_a_ramp_is_its_rise() {
        let x: Vec<f64> = (0..11).map(|i| 5.0 + 2.0 * i as f64).collect();
        assert!((linear_change(&x) - 20.0).abs() < 1e-9);
        assert!(linear_change(&[3.0; 8]).abs() < 1e-12);
    }

    #[test]
    fn pieces_are_cut_where_any_channel_changes() {
        let a = vec![LevelRun {
            start: 0,
            end: 100,
            mean: 1.0,
        }];
        let b = vec![
            LevelRun {
                start: 0,
                end: 40,
                mean: 1.0,
            },
            LevelRun {
                start: 45,
                end: 100,
                mean: 2.0,
            },
        ];
        assert_eq!(held_pieces(100, &[a, b], 10), vec![0..40, 45..100]);
    }
}
