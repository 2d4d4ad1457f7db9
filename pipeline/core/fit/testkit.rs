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
#[allow(clippy::too_many_arguments)]
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
        nominal: NominalLevels {
            pressure_kpa: Some(key.pressure_kpa_nom),
            ..NominalLevels::default()
        },
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

/// An FSAE-size PAC2002 tire (the lateral and longitudinal force coefficients of the virtual
/// machine's base file, `FNOMIN` 1100 N, `R0` 0.2612 m) with the given relaxation coefficients
/// `[PTY1, PTY2, PTX1, PTX2, PTX3]`.
pub fn fsae_model(pt: [f64; 5]) -> crate::tire_model::Pac2002 {
    use crate::tire_model::{Coef::*, Coefs, Pac2002};
    let mut c = Coefs::defaults();
    let values = [
        (FNOMIN, 1100.0),
        (UNLOADED_RADIUS, 0.2612),
        (LONGVL, 11.176),
        (VERTICAL_STIFFNESS, 137_800.0),
        (VXLOW, 1.0),
        (KPUMIN, -0.25),
        (KPUMAX, 0.25),
        (ALPMIN, -0.261799),
        (ALPMAX, 0.261799),
        (CAMMIN, -0.087266),
        (CAMMAX, 0.087266),
        (FZMIN, 100.0),
        (FZMAX, 2500.0),
        (PCX1, 1.55),
        (PDX1, 2.55),
        (PDX2, -0.18),
        (PDX3, 8.0),
        (PEX1, -0.25),
        (PEX2, 0.3),
        (PEX3, 0.05),
        (PEX4, 0.15),
        (PKX1, 52.0),
        (PKX2, -2.0),
        (PKX3, -0.25),
        (PHX1, 0.0006),
        (PHX2, -0.0004),
        (PVX1, -0.01),
        (PVX2, 0.005),
        (RBX1, 11.0),
        (RBX2, 9.0),
        (RCX1, 1.05),
        (REX1, -0.4),
        (REX2, -0.3),
        (RHX1, 0.002),
        (PCY1, 1.45),
        (PDY1, -2.5),
        (PDY2, 0.15),
        (PDY3, 4.0),
        (PEY1, -0.3),
        (PEY2, 0.25),
        (PEY3, 0.05),
        (PEY4, 2.0),
        (PKY1, -56.7),
        (PKY2, 1.75),
        (PKY3, 1.2),
        (PHY1, 0.0015),
        (PHY2, 0.0008),
        (PHY3, 0.06),
        (PVY1, -0.006),
        (PVY2, 0.01),
        (PVY3, -1.5),
        (PVY4, 0.3),
        (RBY1, 14.0),
        (RBY2, 10.0),
        (RBY3, 0.002),
        (RCY1, 1.05),
        (REY1, -0.25),
        (REY2, 0.1),
        (RHY1, 0.003),
        (RHY2, 0.002),
        (RVY1, 0.02),
        (RVY2, -0.015),
        (RVY3, 0.4),
        (RVY4, 15.0),
        (RVY5, 1.9),
        (RVY6, -12.0),
        (PTY1, pt[0]),
        (PTY2, pt[1]),
        (PTX1, pt[2]),
        (PTX2, pt[3]),
        (PTX3, pt[4]),
    ];
    for (k, v) in values {
        c[k] = v;
    }
    Pac2002::new(c)
}
