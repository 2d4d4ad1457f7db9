//! Grip-temperature correction of the steady-state fit: the measured sweeps brought to one
//! reference tread temperature with the thermal stage's `mu(T)` law before PAC2002 is fitted.
//!
//! In: a [`FitInput`] whose samples carry the centre tread temperature as the IR sensor reads it
//! ([`Sample::tread_c`]) and a [`GripLaw`] (the thermal stage's fitted `mu(T)`, from the
//! cold-to-warm runs of the same tire, rim and pressure). Out: the corrected [`FitInput`] and a
//! [`GripReference`] (the reference temperatures the model then describes).
//!
//! Why: a tire's grip follows its tread temperature, which drifts from sweep to sweep (a hot
//! high-load sweep, a cooler one after a dwell). PAC2002 has no temperature term, so in sample
//! the load and camber terms absorb each sweep's thermal deviation, and cannot predict a
//! held-out sweep's. The temperature is a measured input: correcting every sample with the law
//! and its own temperature is an honest prediction of a held-out sweep as well.
//!
//! Method:
//! 1. Contact temperature: the IR spot sees the tread `ir_phase_revolutions` (3/4) of a
//!    revolution after it left the road, so the contact's temperature at `t` is the reading at
//!    `t + 0.75 * 2 pi R/V` (R the loaded radius when recorded, else the context's unloaded
//!    radius), as the thermal stage reads it.
//! 2. Grip factor: with `mu(T)` the law relative to its peak, `s = mu(T)/mu_ref`, where `mu_ref`
//!    is the mean of `mu(T)` over the direction's samples weighted by `|F|/Fz` (near-peak samples
//!    count most). So the mean grip of the fitted data is unchanged; the model describes the
//!    tire at `T_ref`, the temperature on the cold side of the peak with `mu(T_ref) = mu_ref`
//!    (lateral: over the cornering sweeps; longitudinal: over the drive/brake and combined
//!    sweeps). One law serves both directions: the cold-to-warm tests that give it are
//!    cornering sweeps, and no test gives a longitudinal law.
//! 3. Similarity: a friction scaling `s` of a Magic Formula curve (PAC2002's `LMUY`/`LMUX`)
//!    multiplies the peak `D` and divides the shape factor `B` (the slip stiffness does not
//!    change), and scales the vertical shift `SV`; for the aligning moment it divides the trail's
//!    `Bt` and the residual torque's `Br` and multiplies `Dr`. So to first order in the small
//!    horizontal shifts `F(slip; s) = s F_ref(slip/s)` for `Fy`, `Mz` and `Fx` alike. Every
//!    sample becomes `(alpha/s_y, Fy/s_y, Mz/s_y)` with the lateral factor `s_y`, and on
//!    drive/brake and combined sweeps also `(kappa/s_x, Fx/s_x)` with the longitudinal one (the
//!    combined-slip weights `Gxa`, `Gyk` depend on the other slip only weakly). The overturning
//!    moment is mostly `a + b Fy` (`QSX3`): it becomes `Mx - b (1 - 1/s_y) Fy` with `b` the
//!    slope of `Mx` on `Fy` over the sweep. Samples without a finite temperature are unchanged.
//!
//! Deliberately not here: fitting `mu(T)` (the thermal stage), choosing whether to correct (the
//! caller: a law exists and `[fit] grip_correction` is on).

use super::{FitInput, Sample, SweepKind};
use crate::fit::segment_data::interpolate;
use crate::fit::thermal::relative_grip;

/// The thermal stage's `mu(T)` ([`relative_grip`]: `1 - k (T - T_peak)^2`, `k_cold` below the
/// peak, `k_hot` above), floored at [`GripLaw::FLOOR`].
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct GripLaw {
    /// Centre tread temperature of peak grip, degC.
    pub t_peak_c: f64,
    /// Curvature below the peak, 1/degC^2.
    pub k_cold_per_c2: f64,
    /// Curvature above the peak, 1/degC^2.
    pub k_hot_per_c2: f64,
    /// Fraction of a revolution between the road and the IR spot.
    pub ir_phase_revolutions: f64,
}

impl GripLaw {
    /// Lowest relative grip the law gives (far outside any tested temperature).
    pub const FLOOR: f64 = 0.3;

