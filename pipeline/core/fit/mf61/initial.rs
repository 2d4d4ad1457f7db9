//! Starting values of the MF 6.1 fit, built on the per-pressure PAC2002 fits.
//!
//! In: the PAC2002 model of every tested pressure (and, when known, its vertical stiffness and
//! unloaded radius from the spring-rate stage), the nominal pressure the MF 6.1 model is
//! referred to. Out: an MF 6.1 coefficient set and notes.
//!
//! Method: the PAC2002 model nearest the nominal pressure is lifted into MF 6.1 (exact where the
//! forms agree: `tir::convert`); every tested pressure's model is lifted too, and the pressure
//! terms come from the trends of the coefficients they scale across the pressures, by least
//! squares in `dpi = (p - NOMPRES)/NOMPRES`: `PDX1 -> PPX3, PPX4`, `PKX1 -> PPX1, PPX2`,
//! `PDY1 -> PPY3, PPY4`, `PKY1 -> PPY1`, `PKY2 -> PPY2`, the camber stiffness `PKY6 -> PPY5`,
//! `QDZ1 -> PPZ1`, `QDZ8 -> PPZ2`, `QSX2 -> PPMX1`, the vertical stiffness `-> PFZ1`, the
//! carcass stiffnesses `-> PCFX3, PCFY3` (quadratic terms need three pressures, linear ones
//! two). The lifted coefficients are then divided by their pressure factor at the reference
//! model's pressure, so the set describes the tire at NOMPRES.
//!
//! Deliberately not here: the joint refinement (`problem.rs`, `mod.rs`).

use crate::tire_model::params::{Coef, Coef::*, Coefs};
use crate::tire_model::tir::{TirFile, convert};
use crate::tire_model::{MagicFormula, Version};

/// One tested pressure's PAC2002 result.
#[derive(Clone, Debug, PartialEq)]
pub struct Pac2002AtPressure {
    /// Inflation pressure the model describes, Pa.
    pub p_pa: f64,
    /// The PAC2002 fit.
    pub model: MagicFormula,
    /// Vertical stiffness from the spring-rate stage, N/m.
    pub vertical_stiffness_n_per_m: Option<f64>,
    /// Unloaded radius from the spring-rate stage, m.
    pub unloaded_radius_m: Option<f64>,
}

/// The largest magnitude a pressure term may start with.
pub const PRESSURE_TERM_LIMIT: f64 = 3.0;

/// `y ~ c0 (1 + a x + b x^2)` by least squares on `(x, y)`: quadratic with 3+ points, linear
/// with 2, constant with 1. Returns `(c0, a, b)`.
pub fn trend(points: &[(f64, f64)], quadratic: bool) -> (f64, f64, f64) {
    let pts: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    let n = pts.len();
    let degree = match n {
        0 => return (f64::NAN, 0.0, 0.0),
        1 => 0,
        2 => 1,
        _ if quadratic => 2,
        _ => 1,
    };
    let cols = degree + 1;
    let mut a = nalgebra::DMatrix::<f64>::zeros(n, cols);
    let mut b = nalgebra::DVector::<f64>::zeros(n);
    for (i, (x, y)) in pts.iter().enumerate() {
        for j in 0..cols {
            a[(i, j)] = x.powi(j as i32);
        }
        b[i] = *y;
    }
    let Ok(s) = a.svd(true, true).solve(&b, 1e-14) else {
        return (pts[0].1, 0.0, 0.0);
    };
    let c0 = s[0];
    if c0 == 0.0 || !c0.is_finite() {
        return (c0, 0.0, 0.0);
    }
    let lin = if cols > 1 { s[1] / c0 } else { 0.0 };
    let quad = if cols > 2 { s[2] / c0 } else { 0.0 };
    let clip = |v: f64| v.clamp(-PRESSURE_TERM_LIMIT, PRESSURE_TERM_LIMIT);
    (c0, clip(lin), clip(quad))
}

/// An MF 6.1 starting point and what was assumed.
#[derive(Clone, Debug, PartialEq)]
pub struct Start {
    /// Every coefficient, MF 6.1, at `NOMPRES`.
    pub coefs: Coefs<f64>,
    /// Index of the reference model in the input.
    pub reference: usize,
    /// What the start could not carry or assumed.
    pub notes: Vec<String>,
}

/// The lifted (MF 6.1) coefficients of one PAC2002 model at its own pressure.
fn lift(m: &Pac2002AtPressure) -> Option<Coefs<f64>> {
    let file = TirFile::from_coefs(m.model.coefs.clone());
    convert::convert(&file, Version::Mf61, Some(m.p_pa))
        .ok()
        .map(|c| c.file.coefs)
}

/// The index of the reference model in `models`: the one whose pressure is nearest
/// `nominal_pa` (the first of equals; 0 when `models` is empty). Coefficients without a pressure
/// trend (`BREFF`, `DREFF`, `FREFF`, the `My` terms, ..) start as this model's values.
pub fn reference(models: &[Pac2002AtPressure], nominal_pa: f64) -> usize {
    (0..models.len())
        .min_by(|&a, &b| {
            let da = (models[a].p_pa - nominal_pa).abs();
            let db = (models[b].p_pa - nominal_pa).abs();
            da.total_cmp(&db)
        })
        .unwrap_or(0)
}

