//! Steady-state Magic Formula evaluation in ISO-W axes, PAC2002 / MF 5.2 and MF 6.1 / 6.2, as
//! MFeval 4.3.1 evaluates them (`docs/pac2002-equations.md` sections 3-10 for PAC2002; MFeval's
//! `Solver.m` for the MF 6.x forms).
//!
//! In: a coefficient vector ([`Coefs`]), the model [`Version`] (data, not a second copy of the
//! code: the few equations whose form differs branch on it), operating points ([`SlipInput`]:
//! `Fz` N, `kappa`, `alpha` rad, `gamma` rad, `Vx` m/s, all ISO-W) and, for MF 6.x, the
//! inflation pressure (Pa). Out: forces and moments ([`Evaluation`]: `Fx`, `Fy`, `Mx`, `My`, `Mz`
//! plus the diagnostics MFeval reports). Every equation is generic over [`Real`], so the same
//! code gives values (`f64`) and exact coefficient derivatives ([`super::real::Dual`]); the
//! per-family functions ([`pure_fy0`], [`combined_fx`], ...) let a fitter evaluate only what it
//! fits. [`load`] and [`evaluate`] are the PAC2002 entry points; [`load_with`] and
//! [`evaluate_with`] take the version and pressure.
//!
//! MF 6.x differs from PAC2002 in: pressure `dpi = (p - NOMPRES)/NOMPRES` in `mu_x`, `Kx`
//! (`PPX1..4`), `mu_y`, `Ky_alpha`, camber stiffness (`PPY1..5`), `Dt` (`PPZ1`), `Dr` (`PPZ2`),
//! `Mx` (`PPMX1`) and `My` (`(p/p0)^QSY8`); `Ky_alpha` with `PKY4`, `PKY5`; the camber shift
//! `SHy` from the camber stiffness `Kyg0` (`PKY6`, `PKY7`) instead of `PHY3`; `PEY5`; `RBX3`,
//! `RBY4`; `QDZ10/11` in `Dr`; `QSX12..14` in `Mx`; `QSY5..8` in `My`; `LKYC`/`LKZC` on the
//! camber terms; and `Mz` with `Fy' = Gyk Fy0(gamma = 0)` in place of `Fy - SVyk`. In limits mode
//! the pressure is clipped to `[PRESMIN, PRESMAX]`. No turn slip (MFeval useMode xx1).
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
//! - MF 6.x relaxation lengths are `|Kx / Cx|` and `|Ky / Cy|` with the structural stiffnesses
//!   (`LONGITUDINAL_STIFFNESS`, `PCFX1..3`, ...), as MFeval reports them.
//!
//! Deliberately not here: turn slip, MFeval's near-locked-wheel fade of `My` (`kappa` within
//! `VXLOW/|Vx|` of -1; no TTC test comes near a locked wheel), transient dynamics,
//! loaded/effective radius.

use std::f64::consts::{FRAC_2_PI, PI};

use super::params::{Coef, Coef::*, Coefs};
use super::real::Real;
use super::version::Version;

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
    /// The equation forms to follow.
    pub version: Version,
    /// Normalised inflation pressure change `(p - NOMPRES)/NOMPRES` (MF 6.x; 0 for PAC2002).
    pub dpi: f64,
    /// `p / NOMPRES` (MF 6.x; 1 for PAC2002).
    pub p_ratio: f64,
}