    /// The law of a thermal fit row (`None` when its numbers are not usable).
    pub fn new(
        t_peak_c: f64,
        k_cold_per_c2: f64,
        hot_falloff: f64,
        ir_phase_revolutions: f64,
    ) -> Option<GripLaw> {
        let law = GripLaw {
            t_peak_c,
            k_cold_per_c2,
            k_hot_per_c2: k_cold_per_c2 * hot_falloff,
            ir_phase_revolutions,
        };
        let ok = [t_peak_c, law.k_cold_per_c2, law.k_hot_per_c2]
            .iter()
            .all(|v| v.is_finite())
            && law.k_cold_per_c2 > 0.0
            && law.k_hot_per_c2 >= 0.0
            && ir_phase_revolutions.is_finite();
        ok.then_some(law)
    }

    /// Relative grip `mu(T)/mu(T_peak)`.
    pub fn mu_rel(&self, t_c: f64) -> f64 {
        relative_grip(t_c, self.t_peak_c, self.k_cold_per_c2, self.k_hot_per_c2).max(Self::FLOOR)
    }

    /// The temperature on the cold side of the peak with relative grip `mu_rel`, degC.
    pub fn cold_side_temperature(&self, mu_rel: f64) -> f64 {
        self.t_peak_c - ((1.0 - mu_rel).max(0.0) / self.k_cold_per_c2).sqrt()
    }
}

/// The reference the corrected data describe (per direction; `None` when that direction had no
/// sample with a temperature).
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct GripReference {
    /// Tread temperature every sweep's `Fy`, `Mz` and `Mx` was corrected to, degC.
    pub lateral_t_ref_c: Option<f64>,
    /// Tread temperature the drive/brake and combined sweeps' `Fx` was corrected to, degC.
    pub longitudinal_t_ref_c: Option<f64>,
    /// Samples corrected (a finite temperature and a factor applied).
    pub samples_corrected: usize,
    /// Smallest and largest grip factor applied (`s_y` on cornering sweeps, `s_x` on the
    /// others).
    pub factor_range: (f64, f64),
}

/// Contact-patch tread temperature of every sample of a sweep (NaN where unknown): the IR
/// reading one phase lag later.
fn contact_temperatures(samples: &[Sample], law: &GripLaw, r0_m: f64) -> Vec<f64> {
    let t: Vec<f64> = samples.iter().map(|s| s.et_s).collect();
    let y: Vec<f64> = samples.iter().map(|s| s.tread_c).collect();
    let (last_t, last_y) = (t.last().copied(), y.last().copied());
    samples
        .iter()
        .map(|s| {
            if !s.tread_c.is_finite() {
                return f64::NAN;
            }
            let r = s
                .loaded_radius_m
                .filter(|r| r.is_finite() && *r > 0.0)
                .unwrap_or(r0_m);
            let v = s.vx_mps.abs();
            if !(r > 0.0 && v > 0.5) {
                return s.tread_c;
            }
            let at = s.et_s + law.ir_phase_revolutions * std::f64::consts::TAU * r / v;
            match (interpolate(&t, &y, at), last_t, last_y) {
                (Some(v), ..) if v.is_finite() => v,
                (_, Some(tl), Some(yl)) if at > tl && yl.is_finite() => yl,
                _ => s.tread_c,
            }
        })
        .collect()
}

/// Slope of `mx` on `fy` over the finite pairs (`None` with fewer than 10 or no spread).
fn mx_on_fy_slope(samples: &[Sample]) -> Option<f64> {
    let pairs: Vec<(f64, f64)> = samples
        .iter()
        .filter(|s| s.fy_n.is_finite() && s.mx_nm.is_finite())
        .map(|s| (s.fy_n, s.mx_nm))
        .collect();
    if pairs.len() < 10 {
        return None;
    }
    let n = pairs.len() as f64;
    let (mx, my) = pairs
        .iter()
        .fold((0.0, 0.0), |a, p| (a.0 + p.0 / n, a.1 + p.1 / n));
    let (sxx, sxy) = pairs.iter().fold((0.0, 0.0), |a, p| {
        (a.0 + (p.0 - mx).powi(2), a.1 + (p.0 - mx) * (p.1 - my))
    });
    (sxx > 0.0).then(|| sxy / sxx)
}

/// Whether a sweep kind's grip is lateral (cornering) or longitudinal.
fn lateral(kind: SweepKind) -> bool {
    kind == SweepKind::Cornering
}