/// Build the start. `models` must not be empty.
pub fn start(models: &[Pac2002AtPressure], nominal_pa: f64) -> Start {
    let mut notes = Vec::new();
    let reference = reference(models, nominal_pa);
    let lifted: Vec<Option<Coefs<f64>>> = models.iter().map(lift).collect();
    let base = lifted[reference].clone().unwrap_or_else(|| {
        models[reference]
            .model
            .coefs
            .clone()
            .restricted_to(Version::Mf61)
    });
    let mut c = base.clone();
    c[NOMPRES] = nominal_pa;
    c[INFLPRES] = nominal_pa;
    let dpi = |p: f64| (p - nominal_pa) / nominal_pa;
    let d_ref = dpi(models[reference].p_pa);
    let series = |k: Coef| -> Vec<(f64, f64)> {
        models
            .iter()
            .zip(&lifted)
            .filter_map(|(m, l)| l.as_ref().map(|l| (dpi(m.p_pa), l[k])))
            .collect()
    };
    // Peak friction and slip stiffnesses: quadratic factors.
    for (primary, scaled, lin, quad) in [
        (PDX1, [PDX1, PDX2], PPX3, PPX4),
        (PKX1, [PKX1, PKX2], PPX1, PPX2),
        (PDY1, [PDY1, PDY2], PPY3, PPY4),
    ] {
        let (_, a, b) = trend(&series(primary), true);
        c[lin] = a;
        c[quad] = b;
        let f = 1.0 + a * d_ref + b * d_ref * d_ref;
        for k in scaled {
            c[k] = base[k] / f;
        }
    }
    // Linear factors (1 + P dpi) and (1 - PPZ1 dpi).
    for (primary, scaled, term, sign) in [
        (PKY1, &[PKY1][..], PPY1, 1.0),
        (PKY2, &[PKY2][..], PPY2, 1.0),
        (PKY6, &[PKY6, PKY7][..], PPY5, 1.0),
        (QDZ1, &[QDZ1, QDZ2][..], PPZ1, -1.0),
        (QDZ8, &[QDZ8, QDZ9][..], PPZ2, 1.0),
        (QSX2, &[QSX2][..], PPMX1, 1.0),
    ] {
        let (c0, a, _) = trend(&series(primary), false);
        if !c0.is_finite() || c0.abs() < 1e-12 {
            continue;
        }
        c[term] = sign * a;
        let f = 1.0 + a * d_ref;
        for k in scaled {
            c[*k] = base[*k] / f;
        }
    }
    // Carcass stiffnesses (relaxation lengths |Kx/Cx|, |Ky/Cy|): each direction from the
    // PAC2002 models that carry its relaxation law.
    for (law, stiffness, term) in [
        (PTX1, LONGITUDINAL_STIFFNESS, PCFX3),
        (PTY1, LATERAL_STIFFNESS, PCFY3),
    ] {
        let with_law: Vec<usize> = (0..models.len())
            .filter(|&i| models[i].model.coefs[law] != 0.0)
            .collect();
        if with_law.len() >= 2 {
            let pts: Vec<(f64, f64)> = with_law
                .iter()
                .filter_map(|&i| {
                    lifted[i]
                        .as_ref()
                        .map(|l| (dpi(models[i].p_pa), l[stiffness]))
                })
                .collect();
            let (c0, a, _) = trend(&pts, false);
            if c0.is_finite() && c0 > 0.0 {
                c[term] = a;
                c[stiffness] = base[stiffness] / (1.0 + a * d_ref);
            }
        } else if !with_law.is_empty() {
            notes.push(format!(
                "relaxation: one pressure with {}; {} = 0",
                law.name(),
                term.name()
            ));
        }
    }
    // Vertical: PFZ1 from the spring-rate stiffness at each pressure; the unloaded radius at
    // NOMPRES (MF 6.1 has no pressure term for it).
    let cz: Vec<(f64, f64)> = models
        .iter()
        .filter_map(|m| m.vertical_stiffness_n_per_m.map(|v| (dpi(m.p_pa), v)))
        .collect();
    let (cz0, a, _) = trend(&cz, false);
    if cz0.is_finite() && cz0 > 0.0 {
        c[VERTICAL_STIFFNESS] = cz0;
        c[PFZ1] = if cz.len() >= 2 { a } else { 0.0 };
    }
    let r0: Vec<(f64, f64)> = models
        .iter()
        .filter_map(|m| m.unloaded_radius_m.map(|v| (dpi(m.p_pa), v)))
        .collect();
    let (r00, slope, _) = trend(&r0, false);
    if r00.is_finite() && r00 > 0.0 {
        c[UNLOADED_RADIUS] = r00;
        if r0.len() >= 2 && slope != 0.0 {
            notes.push(format!(
                "unloaded radius {:.5} m at NOMPRES; it changes {:+.3} mm per 10 kPa over the \
                 tested pressures, which MF 6.1 cannot carry (no pressure term for R0)",
                r00,
                r00 * slope * 1e4 / nominal_pa * 1e3
            ));
        }
    }
    if models.len() < 3 {
        notes.push(format!(
            "{} tested pressure(s): quadratic pressure terms (PPX2, PPX4, PPY4) held at 0",
            models.len()
        ));
    }
    combined_slip_signs(&mut c);
    Start {
        coefs: c.restricted_to(Version::Mf61),
        reference,
        notes,
    }
}

