//! Test-only builders of [`MeasuredSegment`]s from generated signals (exact known physics), used
//! by the stage tests. Not compiled outside `cfg(test)`.

use super::segment_data::{Channels, MeasuredSegment, NominalLevels, SegmentKind, TireKey};
use crate::numerics::random::SplitMix64;

/// A tire key for tests.
pub fn key(tire: &str, pressure_kpa: i64) -> TireKey {
    TireKey {
        tire: tire.to_string(),
        rim_in: 7,
        pressure_kpa_nom: pressure_kpa,
    }
}

/// A segment with every required channel zero-filled at `rate_hz` for `n` samples, starting at
/// `t0_s`, at `speed_kph`; the caller fills what it needs.
pub fn blank(
    id: &str,
    kind: SegmentKind,
    key: &TireKey,
    source: &str,
    t0_s: f64,
    n: usize,
    rate_hz: f64,
    speed_kph: f64,
) -> MeasuredSegment {
    let z = vec![0.0; n];
    MeasuredSegment {
        segment_id: id.to_string(),
        kind,
        source_file: source.to_string(),
        segment_index: 0,
        key: key.clone(),
        nominal: NominalLevels::default(),
        channels: Channels {
            et_s: (0..n).map(|i| t0_s + i as f64 / rate_hz).collect(),
            speed_kph: vec![speed_kph; n],
            fz_n: z.clone(),
            fx_n: z.clone(),
            fy_n: z.clone(),
            mz_nm: z.clone(),
            alpha_rad: z.clone(),
            gamma_rad: z.clone(),
            kappa: z.clone(),
            pressure_kpa: vec![key.pressure_kpa_nom as f64; n],
            ..Channels::default()
        },
    }
}

/// A load staircase: hold each load `hold_s`, ramp `ramp_s` between them; returns `Fz(t)` samples.
pub fn staircase(loads_n: &[f64], hold_s: f64, ramp_s: f64, rate_hz: f64) -> Vec<f64> {
    let mut out = Vec::new();
    let per = |s: f64| (s * rate_hz).round() as usize;
    for (i, &l) in loads_n.iter().enumerate() {
        if i > 0 {
            let from = loads_n[i - 1];
            let m = per(ramp_s);
            for k in 0..m {
                out.push(from + (l - from) * (k as f64 + 0.5) / m as f64);
            }
        }
        out.extend(std::iter::repeat_n(l, per(hold_s)));
    }
    out
}

/// A triangle wave through the given turning points at `rate` units per second.
pub fn triangle(points: &[f64], rate: f64, rate_hz: f64) -> Vec<f64> {
    let mut out = vec![points[0]];
    for w in points.windows(2) {
        let m = (((w[1] - w[0]).abs() / rate) * rate_hz).round() as usize;
        for k in 1..=m {
            out.push(w[0] + (w[1] - w[0]) * k as f64 / m as f64);
        }
    }
    out
}

/// Add Gaussian noise of standard deviation `sd` (no-op for `sd = 0`).
pub fn add_noise(x: &mut [f64], sd: f64, rng: &mut SplitMix64) {
    if sd > 0.0 {
        for v in x {
            *v += rng.normal(sd);
        }
    }
}
