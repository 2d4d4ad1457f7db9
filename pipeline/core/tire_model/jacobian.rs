//! Residual-ready channel values and their exact derivatives with respect to chosen coefficients,
//! for the least-squares fitter.
//!
//! In: a [`MagicFormula`] tire (any version), one output [`Channel`] (pure `Fx0`, `Fy0`, `Mz0`; combined `Fx`, `Fy`,
//! `Mz`; `Mx`; `My`), the free coefficients (`&[Coef]`) and operating points. Out: the channel's
//! value at every point and the Jacobian `d value / d coef`, row-major `n_points x n_free`, written
//! into caller-owned slices so a solver iteration allocates nothing. MF 6.x tires take one
//! inflation pressure per point ([`Pressures`]), so one fit can span every tested pressure.
//!
//! Derivatives are forward-mode dual numbers ([`Dual<N>`]) through the same generic equations as
//! the `f64` evaluation, so they are exact up to round-off and follow the branch the value takes
//! (a clamped `E` has zero derivative, `kappa == 0` in combined `Mz` uses `alpha_eq = alpha`).
//! `N` is a compile-time width: the free list is cut into blocks of at most [`MAX_BLOCK`]
//! coefficients and each block runs on the narrowest of `Dual<8|16|32>` that holds it (each
//! width is another copy of the model's equations for the compiler: few widths keep the
//! release build short, at the price of some unused derivative lanes).
//! Only the families a channel needs are evaluated (an `Fy0` Jacobian never touches `Mz`).
//!
//! Deliberately not here: the solver, residual weighting, and derivatives with respect to the
//! input ranges (`KPUMIN` ... `FZMAX`), `VXLOW` and `LONGVL`: the equations use those as
//! plain numbers (limits and switches), so their Jacobian columns are zero.

use super::pac2002::{
    Evaluation, Load, MagicFormula, Mode, Pressures, PureFy, SlipInput, TrailPeak, combined_fx,
    combined_fy, combined_mz_given, load_with, mz_trail_force, mz0_trail_force, overturning_mx,
    pure_fx0, pure_fy0, pure_mz0_given, rolling_my, trail_terms,
};
use super::params::{Coef, Coef::*, Coefs};
use super::real::{Dual, Real};
use super::version::Version;

/// Points per batch-evaluator call in [`MagicFormula::channel_into`] (a stack buffer, no allocation).
const CHANNEL_CHUNK: usize = 256;

/// Widest dual number used; longer free lists are evaluated in blocks of this many coefficients.
pub const MAX_BLOCK: usize = 32;

/// One model output a fit can target.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum Channel {
    /// Pure longitudinal force `Fx0(kappa)`, N (slip angle ignored).
    Fx0,
    /// Pure lateral force `Fy0(alpha)`, N (longitudinal slip ignored).
    Fy0,
    /// Pure aligning moment `Mz0 = -t0 Fy0 + Mzr0`, N m (no `s Fx` term).
    Mz0,
    /// Combined-slip longitudinal force `Fx`, N.
    Fx,
    /// Combined-slip lateral force `Fy`, N.
    Fy,
    /// Combined-slip aligning moment `Mz`, N m.
    Mz,
    /// Overturning moment `Mx`, N m (uses combined `Fy`).
    Mx,
    /// Rolling resistance moment `My`, N m (uses combined `Fx`).
    My,
}

impl Channel {
    /// Every channel, pure first, in the order a staged fit visits them.
    pub const ALL: [Channel; 8] = [
        Channel::Fx0,
        Channel::Fy0,
        Channel::Mz0,
        Channel::Fx,
        Channel::Fy,
        Channel::Mz,
        Channel::Mx,
        Channel::My,
    ];

    /// The coefficients this channel's own equations introduce (its family in a staged fit).
    /// The channel also depends on earlier families (combined `Fy` on the `Fy0` family, `Mz` on
    /// `Fx0`, `Fy0`, `Mz0`, `Fx`, `Fy`), which a staged fit holds fixed; scaling factors are not
    /// listed.
    pub const fn family(self) -> &'static [Coef] {
        match self {
            Channel::Fx0 => &[
                PCX1, PDX1, PDX2, PDX3, PEX1, PEX2, PEX3, PEX4, PKX1, PKX2, PKX3, PHX1, PHX2, PVX1,
                PVX2,
            ],
            Channel::Fy0 => &[
                PCY1, PDY1, PDY2, PDY3, PEY1, PEY2, PEY3, PEY4, PKY1, PKY2, PKY3, PHY1, PHY2, PHY3,
                PVY1, PVY2, PVY3, PVY4,
            ],
            Channel::Mz0 => &[
                QBZ1, QBZ2, QBZ3, QBZ4, QBZ5, QBZ9, QBZ10, QCZ1, QDZ1, QDZ2, QDZ3, QDZ4, QDZ6,
                QDZ7, QDZ8, QDZ9, QEZ1, QEZ2, QEZ3, QEZ4, QEZ5, QHZ1, QHZ2, QHZ3, QHZ4,
            ],
            Channel::Fx => &[RBX1, RBX2, RCX1, REX1, REX2, RHX1],
            Channel::Fy => &[
                RBY1, RBY2, RBY3, RCY1, REY1, REY2, RHY1, RHY2, RVY1, RVY2, RVY3, RVY4, RVY5, RVY6,
            ],
            Channel::Mz => &[SSZ1, SSZ2, SSZ3, SSZ4],
            Channel::Mx => &[
                QSX1, QSX2, QSX3, QSX4, QSX5, QSX6, QSX7, QSX8, QSX9, QSX10, QSX11,
            ],
            Channel::My => &[QSY1, QSY2, QSY3, QSY4],
        }
    }

    /// [`Channel::family`] of a `version` model: MF 6.x adds its pressure and camber terms
    /// (`PPX1..4`, `PEY5`, `PKY4..7`, `PPY1..5`, `QDZ10/11`, `PPZ1/2`, `RBX3`, `RBY4`,
    /// `QSX12..14`, `PPMX1`, `QSY5..8`) and has no `PHY3`.
    pub fn family_for(self, version: Version) -> Vec<Coef> {
        let mut out: Vec<Coef> = self
            .family()
            .iter()
            .copied()
            .filter(|c| c.carried_by(version))
            .collect();
        if version.is_mf6() {
            let extra: &[Coef] = match self {
                Channel::Fx0 => &[PPX1, PPX2, PPX3, PPX4],
                Channel::Fy0 => &[PEY5, PKY4, PKY5, PKY6, PKY7, PPY1, PPY2, PPY3, PPY4, PPY5],
                Channel::Mz0 => &[QDZ10, QDZ11, PPZ1, PPZ2],
                Channel::Fx => &[RBX3],
                Channel::Fy => &[RBY4],
                Channel::Mz => &[],
                Channel::Mx => &[QSX12, QSX13, QSX14, PPMX1],
                Channel::My => &[QSY5, QSY6, QSY7, QSY8],
            };
            out.extend_from_slice(extra);
        }
        out
    }
}