/// The input with every sample that has a temperature brought to the reference temperatures
/// (module doc). `r0_m`: the
/// unloaded radius for the IR phase lag when a sample has no loaded radius.
pub fn correct(input: &FitInput, law: &GripLaw, r0_m: f64) -> (FitInput, GripReference) {
    let temps: Vec<Vec<f64>> = input
        .sweeps
        .iter()
        .map(|s| contact_temperatures(&s.samples, law, r0_m))
        .collect();
    // Weighted mean relative grip per direction, over the sweeps the fit reads.
    let mut sums = [(0.0_f64, 0.0_f64); 2];
    for (sweep, temps) in input.sweeps.iter().zip(&temps) {
        if !sweep.qc_ok {
            continue;
        }
        let d = usize::from(!lateral(sweep.kind));
        for (s, &t) in sweep.samples.iter().zip(temps) {
            let f = [s.fx_n, s.fy_n]
                .iter()
                .filter(|v| v.is_finite())
                .map(|v| v * v)
                .sum::<f64>()
                .sqrt();
            let w = f / s.fz_n.max(1.0);
            if t.is_finite() && w.is_finite() && s.fz_n > 0.0 {
                sums[d].0 += w * law.mu_rel(t);
                sums[d].1 += w;
            }
        }
    }
    let mu_ref = sums.map(|(num, den)| (den > 0.0).then(|| num / den));
    let mut out = input.clone();
    let mut reference = GripReference {
        lateral_t_ref_c: mu_ref[0].map(|m| law.cold_side_temperature(m)),
        longitudinal_t_ref_c: mu_ref[1].map(|m| law.cold_side_temperature(m)),
        samples_corrected: 0,
        factor_range: (f64::INFINITY, f64::NEG_INFINITY),
    };
    for (sweep, temps) in out.sweeps.iter_mut().zip(&temps) {
        let b_mx = mx_on_fy_slope(&sweep.samples);
        let cornering = lateral(sweep.kind);
        for (s, &t) in sweep.samples.iter_mut().zip(temps) {
            if !t.is_finite() {
                continue;
            }
            let mu = law.mu_rel(t);
            // Lateral grip factor for Fy, Mz, Mx and alpha; longitudinal for Fx and kappa.
            let ky = mu_ref[0].map_or(1.0, |m| mu / m);
            let kx = mu_ref[1].map_or(1.0, |m| mu / m);
            if cornering && mu_ref[0].is_none() || !cornering && mu_ref[1].is_none() {
                continue;
            }
            reference.samples_corrected += 1;
            let k = if cornering { ky } else { kx };
            reference.factor_range.0 = reference.factor_range.0.min(k);
            reference.factor_range.1 = reference.factor_range.1.max(k);
            s.alpha_rad /= ky;
            if let Some(b) = b_mx
                && s.fy_n.is_finite()
            {
                s.mx_nm -= b * (1.0 - 1.0 / ky) * s.fy_n;
            }
            s.fy_n /= ky;
            s.mz_nm /= ky;
            if !cornering {
                s.kappa /= kx;
                s.fx_n /= kx;
            }
        }
    }
    if reference.samples_corrected == 0 {
        reference.factor_range = (f64::NAN, f64::NAN);
    }
    (out, reference)
}

#[cfg(test)]
mod tests {
    use super::super::synthetic::fsae_demo;
    use super::super::{FitContext, Sweep, SweepNominal};
    use super::*;
    use crate::tire_model::{Coef, Mode, Pac2002, SlipInput};

    fn law() -> GripLaw {
        GripLaw::new(55.0, 0.26 / 900.0, 1.0, 0.75).unwrap()
    }

    #[test]
    fn law_is_one_at_the_peak_and_inverts_on_the_cold_side() {
        let l = GripLaw::new(60.0, 0.3 / 900.0, 1.0, 0.75).unwrap();
        assert_eq!(l.mu_rel(60.0), 1.0);
        assert!((l.mu_rel(30.0) - 0.7).abs() < 1e-12);
        assert!((l.cold_side_temperature(l.mu_rel(45.0)) - 45.0).abs() < 1e-9);
        assert!(GripLaw::new(60.0, 0.0, 1.0, 0.75).is_none());
        assert!(GripLaw::new(f64::NAN, 1e-3, 1.0, 0.75).is_none());
    }

    /// The truth model with its friction scaled by `s` (`LMUX = LMUY = s`).
    fn model(s: f64) -> Pac2002 {
        let mut c = fsae_demo();
        c[Coef::LMUX] = s;
        c[Coef::LMUY] = s;
        Pac2002::new(c)
    }

