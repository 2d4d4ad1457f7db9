//! Yaw-table encoder: raw photo-interrupter voltage -> rising-edge times -> band indices.
//!
//! In: a sampled voltage `(t_s, signal_v)` or already-extracted event times. Out: event times
//! with integer band indices (angle = index * event spacing), after removing contact bounce and
//! re-indexing across missed edges, plus counts of what was repaired. Edge detection uses a
//! hysteresis pair of thresholds set from the signal's own 5th/95th percentiles (tolerates slow
//! baseline drift) and interpolates the crossing of the mid level between samples. Deliberately
//! no band-geometry calibration and no use of falling edges (the thesis found their transients
//! differ; methods section 2.2).

use super::MethodError;
use crate::numerics::least_squares::polyfit_centered;
use crate::numerics::stats::median_high;

/// Event times with their band indices.
#[derive(Debug, Clone, PartialEq)]
pub struct IndexedEvents {
    /// Event times (s), ascending.
    pub times_s: Vec<f64>,
    /// Band index of each event, starting at 0, strictly increasing.
    pub index: Vec<i64>,
    /// Events dropped as contact bounce.
    pub bounces_removed: usize,
    /// Edges missing between detected events (re-indexed across).
    pub missed_edges: usize,
}

/// Rising-edge times of a photo-interrupter voltage. Thresholds: `low = p5 + 0.35 (p95 - p5)`,
/// `high = p5 + 0.65 (p95 - p5)`; an edge fires when the signal rises above `high` after having
/// been below `low`, and is timed where it crosses the mid level.
pub fn rising_edges(t_s: &[f64], signal_v: &[f64]) -> Result<Vec<f64>, MethodError> {
    if t_s.len() < 3 {
        return Err(MethodError::TooFewEdges {
            found: 0,
            needed: 3,
        });
    }
    let mut sorted = signal_v.to_vec();
    sorted.sort_by(f64::total_cmp);
    let q = |p: f64| sorted[((sorted.len() - 1) as f64 * p).round() as usize];
    let (p5, p95) = (q(0.05), q(0.95));
    let swing = p95 - p5;
    if swing.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return Err(MethodError::TooFewEdges {
            found: 0,
            needed: 3,
        });
    }
    let (low, mid, high) = (p5 + 0.35 * swing, p5 + 0.5 * swing, p5 + 0.65 * swing);
    let mut armed = false;
    let mut last_low = 0usize;
    let mut edges = Vec::new();
    for i in 0..signal_v.len() {
        let v = signal_v[i];
        if v < low {
            armed = true;
            last_low = i;
        } else if v > high && armed {
            armed = false;
            // the mid-level crossing lies between the last low sample and i
            let mut k = last_low;
            while k + 1 < i && signal_v[k + 1] < mid {
                k += 1;
            }
            let (a, b) = (signal_v[k], signal_v[k + 1]);
            let frac = if b > a {
                ((mid - a) / (b - a)).clamp(0.0, 1.0)
            } else {
                0.5
            };
            edges.push(t_s[k] + frac * (t_s[k + 1] - t_s[k]));
        }
    }
    Ok(edges)
}

