//! The samples of a slip sweep that belong to a reversal's transient rather than to the steady
//! state, shared by the PAC2002 and MF 6.1 collapses.
//!
//! In: the samples' times and the local rate of the swept slip. Out: a mask, `true` for a
//! transient sample (to leave out of the collapse).
//!
//! A real rig does not reverse a sweep at once: the steer decelerates into the reversal, may
//! creep short of the extreme, jumps or turns and accelerates out of it, and the load cell rings
//! as the steer slows and for a while after (the consortium's cornering data: a ~9 Hz ringing of
//! `Mz` through each reversal and ~0.3 s after it). A collapsed cell that holds the turnaround
//! averages that ringing over a fraction of its period, and the cells the return pass crosses
//! while it decays carry it too; the approach pass, at cruise rate before the steer slows, does
//! not.
//!
//! The rule, from the sweep's own rates: the cruise rate is the median `|rate|`; the speed of a
//! sample is the running median of `|rate|` over the local-slope window (so a jump of a sample
//! or two does not look like cruising). The sweep's passes are the runs of samples at no less
//! than 0.9 of the cruise rate, each with its direction. Between two passes of opposite
//! direction lies a turnaround, from the last sample of the one to the first of the other; the
//! transient is the turnaround and as long again after it (a ringing excited while the steer
//! slows is taken to decay over about the time the turnaround took). Slow stretches between
//! passes of one direction (a sweep crossing zero slowly) and before the first or after the
//! last pass (a sweep's start and end) stay.
//!
//! Deliberately not here: which cells or points result (each collapse bins what is left).

use crate::numerics::stats::finite_median;

/// Fraction of the cruise rate at or above which the steer counts as passing.
const CRUISE_FRAC: f64 = 0.9;

/// `true` for each sample in a reversal's transient. `t`: time of each sample (any unit,
/// increasing); `rate`: the local `d slip / d t` at each sample in the same time unit; `half`:
/// the half-width of the window `rate` was estimated over (in the unit of `t`).
pub(crate) fn transients(t: &[f64], rate: &[f64], half: f64) -> Vec<bool> {
    let n = t.len().min(rate.len());
    let mut out = vec![false; n];
    let Some(cruise) = finite_median(rate[..n].iter().map(|r| r.abs())) else {
        return out;
    };
    if cruise <= 0.0 {
        return out;
    }
    // Running median of |rate| over +-half (two-pointer window on increasing t).
    let mut speed = vec![0.0; n];
    let (mut lo, mut hi) = (0, 0);
    for (i, sp) in speed.iter_mut().enumerate() {
        while t[i] - t[lo] > half {
            lo += 1;
        }
        while hi + 1 < n && t[hi + 1] - t[i] <= half {
            hi += 1;
        }
        *sp = finite_median(rate[lo..=hi].iter().map(|r| r.abs())).unwrap_or(0.0);
    }
    // Passes: (first, last, direction).
    let mut passes: Vec<(usize, usize, f64)> = Vec::new();
    let mut k = 0;
    while k < n {
        if speed[k] < CRUISE_FRAC * cruise {
            k += 1;
            continue;
        }
        let first = k;
        while k + 1 < n && speed[k + 1] >= CRUISE_FRAC * cruise {
            k += 1;
        }
        let sum: f64 = rate[first..=k].iter().filter(|r| r.is_finite()).sum();
        passes.push((first, k, sum.signum()));
        k += 1;
    }
    for w in passes.windows(2) {
        let ((_, last, d0), (first, _, d1)) = (w[0], w[1]);
        if d0 * d1 >= 0.0 {
            continue;
        }
        let end = t[first] + (t[first] - t[last]);
        for (ti, m) in t[last + 1..n].iter().zip(&mut out[last + 1..]) {
            if *ti > end {
                break;
            }
            *m = true;
        }
    }
    out
}

