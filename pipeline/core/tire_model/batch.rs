//! The fast batch evaluator behind [`MagicFormula::eval_batch`]: the combined-slip equations of
//! `pac2002.rs` (PAC2002 and MF 6.x, the version chosen per call), [`LANES`] points at a time,
//! on SIMD-friendly lane packs with polynomial elementary functions (`lanes.rs`).
//!
//! In: coefficients, the model version, a mode, a slice of [`SlipInput`] and their inflation
//! pressures. Out: one [`Evaluation`] per point, equal to the scalar [`evaluate_with`] up to
//! round-off: every expression below is the scalar one with
//! the same operation order, so the only differences come from `atan`, `sin`, `cos`, `tan`
//! (1-3 ulp from the standard library's). The unit tests hold every output to `1e-12` relative
//! (to `max(|scalar|, 1)`) of the scalar path on the reference grids and a dense random grid.
//!
//! Branches become lane selects (`sgn`, the `E <= 1` clamp, `Fz == 0`, `Vx < 0`, `Vx == 0`,
//! the `FZMIN` tapers, `kappa == 0` in combined `Mz`). Points in MFeval's low-speed blend
//! (limits mode, `|Vx| <= VXLOW`) are rare and are re-evaluated by the scalar path; a last block
//! shorter than [`LANES`] is padded. The machine code is built twice (baseline x86-64 and
//! AVX2) and picked at run time; both execute the same IEEE operations (no fused multiply-add),
//! so results are bit-identical whichever runs. No AVX-512 build: each build of these
//! equations is a large share of the crate's compile time, and AVX2 already holds a lane pack
//! in few registers.
//!
//! MF 6.x's `(Fz/Fz0)^QSY7 (p/p0)^QSY8` in `My` uses the standard library's `powf` lane by
//! lane (as `exp`).
//!
//! Deliberately not here: derivatives (see `jacobian.rs`) and the pure-slip channels.

use std::f64::consts::FRAC_2_PI;

use super::lanes::{self, LANES, M, V};
use super::pac2002::{
    EPS, Evaluation, Mode, Pressures, SlipInput, TrailPeak, evaluate_with, limited_pressure,
};
use super::params::{Coef, Coef::*, Coefs};
use super::version::Version;

/// Evaluate every point of `inputs` into `out` (equal lengths, checked by the caller).
pub(crate) fn eval_batch(
    c: &Coefs<f64>,
    trail_peak: TrailPeak,
    version: Version,
    inputs: &[SlipInput],
    pressures: Pressures<'_>,
    mode: Mode,
    out: &mut [Evaluation<f64>],
) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2 (checked just above).
            unsafe { eval_batch_avx2(c, trail_peak, version, inputs, pressures, mode, out) };
            return;
        }
    }
    eval_batch_lanes(c, trail_peak, version, inputs, pressures, mode, out);
}

/// [`eval_batch_lanes`] compiled with AVX2 enabled.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn eval_batch_avx2(
    c: &Coefs<f64>,
    trail_peak: TrailPeak,
    version: Version,
    inputs: &[SlipInput],
    pressures: Pressures<'_>,
    mode: Mode,
    out: &mut [Evaluation<f64>],
) {
    eval_batch_lanes(c, trail_peak, version, inputs, pressures, mode, out);
}

/// Blocks of [`LANES`] points through [`eval_lanes`] (the last one padded with copies of the
/// final point); low-speed points through the scalar evaluator.
#[inline(always)]
fn eval_batch_lanes(
    c: &Coefs<f64>,
    trail_peak: TrailPeak,
    version: Version,
    inputs: &[SlipInput],
    pressures: Pressures<'_>,
    mode: Mode,
    out: &mut [Evaluation<f64>],
) {
    for (b, (pts, slots)) in inputs.chunks(LANES).zip(out.chunks_mut(LANES)).enumerate() {
        let first = b * LANES;
        let last = pts.len() - 1;
        let block: [SlipInput; LANES] = std::array::from_fn(|i| pts[i.min(last)]);
        let p = V(std::array::from_fn(|i| pressures.at(first + i.min(last))));
        let (e, scalar) = eval_lanes(c, trail_peak, version, &block, p, mode);
        for (i, slot) in slots.iter_mut().enumerate() {
            *slot = if scalar.0[i] {
                evaluate_with(
                    c,
                    &pts[i],
                    mode,
                    trail_peak,
                    version,
                    pressures.at(first + i),
                )
            } else {
                e.lane(i)
            };
        }
    }
}

