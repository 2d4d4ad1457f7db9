//! The intermediate Magic Formula factors (B, C, D, E, shifts, combined-slip weights) at one
//! operating point, for diagnostics such as `tir lint`.
//!
//! In: coefficients and a [`Load`] from [`super::pac2002::load_with`] (its version selects the
//! PAC2002 or MF 6.x forms, its pressure the MF 6.x pressure terms). Out: [`SlipFactors`]: the
//! pure-slip factors of `Fx0` and `Fy0`, the combined-slip weighting factors and the weights
//! `Gxa`, `Gyk` themselves, with every curvature factor `E` BEFORE the `E <= 1` clamp.
//! The formulas are those of `pac2002.rs` (`docs/pac2002-equations.md` sections 5, 6, 8);
//! a test rebuilds `Fx0`, `Fy0` and combined `Fy` from these factors and compares with the
//! evaluator, so the two cannot drift apart silently.
//! Deliberately not here: evaluation (see `pac2002.rs`), generic scalars (plain `f64`).

use super::pac2002::{EPS, Load, magic_formula, sgn, sgn_pos, weighting};
use super::params::{Coef::*, Coefs};

/// Factors of one Magic Formula curve `y = D sin(C atan(B x - E (B x - atan(B x)))) + SV`,
/// `x = slip + SH`.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct CurveFactors {
    /// Stiffness factor `B`.
    pub b: f64,
    /// Shape factor `C`.
    pub c: f64,
    /// Peak factor `D`, N.
    pub d: f64,
    /// Curvature factor `E`, unclamped.
    pub e: f64,
    /// Horizontal shift `SH` (slip units).
    pub sh: f64,
    /// Vertical shift `SV`, N.
    pub sv: f64,
}

/// Factors of a combined-slip weighting function `G = cos(C atan(B x - E(...)))/G(SH)`.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct WeightFactors {
    /// `B`.
    pub b: f64,
    /// `C`.
    pub c: f64,
    /// `E`, unclamped.
    pub e: f64,
    /// `SH`.
    pub sh: f64,
    /// The weight at this point, with `E` clamped as the load's mode says.
    pub g: f64,
}

/// Everything at one operating point.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SlipFactors {
    /// Pure longitudinal force `Fx0(kappa)`.
    pub fx0: CurveFactors,
    /// Pure lateral force `Fy0(alpha)`.
    pub fy0: CurveFactors,
    /// `Gxa`: reduction of `Fx0` by slip angle.
    pub gxa: WeightFactors,
    /// `Gyk`: reduction of `Fy0` by longitudinal slip.
    pub gyk: WeightFactors,
    /// `mu_x`.
    pub mux: f64,
    /// Signed `mu_y`.
    pub muy: f64,
    /// `Kx_kappa`, N.
    pub kxk_n: f64,
    /// `Ky_alpha`, N/rad.
    pub kya_n_per_rad: f64,
}