/// The value of one channel at one point of a PAC2002 tire, evaluating only the families it
/// needs.
#[inline(always)]
pub fn channel_value<T: Real>(
    c: &Coefs<T>,
    input: &SlipInput,
    mode: Mode,
    trail_peak: TrailPeak,
    channel: Channel,
) -> T {
    channel_value_with(
        c,
        input,
        mode,
        trail_peak,
        Version::Pac2002,
        f64::NAN,
        channel,
    )
}

/// [`channel_value`] of a `version` tire at inflation pressure `p_pa`.
#[inline(always)]
pub fn channel_value_with<T: Real>(
    c: &Coefs<T>,
    input: &SlipInput,
    mode: Mode,
    trail_peak: TrailPeak,
    version: Version,
    p_pa: f64,
    channel: Channel,
) -> T {
    let l = load_with(c, input, mode, version, p_pa);
    match channel {
        Channel::Fx0 => pure_fx0(c, &l).fx0,
        Channel::Fy0 => pure_fy0(c, &l).fy0,
        Channel::Fx => combined_fx(c, &l, pure_fx0(c, &l).fx0),
        Channel::Fy => combined_fy(c, &l, &pure_fy0(c, &l)).fy,
        Channel::Mz0 | Channel::Mz => {
            let forces = MomentForces::at(c, &l, channel);
            moment_from_forces(c, &l, &forces, trail_peak, channel)
        }
        Channel::Mx => overturning_mx(c, &l, combined_fy(c, &l, &pure_fy0(c, &l)).fy),
        Channel::My => rolling_my(c, &l, combined_fx(c, &l, pure_fx0(c, &l).fx0)),
    }
}

/// Coefficients read only by the trail, residual-torque and arm equations of `Mz0` and `Mz`
/// (never by the load, `Fx` or `Fy` equations): with every free coefficient among them, those
/// forces are constants of the Jacobian ([`MomentForces`], [`moment_from_forces`]).
const MOMENT_OWN: [Coef; 33] = [
    QBZ1, QBZ2, QBZ3, QBZ4, QBZ5, QBZ9, QBZ10, QCZ1, QDZ1, QDZ2, QDZ3, QDZ4, QDZ6, QDZ7, QDZ8,
    QDZ9, QDZ10, QDZ11, QEZ1, QEZ2, QEZ3, QEZ4, QEZ5, QHZ1, QHZ2, QHZ3, QHZ4, PPZ1, PPZ2, SSZ1,
    SSZ2, SSZ3, SSZ4,
];

/// What `Mz0` or `Mz` reads from the load, `Fx` and `Fy` equations at one point. In `f64` (the
/// default, what a solver caches), constants of a Jacobian whose free coefficients are all the
/// moment's own ([`moment_split`]): a solver can compute them once per refinement
/// ([`MagicFormula::moment_forces`]), and each Jacobian lifts them into dual-number constants.
#[derive(Copy, Clone, Debug)]
pub struct MomentForces<T = f64> {
    /// The pure lateral force's factors (trail and residual torque read them).
    py: PureFy<T>,
    /// The lateral force the trail multiplies ([`mz0_trail_force`] or [`mz_trail_force`]), N.
    fy_trail: T,
    /// `Kx_kappa` (combined `Mz` only, else NaN), N.
    kxk: T,
    /// Combined `Fx` (combined `Mz` only, else NaN), N.
    fx: T,
    /// Combined `Fy` (combined `Mz` only, else NaN), N.
    fy: T,
}