/// Assigns band indices to event times: drops events closer than 0.3 x the median interval to
/// the previous kept event (bounce), counts intervals that span several bands (missed edges),
/// then re-indexes every event from a quadratic fit of angle against time until stable.
/// Errors with fewer than `min_events` events or when the indexing does not settle.
pub fn index_events(times_s: &[f64], min_events: usize) -> Result<IndexedEvents, MethodError> {
    let mut times: Vec<f64> = times_s.to_vec();
    times.sort_by(f64::total_cmp);
    if times.len() < min_events {
        return Err(MethodError::TooFewEdges {
            found: times.len(),
            needed: min_events,
        });
    }
    let mut gaps: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
    let median_gap = median_high(&mut gaps).unwrap_or(0.0);
    let mut kept = vec![times[0]];
    for &t in &times[1..] {
        if t - kept[kept.len() - 1] >= 0.3 * median_gap {
            kept.push(t);
        }
    }
    let bounces_removed = times.len() - kept.len();
    if kept.len() < min_events {
        return Err(MethodError::TooFewEdges {
            found: kept.len(),
            needed: min_events,
        });
    }
    // First pass: step counts from the extrapolated single-band interval.
    let mut index = vec![0i64];
    let mut step_prev = kept[1] - kept[0];
    let mut step_prev2 = step_prev;
    for k in 1..kept.len() {
        let gap = kept[k] - kept[k - 1];
        let ratio = if k >= 2 {
            (step_prev / step_prev2).clamp(0.5, 1.5)
        } else {
            1.0
        };
        let predicted = step_prev * ratio;
        let n = if k == 1 {
            1
        } else {
            (gap / predicted).round().max(1.0) as i64
        };
        index.push(index[k - 1] + n);
        step_prev2 = step_prev;
        step_prev = gap / n as f64;
    }
    // Refinement: re-index from a quadratic of index against time.
    for _ in 0..10 {
        let idx_f: Vec<f64> = index.iter().map(|&i| i as f64).collect();
        let fit = polyfit_centered(&kept, &idx_f, 2)?;
        let base = fit.eval(kept[0]);
        let new: Vec<i64> = kept
            .iter()
            .map(|&t| (fit.eval(t) - base).round() as i64)
            .collect();
        let worst = kept
            .iter()
            .zip(&index)
            .map(|(&t, &i)| (fit.eval(t) - base - i as f64).abs())
            .fold(0.0, f64::max);
        if new == index {
            if worst > 0.25 {
                return Err(MethodError::InconsistentEvents {
                    reason: format!(
                        "worst event is {worst:.2} bands off a constant-acceleration fit"
                    ),
                });
            }
            break;
        }
        if new.windows(2).any(|w| w[1] <= w[0]) {
            return Err(MethodError::InconsistentEvents {
                reason: "two events fall in the same band after re-indexing".into(),
            });
        }
        index = new;
    }
    let missed_edges = (index[index.len() - 1] - index[0]) as usize + 1 - index.len();
    Ok(IndexedEvents {
        times_s: kept,
        index,
        bounces_removed,
        missed_edges,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn event_times(n: usize) -> Vec<f64> {
        let alpha = 0.0744;
        let delta = 4f64.to_radians();
        (0..n)
            .map(|k| 0.35 + (2.0 * (0.013 + k as f64 * delta) / alpha).sqrt())
            .collect()
    }

    #[test]
    fn missed_edges_and_bounces_are_repaired() {
        let mut t = event_times(144);
        let truth: Vec<i64> = (0..144).collect();
        // drop events 20, 21 and 90; add bounces 1 ms after events 5 and 100
        let mut idx = truth.clone();
        for k in [90usize, 21, 20] {
            t.remove(k);
            idx.remove(k);
        }
        let mut with_bounce = t.clone();
        with_bounce.push(t[5] + 0.001);
        with_bounce.push(t[97] + 0.001);
        let out = index_events(&with_bounce, 10).unwrap();
        assert_eq!(out.bounces_removed, 2);
        assert_eq!(out.missed_edges, 3);
        assert_eq!(out.index, idx);
    }

    #[test]
    fn too_few_edges_is_an_error() {
        assert!(matches!(
            index_events(&event_times(5), 10),
            Err(MethodError::TooFewEdges {
                found: 5,
                needed: 10
            })
        ));
    }

    #[test]
    fn square_wave_edges_are_found_between_samples() {
        let dt = 1e-3;
        let t: Vec<f64> = (0..10_000).map(|i| i as f64 * dt).collect();
        // rising edges at 0.1234 + 0.5 k with a 0.2 ms first-order rise, plus slow drift
        let v: Vec<f64> = t
            .iter()
            .map(|&ti| {
                let phase = (ti - 0.1234).rem_euclid(0.5);
                let level = if ti < 0.1234 {
                    0.0
                } else if phase < 0.25 {
                    1.0 - (-phase / 2e-4).exp()
                } else {
                    (-(phase - 0.25) / 2e-4).exp()
                };
                0.2 + 2.5 * level + 0.01 * ti
            })
            .collect();
        let edges = rising_edges(&t, &v).unwrap();
        assert_eq!(edges.len(), 20);
        for (k, e) in edges.iter().enumerate() {
            let expected = 0.1234 + 0.5 * k as f64 + 2e-4 * 2f64.ln();
            assert!((e - expected).abs() < 1e-4, "edge {k}: {e} vs {expected}");
        }
    }
}