/// Sign with `sgn(0) = 0`.
#[inline]
pub(crate) fn sgn(x: f64) -> f64 {
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
pub(crate) fn sgn_pos(x: f64) -> f64 {
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

/// Input limiting and the load quantities (`docs` sections 3-4), PAC2002.
#[inline(always)]
pub fn load<T: Real>(c: &Coefs<T>, input: &SlipInput, mode: Mode) -> Load<T> {
    load_with(c, input, mode, Version::Pac2002, f64::NAN)
}

/// The inflation pressure the equations see: clipped to `[PRESMIN, PRESMAX]` in limits mode
/// (NaN limits, MFeval's reading of a blank value, clip nothing).
#[inline]
pub fn limited_pressure(c_presmin: f64, c_presmax: f64, p_pa: f64, mode: Mode) -> f64 {
    let mut p = p_pa;
    if mode == Mode::Limits {
        if p < c_presmin {
            p = c_presmin;
        }
        if p > c_presmax {
            p = c_presmax;
        }
    }
    p
}

/// Input limiting and the load quantities for `version` at inflation pressure `p_pa` (ignored by
/// PAC2002).
#[inline(always)]
pub fn load_with<T: Real>(
    c: &Coefs<T>,
    input: &SlipInput,
    mode: Mode,
    version: Version,
    p_pa: f64,
) -> Load<T> {
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
    let (dpi, p_ratio) = if version.is_mf6() {
        let p = limited_pressure(v(PRESMIN), v(PRESMAX), p_pa, mode);
        let p0 = v(NOMPRES);
        ((p - p0) / p0, p / p0)
    } else {
        (0.0, 1.0)
    };
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
        version,
        dpi,
        p_ratio,
    }
}

/// `1 + a dpi + b dpi^2` (a pressure factor of MF 6.x).
#[inline(always)]
fn pressure_poly<T: Real>(a: T, b: T, dpi: f64) -> T {
    a * dpi + b * (dpi * dpi) + 1.0
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
    let mf6 = l.version.is_mf6();
    let mux = if l.fz.value() == 0.0 {
        T::cst(0.0)
    } else {
        let mut base = c[PDX1] + c[PDX2] * dfz;
        if mf6 {
            base *= pressure_poly(c[PPX3], c[PPX4], l.dpi);
        }
        base * (-(c[PDX3] * gx.sq()) + 1.0) * c[LMUX]
    };
    let dx = mux * l.fz;
    let mut kxk = l.fz * (c[PKX1] + c[PKX2] * dfz) * (c[PKX3] * dfz).exp();
    if mf6 {
        kxk *= pressure_poly(c[PPX1], c[PPX2], l.dpi);
    }
    let kxk = kxk * c[LKX];
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

impl<T: Copy> PureFy<T> {
    /// Every factor through `f` (e.g. `f64` factors lifted into dual-number constants).
    #[inline(always)]
    pub fn map<U>(&self, f: impl Fn(T) -> U) -> PureFy<U> {
        PureFy {
            fy0: f(self.fy0),
            muy: f(self.muy),
            kya: f(self.kya),
            by: f(self.by),
            cy: f(self.cy),
            shy: f(self.shy),
            svy: f(self.svy),
        }
    }
}

/// `Fy0(alpha)` at the load `l`.
#[inline(always)]
pub fn pure_fy0<T: Real>(c: &Coefs<T>, l: &Load<T>) -> PureFy<T> {
    if l.version.is_mf6() {
        return pure_fy0_mf6(c, l);
    }
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

/// MF 6.x `Fy0(alpha)`: pressure terms, `Ky_alpha` with `PKY4`/`PKY5`, the camber shift from
/// the camber stiffness `Kyg0 = Fz (PKY6 + PKY7 dfz)(1 + PPY5 dpi) LKYC`, `PEY5`.
#[inline(always)]
fn pure_fy0_mf6<T: Real>(c: &Coefs<T>, l: &Load<T>) -> PureFy<T> {
    let dfz = l.dfz;
    let g = l.gamma;
    let cy = c[PCY1] * c[LCY];
    let muy = if l.fz.value() == 0.0 {
        T::cst(0.0)
    } else {
        (c[PDY1] + c[PDY2] * dfz)
            * pressure_poly(c[PPY3], c[PPY4], l.dpi)
            * (-(c[PDY3] * g.sq()) + 1.0)
            * c[LMUY]
    };
    let dy = muy * l.fz;
    let kya = c[PKY1]
        * l.fz0_scaled
        * (c[PPY1] * l.dpi + 1.0)
        * (-(c[PKY3] * g.abs()) + 1.0)
        * (c[PKY4]
            * ((l.fz / l.fz0_scaled) / ((c[PKY2] + c[PKY5] * g.sq()) * (c[PPY2] * l.dpi + 1.0)))
                .atan())
        .sin()
        * c[LKY];
    let svyg = l.fz * (c[PVY3] + c[PVY4] * dfz) * g * c[LKYC] * c[LMUY];
    let kyg0 = l.fz * (c[PKY6] + c[PKY7] * dfz) * (c[PPY5] * l.dpi + 1.0) * c[LKYC];
    let kya_prime = kya + EPS * sgn_pos(kya.value());
    let shy = ((c[PHY1] + c[PHY2] * dfz) * c[LHY] + (kyg0 * g - svyg) / kya_prime) * l.low_speed;
    let svy = (l.fz * (c[PVY1] + c[PVY2] * dfz) * c[LVY] * c[LMUY] + svyg) * l.low_speed;
    let ay = l.alpha + shy;
    let ey = (c[PEY1] + c[PEY2] * dfz)
        * (c[PEY5] * g.sq() + 1.0 - (c[PEY3] + c[PEY4] * g) * sgn_pos(ay.value()))
        * c[LEY];
    let ey = clamp_e(ey, l.clamp_e);
    let by = kya / (cy * dy + EPS * sgn_pos(dy.value()));
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

/// The same load with zero inclination (MF 6.x evaluates `Mz`'s lateral force at `gamma = 0`).
#[inline(always)]
fn without_camber<T: Real>(l: &Load<T>) -> Load<T> {
    Load {
        gamma: T::cst(0.0),
        ..*l
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
    let mf6 = l.version.is_mf6();
    let mut peak = c[QDZ1] + c[QDZ2] * dfz;
    if mf6 {
        peak *= -(c[PPZ1] * l.dpi) + 1.0;
    }
    let peak = peak * (c[QDZ3] * gz + c[QDZ4] * gz.sq() + 1.0) * (r0 / l.fz0_scaled) * c[LTR];
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
    let camber_peak = if mf6 {
        ((c[QDZ8] + c[QDZ9] * dfz) * (c[PPZ2] * l.dpi + 1.0)
            + (c[QDZ10] + c[QDZ11] * dfz) * gz.abs())
            * gz
            * c[LKZC]
    } else {
        (c[QDZ8] + c[QDZ9] * dfz) * gz
    };
    let dr = l.fz_low
        * r0
        * ((c[QDZ6] + c[QDZ7] * dfz) * c[LRES] + camber_peak)
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
    pure_mz0_given(l, tt, fy.fy0)
}

/// The lateral force pure `Mz0`'s trail multiplies: PAC2002's `Fy0`; MF 6.x's at zero
/// inclination, `Mz0 = -t0 Fy0(gamma = 0) + Mzr0`.
#[inline(always)]
pub fn mz0_trail_force<T: Real>(c: &Coefs<T>, l: &Load<T>, fy: &PureFy<T>) -> T {
    if l.version.is_mf6() {
        pure_fy0(c, &without_camber(l)).fy0
    } else {
        fy.fy0
    }
}

/// Pure aligning moment `Mz0 = -t0 fy_trail + Mzr0` given the trail's lateral force
/// ([`mz0_trail_force`]), N m.
#[inline(always)]
pub fn pure_mz0_given<T: Real>(l: &Load<T>, tt: &TrailTerms<T>, fy_trail: T) -> T {
    let t0 = trail(tt, tt.alpha_t) * l.low_speed;
    let mzr0 = tt.dr * (tt.br * tt.alpha_r).cos_atan() * l.low_speed;
    -(t0 * fy_trail) + mzr0
}

/// Combined-slip longitudinal force `Fx = Gxa Fx0` (`docs` section 8.1), N.
#[inline(always)]
pub fn combined_fx<T: Real>(c: &Coefs<T>, l: &Load<T>, fx0: T) -> T {
    gxa(c, l) * fx0
}

/// The combined-slip reduction `Gxa` of `Fx0` by slip angle.
#[inline(always)]
pub fn gxa<T: Real>(c: &Coefs<T>, l: &Load<T>) -> T {
    let rbx = if l.version.is_mf6() {
        c[RBX1] + c[RBX3] * l.gamma.sq()
    } else {
        c[RBX1]
    };
    let bxa = rbx * (c[RBX2] * l.kappa).cos_atan() * c[LXAL];
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

/// The combined-slip reduction `Gyk` of `Fy0` by longitudinal slip.
#[inline(always)]
pub fn gyk<T: Real>(c: &Coefs<T>, l: &Load<T>) -> T {
    let rby = if l.version.is_mf6() {
        c[RBY1] + c[RBY4] * l.gamma.sq()
    } else {
        c[RBY1]
    };
    let byk = rby * (c[RBY2] * (l.alpha - c[RBY3])).cos_atan() * c[LYKA];
    let cyk = c[RCY1];
    let eyk = clamp_e(c[REY1] + c[REY2] * l.dfz, l.clamp_e);
    let shyk = c[RHY1] + c[RHY2] * l.dfz;
    weighting(byk, cyk, eyk, l.kappa + shyk) / weighting(byk, cyk, eyk, shyk)
}

/// Combined-slip lateral force at the load `l`, given the pure lateral force factors.
#[inline(always)]
pub fn combined_fy<T: Real>(c: &Coefs<T>, l: &Load<T>, fy: &PureFy<T>) -> CombinedFy<T> {
    let dfz = l.dfz;
    let gy = l.gamma * c[LGAY];
    let gyk = gyk(c, l);
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

/// Combined-slip aligning moment, given the combined forces and the trail terms. MF 6.x
/// replaces PAC2002's `Fy - SVyk` by `Fy' = Gyk Fy0(gamma = 0)` (evaluated here).
#[inline(always)]
pub fn combined_mz<T: Real>(
    c: &Coefs<T>,
    l: &Load<T>,
    kxk: T,
    tt: &TrailTerms<T>,
    fx: T,
    fy: &CombinedFy<T>,
) -> CombinedMz<T> {
    combined_mz_given(c, l, kxk, tt, fx, fy.fy, mz_trail_force(c, l, fy))
}

/// The lateral force combined `Mz`'s trail multiplies: PAC2002's `Fy - SVyk`, MF 6.x's
/// `Fy' = Gyk Fy0(gamma = 0)`.
#[inline(always)]
pub fn mz_trail_force<T: Real>(c: &Coefs<T>, l: &Load<T>, fy: &CombinedFy<T>) -> T {
    if l.version.is_mf6() {
        gyk(c, l) * pure_fy0(c, &without_camber(l)).fy0
    } else {
        fy.fy - fy.svyk
    }
}

/// Combined-slip aligning moment given `Kx_kappa`, the trail terms, the combined forces `fx`,
/// `fy` and the trail's lateral force ([`mz_trail_force`]). Reads only the coefficients of the
/// trail, residual torque and arm (`SSZ*`) beyond `l` and the given values.
#[inline(always)]
pub fn combined_mz_given<T: Real>(
    c: &Coefs<T>,
    l: &Load<T>,
    kxk: T,
    tt: &TrailTerms<T>,
    fx: T,
    fy: T,
    fy_trail: T,
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
        * (c[SSZ1] + c[SSZ2] * (fy / c[FNOMIN]) + (c[SSZ3] + c[SSZ4] * l.dfz) * gz)
        * c[LS];
    CombinedMz {
        mz: -(t * fy_trail) + mzr + s * fx,
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
    if !l.version.is_mf6() {
        return c[UNLOADED_RADIUS] * fz * c[LMX] * inner;
    }
    // MF 6.x (TNO equation manual): the camber term scales with pressure, plus QSX12..14.
    let inner = inner - c[QSX2] * gamma * (c[PPMX1] * l.dpi);
    c[UNLOADED_RADIUS] * fz * c[LMX] * inner
        + c[UNLOADED_RADIUS]
            * c[LMX]
            * (fy * (c[QSX13] + c[QSX14] * gamma.abs()) - fz * c[QSX12] * gamma * gamma.abs())
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
    let my = if l.version.is_mf6() {
        // MF 6.x (Besselink et al. 2010, A48): Fz0 outside, load and pressure as powers.
        let fz0 = c[FNOMIN];
        let fz_rel = fz / fz0;
        let load_power = if fz_rel.value() > 0.0 {
            fz_rel.powf(c[QSY7])
        } else {
            T::cst(0.0)
        };
        -(c[UNLOADED_RADIUS]
            * fz0
            * c[LMY]
            * (c[QSY1]
                + c[QSY2] * fx / fz0
                + c[QSY3] * v_rel.abs()
                + c[QSY4] * v_rel.powi(4)
                + (c[QSY5] + c[QSY6] * fz_rel) * l.gamma.sq())
            * (load_power * T::cst(l.p_ratio).powf(c[QSY8])))
    } else {
        -(c[UNLOADED_RADIUS]
            * fz
            * (c[QSY1]
                + c[QSY2] * fx / c[FNOMIN]
                + c[QSY3] * v_rel.abs()
                + c[QSY4] * v_rel.powi(4))
            * c[LMY])
    };
    if l.vx < 0.0 { -my } else { my }
}

/// Everything at one operating point: combined forces and moments plus diagnostics (PAC2002).
pub fn evaluate<T: Real>(
    c: &Coefs<T>,
    input: &SlipInput,
    mode: Mode,
    trail_peak: TrailPeak,
) -> Evaluation<T> {
    evaluate_loaded(c, &load(c, input, mode), trail_peak)
}

/// Everything at one operating point of a `version` model at inflation pressure `p_pa`
/// (ignored by PAC2002).
pub fn evaluate_with<T: Real>(
    c: &Coefs<T>,
    input: &SlipInput,
    mode: Mode,
    trail_peak: TrailPeak,
    version: Version,
    p_pa: f64,
) -> Evaluation<T> {
    evaluate_loaded(c, &load_with(c, input, mode, version, p_pa), trail_peak)
}

/// Every output at a prepared load.
#[inline(always)]
fn evaluate_loaded<T: Real>(c: &Coefs<T>, l: &Load<T>, trail_peak: TrailPeak) -> Evaluation<T> {
    let px = pure_fx0(c, l);
    let py = pure_fy0(c, l);
    let tt = trail_terms(c, l, &py, trail_peak);
    let fx = combined_fx(c, l, px.fx0);
    let fy = combined_fy(c, l, &py);
    let mz = combined_mz(c, l, px.kxk, &tt, fx, &fy);
    Evaluation {
        fx_n: fx,
        fy_n: fy.fy,
        mx_nm: overturning_mx(c, l, fy.fy),
        my_nm: rolling_my(c, l, fx),
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

/// MF 6.x relaxation lengths `(|Kx_kappa / Cx|, |Ky_alpha / Cy|)` in m, with the structural
/// stiffnesses `Cx = LONGITUDINAL_STIFFNESS (1 + PCFX1 dfz + PCFX2 dfz^2)(1 + PCFX3 dpi)` (and
/// `Cy` likewise), at load `fz_n`, inclination `gamma_rad` and pressure `p_pa` (no limiting).
pub fn relaxation_lengths_mf6(c: &Coefs<f64>, fz_n: f64, gamma_rad: f64, p_pa: f64) -> (f64, f64) {
    let input = SlipInput {
        fz_n,
        kappa: 0.0,
        alpha_rad: 0.0,
        gamma_rad,
        vx_mps: c[LONGVL],
    };
    let l = load_with(c, &input, Mode::Raw, Version::Mf61, p_pa);
    let kxk = pure_fx0(c, &l).kxk;
    let kya = pure_fy0(c, &l).kya;
    let dfz = l.dfz;
    let cx = c[LONGITUDINAL_STIFFNESS]
        * (1.0 + c[PCFX1] * dfz + c[PCFX2] * dfz * dfz)
        * (1.0 + c[PCFX3] * l.dpi);
    let cy = c[LATERAL_STIFFNESS]
        * (1.0 + c[PCFY1] * dfz + c[PCFY2] * dfz * dfz)
        * (1.0 + c[PCFY3] * l.dpi);
    ((kxk / cx).abs(), (kya / cy).abs())
}

/// Which inflation pressure `MagicFormula` evaluates at.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Pressures<'a> {
    /// The same pressure (Pa) at every point.
    Uniform(f64),
    /// One pressure (Pa) per point (as long as the points).
    PerPoint(&'a [f64]),
}

impl Pressures<'_> {
    /// The pressure of point `i`.
    #[inline]
    pub fn at(&self, i: usize) -> f64 {
        match self {
            Pressures::Uniform(p) => *p,
            Pressures::PerPoint(p) => p[i],
        }
    }
}

/// A Magic Formula tire: coefficients, the model version they belong to, and the trail-peak
/// variant they were fitted with (PAC2002 only).
#[derive(Clone, Debug, PartialEq)]
pub struct MagicFormula {
    /// Every coefficient (see [`super::params::Coef`]); keys the version does not carry hold
    /// their defaults.
    pub coefs: Coefs<f64>,
    /// PAC2002 / MF 5.2, MF 6.1 or MF 6.2.
    pub version: Version,
    /// Standard PAC2002 unless deliberately fitted with the thesis variant.
    pub trail_peak: TrailPeak,
}

/// The PAC2002 name of [`MagicFormula`] (what PAC2002 code builds with [`MagicFormula::new`]).
pub type Pac2002 = MagicFormula;

impl MagicFormula {
    /// A standard PAC2002 tire from its coefficients.
    pub fn new(coefs: Coefs<f64>) -> Self {
        MagicFormula {
            coefs,
            version: Version::Pac2002,
            trail_peak: TrailPeak::Standard,
        }
    }

    /// A `version` tire; keys the version does not carry are reset to their defaults.
    pub fn with_version(coefs: Coefs<f64>, version: Version) -> Self {
        MagicFormula {
            coefs: coefs.restricted_to(version),
            version,
            trail_peak: TrailPeak::Standard,
        }
    }

    /// The pressure used when none is given, Pa: `INFLPRES`, else `NOMPRES` (MF 6.x); NaN for
    /// PAC2002, which has no pressure terms.
    pub fn default_pressure_pa(&self) -> f64 {
        if !self.version.is_mf6() {
            return f64::NAN;
        }
        let p = self.coefs[INFLPRES];
        if p > 0.0 { p } else { self.coefs[NOMPRES] }
    }

    /// Forces, moments and diagnostics at one point, at the default pressure.
    pub fn eval(&self, input: &SlipInput, mode: Mode) -> Evaluation<f64> {
        self.eval_at(input, self.default_pressure_pa(), mode)
    }

    /// Forces, moments and diagnostics at one point and inflation pressure `p_pa` (PAC2002
    /// ignores it).
    pub fn eval_at(&self, input: &SlipInput, p_pa: f64, mode: Mode) -> Evaluation<f64> {
        evaluate_with(
            &self.coefs,
            input,
            mode,
            self.trail_peak,
            self.version,
            p_pa,
        )
    }

    /// How far `fitted` is from this model over `points` (rolling at this model's `LONGVL`,
    /// limits mode): the RMS difference as % of this model's largest `|value|` there, `[Fx, Fy,
    /// Mz]`. Both are evaluated at `p_pa`, or each at its own default pressure when `None`. How a
    /// fit is scored against a known truth over the envelope the data tested.
    pub fn rms_error_pct_of_peak(
        &self,
        fitted: &MagicFormula,
        points: &[SlipInput],
        p_pa: Option<f64>,
    ) -> [f64; 3] {
        let (p_self, p_fitted) = match p_pa {
            Some(p) => (p, p),
            None => (self.default_pressure_pa(), fitted.default_pressure_pa()),
        };
        let vx = self.coefs[LONGVL];
        let mut ss = [0.0; 3];
        let mut peak = [0.0_f64; 3];
        for pt in points {
            let pt = SlipInput { vx_mps: vx, ..*pt };
            let t = self.eval_at(&pt, p_self, Mode::Limits);
            let f = fitted.eval_at(&pt, p_fitted, Mode::Limits);
            for (k, (a, b)) in [(t.fx_n, f.fx_n), (t.fy_n, f.fy_n), (t.mz_nm, f.mz_nm)]
                .into_iter()
                .enumerate()
            {
                ss[k] += (b - a).powi(2);
                peak[k] = peak[k].max(a.abs());
            }
        }
        let n = points.len() as f64;
        std::array::from_fn(|k| 100.0 * (ss[k] / n).sqrt() / peak[k])
    }

    /// Combined-slip forces and moments at a vertical load (N), slip angle (rad), longitudinal
    /// slip, inclination (rad) and inflation pressure (Pa), rolling at the reference speed
    /// `LONGVL`, limits mode: the call for "what does this tire do at 11 psi".
    pub fn forces(
        &self,
        fz_n: f64,
        alpha_rad: f64,
        kappa: f64,
        gamma_rad: f64,
        p_pa: f64,
    ) -> Evaluation<f64> {
        let input = SlipInput {
            fz_n,
            kappa,
            alpha_rad,
            gamma_rad,
            vx_mps: self.coefs[LONGVL],
        };
        self.eval_at(&input, p_pa, Mode::Limits)
    }

    /// Evaluate many points at the default pressure; `out` must be as long as `inputs`.
    ///
    /// Runs the structure-of-arrays evaluator (`batch.rs`): several points at a time with
    /// polynomial elementary functions. Every output equals [`MagicFormula::eval`]'s to within
    /// `1e-12` relative to `max(|value|, 1)` (measured: a few `1e-15`), not bit for bit.
    ///
    /// # Panics
    /// If `out.len() != inputs.len()`.
    pub fn eval_batch(&self, inputs: &[SlipInput], mode: Mode, out: &mut [Evaluation<f64>]) {
        self.eval_batch_at(
            inputs,
            Pressures::Uniform(self.default_pressure_pa()),
            mode,
            out,
        );
    }

    /// [`MagicFormula::eval_batch`] at the given pressures (PAC2002 ignores them).
    ///
    /// # Panics
    /// If `out.len() != inputs.len()`, or per-point pressures are not as long as `inputs`.
    pub fn eval_batch_at(
        &self,
        inputs: &[SlipInput],
        pressures: Pressures<'_>,
        mode: Mode,
        out: &mut [Evaluation<f64>],
    ) {
        assert_eq!(inputs.len(), out.len(), "eval_batch: output length");
        if let Pressures::PerPoint(p) = pressures {
            assert_eq!(p.len(), inputs.len(), "eval_batch: pressures length");
        }
        super::batch::eval_batch(
            &self.coefs,
            self.trail_peak,
            self.version,
            inputs,
            pressures,
            mode,
            out,
        );
    }

    /// Relaxation lengths `(sigma_kappa, sigma_alpha)`, m, at the default pressure.
    pub fn relaxation_lengths(&self, fz_n: f64, gamma_rad: f64) -> (f64, f64) {
        self.relaxation_lengths_at(fz_n, gamma_rad, self.default_pressure_pa())
    }

    /// Relaxation lengths `(sigma_kappa, sigma_alpha)`, m, at pressure `p_pa` (PAC2002's
    /// `PTX*`/`PTY*` laws ignore it).
    pub fn relaxation_lengths_at(&self, fz_n: f64, gamma_rad: f64, p_pa: f64) -> (f64, f64) {
        if self.version.is_mf6() {
            relaxation_lengths_mf6(&self.coefs, fz_n, gamma_rad, p_pa)
        } else {
            relaxation_lengths(&self.coefs, fz_n, gamma_rad)
        }
    }
}