/// The outputs of one block, one lane per point.
struct Outputs {
    fx: V,
    fy: V,
    mx: V,
    my: V,
    mz: V,
    mux: V,
    muy: V,
    kxk: V,
    kya: V,
    trail: V,
    mzr: V,
}

impl Outputs {
    #[inline(always)]
    fn lane(&self, i: usize) -> Evaluation<f64> {
        Evaluation {
            fx_n: self.fx.0[i],
            fy_n: self.fy.0[i],
            mx_nm: self.mx.0[i],
            my_nm: self.my.0[i],
            mz_nm: self.mz.0[i],
            mux: self.mux.0[i],
            muy: self.muy.0[i],
            kxk_n: self.kxk.0[i],
            kya_n_per_rad: self.kya.0[i],
            trail_m: self.trail.0[i],
            mzr_nm: self.mzr.0[i],
        }
    }
}

/// `D sin(C atan(B x - E (B x - atan(B x))))`, as [`super::pac2002::magic_formula`].
#[inline(always)]
fn magic_formula(b: V, c: V, d: V, e: V, x: V) -> V {
    let bx = b * x;
    d * lanes::sin(c * lanes::atan(bx - e * (bx - lanes::atan(bx))))
}

/// `cos(C atan(B x - E (B x - atan(B x))))`, as [`super::pac2002::weighting`].
#[inline(always)]
fn weighting(b: V, c: f64, e: V, x: V) -> V {
    let bx = b * x;
    lanes::cos(c * lanes::atan(bx - e * (bx - lanes::atan(bx))))
}

/// The pure lateral force factors of one block (pac2002::PureFy without `Cy`).
struct LaneFy {
    fy0: V,
    muy: V,
    kya: V,
    by: V,
    shy: V,
    svy: V,
}

/// MF 6.x pure lateral force of one block (pac2002::pure_fy0_mf6); `gamma` is zero for the
/// lateral force `Mz` uses.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn pure_fy0_mf6(
    c: &Coefs<f64>,
    gamma: V,
    fz: V,
    dfz: V,
    dpi: V,
    alpha: V,
    fz_is_zero: M,
    limits: bool,
) -> LaneFy {
    let k = |coef: Coef| c[coef];
    let fz0_scaled = k(FNOMIN) * k(LFZO);
    let cy = k(PCY1) * k(LCY);
    let muy = fz_is_zero.select(
        V::splat(0.0),
        (k(PDY1) + k(PDY2) * dfz)
            * (k(PPY3) * dpi + k(PPY4) * (dpi * dpi) + 1.0)
            * (-(k(PDY3) * gamma.sq()) + 1.0)
            * k(LMUY),
    );
    let dy = muy * fz;
    let kya = k(PKY1)
        * fz0_scaled
        * (k(PPY1) * dpi + 1.0)
        * (-(k(PKY3) * gamma.abs()) + 1.0)
        * lanes::sin(
            k(PKY4)
                * lanes::atan(
                    (fz / fz0_scaled) / ((k(PKY2) + k(PKY5) * gamma.sq()) * (k(PPY2) * dpi + 1.0)),
                ),
        )
        * k(LKY);
    let svyg = fz * (k(PVY3) + k(PVY4) * dfz) * gamma * k(LKYC) * k(LMUY);
    let kyg0 = fz * (k(PKY6) + k(PKY7) * dfz) * (k(PPY5) * dpi + 1.0) * k(LKYC);
    let kya_prime = kya + EPS * kya.sgn_pos();
    let shy = (k(PHY1) + k(PHY2) * dfz) * k(LHY) + (kyg0 * gamma - svyg) / kya_prime;
    let svy = fz * (k(PVY1) + k(PVY2) * dfz) * k(LVY) * k(LMUY) + svyg;
    let ay = alpha + shy;
    let ey = ((k(PEY1) + k(PEY2) * dfz)
        * (k(PEY5) * gamma.sq() + 1.0 - (k(PEY3) + k(PEY4) * gamma) * ay.sgn_pos())
        * k(LEY))
    .clamp_e(limits);
    let by = kya / (cy * dy + EPS * dy.sgn_pos());
    let fy0 = magic_formula(by, V::splat(cy), dy, ey, ay) + svy;
    LaneFy {
        fy0,
        muy,
        kya,
        by,
        shy,
        svy,
    }
}