impl<T: Real> MomentForces<T> {
    /// The forces `channel` (`Mz0` or `Mz`) reads at the load `l`.
    #[inline(always)]
    pub(crate) fn at(c: &Coefs<T>, l: &Load<T>, channel: Channel) -> MomentForces<T> {
        let py = pure_fy0(c, l);
        if channel == Channel::Mz0 {
            return MomentForces {
                py,
                fy_trail: mz0_trail_force(c, l, &py),
                kxk: T::cst(f64::NAN),
                fx: T::cst(f64::NAN),
                fy: T::cst(f64::NAN),
            };
        }
        debug_assert_eq!(channel, Channel::Mz);
        let px = pure_fx0(c, l);
        let fy = combined_fy(c, l, &py);
        MomentForces {
            py,
            fy_trail: mz_trail_force(c, l, &fy),
            kxk: px.kxk,
            fx: combined_fx(c, l, px.fx0),
            fy: fy.fy,
        }
    }
}

impl<T: Copy> MomentForces<T> {
    /// Every force through `f` (e.g. `f64` forces lifted into dual-number constants).
    #[inline(always)]
    pub(crate) fn map<U>(&self, f: impl Fn(T) -> U) -> MomentForces<U> {
        MomentForces {
            py: self.py.map(&f),
            fy_trail: f(self.fy_trail),
            kxk: f(self.kxk),
            fx: f(self.fx),
            fy: f(self.fy),
        }
    }
}

/// `Mz0` or `Mz` at the load `l` from the forces it reads: the moment's own equations (trail,
/// residual torque, arm `s`), the only ones that read the coefficients of [`MOMENT_OWN`].
#[inline(always)]
pub(crate) fn moment_from_forces<T: Real>(
    c: &Coefs<T>,
    l: &Load<T>,
    forces: &MomentForces<T>,
    trail_peak: TrailPeak,
    channel: Channel,
) -> T {
    let f = forces;
    let tt = trail_terms(c, l, &f.py, trail_peak);
    if channel == Channel::Mz0 {
        return pure_mz0_given(l, &tt, f.fy_trail);
    }
    debug_assert_eq!(channel, Channel::Mz);
    combined_mz_given(c, l, f.kxk, &tt, f.fx, f.fy, f.fy_trail).mz
}

/// True when `channel`'s Jacobian with respect to `free` can take the forces as constants
/// ([`MomentForces`]): `Mz0` or `Mz` with every free coefficient in `MOMENT_OWN` (the
/// `QBZ*`, `QCZ1`, `QDZ*`, `QEZ*`, `QHZ*`, `PPZ*` and `SSZ*` coefficients).
pub fn moment_split(channel: Channel, free: &[Coef]) -> bool {
    matches!(channel, Channel::Mz0 | Channel::Mz) && free.iter().all(|f| MOMENT_OWN.contains(f))
}

impl MagicFormula {
    /// One channel at every point, at the default pressure; `values.len() == points.len()`.
    pub fn channel_into(
        &self,
        channel: Channel,
        points: &[SlipInput],
        mode: Mode,
        values: &mut [f64],
    ) {
        let p = Pressures::Uniform(self.default_pressure_pa());
        self.channel_into_at(channel, points, p, mode, values);
    }

    /// One channel at every point (the residual side of a fit); `values.len() == points.len()`.
    ///
    /// The pure channels run the scalar per-family equations (only the families they need);
    /// the combined channels and `Mx`, `My` need almost the whole model and run the batch
    /// evaluator of [`MagicFormula::eval_batch`] (within `1e-12` relative of the scalar path).
    ///
    /// # Panics
    /// If the lengths differ.
    pub fn channel_into_at(
        &self,
        channel: Channel,
        points: &[SlipInput],
        pressures: Pressures<'_>,
        mode: Mode,
        values: &mut [f64],
    ) {
        assert_eq!(points.len(), values.len(), "channel_into: values length");
        if let Pressures::PerPoint(p) = pressures {
            assert_eq!(p.len(), points.len(), "channel_into: pressures length");
        }
        let pick: fn(&Evaluation<f64>) -> f64 = match channel {
            Channel::Fx0 | Channel::Fy0 | Channel::Mz0 => {
                for (i, (p, v)) in points.iter().zip(values.iter_mut()).enumerate() {
                    *v = channel_value_with(
                        &self.coefs,
                        p,
                        mode,
                        self.trail_peak,
                        self.version,
                        pressures.at(i),
                        channel,
                    );
                }
                return;
            }
            Channel::Fx => |e| e.fx_n,
            Channel::Fy => |e| e.fy_n,
            Channel::Mz => |e| e.mz_nm,
            Channel::Mx => |e| e.mx_nm,
            Channel::My => |e| e.my_nm,
        };
        let mut buffer = [Evaluation::default(); CHANNEL_CHUNK];
        for (k, (pts, vals)) in points
            .chunks(CHANNEL_CHUNK)
            .zip(values.chunks_mut(CHANNEL_CHUNK))
            .enumerate()
        {
            let evals = &mut buffer[..pts.len()];
            let chunk_pressures = match pressures {
                Pressures::Uniform(p) => Pressures::Uniform(p),
                Pressures::PerPoint(p) => {
                    Pressures::PerPoint(&p[k * CHANNEL_CHUNK..k * CHANNEL_CHUNK + pts.len()])
                }
            };
            self.eval_batch_at(pts, chunk_pressures, mode, evals);
            for (v, e) in vals.iter_mut().zip(evals.iter()) {
                *v = pick(e);
            }
        }
    }

    /// [`MagicFormula::jacobian_into_at`] at the default pressure.
    pub fn jacobian_into(
        &self,
        channel: Channel,
        free: &[Coef],
        points: &[SlipInput],
        mode: Mode,
        values: &mut [f64],
        jac: &mut [f64],
    ) {
        let p = Pressures::Uniform(self.default_pressure_pa());
        self.jacobian_into_at(channel, free, points, p, mode, values, jac);
    }

