//! Steady-state PAC2002 / Magic Formula 5.2 evaluation in ISO-W axes, as MFeval 4.3.1 evaluates
//! it (`docs/pac2002-equations.md` sections 3-10).
//!
//! In: a coefficient vector ([`Coefs`]) and operating points ([`SlipInput`]: `Fz` N, `kappa`,
//! `alpha` rad, `gamma` rad, `Vx` m/s, all ISO-W). Out: forces and moments ([`Evaluation`]: `Fx`,
//! `Fy`, `Mx`, `My`, `Mz` plus the diagnostics MFeval reports). Every equation is generic over
//! [`Real`], so the same code gives values (`f64`) and exact coefficient derivatives
//! ([`super::real::Dual`]); the per-family functions ([`pure_fy0`], [`combined_fx`], ...) let a
//! fitter evaluate only what it fits.
//!
//! Choices (all MFeval's, so results match it to round-off):
//! - `alpha* = alpha`, `gamma* = gamma` (MFeval useMode 1x1, TNO); no turn slip.
//! - [`Mode::Limits`] = useMode 111: inputs clipped to the file's ranges, `Fz_low = max(Fz, FZMIN)`
//!   in the trail and residual-torque peaks, every curvature factor `E <= 1`, low-speed blending
//!   below `VXLOW`. [`Mode::Raw`] = useMode 211: none of that.
//! - Combined `Mz` uses the tan-form equivalent slip angles, `Fy - SVyk`, and `t * LFZO`.
//! - `Mx` is the form with `QSX4..QSX11` (it collapses to the PAC2002 core form with MFeval's
//!   defaults); `Mx` and `My` taper their load below `FZMIN` as MFeval does.
//! - Camber scalings `LGAX/LGAY/LGAZ` are applied as PAC2002 defines them (`gamma_x = gamma*LGAX`
//!   in `mu_x`, `gamma_y` in `Fy0` and `SVyk`, `gamma_z` in `Mz`); MFeval ignores them, so results
//!   are identical whenever they are 1 (every reference file).
//!
//! Deliberately not here: MFeval's near-locked-wheel fade of `My` (`kappa` within `VXLOW/|Vx|`
//! of -1; no TTC test comes near a locked wheel), transient dynamics, loaded/effective radius.

use std::f64::consts::{FRAC_2_PI, PI};

use super::params::{Coef, Coef::*, Coefs};
use super::real::Real;

/// MFeval's `epsilon` guarding divisions (`epsx = epsy = epsk = epsv = 1e-6`).
pub const EPS: f64 = 1e-6;

/// Input limiting, as MFeval's `useMode` hundreds digit.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub enum Mode {
    /// useMode 111: clip inputs to the `.tir` ranges, clamp every `E` to `<= 1`, low-speed blend.
    #[default]
    Limits,
    /// useMode 211: evaluate the equations as they stand (an `E > 1` then gives nonsense).
    Raw,
}

/// How the peak of the pneumatic trail `Dt` depends on load.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub enum TrailPeak {
    /// PAC2002: `Dt = Fz (QDZ1 + QDZ2 dfz)(1 + QDZ3 gz + QDZ4 gz^2) R0/Fz0' LTR`.
    #[default]
    Standard,
    /// The thesis's variant (seed section 8.2, appendix D.2): the leading `Fz` factor dropped,
    /// `Dt = (QDZ1 + QDZ2 dfz)(1 + QDZ3 gz + QDZ4 gz^2) R0/Fz0' LTR`. Coefficients fitted this
    /// way are NOT standard PAC2002 and must never be written to a `.tir` as if they were.
    ThesisWithoutFz,
}

/// One operating point, ISO-W axes, SI units.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct SlipInput {
    /// Vertical load, N, positive in compression.
    pub fz_n: f64,
    /// Longitudinal slip (positive driving, -1 locked).
    pub kappa: f64,
    /// Slip angle, rad (ISO-W: positive gives negative `Fy` on a normal tire).
    pub alpha_rad: f64,
    /// Inclination angle, rad.
    pub gamma_rad: f64,
    /// Longitudinal speed of the wheel centre, m/s.
    pub vx_mps: f64,
}