/// A test sweep as a real rig runs it: 0 -> +0.2 -> -0.2 -> 0 rad at 0.055 rad/s, sampled at
/// 100 Hz, decelerating over 0.1 s into each reversal to a creep of 0.005 rad/s, creeping for
/// 0.2 s up to 0.003 rad short of the extreme, jumping there in one sample and reversing; a
/// damped 9 Hz ringing (unit amplitude, 0.1 s decay) excited as the steer slows and again at the
/// jump, signed by the approach direction. Returns `(t, alpha, ring)` per sample.
#[cfg(test)]
pub(crate) fn rig_sweep() -> Vec<(f64, f64, f64)> {
    let (dt, rate, decel, creep, dwell, short) = (0.01, 0.055, 0.1, 0.005, 0.2, 0.003);
    let mut path: Vec<(f64, f64)> = vec![(0.0, 0.0)];
    let mut rings: Vec<(f64, f64)> = Vec::new();
    let step = |path: &mut Vec<(f64, f64)>, r: f64, dur: f64| {
        let steps = (dur / dt).round() as usize;
        for _ in 0..steps {
            let &(t, a) = path.last().unwrap();
            path.push((t + dt, a + r * dt));
        }
    };
    for (from, to) in [(0.0, 0.2), (0.2, -0.2), (-0.2, 0.0)] {
        let d: f64 = f64::signum(to - from);
        if to == 0.0 {
            step(&mut path, d * rate, f64::abs(to - from) / rate);
            continue;
        }
        let slow = (rate + creep) / 2.0 * decel + creep * dwell + short;
        let cruise = (f64::abs(to - from) - slow) / rate;
        step(&mut path, d * rate, cruise);
        rings.push((path.last().unwrap().0, d));
        step(&mut path, d * (rate + creep) / 2.0, decel);
        step(&mut path, d * creep, dwell);
        rings.push((path.last().unwrap().0, d));
        let &(t, _) = path.last().unwrap();
        path.push((t + dt, to));
    }
    path.iter()
        .map(|&(t, a)| {
            let ring = rings
                .iter()
                .filter(|(t0, _)| t >= *t0)
                .map(|(t0, sign)| {
                    let u = t - t0;
                    sign * (-u / 0.1).exp() * (std::f64::consts::TAU * 9.0 * u).sin()
                })
                .sum();
            (t, a, ring)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A triangle sweep at 0.05 /s reversing at t = 1 s with a 0.2 s stop at the extreme: the
    /// samples from the approach's last cruise sample to the return's first, and as long again,
    /// are transients; the rest (both ends, slow or not) are not.
    #[test]
    fn marks_the_turnaround_and_as_long_again() {
        let dt = 0.01;
        let t: Vec<f64> = (0..300).map(|k| k as f64 * dt).collect();
        let rate: Vec<f64> = t
            .iter()
            .map(|&t| {
                if t < 0.05 {
                    0.0 // a slow start: kept
                } else if t < 1.0 {
                    0.05
                } else if t < 1.2 {
                    0.0
                } else {
                    -0.05
                }
            })
            .collect();
        let m = transients(&t, &rate, 0.0);
        let marked: Vec<f64> = t
            .iter()
            .zip(&m)
            .filter(|(_, m)| **m)
            .map(|(t, _)| *t)
            .collect();
        let (first, last) = (marked[0], *marked.last().unwrap());
        assert!((first - 1.0).abs() < 1e-9, "{first}");
        // Turnaround 0.99 .. 1.2 s, as long again: up to 1.41 s.
        assert!((last - 1.41).abs() < 1e-9, "{last}");
        assert_eq!(marked.len(), 42);
        assert!(!m[0] && !m[299]);
    }

    /// No reversal, no transient; a sweep that does not move has none either.
    #[test]
    fn a_one_way_sweep_has_none() {
        let t: Vec<f64> = (0..100).map(|k| k as f64).collect();
        let mut rate = vec![1.0; 100];
        rate[50] = 0.0;
        assert!(transients(&t, &rate, 2.0).iter().all(|m| !m));
        assert!(transients(&t, &[0.0; 100], 2.0).iter().all(|m| !m));
    }
}