/// One block of points; returns the outputs and the lanes the scalar path must redo.
#[inline(always)]
fn eval_lanes(
    c: &Coefs<f64>,
    trail_peak: TrailPeak,
    version: Version,
    pts: &[SlipInput; LANES],
    pressure: V,
    mode: Mode,
) -> (Outputs, M) {
    let k = |coef: Coef| c[coef];
    let limits = mode == Mode::Limits;
    let mf6 = version.is_mf6();
    let field = |f: fn(&SlipInput) -> f64| V(std::array::from_fn(|i| f(&pts[i])));

    // Load (pac2002::load).
    let fz_unlimited = field(|p| p.fz_n).max(0.0);
    let vx = field(|p| p.vx_mps);
    let (kappa, alpha, gamma, fz, fz_low) = if limits {
        let fz = fz_unlimited.min(k(FZMAX));
        (
            field(|p| p.kappa).clamp(k(KPUMIN), k(KPUMAX)),
            field(|p| p.alpha_rad).clamp(k(ALPMIN), k(ALPMAX)),
            field(|p| p.gamma_rad).clamp(k(CAMMIN), k(CAMMAX)),
            fz,
            fz.max(k(FZMIN)),
        )
    } else {
        let raw = (
            field(|p| p.kappa),
            field(|p| p.alpha_rad),
            field(|p| p.gamma_rad),
        );
        (raw.0, raw.1, raw.2, fz_unlimited, fz_unlimited)
    };
    let vxlow = k(VXLOW);
    let scalar = if limits && vxlow > 0.0 {
        M(std::array::from_fn(|i| vx.0[i].abs() <= vxlow))
    } else {
        M([false; LANES])
    };
    let fz0_scaled = k(FNOMIN) * k(LFZO);
    let dfz = (fz - fz0_scaled) / fz0_scaled;
    let fz_is_zero = fz.eq(0.0);
    let zero = V::splat(0.0);
    // Pressure (pac2002::load_with): MF 6.x only.
    let (dpi, p_ratio) = if mf6 {
        let p = pressure.map(|p| limited_pressure(k(PRESMIN), k(PRESMAX), p, mode));
        ((p - k(NOMPRES)) / k(NOMPRES), p / k(NOMPRES))
    } else {
        (zero, V::splat(1.0))
    };
    let pressure_poly = |a: Coef, b: Coef| k(a) * dpi + k(b) * (dpi * dpi) + 1.0;

    // Pure Fx0 (pac2002::pure_fx0).
    let gx = gamma * k(LGAX);
    let cx = k(PCX1) * k(LCX);
    let mux_base = k(PDX1) + k(PDX2) * dfz;
    let mux_base = if mf6 {
        mux_base * pressure_poly(PPX3, PPX4)
    } else {
        mux_base
    };
    let mux = fz_is_zero.select(zero, mux_base * (-(k(PDX3) * gx.sq()) + 1.0) * k(LMUX));
    let dx = mux * fz;
    let kxk = fz * (k(PKX1) + k(PKX2) * dfz) * lanes::exp(k(PKX3) * dfz);
    let kxk = if mf6 {
        kxk * pressure_poly(PPX1, PPX2)
    } else {
        kxk
    };
    let kxk = kxk * k(LKX);
    let bx = kxk / (cx * dx + EPS * dx.sgn_pos());
    let shx = (k(PHX1) + k(PHX2) * dfz) * k(LHX);
    let svx = fz * (k(PVX1) + k(PVX2) * dfz) * k(LVX) * k(LMUX);
    let kx = kappa + shx;
    let ex =
        ((k(PEX1) + k(PEX2) * dfz + k(PEX3) * dfz.sq()) * (-(k(PEX4) * kx.sgn()) + 1.0) * k(LEX))
            .clamp_e(limits);
    let fx0 = magic_formula(bx, V::splat(cx), dx, ex, kx) + svx;
    let fx0 = vx.lt(0.0).select(-fx0, fx0);

    // Pure Fy0 (pac2002::pure_fy0).
    let gy = gamma * k(LGAY);
    let cy = k(PCY1) * k(LCY);
    let py = if mf6 {
        pure_fy0_mf6(c, gamma, fz, dfz, dpi, alpha, fz_is_zero, limits)
    } else {
        let muy = fz_is_zero.select(
            zero,
            (k(PDY1) + k(PDY2) * dfz) * (-(k(PDY3) * gy.sq()) + 1.0) * k(LMUY),
        );
        let dy = muy * fz;
        let kya = k(PKY1)
            * fz0_scaled
            * (fz / (k(PKY2) * fz0_scaled)).sin_2atan()
            * (-(k(PKY3) * gy.abs()) + 1.0)
            * k(LKY);
        let by = kya / (cy * dy + EPS * dy.sgn_pos());
        let shy = (k(PHY1) + k(PHY2) * dfz) * k(LHY) + k(PHY3) * gy;
        let svy =
            fz * ((k(PVY1) + k(PVY2) * dfz) * k(LVY) + (k(PVY3) + k(PVY4) * dfz) * gy) * k(LMUY);
        let ay = alpha + shy;
        let ey = ((k(PEY1) + k(PEY2) * dfz)
            * (-((k(PEY3) + k(PEY4) * gy) * ay.sgn_pos()) + 1.0)
            * k(LEY))
        .clamp_e(limits);
        let fy0 = magic_formula(by, V::splat(cy), dy, ey, ay) + svy;
        LaneFy {
            fy0,
            muy,
            kya,
            by,
            shy,
            svy,
        }
    };
    let LaneFy {
        fy0,
        muy,
        kya,
        by,
        shy,
        svy,
    } = py;

    // Trail and residual torque factors (pac2002::trail_terms).
    let gz = gamma * k(LGAZ);
    let r0 = k(UNLOADED_RADIUS);
    let sht = k(QHZ1) + k(QHZ2) * dfz + (k(QHZ3) + k(QHZ4) * dfz) * gz;
    let alpha_t = alpha + sht;
    let bt = (k(QBZ1) + k(QBZ2) * dfz + k(QBZ3) * dfz.sq())
        * (k(QBZ4) * gz + k(QBZ5) * gz.abs() + 1.0)
        * k(LKY)
        / k(LMUY);
    let ct = k(QCZ1);
    let peak = k(QDZ1) + k(QDZ2) * dfz;
    let peak = if mf6 {
        peak * (-(k(PPZ1) * dpi) + 1.0)
    } else {
        peak
    };
    let peak = peak * (k(QDZ3) * gz + k(QDZ4) * gz.sq() + 1.0) * (r0 / fz0_scaled) * k(LTR);
    let dt = match trail_peak {
        TrailPeak::Standard => fz_low * peak,
        TrailPeak::ThesisWithoutFz => peak,
    };
    let et = ((k(QEZ1) + k(QEZ2) * dfz + k(QEZ3) * dfz.sq())
        * ((k(QEZ4) + k(QEZ5) * gz) * lanes::atan(bt * ct * alpha_t) * FRAC_2_PI + 1.0))
        .clamp_e(limits);
    let vsy = lanes::tan(alpha) * vx.abs();
    let vc = (vx * vx + vsy * vsy).sqrt();
    let cos_alpha_prime = vx / (vc + EPS);
    let kya_prime = kya + EPS * kya.sgn_pos();
    let alpha_r = alpha + shy + svy / kya_prime;
    let br = k(QBZ9) * k(LKY) / k(LMUY) + k(QBZ10) * by * cy;
    let camber_peak = if mf6 {
        ((k(QDZ8) + k(QDZ9) * dfz) * (k(PPZ2) * dpi + 1.0) + (k(QDZ10) + k(QDZ11) * dfz) * gz.abs())
            * gz
            * k(LKZC)
    } else {
        (k(QDZ8) + k(QDZ9) * dfz) * gz
    };
    let dr = fz_low
        * r0
        * ((k(QDZ6) + k(QDZ7) * dfz) * k(LRES) + camber_peak)
        * k(LMUY)
        * (vx.sgn() * lanes::cos(alpha));

    // Combined Fx (pac2002::gxa, combined_fx).
    let bxa = if mf6 {
        (k(RBX1) + k(RBX3) * gamma.sq()) * (k(RBX2) * kappa).cos_atan() * k(LXAL)
    } else {
        k(RBX1) * (k(RBX2) * kappa).cos_atan() * k(LXAL)
    };
    let exa = (k(REX1) + k(REX2) * dfz).clamp_e(limits);
    let shxa = V::splat(k(RHX1));
    let gxa = weighting(bxa, k(RCX1), exa, alpha + shxa) / weighting(bxa, k(RCX1), exa, shxa);
    let fx = gxa * fx0;

    // Combined Fy (pac2002::combined_fy).
    let byk = if mf6 {
        (k(RBY1) + k(RBY4) * gamma.sq()) * (k(RBY2) * (alpha - k(RBY3))).cos_atan() * k(LYKA)
    } else {
        k(RBY1) * (k(RBY2) * (alpha - k(RBY3))).cos_atan() * k(LYKA)
    };
    let eyk = (k(REY1) + k(REY2) * dfz).clamp_e(limits);
    let shyk = k(RHY1) + k(RHY2) * dfz;
    let gyk = weighting(byk, k(RCY1), eyk, kappa + shyk) / weighting(byk, k(RCY1), eyk, shyk);
    let dvyk = muy * fz * (k(RVY1) + k(RVY2) * dfz + k(RVY3) * gy) * (k(RVY4) * alpha).cos_atan();
    let svyk = dvyk * lanes::sin(k(RVY5) * lanes::atan(k(RVY6) * kappa)) * k(LVYKA);
    let fy = gyk * fy0 + svyk;

    // Combined Mz (pac2002::combined_mz).
    let ratio_kappa_sq = (kxk / kya_prime).sq() * kappa.sq();
    let eq = |a: V| lanes::atan((lanes::tan(a).sq() + ratio_kappa_sq).sqrt()) * a.sgn();
    let kappa_is_zero = kappa.eq(0.0);
    let alpha_t_eq = kappa_is_zero.select(alpha_t, eq(alpha_t));
    let alpha_r_eq = kappa_is_zero.select(alpha_r, eq(alpha_r));
    let bxt = bt * alpha_t_eq;
    let trail = dt
        * lanes::cos(ct * lanes::atan(bxt - et * (bxt - lanes::atan(bxt))))
        * cos_alpha_prime
        * k(LFZO);
    let mzr = dr * (br * alpha_r_eq).cos_atan();
    let s = r0 * (k(SSZ1) + k(SSZ2) * (fy / k(FNOMIN)) + (k(SSZ3) + k(SSZ4) * dfz) * gz) * k(LS);
    let fy_trail = if mf6 {
        let flat = pure_fy0_mf6(c, zero, fz, dfz, dpi, alpha, fz_is_zero, limits);
        gyk * flat.fy0
    } else {
        fy - svyk
    };
    let mz = -(trail * fy_trail) + mzr + s * fx;

    // Overturning moment (pac2002::overturning_mx).
    let fzmin = k(FZMIN);
    let fz_mx = fz.lt(fzmin).select(fz * (fz / fzmin).sq(), fz);
    let fz0 = k(FNOMIN);
    let fz_rel = fz_mx / fz0;
    let fy_rel = fy / fz0;
    let inner = k(QSX1) * k(LVMX) - k(QSX2) * gamma
        + k(QSX3) * fy_rel
        + k(QSX4)
            * lanes::cos(k(QSX5) * lanes::atan((k(QSX6) * fz_rel).sq()))
            * lanes::sin(k(QSX7) * gamma + k(QSX8) * lanes::atan(k(QSX9) * fy_rel))
        + k(QSX10) * lanes::atan(k(QSX11) * fz_rel) * gamma;
    let mx = if mf6 {
        let inner = inner - k(QSX2) * gamma * (k(PPMX1) * dpi);
        r0 * fz_mx * k(LMX) * inner
            + r0 * k(LMX)
                * (fy * (k(QSX13) + k(QSX14) * gamma.abs())
                    - fz_mx * k(QSX12) * gamma * gamma.abs())
    } else {
        r0 * fz_mx * k(LMX) * inner
    };

    // Rolling resistance moment (pac2002::rolling_my).
    let fz_my = fz_unlimited
        .lt(fzmin)
        .select(fz_unlimited.sq() / fzmin, fz_unlimited);
    let v_rel = vx / k(LONGVL);
    let v_rel_sq = v_rel * v_rel;
    let my = if mf6 {
        let fz0 = k(FNOMIN);
        let fz_rel = fz_my / fz0;
        let load_power = fz_rel.map(|x| if x > 0.0 { x.powf(k(QSY7)) } else { 0.0 });
        -(r0 * fz0
            * k(LMY)
            * (k(QSY1)
                + k(QSY2) * fx / fz0
                + k(QSY3) * v_rel.abs()
                + k(QSY4) * (v_rel_sq * v_rel_sq)
                + (k(QSY5) + k(QSY6) * fz_rel) * gamma.sq())
            * (load_power * p_ratio.map(|x| x.powf(k(QSY8)))))
    } else {
        -(r0 * fz_my
            * (k(QSY1)
                + k(QSY2) * fx / k(FNOMIN)
                + k(QSY3) * v_rel.abs()
                + k(QSY4) * (v_rel_sq * v_rel_sq))
            * k(LMY))
    };
    let my = vx.lt(0.0).select(-my, my);
    let my = vx.eq(0.0).select(zero, my);

    let outputs = Outputs {
        fx,
        fy,
        mx,
        my,
        mz,
        mux,
        muy: muy.abs(),
        kxk,
        kya,
        trail,
        mzr,
    };
    (outputs, scalar)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::random::SplitMix64;
    use crate::tire_model::Pac2002;
    use crate::tire_model::test_support::*;

    /// Largest `|fast - scalar| / max(|scalar|, 1)` per output over `points`.
    fn worst_vs_scalar(tire: &Pac2002, points: &[SlipInput], mode: Mode) -> [f64; 11] {
        let pressures = vec![tire.default_pressure_pa(); points.len()];
        worst_vs_scalar_at(tire, points, &pressures, mode)
    }

    /// [`worst_vs_scalar`] at one pressure per point.
    fn worst_vs_scalar_at(
        tire: &Pac2002,
        points: &[SlipInput],
        pressures: &[f64],
        mode: Mode,
    ) -> [f64; 11] {
        let mut fast = vec![Evaluation::default(); points.len()];
        eval_batch(
            &tire.coefs,
            tire.trail_peak,
            tire.version,
            points,
            Pressures::PerPoint(pressures),
            mode,
            &mut fast,
        );
        let mut worst = [0.0f64; 11];
        for ((p, f), pa) in points.iter().zip(&fast).zip(pressures) {
            let s = tire.eval_at(p, *pa, mode);
            for (w, (a, b)) in worst
                .iter_mut()
                .zip(outputs(f).into_iter().zip(outputs(&s)))
            {
                assert!(a.is_finite() == b.is_finite(), "{p:?}: {a} vs {b}");
                *w = w.max((a - b).abs() / b.abs().max(1.0));
            }
        }
        worst
    }

    /// Every 7th point made an edge lane (drawn with `seed`): zero load, below FZMIN, zero slip,
    /// standstill, low or reverse speed.
    fn add_edge_lanes(points: &mut [SlipInput], seed: u64, fnomin_n: f64) {
        let mut rng = SplitMix64::new(seed);
        for p in points.iter_mut().step_by(7) {
            match rng.next_u64() % 7 {
                0 => p.fz_n = 0.0,
                1 => p.fz_n = rng.uniform_in(0.0, 0.1) * fnomin_n,
                2 => p.kappa = 0.0,
                3 => p.alpha_rad = 0.0,
                4 => p.vx_mps = 0.0,
                5 => p.vx_mps = rng.uniform_in(-1.5, 1.5),
                _ => p.vx_mps = -p.vx_mps,
            }
        }
    }

    /// The 11 outputs compared, in one order.
    fn outputs(e: &Evaluation<f64>) -> [f64; 11] {
        [
            e.fx_n,
            e.fy_n,
            e.mx_nm,
            e.my_nm,
            e.mz_nm,
            e.mux,
            e.muy,
            e.kxk_n,
            e.kya_n_per_rad,
            e.trail_m,
            e.mzr_nm,
        ]
    }

    fn assert_close(name: &str, worst: [f64; 11]) {
        assert_close_within(name, worst, 1e-12);
    }

    fn assert_close_within(name: &str, worst: [f64; 11], tol: f64) {
        let shown: Vec<String> = worst.iter().map(|w| format!("{w:.1e}")).collect();
        eprintln!("{name}: worst relative difference fast vs scalar {shown:?}");
        assert!(worst.iter().all(|w| *w <= tol), "{name}: {worst:?}");
    }

    #[test]
    fn fast_batch_matches_scalar_on_reference_grids() {
        let fsae = Pac2002::new(coefs_from_tir(FSAE_DEMO_TIR));
        let sample = Pac2002::new(coefs_from_tir(MFEVAL_SAMPLE_TIR));
        for (name, tire, csv, mode) in [
            ("fsae-demo 111", &fsae, FSAE_DEMO_COMBINED_111, Mode::Limits),
            (
                "mfeval-sample 111",
                &sample,
                MFEVAL_SAMPLE_COMBINED_111,
                Mode::Limits,
            ),
            (
                "mfeval-sample 211",
                &sample,
                MFEVAL_SAMPLE_COMBINED_211,
                Mode::Raw,
            ),
        ] {
            let rows = reference_rows(csv);
            let points: Vec<SlipInput> = rows.iter().map(|r| r.input).collect();
            assert_close(name, worst_vs_scalar(tire, &points, mode));
            // And directly against MFeval, at issue 2's 1e-9.
            let mut fast = vec![Evaluation::default(); points.len()];
            tire.eval_batch(&points, mode, &mut fast);
            let mut worst: f64 = 0.0;
            for (row, e) in rows.iter().zip(&fast) {
                let ours = [e.fx_n, e.fy_n, e.mx_nm, e.my_nm, e.mz_nm];
                for (a, b) in ours.iter().zip(row.outputs) {
                    worst = worst.max((a - b).abs() / b.abs().max(1.0));
                }
            }
            eprintln!("{name}: eval_batch vs MFeval, worst relative error {worst:.1e}");
            assert!(worst <= 1e-9, "{name}: eval_batch vs MFeval {worst:e}");
        }
    }

    /// The baseline and AVX2 builds give the same bits (no fused multiply-add).
    #[test]
    fn every_instruction_set_gives_the_same_bits() {
        let tire = Pac2002::new(coefs_from_tir(MFEVAL_SAMPLE_TIR));
        let points = random_points(4 * LANES + 3, 21, tire.coefs[FNOMIN]);
        let run = |f: &dyn Fn(&mut [Evaluation<f64>])| {
            let mut out = vec![Evaluation::default(); points.len()];
            f(&mut out);
            out.iter()
                .map(|e| outputs(e).map(f64::to_bits))
                .collect::<Vec<_>>()
        };
        let base = run(&|o| {
            eval_batch_lanes(
                &tire.coefs,
                tire.trail_peak,
                tire.version,
                &points,
                Pressures::Uniform(tire.default_pressure_pa()),
                Mode::Limits,
                o,
            )
        });
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: AVX2 present (checked).
                let avx2 = run(&|o| unsafe {
                    eval_batch_avx2(
                        &tire.coefs,
                        tire.trail_peak,
                        tire.version,
                        &points,
                        Pressures::Uniform(tire.default_pressure_pa()),
                        Mode::Limits,
                        o,
                    )
                });
                assert!(base == avx2, "AVX2 build differs from baseline");
            }
        }
    }

    /// Batches shorter than, equal to and just past one block (padding of the last block).
    #[test]
    fn fast_batch_handles_every_length() {
        let tire = Pac2002::new(coefs_from_tir(FSAE_DEMO_TIR));
        let points = random_points(2 * LANES + 1, 9, tire.coefs[FNOMIN]);
        for n in [0, 1, 5, LANES - 1, LANES, LANES + 1, 2 * LANES + 1] {
            assert_close(
                &format!("{n} points"),
                worst_vs_scalar(&tire, &points[..n], Mode::Limits),
            );
        }
    }

    /// Issue 19: MF 6.1 tires (MFeval's sample and the book values) at per-point pressures
    /// 0.5..1.5 NOMPRES (outside the sample's PRESMIN..PRESMAX too), both modes, edge lanes.
    /// The bound is 1e-11, not 1e-12: the sample's `Mx` is a difference of terms up to 5e4 N m
    /// (`QSX4 = 11.4`, `QSX8 = 4.5`, `R0 Fz` ~ 5e3 N m), so one ulp of `sin`/`cos` in one term is
    /// ~1e-11 N m on an `Mx` of ~1 N m (measured: 4e-12).
    #[test]
    fn mf61_fast_batch_matches_scalar_on_a_dense_random_grid() {
        for (name, tir) in [
            ("mf61-sample", MF61_SAMPLE_TIR),
            ("mf61-book", MF61_BOOK_TIR),
        ] {
            let tire = model_from_tir(tir);
            assert!(tire.version.is_mf6());
            let n = 100_000;
            let mut points = random_points(n, 6, tire.coefs[FNOMIN]);
            let pressures = random_pressures(n, 7, tire.coefs[NOMPRES], 0.5, 1.5);
            add_edge_lanes(&mut points, 18, tire.coefs[FNOMIN]);
            for mode in [Mode::Limits, Mode::Raw] {
                assert_close_within(
                    &format!("{name} {mode:?}"),
                    worst_vs_scalar_at(&tire, &points, &pressures, mode),
                    1e-11,
                );
            }
        }
    }

    #[test]
    fn fast_batch_matches_scalar_on_a_dense_random_grid() {
        for (name, tir) in [
            ("fsae-demo", FSAE_DEMO_TIR),
            ("mfeval-sample", MFEVAL_SAMPLE_TIR),
        ] {
            let tire = Pac2002::new(coefs_from_tir(tir));
            let mut points = random_points(200_000, 5, tire.coefs[FNOMIN]);
            add_edge_lanes(&mut points, 17, tire.coefs[FNOMIN]);
            for mode in [Mode::Limits, Mode::Raw] {
                assert_close(
                    &format!("{name} {mode:?}"),
                    worst_vs_scalar(&tire, &points, mode),
                );
            }
        }
    }
}