/// Forces, moments and diagnostics at one operating point (ISO-W, SI).
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct Evaluation<T> {
    /// Longitudinal force, N (combined slip).
    pub fx_n: T,
    /// Lateral force, N (combined slip).
    pub fy_n: T,
    /// Overturning moment, N m.
    pub mx_nm: T,
    /// Rolling resistance moment, N m (negative when rolling forward).
    pub my_nm: T,
    /// Aligning moment, N m (combined slip).
    pub mz_nm: T,
    /// Peak longitudinal friction coefficient `mu_x`.
    pub mux: T,
    /// Peak lateral friction coefficient as MFeval reports it: `|mu_y|`.
    pub muy: T,
    /// Longitudinal slip stiffness `dFx0/dkappa` at `kappa_x = 0`, N.
    pub kxk_n: T,
    /// Cornering stiffness `dFy0/dalpha` at `alpha_y = 0`, N/rad (negative for a normal tire).
    pub kya_n_per_rad: T,
    /// Combined-slip pneumatic trail `t`, m.
    pub trail_m: T,
    /// Combined-slip residual torque `Mzr`, N m.
    pub mzr_nm: T,
}

/// Operating point after input limiting, plus the load quantities every family uses.
#[derive(Copy, Clone, Debug)]
pub struct Load<T> {
    /// Load used in the force equations (clipped to `FZMAX` in limits mode), N.
    pub fz: T,
    /// `max(Fz, FZMIN)` in limits mode (trail and residual-torque peaks), else `fz`.
    pub fz_low: T,
    /// Load before clipping (used by `My`), N.
    pub fz_unlimited: T,
    /// Scaled nominal load `Fz0' = LFZO FNOMIN`, N.
    pub fz0_scaled: T,
    /// Normalised load change `(Fz - Fz0')/Fz0'`.
    pub dfz: T,
    /// Longitudinal slip after limiting (and low-speed scaling).
    pub kappa: T,
    /// Slip angle after limiting (and low-speed scaling), rad.
    pub alpha: T,
    /// Inclination after limiting, rad.
    pub gamma: T,
    /// Longitudinal speed, m/s.
    pub vx: f64,
    /// Low-speed weight (1 above `VXLOW`; MFeval's cosine blend below it in limits mode).
    pub low_speed: f64,
    /// Curvature factors clamped to `<= 1`?
    pub clamp_e: bool,
}