    /// One channel at every point and its Jacobian with respect to the `free` coefficients.
    ///
    /// `values[i]` is the channel at `points[i]`; `jac[i * free.len() + j]` is
    /// `d values[i] / d coefs[free[j]]` (row-major `n_points x n_free`; nalgebra:
    /// `DMatrix::from_row_slice(n_points, n_free, jac)`). Any number of free coefficients is
    /// accepted; more than [`MAX_BLOCK`] are evaluated block by block.
    ///
    /// # Panics
    /// If `values.len() != points.len()`, `jac.len() != points.len() * free.len()`, or `free`
    /// names a coefficient twice.
    #[allow(clippy::too_many_arguments)]
    pub fn jacobian_into_at(
        &self,
        channel: Channel,
        free: &[Coef],
        points: &[SlipInput],
        pressures: Pressures<'_>,
        mode: Mode,
        values: &mut [f64],
        jac: &mut [f64],
    ) {
        self.jacobian_into_with(channel, free, points, pressures, mode, None, values, jac);
    }

    /// The forces `Mz0` or `Mz` read at every point ([`MomentForces`]), for
    /// [`MagicFormula::jacobian_into_with`]: a refinement whose free coefficients are all the
    /// moment's own ([`moment_split`]) computes them once instead of in every Jacobian.
    ///
    /// # Panics
    /// If `channel` is not `Mz0` or `Mz`, or the pressures' length differs from the points'.
    pub fn moment_forces(
        &self,
        channel: Channel,
        points: &[SlipInput],
        pressures: Pressures<'_>,
        mode: Mode,
    ) -> Vec<MomentForces> {
        assert!(
            matches!(channel, Channel::Mz0 | Channel::Mz),
            "moment_forces: {channel:?} is not an aligning moment"
        );
        if let Pressures::PerPoint(p) = pressures {
            assert_eq!(p.len(), points.len(), "moment_forces: pressures length");
        }
        points
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let l = load_with(&self.coefs, p, mode, self.version, pressures.at(i));
                MomentForces::at(&self.coefs, &l, channel)
            })
            .collect()
    }

    /// [`MagicFormula::jacobian_into_at`], optionally with the forces of
    /// [`MagicFormula::moment_forces`] computed beforehand by a model that differs from this one
    /// at most in the free coefficients (without them, and whenever [`moment_split`] holds, the
    /// forces are computed here, once for every block).
    ///
    /// # Panics
    /// As [`MagicFormula::jacobian_into_at`]; also if `forces` is given when [`moment_split`]
    /// does not hold, or its length differs from the points'.
    #[allow(clippy::too_many_arguments)]
    pub fn jacobian_into_with(
        &self,
        channel: Channel,
        free: &[Coef],
        points: &[SlipInput],
        pressures: Pressures<'_>,
        mode: Mode,
        forces: Option<&[MomentForces]>,
        values: &mut [f64],
        jac: &mut [f64],
    ) {
        assert_eq!(points.len(), values.len(), "jacobian_into: values length");
        if let Pressures::PerPoint(p) = pressures {
            assert_eq!(p.len(), points.len(), "jacobian_into: pressures length");
        }
        assert_eq!(
            points.len() * free.len(),
            jac.len(),
            "jacobian_into: jacobian length (n_points * n_free)"
        );
        for (i, a) in free.iter().enumerate() {
            assert!(
                !free[..i].contains(a),
                "jacobian_into: coefficient {} listed twice",
                a.name()
            );
        }
        if free.is_empty() {
            self.channel_into_at(channel, points, pressures, mode, values);
            return;
        }
        let n_free = free.len();
        let own;
        let forces = match forces {
            Some(f) => {
                assert!(
                    moment_split(channel, free),
                    "jacobian_into: given forces, but {channel:?} depends on a free force coefficient"
                );
                assert_eq!(f.len(), points.len(), "jacobian_into: forces length");
                Some(f)
            }
            None if moment_split(channel, free) => {
                own = self.moment_forces(channel, points, pressures, mode);
                Some(own.as_slice())
            }
            None => None,
        };
        let rows = Rows {
            points,
            pressures,
            forces,
        };
        for (b, block) in free.chunks(MAX_BLOCK).enumerate() {
            let cols = Columns {
                free: block,
                first: b * MAX_BLOCK,
                n_free,
            };
            match block.len() {
                1..=8 => self.jacobian_block::<8>(channel, cols, rows, mode, values, jac),
                9..=16 => self.jacobian_block::<16>(channel, cols, rows, mode, values, jac),
                _ => self.jacobian_block::<MAX_BLOCK>(channel, cols, rows, mode, values, jac),
            }
        }
    }

    /// [`Self::jacobian_block_inline`] in AVX2 where the CPU has it, else the baseline build
    /// (the dual numbers' derivative arrays are where the time goes; no fused multiply-add is
    /// enabled, so both builds give the same bits).
    fn jacobian_block<const N: usize>(
        &self,
        channel: Channel,
        cols: Columns<'_>,
        rows: Rows<'_>,
        mode: Mode,
        values: &mut [f64],
        jac: &mut [f64],
    ) {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU supports AVX2 (checked just above).
                unsafe { self.jacobian_block_avx2::<N>(channel, cols, rows, mode, values, jac) };
                return;
            }
        }
        self.jacobian_block_inline::<N>(channel, cols, rows, mode, values, jac);
    }

    /// [`Self::jacobian_block_inline`] compiled with AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn jacobian_block_avx2<const N: usize>(
        &self,
        channel: Channel,
        cols: Columns<'_>,
        rows: Rows<'_>,
        mode: Mode,
        values: &mut [f64],
        jac: &mut [f64],
    ) {
        self.jacobian_block_inline::<N>(channel, cols, rows, mode, values, jac);
    }

    /// Values and the Jacobian columns of one block of at most `N` free coefficients.
    #[inline(always)]
    fn jacobian_block_inline<const N: usize>(
        &self,
        channel: Channel,
        cols: Columns<'_>,
        rows: Rows<'_>,
        mode: Mode,
        values: &mut [f64],
        jac: &mut [f64],
    ) {
        debug_assert!(cols.free.len() <= N);
        let mut c: Coefs<Dual<N>> = Coefs(self.coefs.0.map(Dual::cst));
        for (k, &coef) in cols.free.iter().enumerate() {
            c[coef] = Dual::var(self.coefs[coef], k);
        }
        let width = cols.free.len();
        for (i, ((p, v), row)) in rows
            .points
            .iter()
            .zip(values.iter_mut())
            .zip(jac.chunks_exact_mut(cols.n_free))
            .enumerate()
        {
            let p_pa = rows.pressures.at(i);
            let r = if let Some(forces) = rows.forces {
                // The forces are constants of this Jacobian (`moment_split`): only the moment's
                // own equations run in dual numbers.
                let l = load_with(&c, p, mode, self.version, p_pa);
                let forces = forces[i].map(Dual::cst);
                moment_from_forces(&c, &l, &forces, self.trail_peak, channel)
            } else {
                channel_value_with(&c, p, mode, self.trail_peak, self.version, p_pa, channel)
            };
            *v = r.v;
            row[cols.first..cols.first + width].copy_from_slice(&r.d[..width]);
        }
    }
}

