//! The load cell's measurement lag from the spring-rate load steps: where every sweep of a tire
//! ran at one road speed, the sweeps cannot tell a lag in time from a relaxation length (both
//! shift a ramp by `rate x (lag + sigma/V)`), but the spring-rate holds can. Their load steps
//! move the loaded radius `RL`, a position channel outside the load cell's chain, together with
//! the load `FZ`, which passes through it; the chain's lag is the time shift between the two.
//!
//! Model, per hold segment: `FZ_measured(t) = chain[a + b RL(t) (+ c dRL/dt)](t)` with `chain`
//! the configured [`LagForm`](super::LagForm) (delay or first-order filter) at the trial lag. `a` and `b` (the
//! segment's spring line; static and rolling holds and each inclination have their own) and,
//! when asked for, a damping coefficient `c` are linear given the lag and solved in closed form
//! (variable projection); the lag minimises the summed residual sum of squares by grid + Brent
//! over `measurement_lag_range_s`.
//!
//! `FZ` and `RL` are both smoothed by the same centred moving average before the fit (a linear,
//! time-invariant smoothing commutes with the chain, so the model holds for the smoothed pair):
//! interpolating a fractional delay averages neighbouring samples of the raw `RL` noise, which
//! would lower the cost at every half-sample lag whatever the true lag.
//!
//! Damping: a tire's vertical damping makes the force lead the deflection, `c dRL/dt` against
//! `b RL(t - lag) ~ b RL - b lag dRL/dt`: to first order only `b lag - c` is seen, and the two
//! separate only through the curvature of the step corners (`b lag^2/2 d2RL/dt2`), so the term
//! is off by default ([`super::RelaxationConfig::load_step_damping`]).
//!
//! The lag is kept only when the data support it over none: the drop of the summed cost from
//! lag 0 to the minimum, in residual variances per effective sample (counted samples over the
//! residuals' autocorrelation time, as in the speed-based identification), must exceed
//! the stage's `LAG_LR_THRESHOLD`.
//!
//! Deliberately not here: deciding which lag the relaxation rows use (the stage's
//! `identify_measurement_lag`), the vertical stiffness the spring-rate stage reports.

use nalgebra::{DMatrix, DVector};

use super::{LAG_LR_THRESHOLD, LAG_SEARCH, LagTest, MeasurementLag, RelaxationConfig};
use crate::fit::scalar;
use crate::fit::segment_data::{MeasuredSegment, SegmentKind, moving_average};

/// The lag identified from the load steps of one tire/rim/pressure.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadStepLag {
    /// The lag at the minimum of the summed cost (form as configured).
    pub lag: MeasurementLag,
    /// The data support the lag over none (the statistic is above the threshold).
    pub supported: bool,
    /// Drop of the summed cost from lag 0 to the minimum, in effective noise variances.
    pub statistic: f64,
    /// Hold segments used.
    pub segments: usize,
    /// Counted samples.
    pub samples: usize,
    /// Effective samples (counted over the residual autocorrelation time).
    pub effective_samples: f64,
    /// Median over the segments of the fitted spring `b`, N/m (negative: `RL` falls as the load
    /// rises).
    pub spring_n_per_m: f64,
    /// The damping term's coefficient (median over segments), N s/m, when fitted.
    pub damping_n_s_per_m: Option<f64>,
    /// The minimum is on a bound of the search interval.
    pub at_bound: bool,
}

impl LoadStepLag {
    /// One line for the relaxation rows' `lag_note`.
    pub fn summary(&self) -> String {
        let damping = self
            .damping_n_s_per_m
            .map_or(String::new(), |c| format!(", damping {c:.0} N s/m"));
        format!(
            "{:.2} ms from the spring-rate load steps lowers their cost below no lag by {:.1} \
             effective noise variances ({} holds, {} samples, {:.0} effective; spring {:.0} \
             N/mm{damping}; threshold {LAG_LR_THRESHOLD})",
            1e3 * self.lag.lag_s,
            self.statistic,
            self.segments,
            self.samples,
            self.effective_samples,
            -1e-3 * self.spring_n_per_m,
        )
    }
}