    /// A sweep of `n` samples along `slip` (alpha for cornering, kappa otherwise) whose tread
    /// temperature ramps over `temps`; forces from the truth at grip `mu(T)/mu0`.
    fn planted_sweep(kind: SweepKind, temps: (f64, f64), mu0: f64) -> Sweep {
        let n = 400;
        let (fz, gamma) = (1100.0, 0.02);
        let samples = (0..n)
            .map(|k| {
                let f = k as f64 / (n - 1) as f64;
                let slip = -1.0 + 2.0 * f;
                let t = temps.0 + (temps.1 - temps.0) * f;
                let input = SlipInput {
                    fz_n: fz,
                    kappa: if kind == SweepKind::Cornering {
                        0.0
                    } else {
                        0.2 * slip
                    },
                    alpha_rad: if kind == SweepKind::Cornering {
                        0.2 * slip
                    } else {
                        0.0
                    },
                    gamma_rad: gamma,
                    vx_mps: 11.0,
                };
                let e = model(law().mu_rel(t) / mu0).eval(&input, Mode::Raw);
                Sample {
                    et_s: 0.01 * k as f64,
                    fz_n: fz,
                    kappa: input.kappa,
                    alpha_rad: input.alpha_rad,
                    gamma_rad: gamma,
                    vx_mps: 11.0,
                    fx_n: e.fx_n,
                    fy_n: e.fy_n,
                    mz_nm: e.mz_nm,
                    mx_nm: e.mx_nm,
                    loaded_radius_m: None,
                    tread_c: t,
                }
            })
            .collect();
        Sweep {
            id: format!("{kind:?}"),
            kind,
            nominal: SweepNominal {
                fz_n: fz,
                gamma_rad: gamma,
                alpha_rad: 0.0,
            },
            qc_ok: true,
            samples,
        }
    }

    /// Largest |measured - reference model| of a channel over a sweep, % of the channel's peak.
    fn worst(sweep: &Sweep, reference: &Pac2002, ch: fn(&Sample) -> f64) -> f64 {
        let (mut err, mut peak) = (0.0_f64, 0.0_f64);
        for s in &sweep.samples {
            let e = reference.eval(&s.slip_input(), Mode::Raw);
            let m = Sample {
                fx_n: e.fx_n,
                fy_n: e.fy_n,
                mz_nm: e.mz_nm,
                ..*s
            };
            err = err.max((ch(s) - ch(&m)).abs());
            peak = peak.max(ch(&m).abs());
        }
        100.0 * err / peak
    }

    /// A planted grip law through the PAC2002 equations: the corrected samples lie on the truth
    /// at the reference temperature (the similarity holds for Fy, Mz and Fx), the measured ones
    /// do not.
    #[test]
    fn correction_recovers_a_planted_grip_law() {
        // Grip factors relative to an arbitrary level: the correction must find its own.
        let mu0 = 0.93;
        let input = FitInput {
            context: FitContext {
                tire: "t".into(),
                rim_in: 7.0,
                pressure_kpa_nom: 83.0,
                test_speed_mps: 11.0,
                vertical_stiffness_n_per_m: None,
                unloaded_radius_m: None,
                relaxation: None,
            },
            sweeps: vec![
                planted_sweep(SweepKind::Cornering, (38.0, 64.0), mu0),
                planted_sweep(SweepKind::DriveBrake, (30.0, 50.0), mu0),
            ],
        };
        let (out, r) = correct(&input, &law(), f64::NAN);
        assert_eq!(r.samples_corrected, 800);
        let (t_lat, t_lon) = (r.lateral_t_ref_c.unwrap(), r.longitudinal_t_ref_c.unwrap());
        assert!(
            t_lat > 38.0 && t_lat < 55.0 && t_lon > 30.0 && t_lon < 50.0,
            "{r:?}"
        );
        let lateral = model(law().mu_rel(t_lat) / mu0);
        let longitudinal = model(law().mu_rel(t_lon) / mu0);
        let fy = |s: &Sample| s.fy_n;
        let mz = |s: &Sample| s.mz_nm;
        let fx = |s: &Sample| s.fx_n;
        let cases = [
            ("Fy", 0, &lateral, fy as fn(&Sample) -> f64),
            ("Mz", 0, &lateral, mz),
            ("Fx", 1, &longitudinal, fx),
        ];
        for (name, k, reference, ch) in cases {
            let before = worst(&input.sweeps[k], reference, ch);
            let after = worst(&out.sweeps[k], reference, ch);
            eprintln!("{name}: {before:.3} % of peak as measured, {after:.3} % corrected");
            assert!(
                before > 2.0,
                "{name}: the planted law moves the data {before} %"
            );
            assert!(after < 0.25 * before && after < 0.6, "{name}: {after} %");
        }
    }
}