/// The factors at the load (and slips) in `l`.
pub fn slip_factors(c: &Coefs<f64>, l: &Load<f64>) -> SlipFactors {
    let dfz = l.dfz;
    let clamp = |e: f64| if l.clamp_e { e.min(1.0) } else { e };

    let mf6 = l.version.is_mf6();
    let dpi = l.dpi;
    let poly = |a: f64, b: f64| {
        if mf6 {
            1.0 + a * dpi + b * dpi * dpi
        } else {
            1.0
        }
    };
    let gx = l.gamma * c[LGAX];
    let cx = c[PCX1] * c[LCX];
    let mux = if l.fz == 0.0 {
        0.0
    } else {
        (c[PDX1] + c[PDX2] * dfz) * poly(c[PPX3], c[PPX4]) * (1.0 - c[PDX3] * gx * gx) * c[LMUX]
    };
    let dx = mux * l.fz;
    let kxk =
        l.fz * (c[PKX1] + c[PKX2] * dfz) * (c[PKX3] * dfz).exp() * poly(c[PPX1], c[PPX2]) * c[LKX];
    let bx = kxk / (cx * dx + EPS * sgn_pos(dx));
    let shx = (c[PHX1] + c[PHX2] * dfz) * c[LHX] * l.low_speed;
    let svx = l.fz * (c[PVX1] + c[PVX2] * dfz) * c[LVX] * c[LMUX] * l.low_speed;
    let ex = (c[PEX1] + c[PEX2] * dfz + c[PEX3] * dfz * dfz)
        * (1.0 - c[PEX4] * sgn(l.kappa + shx))
        * c[LEX];

    let gy = l.gamma * c[LGAY];
    let cy = c[PCY1] * c[LCY];
    let muy = if l.fz == 0.0 {
        0.0
    } else {
        (c[PDY1] + c[PDY2] * dfz) * poly(c[PPY3], c[PPY4]) * (1.0 - c[PDY3] * gy * gy) * c[LMUY]
    };
    let dy = muy * l.fz;
    let (kya, shy, svy, ey) = if mf6 {
        let g = l.gamma;
        let kya = c[PKY1]
            * l.fz0_scaled
            * (1.0 + c[PPY1] * dpi)
            * (1.0 - c[PKY3] * g.abs())
            * (c[PKY4]
                * ((l.fz / l.fz0_scaled) / ((c[PKY2] + c[PKY5] * g * g) * (1.0 + c[PPY2] * dpi)))
                    .atan())
            .sin()
            * c[LKY];
        let svyg = l.fz * (c[PVY3] + c[PVY4] * dfz) * g * c[LKYC] * c[LMUY];
        let kyg0 = l.fz * (c[PKY6] + c[PKY7] * dfz) * (1.0 + c[PPY5] * dpi) * c[LKYC];
        let shy = ((c[PHY1] + c[PHY2] * dfz) * c[LHY]
            + (kyg0 * g - svyg) / (kya + EPS * sgn_pos(kya)))
            * l.low_speed;
        let svy = (l.fz * (c[PVY1] + c[PVY2] * dfz) * c[LVY] * c[LMUY] + svyg) * l.low_speed;
        let ey = (c[PEY1] + c[PEY2] * dfz)
            * (1.0 + c[PEY5] * g * g - (c[PEY3] + c[PEY4] * g) * sgn_pos(l.alpha + shy))
            * c[LEY];
        (kya, shy, svy, ey)
    } else {
        let load_ratio = l.fz / (c[PKY2] * l.fz0_scaled);
        let kya = c[PKY1]
            * l.fz0_scaled
            * (2.0 * load_ratio.atan()).sin()
            * (1.0 - c[PKY3] * gy.abs())
            * c[LKY];
        let shy = ((c[PHY1] + c[PHY2] * dfz) * c[LHY] + c[PHY3] * gy) * l.low_speed;
        let svy = l.fz
            * ((c[PVY1] + c[PVY2] * dfz) * c[LVY] + (c[PVY3] + c[PVY4] * dfz) * gy)
            * c[LMUY]
            * l.low_speed;
        let ey = (c[PEY1] + c[PEY2] * dfz)
            * (1.0 - (c[PEY3] + c[PEY4] * gy) * sgn_pos(l.alpha + shy))
            * c[LEY];
        (kya, shy, svy, ey)
    };
    let by = kya / (cy * dy + EPS * sgn_pos(dy));

    let camber_sq = if mf6 { l.gamma * l.gamma } else { 0.0 };
    let bxa = (c[RBX1] + c[RBX3] * camber_sq) * (c[RBX2] * l.kappa).atan().cos() * c[LXAL];
    let cxa = c[RCX1];
    let exa = c[REX1] + c[REX2] * dfz;
    let shxa = c[RHX1];
    let gxa =
        weighting(bxa, cxa, clamp(exa), l.alpha + shxa) / weighting(bxa, cxa, clamp(exa), shxa);

    let byk =
        (c[RBY1] + c[RBY4] * camber_sq) * (c[RBY2] * (l.alpha - c[RBY3])).atan().cos() * c[LYKA];
    let cyk = c[RCY1];
    let eyk = c[REY1] + c[REY2] * dfz;
    let shyk = c[RHY1] + c[RHY2] * dfz;
    let gyk =
        weighting(byk, cyk, clamp(eyk), l.kappa + shyk) / weighting(byk, cyk, clamp(eyk), shyk);

    SlipFactors {
        fx0: CurveFactors {
            b: bx,
            c: cx,
            d: dx,
            e: ex,
            sh: shx,
            sv: svx,
        },
        fy0: CurveFactors {
            b: by,
            c: cy,
            d: dy,
            e: ey,
            sh: shy,
            sv: svy,
        },
        gxa: WeightFactors {
            b: bxa,
            c: cxa,
            e: exa,
            sh: shxa,
            g: gxa,
        },
        gyk: WeightFactors {
            b: byk,
            c: cyk,
            e: eyk,
            sh: shyk,
            g: gyk,
        },
        mux,
        muy,
        kxk_n: kxk,
        kya_n_per_rad: kya,
    }
}