/// One hold segment ready to fit: smoothed load and radius (and its rate) on the segment's
/// times, and which samples count.
struct Hold {
    t_s: Vec<f64>,
    fz: Vec<f64>,
    rl: Vec<f64>,
    drl: Vec<f64>,
    counted: Vec<bool>,
}

/// Whether the stage reads `kind` for the load-step lag.
pub fn is_hold(kind: SegmentKind) -> bool {
    matches!(
        kind,
        SegmentKind::SpringRateStatic | SegmentKind::SpringRateDynamic
    )
}

/// The lag from the hold segments among `segments` (other kinds are ignored); `None` when no
/// hold has a loaded radius, enough samples and a load step.
pub fn identify(segments: &[MeasuredSegment], cfg: &RelaxationConfig) -> Option<LoadStepLag> {
    let holds: Vec<Hold> = segments
        .iter()
        .filter(|s| is_hold(s.kind))
        .filter_map(|s| hold(s, cfg))
        .collect();
    if holds.is_empty() {
        return None;
    }
    let lag_of = |lag_s: f64| MeasurementLag {
        form: cfg.measurement_lag_form,
        lag_s,
    };
    let profile = |lag_s: f64| -> f64 {
        let lag = lag_of(lag_s);
        holds
            .iter()
            .map(|h| fit_hold(h, &lag, cfg.load_step_damping).map_or(f64::INFINITY, |f| f.cost))
            .sum()
    };
    let (lo, hi) = cfg.measurement_lag_range_s;
    let best = scalar::minimize(&profile, lo, hi, &LAG_SEARCH).ok()?;
    let best_lag = lag_of(best.x);
    let fits: Vec<HoldFit> = holds
        .iter()
        .filter_map(|h| fit_hold(h, &best_lag, cfg.load_step_damping))
        .collect();
    let residuals: Vec<Vec<Option<f64>>> = fits.iter().map(|f| f.residuals.clone()).collect();
    let LagTest {
        n,
        n_eff,
        statistic,
        ..
    } = LagTest::new(&residuals, profile(0.0_f64.max(lo)), best.cost);
    let median = |mut v: Vec<f64>| -> f64 {
        v.sort_by(f64::total_cmp);
        if v.is_empty() {
            f64::NAN
        } else {
            v[v.len() / 2]
        }
    };
    Some(LoadStepLag {
        lag: best_lag,
        supported: statistic > LAG_LR_THRESHOLD,
        statistic,
        segments: holds.len(),
        samples: n,
        effective_samples: n_eff,
        spring_n_per_m: median(fits.iter().map(|f| f.spring).collect()),
        damping_n_s_per_m: cfg
            .load_step_damping
            .then(|| median(fits.iter().filter_map(|f| f.damping).collect())),
        at_bound: best.at_bound,
    })
}