/// The operating points of a Jacobian, their inflation pressures and, when the channel's
/// forces are constants of it ([`moment_split`]), those forces.
#[derive(Copy, Clone)]
struct Rows<'a> {
    /// Operating points.
    points: &'a [SlipInput],
    /// Their pressures.
    pressures: Pressures<'a>,
    /// Per point, the forces `Mz0`/`Mz` read (`Some` exactly when the split applies).
    forces: Option<&'a [MomentForces]>,
}

/// Where one block of free coefficients lands in the Jacobian row.
#[derive(Copy, Clone)]
struct Columns<'a> {
    /// The block's coefficients.
    free: &'a [Coef],
    /// Column of `free[0]`.
    first: usize,
    /// Row length (all free coefficients).
    n_free: usize,
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;
    use proptest::test_runner::RngSeed;

    use super::*;
    use crate::tire_model::Pac2002;
    use crate::tire_model::test_support::{
        FSAE_DEMO_TIR, MF61_SAMPLE_TIR, MFEVAL_SAMPLE_TIR, model_from_tir, random_pressures,
    };

    /// Scaling factors added to every free list (most channels depend on a few of them).
    const SCALINGS: [Coef; 10] = [LFZO, LMUX, LMUY, LKX, LKY, LTR, LRES, LS, LMX, LMY];

    /// Every coefficient family `channel` of a PAC2002 tire depends on, plus [`SCALINGS`].
    fn free_for(channel: Channel) -> Vec<Coef> {
        free_for_version(channel, Version::Pac2002)
    }

    /// Every coefficient family `channel` of a `version` tire depends on, plus [`SCALINGS`]
    /// (and MF 6.x's camber scalings).
    fn free_for_version(channel: Channel, version: Version) -> Vec<Coef> {
        use Channel::*;
        let families: &[Channel] = match channel {
            Fx0 => &[Fx0],
            Fy0 => &[Fy0],
            Mz0 => &[Fy0, Mz0],
            Fx => &[Fx0, Fx],
            Fy => &[Fy0, Fy],
            Mz => &[Fx0, Fy0, Mz0, Fx, Fy, Mz],
            Mx => &[Fy0, Fy, Mx],
            My => &[Fx0, Fx, My],
        };
        let mut free: Vec<Coef> = families
            .iter()
            .flat_map(|f| f.family_for(version))
            .collect();
        free.extend(SCALINGS);
        if version.is_mf6() {
            free.extend([LKYC, LKZC]);
        }
        free
    }

    /// Finite-difference step for coefficient value `c`: `1e-5` relative, floor `1e-7`.
    fn step(c: f64) -> f64 {
        1e-5 * c.abs().max(0.01)
    }

    /// Fourth-order central difference `d channel / d coef` at one point.
    fn central_difference(
        tire: &Pac2002,
        coef: Coef,
        p: &SlipInput,
        pressure: f64,
        mode: Mode,
        ch: Channel,
    ) -> f64 {
        let h = step(tire.coefs[coef]);
        let at = |k: f64| {
            let mut c = tire.coefs.clone();
            c[coef] += k * h;
            channel_value_with(&c, p, mode, tire.trail_peak, tire.version, pressure, ch)
        };
        (at(-2.0) - 8.0 * at(-1.0) + 8.0 * at(1.0) - at(2.0)) / (12.0 * h)
    }

    /// Compare the dual Jacobian with finite differences; returns the worst error ratio
    /// `|ad - fd| / allowed` (must be <= 1). Allowed error, per entry:
    /// `1e-7 max(|ad|, |fd|)` (the 5-point stencil's truncation at a 1e-5 relative step is
    /// ~1e-20 relative, so this bounds round-off in the derivative itself) plus
    /// `1e3 eps max(|f|, 1) / h` (round-off of the four evaluations, each accurate to ~100 ulp
    /// of the largest term, amplified by the stencil's `18 / 12h`).
    fn check(tire: &Pac2002, ch: Channel, free: &[Coef], points: &[SlipInput], mode: Mode) -> f64 {
        check_at(tire, ch, free, points, tire.default_pressure_pa(), mode)
    }

    /// [`check`] at one inflation pressure.
    fn check_at(
        tire: &Pac2002,
        ch: Channel,
        free: &[Coef],
        points: &[SlipInput],
        pressure: f64,
        mode: Mode,
    ) -> f64 {
        let n = free.len();
        let mut values = vec![0.0; points.len()];
        let mut jac = vec![0.0; points.len() * n];
        let pressures = Pressures::Uniform(pressure);
        tire.jacobian_into_at(ch, free, points, pressures, mode, &mut values, &mut jac);
        let mut worst: f64 = 0.0;
        for (i, p) in points.iter().enumerate() {
            let f = channel_value_with(
                &tire.coefs,
                p,
                mode,
                tire.trail_peak,
                tire.version,
                pressure,
                ch,
            );
            let scale = f.abs().max(1.0);
            assert!(
                (values[i] - f).abs() <= 1e-13 * scale,
                "{ch:?} value at {p:?}: {} vs f64 path {f}",
                values[i]
            );
            for (j, &coef) in free.iter().enumerate() {
                let ad = jac[i * n + j];
                let fd = central_difference(tire, coef, p, pressure, mode, ch);
                let allowed = 1e-7 * ad.abs().max(fd.abs())
                    + 1e3 * f64::EPSILON * scale / step(tire.coefs[coef]);
                let ratio = (ad - fd).abs() / allowed;
                assert!(
                    ratio <= 1.0,
                    "{ch:?} {mode:?} d/d{}: dual {ad:e} vs central difference {fd:e} \
                     (allowed {allowed:e}) at {p:?}",
                    coef.name()
                );
                worst = worst.max(ratio);
            }
        }
        worst
    }

    /// The FSAE demo and MFeval's MF 5.2 sample (PAC2002), MFeval's MF 6.1 sample.
    fn tire(index: usize) -> Pac2002 {
        model_from_tir([FSAE_DEMO_TIR, MFEVAL_SAMPLE_TIR, MF61_SAMPLE_TIR][index])
    }

    /// A point over (and a little beyond) the tire's envelope, with exact zeros of `kappa` and
    /// `alpha` (branch points) drawn often, low loads below `FZMIN`, low and negative speeds.
    fn point(fnomin: f64) -> impl Strategy<Value = SlipInput> {
        (
            0.02..2.2f64,
            prop_oneof![1 => Just(0.0), 4 => -0.3..0.3f64],
            prop_oneof![1 => Just(0.0), 4 => -0.26..0.26f64],
            -0.03..0.1f64,
            prop_oneof![6 => Just(11.176), 1 => 0.2..30.0f64, 1 => -20.0..-0.5f64],
        )
            .prop_map(move |(fz, kappa, alpha, gamma, vx)| SlipInput {
                fz_n: fz * fnomin,
                kappa,
                alpha_rad: alpha,
                gamma_rad: gamma,
                vx_mps: vx,
            })
    }

    fn case() -> impl Strategy<Value = (usize, Channel, Mode, Vec<f64>, Vec<SlipInput>)> {
        (
            0..2usize,
            proptest::sample::select(Channel::ALL.to_vec()),
            any::<bool>(),
        )
            .prop_flat_map(|(t, ch, raw)| {
                let fnomin = tire(t).coefs[FNOMIN];
                (
                    Just(t),
                    Just(ch),
                    Just(if raw { Mode::Raw } else { Mode::Limits }),
                    proptest::collection::vec(-0.2..0.2f64, free_for(ch).len()),
                    proptest::collection::vec(point(fnomin), 6),
                )
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            cases: 96,
            rng_seed: RngSeed::Fixed(2002),
            failure_persistence: None,
            ..ProptestConfig::default()
        })]

        /// Issue 2: the Jacobian of every channel matches central finite differences, for
        /// reference tires with every free coefficient scaled by a random factor in [0.8, 1.2].
        #[test]
        fn jacobian_matches_finite_differences((t, ch, mode, factors, points) in case()) {
            let mut tire = tire(t);
            let free = free_for(ch);
            for (&coef, f) in free.iter().zip(&factors) {
                tire.coefs[coef] *= 1.0 + f;
            }
            let worst = check(&tire, ch, &free, &points, mode);
            prop_assert!(worst <= 1.0);
        }
    }

    fn mf6_case() -> impl Strategy<Value = (Channel, Mode, f64, Vec<f64>, Vec<SlipInput>)> {
        (
            proptest::sample::select(Channel::ALL.to_vec()),
            any::<bool>(),
            0.6..1.4f64,
        )
            .prop_flat_map(|(ch, raw, p)| {
                let fnomin = tire(2).coefs[FNOMIN];
                (
                    Just(ch),
                    Just(if raw { Mode::Raw } else { Mode::Limits }),
                    Just(p),
                    proptest::collection::vec(
                        -0.2..0.2f64,
                        free_for_version(ch, Version::Mf61).len(),
                    ),
                    proptest::collection::vec(point(fnomin), 6),
                )
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            cases: 96,
            rng_seed: RngSeed::Fixed(61),
            failure_persistence: None,
            ..ProptestConfig::default()
        })]

        /// Issue 19: the same for MF 6.1 (every family with its pressure and camber terms free),
        /// at a random inflation pressure 0.6..1.4 NOMPRES.
        #[test]
        fn mf61_jacobian_matches_finite_differences(
            (ch, mode, p, factors, points) in mf6_case()
        ) {
            let mut tire = tire(2);
            let free = free_for_version(ch, Version::Mf61);
            for (&coef, f) in free.iter().zip(&factors) {
                tire.coefs[coef] *= 1.0 + f;
            }
            let pressure = p * tire.coefs[NOMPRES];
            let worst = check_at(&tire, ch, &free, &points, pressure, mode);
            prop_assert!(worst <= 1.0);
        }
    }

    /// Per-point pressures reach every point: values equal the scalar path at each pressure,
    /// for every channel, over more than one batch chunk (to 1e-11 relative: the sample's `Mx`
    /// cancels terms of ~5e4 N m, so the dual numbers' `a * (1/b)` and the batch's polynomial
    /// `sin`/`cos` differ from the scalar `f64` path by ~1e-12 N m there).
    #[test]
    fn mf61_per_point_pressures() {
        let tire = tire(2);
        let n = CHANNEL_CHUNK + 9;
        let points = crate::tire_model::test_support::random_points(n, 12, tire.coefs[FNOMIN]);
        let pressures = random_pressures(n, 13, tire.coefs[NOMPRES], 0.6, 1.4);
        let free = [PKY1, PPY1, QSY8];
        for ch in Channel::ALL {
            let mut values = vec![0.0; n];
            let mut jac = vec![0.0; n * free.len()];
            let p = Pressures::PerPoint(&pressures);
            tire.jacobian_into_at(ch, &free, &points, p, Mode::Raw, &mut values, &mut jac);
            let mut direct = vec![0.0; n];
            tire.channel_into_at(ch, &points, p, Mode::Raw, &mut direct);
            for i in 0..n {
                let s = channel_value_with(
                    &tire.coefs,
                    &points[i],
                    Mode::Raw,
                    tire.trail_peak,
                    tire.version,
                    pressures[i],
                    ch,
                );
                let tol = 1e-11 * s.abs().max(1.0);
                assert!(
                    (values[i] - s).abs() <= tol,
                    "{ch:?} {i}: {} vs {s}",
                    values[i]
                );
                assert!(
                    (direct[i] - s).abs() <= tol,
                    "{ch:?} {i}: {} vs {s}",
                    direct[i]
                );
            }
        }
    }

    /// Where the `E <= 1` clamp acts (MFeval sample, `Fz = 2 FNOMIN`, braking: `Ex = 1.31`),
    /// the `PEX*` columns are exactly zero in limits mode and not in raw mode; everything else
    /// matches finite differences in both.
    #[test]
    fn jacobian_at_the_e_clamp() {
        let tire = tire(1);
        let p = SlipInput {
            fz_n: 2.0 * tire.coefs[FNOMIN],
            kappa: -0.15,
            alpha_rad: 0.05,
            gamma_rad: 0.0,
            vx_mps: 11.1,
        };
        let free = free_for(Channel::Fx);
        for mode in [Mode::Limits, Mode::Raw] {
            check(&tire, Channel::Fx, &free, &[p], mode);
            let mut values = [0.0];
            let mut jac = vec![0.0; free.len()];
            tire.jacobian_into(Channel::Fx, &free, &[p], mode, &mut values, &mut jac);
            for (coef, d) in free.iter().zip(&jac) {
                if [PEX1, PEX2, PEX3, PEX4].contains(coef) {
                    assert_eq!(
                        *d == 0.0,
                        mode == Mode::Limits,
                        "{mode:?} {}: {d}",
                        coef.name()
                    );
                }
            }
        }
    }

    /// At `kappa == 0` combined `Mz` takes `alpha_eq = alpha`: derivatives stay finite (also at
    /// `alpha == 0`, where the square-root form has none) and match finite differences.
    #[test]
    fn jacobian_at_zero_longitudinal_slip() {
        for t in 0..2 {
            let tire = tire(t);
            let points: Vec<SlipInput> = [0.0, 1e-3, -0.1]
                .iter()
                .map(|&alpha_rad| SlipInput {
                    fz_n: tire.coefs[FNOMIN],
                    kappa: 0.0,
                    alpha_rad,
                    gamma_rad: 0.02,
                    vx_mps: 11.176,
                })
                .collect();
            check(
                &tire,
                Channel::Mz,
                &free_for(Channel::Mz),
                &points,
                Mode::Limits,
            );
        }
    }

    /// `channel_into` (batch evaluator for combined channels) agrees with the scalar
    /// `channel_value` to 1e-12 relative to `max(|value|, 1)`, over more than one chunk.
    #[test]
    fn channel_into_matches_channel_value() {
        for t in 0..2 {
            let tire = tire(t);
            let points = crate::tire_model::test_support::random_points(
                2 * CHANNEL_CHUNK + 7,
                4,
                tire.coefs[FNOMIN],
            );
            let mut values = vec![0.0; points.len()];
            for ch in Channel::ALL {
                tire.channel_into(ch, &points, Mode::Limits, &mut values);
                for (p, v) in points.iter().zip(&values) {
                    let s = channel_value(&tire.coefs, p, Mode::Limits, tire.trail_peak, ch);
                    assert!(
                        (v - s).abs() <= 1e-12 * s.abs().max(1.0),
                        "{ch:?} {p:?}: {v} vs {s}"
                    );
                }
            }
        }
    }

    /// The dispatched (AVX2) Jacobian equals the baseline build bit for bit.
    #[test]
    fn every_instruction_set_gives_the_same_bits() {
        let tire = tire(1);
        let free = free_for(Channel::Mz);
        let block = &free[..16];
        let points = crate::tire_model::test_support::random_points(40, 8, tire.coefs[FNOMIN]);
        let cols = Columns {
            free: block,
            first: 0,
            n_free: block.len(),
        };
        let run = |dispatched: bool| {
            let mut values = vec![0.0; points.len()];
            let mut jac = vec![0.0; points.len() * block.len()];
            let rows = Rows {
                points: &points,
                pressures: Pressures::Uniform(tire.default_pressure_pa()),
                forces: None,
            };
            let args = (Channel::Mz, cols, rows, Mode::Limits);
            if dispatched {
                tire.jacobian_block::<16>(args.0, args.1, args.2, args.3, &mut values, &mut jac);
            } else {
                tire.jacobian_block_inline::<16>(
                    args.0,
                    args.1,
                    args.2,
                    args.3,
                    &mut values,
                    &mut jac,
                );
            }
            values
                .iter()
                .chain(&jac)
                .map(|x| x.to_bits())
                .collect::<Vec<u64>>()
        };
        assert!(run(true) == run(false));
    }

    /// More than `MAX_BLOCK` free coefficients are evaluated block by block; the columns equal a
    /// one-block evaluation of the same coefficients.
    #[test]
    fn blocks_agree_with_a_single_block() {
        let tire = tire(0);
        let free = free_for(Channel::Mz);
        assert!(free.len() > 2 * MAX_BLOCK);
        let points = crate::tire_model::test_support::random_points(16, 3, tire.coefs[FNOMIN]);
        let mut values = vec![0.0; points.len()];
        let mut jac = vec![0.0; points.len() * free.len()];
        tire.jacobian_into(
            Channel::Mz,
            &free,
            &points,
            Mode::Limits,
            &mut values,
            &mut jac,
        );
        for (j, &coef) in free.iter().enumerate() {
            let mut one = vec![0.0; points.len()];
            let mut v = vec![0.0; points.len()];
            tire.jacobian_into(
                Channel::Mz,
                &[coef],
                &points,
                Mode::Limits,
                &mut v,
                &mut one,
            );
            for i in 0..points.len() {
                let full = jac[i * free.len() + j];
                assert!(
                    (full - one[i]).abs() <= 1e-12 * full.abs().max(1e-300),
                    "{}: {full} vs {}",
                    coef.name(),
                    one[i]
                );
            }
        }
    }

    /// With only the moment's own coefficients free, `Mz0` and `Mz` take the split path (load
    /// and forces in `f64`, lifted into dual-number constants): its values and Jacobian equal
    /// the all-dual path's (every force in dual numbers, `channel_value_with`), for PAC2002 and
    /// MF 6.1 tires, both modes, per-point pressures, in blocks of `MAX_BLOCK`, to round-off
    /// (the dual numbers divide as `a * (1/b)`, the `f64` path as `a / b`: an ulp or two in the
    /// forces).
    #[test]
    fn moment_split_matches_the_all_dual_path() {
        let n = 300;
        for t in [0, 1, 2] {
            let tire = tire(t);
            let points = crate::tire_model::test_support::random_points(n, 21, tire.coefs[FNOMIN]);
            let pressures = random_pressures(n, 22, tire.default_pressure_pa(), 0.6, 1.4);
            let own: Vec<Coef> = MOMENT_OWN
                .iter()
                .copied()
                .filter(|c| c.carried_by(tire.version))
                .collect();
            for block in own.chunks(MAX_BLOCK) {
                let mut c: Coefs<Dual<MAX_BLOCK>> = Coefs(tire.coefs.0.map(Dual::cst));
                for (k, &coef) in block.iter().enumerate() {
                    c[coef] = Dual::var(tire.coefs[coef], k);
                }
                for ch in [Channel::Mz0, Channel::Mz] {
                    assert!(moment_split(ch, block), "{ch:?}: the split path must apply");
                    for mode in [Mode::Raw, Mode::Limits] {
                        let mut values = vec![0.0; n];
                        let mut jac = vec![0.0; n * block.len()];
                        let p = Pressures::PerPoint(&pressures);
                        tire.jacobian_into_at(ch, block, &points, p, mode, &mut values, &mut jac);
                        for (i, (p, &p_pa)) in points.iter().zip(&pressures).enumerate() {
                            let (tp, v) = (tire.trail_peak, tire.version);
                            let all = channel_value_with(&c, p, mode, tp, v, p_pa, ch);
                            let split = &jac[i * block.len()..(i + 1) * block.len()];
                            let same = |a: f64, b: f64| {
                                (a - b).abs() <= 1e-12 * a.abs().max(b.abs())
                                    || (a.is_nan() && b.is_nan())
                            };
                            assert!(same(all.v, values[i]), "{t} {ch:?} {mode:?} {p:?}");
                            for ((coef, &a), &b) in block.iter().zip(&all.d).zip(split) {
                                assert!(
                                    same(a, b),
                                    "{t} {ch:?} {mode:?} {}: {a} vs {b}",
                                    coef.name()
                                );
                            }
                        }
                    }
                }
            }
        }
    }
}