impl CurveFactors {
    /// The curve's value at `slip`, with `E` clamped to `<= 1` when `clamp_e`.
    pub fn value(&self, slip: f64, clamp_e: bool) -> f64 {
        let e = if clamp_e { self.e.min(1.0) } else { self.e };
        magic_formula(self.b, self.c, self.d, e, slip + self.sh) + self.sv
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tire_model::pac2002::{combined_fy, gxa, load_with, pure_fx0, pure_fy0};
    use crate::tire_model::tir::TirFile;
    use crate::tire_model::{Mode, SlipInput};

    const FSAE: &str =
        include_str!("../../../tests/fixtures/reference/fsae-demo/fsae_demo_pac2002.tir");
    const MFEVAL: &str = include_str!(
        "../../../tests/fixtures/reference/mfeval-sample/MagicFormula52_Parameters.tir"
    );
    const MF61: &str =
        include_str!("../../../tests/fixtures/reference/mfeval-mf6/MagicFormula61_Parameters.tir");

    /// The factors rebuild the evaluator's Fx0, Fy0 and combined Fy (both modes, E > 1 cases
    /// included: the MFeval sample reaches Ex = 1.31).
    #[test]
    fn factors_rebuild_the_evaluator() {
        for tir in [FSAE, MFEVAL, MF61] {
            let (file, _) = TirFile::parse(tir).unwrap();
            let c = &file.coefs;
            // MF 6.1 away from its nominal pressure, so the pressure terms count.
            let p = 0.8 * c[NOMPRES];
            let fz0 = c[FNOMIN];
            for mode in [Mode::Limits, Mode::Raw] {
                for fz in [0.3 * fz0, fz0, 2.0 * fz0] {
                    for kappa in [-0.2, -0.03, 0.0, 0.05, 0.2] {
                        for alpha in [-0.2, -0.01, 0.0, 0.02, 0.2] {
                            for gamma in [0.0, 0.05] {
                                let input = SlipInput {
                                    fz_n: fz,
                                    kappa,
                                    alpha_rad: alpha,
                                    gamma_rad: gamma,
                                    vx_mps: 11.0,
                                };
                                let l = load_with(c, &input, mode, file.version, p);
                                let f = slip_factors(c, &l);
                                let clamp = mode == Mode::Limits;
                                let fx0 = pure_fx0(c, &l).fx0;
                                let py = pure_fy0(c, &l);
                                let fy = combined_fy(c, &l, &py);
                                let tol = |r: f64| 1e-12 * r.abs().max(1.0);
                                let x = f.fx0.value(l.kappa, clamp);
                                assert!((x - fx0).abs() <= tol(fx0), "Fx0 {x} vs {fx0}");
                                let y = f.fy0.value(l.alpha, clamp);
                                assert!((y - py.fy0).abs() <= tol(py.fy0), "Fy0 {y} vs {}", py.fy0);
                                let fy_rebuilt = f.gyk.g * py.fy0 + fy.svyk;
                                assert!((fy_rebuilt - fy.fy).abs() <= tol(fy.fy));
                                let g = gxa(c, &l);
                                assert!((f.gxa.g - g).abs() <= 1e-12, "Gxa {} vs {g}", f.gxa.g);
                            }
                        }
                    }
                }
            }
        }
    }
}