/// A hold segment's smoothed channels, or `None` when it cannot carry the lag.
fn hold(s: &MeasuredSegment, cfg: &RelaxationConfig) -> Option<Hold> {
    let c = &s.channels;
    let rl = c.loaded_radius_m.as_ref()?;
    let n = c.et_s.len();
    if n < 3 || rl.len() != n || c.fz_n.len() != n {
        return None;
    }
    let dt = (c.et_s[n - 1] - c.et_s[0]) / (n - 1) as f64;
    if dt.is_nan() || dt <= 0.0 {
        return None;
    }
    let half = (cfg.load_step_smoothing_half_s / dt).round() as usize;
    let fz = moving_average(&c.fz_n, half);
    let rl_s = moving_average(rl, half);
    let drl: Vec<f64> = (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            (rl_s[b] - rl_s[a]) / (c.et_s[b] - c.et_s[a])
        })
        .collect();
    // The chain starts settled at the first sample: the first `half + longest lag` samples and
    // the last `half` (where the shrinking average is not the same filter) do not count.
    let t_first = c.et_s[0] + (half as f64 + 1.0) * dt + cfg.measurement_lag_range_s.1;
    let t_last = c.et_s[n - 1] - (half as f64 + 1.0) * dt;
    let counted: Vec<bool> = (0..n)
        .map(|i| {
            c.et_s[i] >= t_first
                && c.et_s[i] <= t_last
                && fz[i].is_finite()
                && rl_s[i].is_finite()
                && drl[i].is_finite()
        })
        .collect();
    let mut loads: Vec<f64> = (0..n).filter(|&i| counted[i]).map(|i| fz[i]).collect();
    if loads.len() < cfg.min_samples {
        return None;
    }
    loads.sort_by(f64::total_cmp);
    let pct = |p: f64| loads[((loads.len() - 1) as f64 * p).round() as usize];
    if pct(0.95) - pct(0.05) < cfg.load_step_min_span_n {
        return None;
    }
    // The chain needs finite inputs everywhere: a missing radius holds its neighbour's value.
    let fill = |v: &[f64]| -> Vec<f64> {
        let mut last = v.iter().copied().find(|x| x.is_finite()).unwrap_or(0.0);
        v.iter()
            .map(|&x| {
                if x.is_finite() {
                    last = x;
                }
                last
            })
            .collect()
    };
    Some(Hold {
        t_s: c.et_s.clone(),
        fz,
        rl: fill(&rl_s),
        drl: fill(&drl),
        counted,
    })
}

/// One hold's linear fit at a trial lag.
struct HoldFit {
    cost: f64,
    spring: f64,
    damping: Option<f64>,
    residuals: Vec<Option<f64>>,
}