/// Sign with `sgn(0) = 0`.
#[inline]
fn sgn(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// Sign with `sgn(0) = +1` (protects divisions; also MFeval's choice in `Ey`).
#[inline]
fn sgn_pos(x: f64) -> f64 {
    if x < 0.0 { -1.0 } else { 1.0 }
}

/// Apply the `E <= 1` clamp when limiting is on.
#[inline]
fn clamp_e<T: Real>(e: T, on: bool) -> T {
    if on { e.min_cst(1.0) } else { e }
}

/// The Magic Formula sine: `D sin(C atan(B x - E (B x - atan(B x))))`.
#[inline]
pub fn magic_formula<T: Real>(b: T, c: T, d: T, e: T, x: T) -> T {
    let bx = b * x;
    d * (c * (bx - e * (bx - bx.atan())).atan()).sin()
}

/// The combined-slip weighting kernel `cos(C atan(B x - E (B x - atan(B x))))`.
#[inline]
pub fn weighting<T: Real>(b: T, c: T, e: T, x: T) -> T {
    let bx = b * x;
    (c * (bx - e * (bx - bx.atan())).atan()).cos()
}

/// Input limiting and the load quantities (`docs` sections 3-4).
#[inline(always)]
pub fn load<T: Real>(c: &Coefs<T>, input: &SlipInput, mode: Mode) -> Load<T> {
    let limits = mode == Mode::Limits;
    let v = |k: Coef| Real::value(c[k]);
    let fz_unlimited = input.fz_n.max(0.0);
    let (mut kappa, mut alpha, gamma, fz, fz_low) = if limits {
        let fz = fz_unlimited.min(v(FZMAX));
        (
            input.kappa.clamp(v(KPUMIN), v(KPUMAX)),
            input.alpha_rad.clamp(v(ALPMIN), v(ALPMAX)),
            input.gamma_rad.clamp(v(CAMMIN), v(CAMMAX)),
            fz,
            fz.max(v(FZMIN)),
        )
    } else {
        (
            input.kappa,
            input.alpha_rad,
            input.gamma_rad,
            fz_unlimited,
            fz_unlimited,
        )
    };
    let vx = input.vx_mps;
    let vxlow = v(VXLOW);
    let mut low_speed = 1.0;
    if limits && vx.abs() <= vxlow && vxlow > 0.0 {
        low_speed = 1.0 - 0.5 * (1.0 + (PI * vx / vxlow).cos());
        kappa *= vx.abs() / vxlow;
        let vsy = alpha.tan() * vx.abs();
        let blend = (vx.abs() + vsy.abs()) / vxlow;
        if blend < 1.0 {
            alpha *= blend;
        }
    }
    let fz0_scaled = c[FNOMIN] * c[LFZO];
    let fz_t = T::cst(fz);
    Load {
        fz: fz_t,
        fz_low: T::cst(fz_low),
        fz_unlimited: T::cst(fz_unlimited),
        fz0_scaled,
        dfz: (fz_t - fz0_scaled) / fz0_scaled,
        kappa: T::cst(kappa),
        alpha: T::cst(alpha),
        gamma: T::cst(gamma),
        vx,
        low_speed,
        clamp_e: limits,
    }
}

/// Pure longitudinal force and its factors (`docs` section 5).
#[derive(Copy, Clone, Debug)]
pub struct PureFx<T> {
    /// `Fx0`, N.
    pub fx0: T,
    /// `mu_x`.
    pub mux: T,
    /// `Kx_kappa`, N.
    pub kxk: T,
}

/// `Fx0(kappa)` at the load `l`.
#[inline(always)]
pub fn pure_fx0<T: Real>(c: &Coefs<T>, l: &Load<T>) -> PureFx<T> {
    let dfz = l.dfz;
    let gx = l.gamma * c[LGAX];
    let cx = c[PCX1] * c[LCX];
    let mux = if l.fz.value() == 0.0 {
        T::cst(0.0)
    } else {
        (c[PDX1] + c[PDX2] * dfz) * (-(c[PDX3] * gx.sq()) + 1.0) * c[LMUX]
    };
    let dx = mux * l.fz;
    let kxk = l.fz * (c[PKX1] + c[PKX2] * dfz) * (c[PKX3] * dfz).exp() * c[LKX];
    let bx = kxk / (cx * dx + EPS * sgn_pos(dx.value()));
    let shx = (c[PHX1] + c[PHX2] * dfz) * c[LHX] * l.low_speed;
    let svx = l.fz * (c[PVX1] + c[PVX2] * dfz) * c[LVX] * c[LMUX] * l.low_speed;
    let kx = l.kappa + shx;
    let ex = (c[PEX1] + c[PEX2] * dfz + c[PEX3] * dfz.sq())
        * (-(c[PEX4] * sgn(kx.value())) + 1.0)
        * c[LEX];
    let ex = clamp_e(ex, l.clamp_e);
    let mut fx0 = magic_formula(bx, cx, dx, ex, kx) + svx;
    if l.vx < 0.0 {
        fx0 = -fx0;
    }
    PureFx { fx0, mux, kxk }
}

/// Pure lateral force and the factors `Mz` reuses (`docs` section 6).
#[derive(Copy, Clone, Debug)]
pub struct PureFy<T> {
    /// `Fy0`, N.
    pub fy0: T,
    /// Signed `mu_y` (negative when `PDY1 < 0`).
    pub muy: T,
    /// `Ky_alpha`, N/rad.
    pub kya: T,
    /// `By`.
    pub by: T,
    /// `Cy`.
    pub cy: T,
    /// `SHy`, rad.
    pub shy: T,
    /// `SVy`, N.
    pub svy: T,
}

/// `Fy0(alpha)` at the load `l`.
#[inline(always)]
pub fn pure_fy0<T: Real>(c: &Coefs<T>, l: &Load<T>) -> PureFy<T> {
    let dfz = l.dfz;
    let gy = l.gamma * c[LGAY];
    let cy = c[PCY1] * c[LCY];
    let muy = if l.fz.value() == 0.0 {
        T::cst(0.0)
    } else {
        (c[PDY1] + c[PDY2] * dfz) * (-(c[PDY3] * gy.sq()) + 1.0) * c[LMUY]
    };
    let dy = muy * l.fz;
    let kya = c[PKY1]
        * l.fz0_scaled
        * (l.fz / (c[PKY2] * l.fz0_scaled)).sin_2atan()
        * (-(c[PKY3] * gy.abs()) + 1.0)
        * c[LKY];
    let by = kya / (cy * dy + EPS * sgn_pos(dy.value()));
    let shy = ((c[PHY1] + c[PHY2] * dfz) * c[LHY] + c[PHY3] * gy) * l.low_speed;
    let svy = l.fz
        * ((c[PVY1] + c[PVY2] * dfz) * c[LVY] + (c[PVY3] + c[PVY4] * dfz) * gy)
        * c[LMUY]
        * l.low_speed;
    let ay = l.alpha + shy;
    let ey = (c[PEY1] + c[PEY2] * dfz)
        * (-((c[PEY3] + c[PEY4] * gy) * sgn_pos(ay.value())) + 1.0)
        * c[LEY];
    let ey = clamp_e(ey, l.clamp_e);
    let fy0 = magic_formula(by, cy, dy, ey, ay) + svy;
    PureFy {
        fy0,
        muy,
        kya,
        by,
        cy,
        shy,
        svy,
    }
}

/// Trail and residual-torque factors shared by pure and combined `Mz` (`docs` section 7).
#[derive(Copy, Clone, Debug)]
pub struct TrailTerms<T> {
    /// `alpha_t = alpha + SHt`, rad.
    pub alpha_t: T,
    /// `Bt`.
    pub bt: T,
    /// `Ct`.
    pub ct: T,
    /// `Dt`, m.
    pub dt: T,
    /// `Et` (evaluated at `alpha_t`, clamped in limits mode).
    pub et: T,
    /// `alpha_r = alpha + SHf`, rad.
    pub alpha_r: T,
    /// `Br`.
    pub br: T,
    /// `Dr`, N m.
    pub dr: T,
    /// `cos(alpha')`.
    pub cos_alpha_prime: f64,
    /// `Ky_alpha' = Ky_alpha + eps sgn(Ky_alpha)`, N/rad.
    pub kya_prime: T,
}

/// Trail and residual-torque factors at the load `l`, given the pure lateral force factors.
#[inline(always)]
pub fn trail_terms<T: Real>(
    c: &Coefs<T>,
    l: &Load<T>,
    fy: &PureFy<T>,
    trail_peak: TrailPeak,
) -> TrailTerms<T> {
    let dfz = l.dfz;
    let gz = l.gamma * c[LGAZ];
    let r0 = c[UNLOADED_RADIUS];
    let sht = c[QHZ1] + c[QHZ2] * dfz + (c[QHZ3] + c[QHZ4] * dfz) * gz;
    let alpha_t = l.alpha + sht;
    let bt = (c[QBZ1] + c[QBZ2] * dfz + c[QBZ3] * dfz.sq())
        * (c[QBZ4] * gz + c[QBZ5] * gz.abs() + 1.0)
        * c[LKY]
        / c[LMUY];
    let ct = c[QCZ1];
    let peak = (c[QDZ1] + c[QDZ2] * dfz)
        * (c[QDZ3] * gz + c[QDZ4] * gz.sq() + 1.0)
        * (r0 / l.fz0_scaled)
        * c[LTR];
    let dt = match trail_peak {
        TrailPeak::Standard => l.fz_low * peak,
        TrailPeak::ThesisWithoutFz => peak,
    };
    let et = (c[QEZ1] + c[QEZ2] * dfz + c[QEZ3] * dfz.sq())
        * ((c[QEZ4] + c[QEZ5] * gz) * (bt * ct * alpha_t).atan() * FRAC_2_PI + 1.0);
    let et = clamp_e(et, l.clamp_e);
    let alpha = l.alpha.value();
    let vsy = alpha.tan() * l.vx.abs();
    let vc = (l.vx * l.vx + vsy * vsy).sqrt();
    let cos_alpha_prime = l.vx / (vc + EPS);
    let kya_prime = fy.kya + EPS * sgn_pos(fy.kya.value());
    let alpha_r = l.alpha + fy.shy + fy.svy / kya_prime;
    let br = c[QBZ9] * c[LKY] / c[LMUY] + c[QBZ10] * fy.by * fy.cy;
    let dr = l.fz_low
        * r0
        * ((c[QDZ6] + c[QDZ7] * dfz) * c[LRES] + (c[QDZ8] + c[QDZ9] * dfz) * gz)
        * c[LMUY]
        * (sgn(l.vx) * alpha.cos());
    TrailTerms {
        alpha_t,
        bt,
        ct,
        dt,
        et,
        alpha_r,
        br,
        dr,
        cos_alpha_prime,
        kya_prime,
    }
}

/// Pneumatic trail at a (possibly equivalent) trail slip angle `alpha_t`, m.
#[inline]
fn trail<T: Real>(tt: &TrailTerms<T>, alpha_t: T) -> T {
    let bx = tt.bt * alpha_t;
    tt.dt * (tt.ct * (bx - tt.et * (bx - bx.atan())).atan()).cos() * tt.cos_alpha_prime
}

/// Pure aligning moment `Mz0 = -t0 Fy0 + Mzr0`, N m.
#[inline(always)]
pub fn pure_mz0<T: Real>(l: &Load<T>, fy: &PureFy<T>, tt: &TrailTerms<T>) -> T {
    let t0 = trail(tt, tt.alpha_t) * l.low_speed;
    let mzr0 = tt.dr * (tt.br * tt.alpha_r).cos_atan() * l.low_speed;
    -(t0 * fy.fy0) + mzr0
}

/// Combined-slip longitudinal force `Fx = Gxa Fx0` (`docs` section 8.1), N.
#[inline(always)]
pub fn combined_fx<T: Real>(c: &Coefs<T>, l: &Load<T>, fx0: T) -> T {
    gxa(c, l) * fx0
}

/// The combined-slip reduction `Gxa` of `Fx0` by slip angle.
#[inline(always)]
pub fn gxa<T: Real>(c: &Coefs<T>, l: &Load<T>) -> T {
    let bxa = c[RBX1] * (c[RBX2] * l.kappa).cos_atan() * c[LXAL];
    let cxa = c[RCX1];
    let exa = clamp_e(c[REX1] + c[REX2] * l.dfz, l.clamp_e);
    let shxa = c[RHX1];
    weighting(bxa, cxa, exa, l.alpha + shxa) / weighting(bxa, cxa, exa, shxa)
}

/// Combined-slip lateral force and its slip-induced part (`docs` section 8.2).
#[derive(Copy, Clone, Debug)]
pub struct CombinedFy<T> {
    /// `Fy = Gyk Fy0 + SVyk`, N.
    pub fy: T,
    /// `SVyk`, N.
    pub svyk: T,
}

/// Combined-slip lateral force at the load `l`, given the pure lateral force factors.
#[inline(always)]
pub fn combined_fy<T: Real>(c: &Coefs<T>, l: &Load<T>, fy: &PureFy<T>) -> CombinedFy<T> {
    let dfz = l.dfz;
    let gy = l.gamma * c[LGAY];
    let byk = c[RBY1] * (c[RBY2] * (l.alpha - c[RBY3])).cos_atan() * c[LYKA];
    let cyk = c[RCY1];
    let eyk = clamp_e(c[REY1] + c[REY2] * dfz, l.clamp_e);
    let shyk = c[RHY1] + c[RHY2] * dfz;
    let gyk = weighting(byk, cyk, eyk, l.kappa + shyk) / weighting(byk, cyk, eyk, shyk);
    let dvyk =
        fy.muy * l.fz * (c[RVY1] + c[RVY2] * dfz + c[RVY3] * gy) * (c[RVY4] * l.alpha).cos_atan();
    let svyk = dvyk * (c[RVY5] * (c[RVY6] * l.kappa).atan()).sin() * c[LVYKA] * l.low_speed;
    CombinedFy {
        fy: gyk * fy.fy0 + svyk,
        svyk,
    }
}

/// Combined-slip aligning moment and its parts (`docs` section 8.3).
#[derive(Copy, Clone, Debug)]
pub struct CombinedMz<T> {
    /// `Mz = -t (Fy - SVyk) + Mzr + s Fx`, N m.
    pub mz: T,
    /// Pneumatic trail `t`, m.
    pub trail: T,
    /// Residual torque `Mzr`, N m.
    pub mzr: T,
}

/// Combined-slip aligning moment, given the combined forces and the trail terms.
#[inline(always)]
pub fn combined_mz<T: Real>(
    c: &Coefs<T>,
    l: &Load<T>,
    kxk: T,
    tt: &TrailTerms<T>,
    fx: T,
    fy: &CombinedFy<T>,
) -> CombinedMz<T> {
    let (alpha_t_eq, alpha_r_eq) = if l.kappa.value() == 0.0 {
        // atan(sqrt(tan^2 a)) sgn(a) = a exactly; skipping the square root keeps derivatives
        // finite at a = 0.
        (tt.alpha_t, tt.alpha_r)
    } else {
        let ratio_kappa_sq = (kxk / tt.kya_prime).sq() * l.kappa.sq();
        let eq = |a: T| (a.tan().sq() + ratio_kappa_sq).sqrt().atan() * sgn(a.value());
        (eq(tt.alpha_t), eq(tt.alpha_r))
    };
    let t = trail(tt, alpha_t_eq) * c[LFZO] * l.low_speed;
    let mzr = tt.dr * (tt.br * alpha_r_eq).cos_atan() * l.low_speed;
    let gz = l.gamma * c[LGAZ];
    let s = c[UNLOADED_RADIUS]
        * (c[SSZ1] + c[SSZ2] * (fy.fy / c[FNOMIN]) + (c[SSZ3] + c[SSZ4] * l.dfz) * gz)
        * c[LS];
    CombinedMz {
        mz: -(t * (fy.fy - fy.svyk)) + mzr + s * fx,
        trail: t,
        mzr,
    }
}

/// Overturning moment (`docs` section 9, the form with `QSX4..QSX11`), N m, given combined `Fy`.
#[inline(always)]
pub fn overturning_mx<T: Real>(c: &Coefs<T>, l: &Load<T>, fy: T) -> T {
    let fzmin = c[FZMIN].value();
    let mut fz = l.fz;
    if fz.value() < fzmin {
        fz = fz * (fz / fzmin).sq();
    }
    let fz0 = c[FNOMIN];
    let gamma = l.gamma;
    let fz_rel = fz / fz0;
    let fy_rel = fy / fz0;
    let inner = c[QSX1] * c[LVMX] - c[QSX2] * gamma
        + c[QSX3] * fy_rel
        + c[QSX4]
            * (c[QSX5] * (c[QSX6] * fz_rel).sq().atan()).cos()
            * (c[QSX7] * gamma + c[QSX8] * (c[QSX9] * fy_rel).atan()).sin()
        + c[QSX10] * (c[QSX11] * fz_rel).atan() * gamma;
    c[UNLOADED_RADIUS] * fz * c[LMX] * inner
}

/// Rolling resistance moment (`docs` section 9), N m, given combined `Fx`.
#[inline(always)]
pub fn rolling_my<T: Real>(c: &Coefs<T>, l: &Load<T>, fx: T) -> T {
    if l.vx == 0.0 {
        return T::cst(0.0);
    }
    let fzmin = c[FZMIN].value();
    let mut fz = l.fz_unlimited;
    if fz.value() < fzmin {
        fz = fz.sq() / fzmin;
    }
    let v_rel = l.vx / c[LONGVL].value();
    let my = -(c[UNLOADED_RADIUS]
        * fz
        * (c[QSY1] + c[QSY2] * fx / c[FNOMIN] + c[QSY3] * v_rel.abs() + c[QSY4] * v_rel.powi(4))
        * c[LMY]);
    if l.vx < 0.0 { -my } else { my }
}

/// Everything at one operating point: combined forces and moments plus diagnostics.
pub fn evaluate<T: Real>(
    c: &Coefs<T>,
    input: &SlipInput,
    mode: Mode,
    trail_peak: TrailPeak,
) -> Evaluation<T> {
    let l = load(c, input, mode);
    let px = pure_fx0(c, &l);
    let py = pure_fy0(c, &l);
    let tt = trail_terms(c, &l, &py, trail_peak);
    let fx = combined_fx(c, &l, px.fx0);
    let fy = combined_fy(c, &l, &py);
    let mz = combined_mz(c, &l, px.kxk, &tt, fx, &fy);
    Evaluation {
        fx_n: fx,
        fy_n: fy.fy,
        mx_nm: overturning_mx(c, &l, fy.fy),
        my_nm: rolling_my(c, &l, fx),
        mz_nm: mz.mz,
        mux: px.mux,
        muy: py.muy.abs(),
        kxk_n: px.kxk,
        kya_n_per_rad: py.kya,
        trail_m: mz.trail,
        mzr_nm: mz.mzr,
    }
}

/// Relaxation lengths `(sigma_kappa, sigma_alpha)` in m at load `fz_n` and inclination
/// `gamma_rad` (`docs` section 10; no input limiting).
pub fn relaxation_lengths(c: &Coefs<f64>, fz_n: f64, gamma_rad: f64) -> (f64, f64) {
    let fz0 = c[FNOMIN];
    let fz0_scaled = fz0 * c[LFZO];
    let dfz = (fz_n - fz0_scaled) / fz0_scaled;
    let r0 = c[UNLOADED_RADIUS];
    let sigma_kappa =
        fz_n * (c[PTX1] + c[PTX2] * dfz) * (-c[PTX3] * dfz).exp() * (r0 / fz0) * c[LSGKP];
    let gy = gamma_rad * c[LGAY];
    let sigma_alpha = c[PTY1]
        * (fz_n / (c[PTY2] * fz0_scaled)).sin_2atan()
        * (1.0 - c[PKY3] * gy.abs())
        * r0
        * c[LFZO]
        * c[LSGAL];
    (sigma_kappa, sigma_alpha)
}

/// A PAC2002 tire: coefficients plus the trail-peak variant they were fitted with.
#[derive(Clone, Debug, PartialEq)]
pub struct Pac2002 {
    /// Every coefficient (see [`super::params::Coef`]).
    pub coefs: Coefs<f64>,
    /// Standard PAC2002 unless deliberately fitted with the thesis variant.
    pub trail_peak: TrailPeak,
}

impl Pac2002 {
    /// A standard PAC2002 tire from its coefficients.
    pub fn new(coefs: Coefs<f64>) -> Self {
        Pac2002 {
            coefs,
            trail_peak: TrailPeak::Standard,
        }
    }

    /// Forces, moments and diagnostics at one point.
    pub fn eval(&self, input: &SlipInput, mode: Mode) -> Evaluation<f64> {
        evaluate(&self.coefs, input, mode, self.trail_peak)
    }

    /// Evaluate many points; `out` must be as long as `inputs`.
    ///
    /// Runs the structure-of-arrays evaluator (`batch.rs`): several points at a time with
    /// polynomial elementary functions. Every output equals [`Pac2002::eval`]'s to within
    /// `1e-12` relative to `max(|value|, 1)` (measured: a few `1e-15`), not bit for bit.
    ///
    /// # Panics
    /// If `out.len() != inputs.len()`.
    pub fn eval_batch(&self, inputs: &[SlipInput], mode: Mode, out: &mut [Evaluation<f64>]) {
        assert_eq!(inputs.len(), out.len(), "eval_batch: output length");
        super::batch::eval_batch(&self.coefs, self.trail_peak, inputs, mode, out);
    }

    /// Relaxation lengths `(sigma_kappa, sigma_alpha)`, m.
    pub fn relaxation_lengths(&self, fz_n: f64, gamma_rad: f64) -> (f64, f64) {
        relaxation_lengths(&self.coefs, fz_n, gamma_rad)
    }
}