/// Brings the combined-slip weighting terms to the signs of the refinement's boxes
/// (`pac2002::combined_slip_box`: slopes and shape terms >= 0) without changing any force:
/// the weightings are even in their slopes `Bxa = (RBX1 + RBX3 g^2) cos(atan(RBX2 k))` and
/// `Byk = (RBY1 + RBY4 g^2) cos(atan(RBY2 (a - RBY3)))`, `cos(atan(.))` is even in `RBX2`,
/// `RBY2`, `RVY4`, and `SVyk = DVyk sin(RVY5 atan(RVY6 k))` with `DVyk` linear in `RVY1..3` is
/// unchanged when `RVY6` and `RVY1..3` all change sign. A start outside a box would be clamped
/// onto its edge, where a zero shape term switches its whole term off (`RVY6 = 0` leaves
/// `RVY1..5` without effect on any point).
pub fn combined_slip_signs(c: &mut Coefs<f64>) {
    for (slope, camber) in [(RBX1, RBX3), (RBY1, RBY4)] {
        if c[slope] < 0.0 {
            c[slope] = -c[slope];
            c[camber] = -c[camber];
        }
    }
    for k in [RBX2, RBY2, RVY4] {
        c[k] = c[k].abs();
    }
    if c[RVY6] < 0.0 {
        for k in [RVY6, RVY1, RVY2, RVY3] {
            c[k] = -c[k];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sign normalisation leaves every force and moment of a model unchanged.
    #[test]
    fn combined_slip_signs_change_no_force() {
        use crate::tire_model::{Evaluation, Mode, SlipInput};
        let fsae =
            include_str!("../../../../tests/fixtures/reference/fsae-demo/fsae_demo_pac2002.tir");
        let pac = TirFile::parse(fsae).unwrap().0;
        let mut c = convert::convert(&pac, Version::Mf61, Some(83e3))
            .unwrap()
            .file
            .coefs;
        c[RBX1] = -c[RBX1];
        c[RBX3] = 0.5;
        c[RBY1] = -c[RBY1];
        c[RBY4] = -0.7;
        c[RBY2] = -c[RBY2];
        c[RVY4] = -c[RVY4];
        assert!(c[RVY6] < 0.0, "the demo tire's RVY6 is negative");
        let before = MagicFormula::with_version(c.clone(), Version::Mf61);
        combined_slip_signs(&mut c);
        let after = MagicFormula::with_version(c.clone(), Version::Mf61);
        assert!(c[RBX1] > 0.0 && c[RBY1] > 0.0 && c[RBY2] > 0.0 && c[RVY4] > 0.0);
        assert!(c[RVY6] > 0.0);
        let mut points = Vec::new();
        for fz_n in [400.0, 1100.0, 2000.0] {
            for gamma in [-0.05, 0.0, 0.06] {
                for i in -6..=6 {
                    for j in -6..=6 {
                        points.push(SlipInput {
                            fz_n,
                            kappa: 0.03 * i as f64,
                            alpha_rad: 0.03 * j as f64,
                            gamma_rad: gamma,
                            vx_mps: 11.0,
                        });
                    }
                }
            }
        }
        let mut a = vec![Evaluation::default(); points.len()];
        let mut b = a.clone();
        before.eval_batch(&points, Mode::Raw, &mut a);
        after.eval_batch(&points, Mode::Raw, &mut b);
        for ((p, x), y) in points.iter().zip(&a).zip(&b) {
            for (u, v) in [
                (x.fx_n, y.fx_n),
                (x.fy_n, y.fy_n),
                (x.mz_nm, y.mz_nm),
                (x.mx_nm, y.mx_nm),
            ] {
                assert!((u - v).abs() <= 1e-9 * (1.0 + u.abs()), "{p:?}: {u} vs {v}");
            }
        }
    }

    #[test]
    fn trend_recovers_factors() {
        let pts: Vec<(f64, f64)> = [-0.2, -0.1, 0.0, 0.15]
            .iter()
            .map(|&x| (x, 2.0 * (1.0 + 0.3 * x - 0.5 * x * x)))
            .collect();
        let (c0, a, b) = trend(&pts, true);
        assert!((c0 - 2.0).abs() < 1e-12 && (a - 0.3).abs() < 1e-12 && (b + 0.5).abs() < 1e-12);
        let (c0, a, b) = trend(&pts[..2], true);
        assert!(c0.is_finite() && a != 0.0 && b == 0.0);
        let (c0, a, _) = trend(&pts[..1], true);
        assert!(c0 == pts[0].1 && a == 0.0);
        assert!(trend(&[], true).0.is_nan());
    }
}