/// `FZ ~ chain[a + b RL (+ c dRL/dt)]` by least squares on the counted samples.
fn fit_hold(h: &Hold, lag: &MeasurementLag, damping: bool) -> Option<HoldFit> {
    let mut columns = vec![lag.apply(&h.t_s, h.rl.clone())];
    if damping {
        columns.push(lag.apply(&h.t_s, h.drl.clone()));
    }
    let rows: Vec<usize> = (0..h.t_s.len()).filter(|&i| h.counted[i]).collect();
    let p = columns.len() + 1;
    // Centre the columns: the offset `a` then drops out and the normal equations stay well
    // conditioned (`RL` is ~0.2 m with a span of millimetres).
    let mean = |v: &[f64]| rows.iter().map(|&i| v[i]).sum::<f64>() / rows.len() as f64;
    let y_mean = mean(&h.fz);
    let x_means: Vec<f64> = columns.iter().map(|c| mean(c.as_slice())).collect();
    let x = DMatrix::from_fn(rows.len(), p - 1, |r, j| columns[j][rows[r]] - x_means[j]);
    let y = DVector::from_iterator(rows.len(), rows.iter().map(|&i| h.fz[i] - y_mean));
    let xtx = x.transpose() * &x;
    let xty = x.transpose() * &y;
    let beta = xtx.lu().solve(&xty)?;
    let fitted = &x * &beta;
    let mut residuals = vec![None; h.t_s.len()];
    let mut cost = 0.0;
    for (r, &i) in rows.iter().enumerate() {
        let e = y[r] - fitted[r];
        cost += e * e;
        residuals[i] = Some(e);
    }
    cost.is_finite().then_some(HoldFit {
        cost,
        spring: beta[0],
        damping: damping.then(|| beta[1]),
        residuals,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::relaxation::LagForm;
    use crate::fit::testkit::{add_noise, blank, key, staircase};
    use crate::numerics::random::SplitMix64;
    use crate::synth::physics::MeasurementChain;

    const RATE_HZ: f64 = 50.0;
    const CZ_N_PER_M: f64 = 130e3;
    const R0_M: f64 = 0.26;

    /// Spring-rate staircases as the virtual machine runs them (50..350 lb, 1 s holds, 0.3 s
    /// ramps), the load through a chain of `delay_s` and `filter_s`, the radius from the true
    /// load; the machine's noise (4 N on the load, 40 um on the radius) and a slow load wander.
    fn holds(delay_s: f64, filter_s: f64, seed: u64) -> Vec<MeasuredSegment> {
        let k = key("T", 83);
        let mut rng = SplitMix64::new(seed);
        let loads: Vec<f64> = [50.0, 100.0, 150.0, 250.0, 350.0]
            .iter()
            .map(|lb| lb * 4.448)
            .collect();
        (0..7)
            .map(|j| {
                let mut fz = staircase(&loads, 1.0, 0.3, RATE_HZ);
                // A slow wander of the true load (both channels see it).
                let phase = rng.normal(1.0);
                for (i, f) in fz.iter_mut().enumerate() {
                    *f += 8.0 * (0.7 * i as f64 / RATE_HZ + phase).sin();
                }
                let n = fz.len();
                let kind = if j < 3 {
                    SegmentKind::SpringRateStatic
                } else {
                    SegmentKind::SpringRateDynamic
                };
                let mut s = blank("h", kind, &k, "run", 100.0 * j as f64, n, RATE_HZ, 0.0);
                let mut chain = MeasurementChain::new(delay_s, filter_s, 1.0 / RATE_HZ);
                let mut measured: Vec<f64> = fz.iter().map(|&f| chain.step(f)).collect();
                add_noise(&mut measured, 4.0, &mut rng);
                let mut rl: Vec<f64> = fz.iter().map(|&f| R0_M - f / CZ_N_PER_M).collect();
                add_noise(&mut rl, 4e-5, &mut rng);
                s.channels.fz_n = measured;
                s.channels.loaded_radius_m = Some(rl);
                s
            })
            .collect()
    }

    fn cfg(form: LagForm) -> RelaxationConfig {
        RelaxationConfig {
            measurement_lag_form: form,
            ..RelaxationConfig::default()
        }
    }

    #[test]
    fn load_steps_recover_a_planted_delay() {
        for seed in 1..4 {
            let r = identify(&holds(0.02, 0.0, seed), &cfg(LagForm::Delay)).unwrap();
            assert!(r.supported, "{}", r.summary());
            assert!((r.lag.lag_s / 0.02 - 1.0).abs() < 0.05, "{}", r.summary());
            assert!(
                (-r.spring_n_per_m / CZ_N_PER_M - 1.0).abs() < 0.01,
                "{}",
                r.summary()
            );
            assert_eq!(r.segments, 7);
        }
    }

    #[test]
    fn load_steps_recover_a_planted_filter() {
        for seed in 1..4 {
            let r = identify(&holds(0.0, 0.02, seed), &cfg(LagForm::FirstOrder)).unwrap();
            assert!(r.supported, "{}", r.summary());
            assert!((r.lag.lag_s / 0.02 - 1.0).abs() < 0.05, "{}", r.summary());
        }
    }

    #[test]
    fn load_steps_without_a_lag_do_not_support_one() {
        for seed in 1..6 {
            for form in [LagForm::Delay, LagForm::FirstOrder] {
                let r = identify(&holds(0.0, 0.0, seed), &cfg(form)).unwrap();
                assert!(!r.supported, "{form:?}: {}", r.summary());
                assert!(r.lag.lag_s < 0.002, "{form:?}: {}", r.summary());
            }
        }
    }

    #[test]
    fn holds_without_a_radius_or_a_step_give_nothing() {
        let mut segs = holds(0.02, 0.0, 1);
        for s in &mut segs[..3] {
            s.channels.loaded_radius_m = None;
        }
        for s in &mut segs[3..] {
            let n = s.channels.fz_n.len();
            s.channels.fz_n = vec![1000.0; n];
        }
        assert!(identify(&segs, &cfg(LagForm::Delay)).is_none());
    }

    #[test]
    fn holds_spanning_less_load_than_the_configured_minimum_give_nothing_issue_18() {
        // The staircases span 222..1557 N.
        let segs = holds(0.02, 0.0, 1);
        let with_min = |span_n: f64| RelaxationConfig {
            load_step_min_span_n: span_n,
            ..cfg(LagForm::Delay)
        };
        assert_eq!(
            identify(&segs, &with_min(1000.0)).map(|r| r.segments),
            Some(7)
        );
        assert!(identify(&segs, &with_min(2000.0)).is_none());
    }
}
