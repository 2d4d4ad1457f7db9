//! The lint's dense checks: every output channel evaluated along slip sweeps the way a vehicle
//! simulation meets the model, judged by what a driver would feel.
//!
//! In: a batch evaluator (the model's public evaluation API, so the checks apply to any model
//! version), the sampled envelope, the families `USE_MODE` uses and the unloaded radius. Out:
//! findings pushed to the [`Linter`] and the number of points evaluated.
//!
//! Sweeps, at every sampled load and inclination: pure slip angle (`kappa = 0`), pure slip
//! ratio (`alpha = 0`) and, for combined files, each slip at half the other's limits. Each sweep
//! is a uniform grid of [`N_BASE`] points plus a fine grid ([`FINE_STEP`] steps within
//! [`FINE_HALF`]) around zero slip and around the zero crossing of the swept force: the centre of
//! the residual torque (`alpha_r = 0`) and of the force curve, where degenerate coefficients hide
//! narrow features that sampled fit points straddle.
//!
//! Checks (all errors):
//! - `spike` / `discontinuity`: a value off the chord through its neighbours `CHORD` either side
//!   by more than [`FORCE_SPIKE`] `Fz` (forces) or [`MOMENT_SPIKE`] `Fz R0` (moments). A smooth
//!   Magic Formula curve bends by far less over 2 mrad (its slip scale `1/B` is ~10-100 mrad):
//!   on the reference files, the supplier layout and fits of real data the worst deviation is
//!   0.004 `Fz` and 0.0011 `Fz R0`, 7x and 18x below the limits. A step (the chord's ends differ
//!   by about twice the deviation and the largest jump between neighbours survives bisection
//!   down to [`STEP_WIDTH`]) is a discontinuity.
//! - `friction-range`: `|F| > MU_MAX Fz` anywhere; `moment-range`: `|Mz| > MZ_MAX Fz R0` or
//!   `|Mx| > MX_MAX Fz R0` (an FSAE tire's aligning moment peaks near 0.1-0.2 `Fz R0`).
//! - `force-sign` (pure sweeps): the force the slip creates, `F(s) - F(0)`, against the ISO-W
//!   convention (`kappa > 0 -> Fx` up, `alpha > 0 -> Fy` down) by more than [`SIGN_TOL`] `Fz`,
//!   or no grip (`max |F(s) - F(0)| < MU_MIN Fz`). The signs of single coefficients (`PDX1`,
//!   `PDY1`) are free: the Magic Formula is unchanged when `B` and `D` flip together.
//! - `non-finite`: NaN or infinite output.
//!
//! Deliberately not here: coefficient-level rules (curvature factors, weighting functions, shape
//! factors: the parent module), oscillation counts (the parent's coarse sweeps).

use super::{Envelope, Families, Linter, Severity, Worst, describe, linspace};
use crate::tire_model::{Evaluation, SlipInput};

/// Evaluates operating points into outputs of the same length (e.g. `Pac2002::eval_batch` in
/// limits mode).
pub type BatchEval<'a> = dyn Fn(&[SlipInput], &mut [Evaluation<f64>]) + 'a;

/// Uniform points per sweep.
pub const N_BASE: usize = 1001;
/// Half width of each fine grid, rad or slip ratio.
pub const FINE_HALF: f64 = 2e-3;
/// Step of the fine grids.
pub const FINE_STEP: f64 = 2e-5;
/// Distance to the chord's end points in the spike test.
pub const CHORD: f64 = 1e-3;
/// Spike limit of forces, fraction of `Fz`.
pub const FORCE_SPIKE: f64 = 0.03;
/// Spike limit of moments, fraction of `Fz R0`.
pub const MOMENT_SPIKE: f64 = 0.02;
/// Largest friction `|F|/Fz`.
pub const MU_MAX: f64 = 4.0;
/// Smallest grip of a pure sweep, `max |F(s) - F(0)| / Fz`.
pub const MU_MIN: f64 = 0.05;
/// Largest `|Mz| / (Fz R0)`.
pub const MZ_MAX: f64 = 1.0;
/// Largest `|Mx| / (Fz R0)`.
pub const MX_MAX: f64 = 1.5;
/// Tolerated wrong-signed slip force in a pure sweep, fraction of `Fz`.
pub const SIGN_TOL: f64 = 0.02;

/// An output channel.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
enum Channel {
    Fx,
    Fy,
    Mz,
    Mx,
}

impl Channel {
    const ALL: [Channel; 4] = [Channel::Fx, Channel::Fy, Channel::Mz, Channel::Mx];

    fn of(self, e: &Evaluation<f64>) -> f64 {
        match self {
            Channel::Fx => e.fx_n,
            Channel::Fy => e.fy_n,
            Channel::Mz => e.mz_nm,
            Channel::Mx => e.mx_nm,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Channel::Fx => "Fx",
            Channel::Fy => "Fy",
            Channel::Mz => "Mz",
            Channel::Mx => "Mx",
        }
    }

    fn is_force(self) -> bool {
        matches!(self, Channel::Fx | Channel::Fy)
    }

    fn unit(self) -> &'static str {
        if self.is_force() { "N" } else { "N m" }
    }

    fn index(self) -> usize {
        self as usize
    }
}

/// One sweep: along `kappa` or `alpha`, the other slip held at `other`.
#[derive(Copy, Clone, Debug)]
struct Sweep {
    along_kappa: bool,
    fz: f64,
    gamma: f64,
    other: f64,
    vx: f64,
}

impl Sweep {
    fn input(&self, s: f64) -> SlipInput {
        let (kappa, alpha) = if self.along_kappa {
            (s, self.other)
        } else {
            (self.other, s)
        };
        SlipInput {
            fz_n: self.fz,
            kappa,
            alpha_rad: alpha,
            gamma_rad: self.gamma,
            vx_mps: self.vx,
        }
    }

    fn pure(&self) -> bool {
        self.other == 0.0
    }

    /// The force the sweep's slip drives and its ISO-W sign per unit of slip.
    fn swept_force(&self) -> (Channel, f64) {
        if self.along_kappa {
            (Channel::Fx, 1.0)
        } else {
            (Channel::Fy, -1.0)
        }
    }
}

/// Violations over every sweep, per channel.
#[derive(Default)]
struct Findings {
    spike: [Option<(Worst, bool)>; 4],
    range: [Option<Worst>; 4],
    sign: [Option<Worst>; 2],
    vanishing: [Option<Worst>; 2],
    non_finite: Option<Worst>,
}

fn hit(slot: &mut Option<Worst>, value: f64, at: &SlipInput) {
    slot.get_or_insert_with(Worst::new)
        .hit(value, at, |a, b| a.abs() > b.abs());
}

/// The dense checks (see the module docs); returns the number of points evaluated.
pub(super) fn run(
    eval: &BatchEval<'_>,
    env: &Envelope,
    fam: Families,
    r0_m: f64,
    n_fz: usize,
    n_gamma: usize,
    l: &mut Linter,
) -> usize {
    let mut found = Findings::default();
    let mut points = 0;
    let (k_lo, k_hi) = env.kappa;
    let (a_lo, a_hi) = env.alpha_rad;
    for fz in linspace(env.fz_n, n_fz) {
        for gamma in linspace(env.gamma_rad, n_gamma) {
            let mut sweeps = Vec::new();
            let mut add = |along_kappa: bool, other: f64| {
                sweeps.push(Sweep {
                    along_kappa,
                    fz,
                    gamma,
                    other,
                    vx: env.vx_mps,
                });
            };
            if fam.fy_mz {
                add(false, 0.0);
                if fam.combined && fam.fx {
                    add(false, 0.5 * k_lo);
                    add(false, 0.5 * k_hi);
                }
            }
            if fam.fx {
                add(true, 0.0);
                if fam.combined && fam.fy_mz {
                    add(true, 0.5 * a_lo);
                    add(true, 0.5 * a_hi);
                }
            }
            for s in &sweeps {
                points += check_sweep(eval, s, env, fam, r0_m, &mut found);
            }
        }
    }
    report(&found, r0_m, l);
    points
}

/// The sweep's slip values: uniform, plus fine grids around zero and `centres`, sorted.
fn grid(range: (f64, f64), centres: &[f64]) -> Vec<f64> {
    let mut x: Vec<f64> = linspace(range, N_BASE).collect();
    let n_fine = (FINE_HALF / FINE_STEP).round() as i64;
    for &c in std::iter::once(&0.0).chain(centres) {
        if !c.is_finite() {
            continue;
        }
        for k in -n_fine..=n_fine {
            let v = c + k as f64 * FINE_STEP;
            if v > range.0 && v < range.1 {
                x.push(v);
            }
        }
    }
    x.sort_by(f64::total_cmp);
    x.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
    x
}

fn evaluate(eval: &BatchEval<'_>, s: &Sweep, x: &[f64]) -> Vec<Evaluation<f64>> {
    let inputs: Vec<SlipInput> = x.iter().map(|v| s.input(*v)).collect();
    let mut out = vec![Evaluation::default(); inputs.len()];
    eval(&inputs, &mut out);
    out
}

/// Where the swept force changes sign, nearest zero slip (`None` when it keeps its sign).
fn zero_crossing(x: &[f64], f: &[f64]) -> Option<f64> {
    let mut best: Option<f64> = None;
    for i in 1..x.len() {
        let (a, b) = (f[i - 1], f[i]);
        if a == 0.0 || a.signum() != b.signum() {
            let t = if b == a { 0.0 } else { a / (a - b) };
            let z = x[i - 1] + t * (x[i] - x[i - 1]);
            if best.is_none_or(|z0| z.abs() < z0.abs()) {
                best = Some(z);
            }
        }
    }
    best
}

/// The largest deviation from the chord through the points `CHORD` either side.
#[derive(Copy, Clone, Debug)]
struct ChordDeviation {
    /// Grid index of the worst point.
    i: usize,
    /// Its deviation.
    d: f64,
    /// The chord's end points.
    j: usize,
    k: usize,
}

fn worst_chord_deviation(x: &[f64], f: &[f64]) -> Option<ChordDeviation> {
    let mut best: Option<ChordDeviation> = None;
    let (mut j, mut k) = (0usize, 0usize);
    for i in 0..x.len() {
        while j + 1 < i && x[i] - x[j + 1] >= CHORD {
            j += 1;
        }
        if x[i] - x[j] < CHORD {
            continue;
        }
        if k < i {
            k = i;
        }
        while k < x.len() && x[k] - x[i] < CHORD {
            k += 1;
        }
        if k >= x.len() {
            break;
        }
        let t = (x[i] - x[j]) / (x[k] - x[j]);
        let d = f[i] - (f[j] + t * (f[k] - f[j]));
        if d.is_finite() && best.is_none_or(|b| d.abs() > b.d.abs()) {
            best = Some(ChordDeviation { i, d, j, k });
        }
    }
    best
}

/// Most bisections of the largest jump when telling a step from a spike.
const BISECTIONS: usize = 12;
/// A jump across an interval this narrow (rad or slip ratio) is a discontinuity: a thousand
/// times narrower than the finest feature of a physical tire curve.
const STEP_WIDTH: f64 = 1e-6;

/// The jump of `ch` across the interval shrunk to [`STEP_WIDTH`] by halvings, each keeping the
/// half that changes more: what remains of a step.
fn bisected_jump(
    eval: &BatchEval<'_>,
    s: &Sweep,
    ch: Channel,
    mut a: (f64, f64),
    mut b: (f64, f64),
) -> f64 {
    for _ in 0..BISECTIONS {
        let xm = 0.5 * (a.0 + b.0);
        if b.0 - a.0 <= STEP_WIDTH || xm <= a.0 || xm >= b.0 {
            break;
        }
        let m = (xm, ch.of(&evaluate(eval, s, &[xm])[0]));
        if (m.1 - a.1).abs() >= (b.1 - m.1).abs() {
            b = m;
        } else {
            a = m;
        }
    }
    (b.1 - a.1).abs()
}

fn check_sweep(
    eval: &BatchEval<'_>,
    s: &Sweep,
    env: &Envelope,
    fam: Families,
    r0_m: f64,
    found: &mut Findings,
) -> usize {
    let range = if s.along_kappa {
        env.kappa
    } else {
        env.alpha_rad
    };
    let (swept, sign) = s.swept_force();
    let coarse = grid(range, &[]);
    let first = evaluate(eval, s, &coarse);
    let f: Vec<f64> = first.iter().map(|e| swept.of(e)).collect();
    let x = match zero_crossing(&coarse, &f) {
        Some(z) if z.abs() > FINE_STEP => grid(range, &[z]),
        _ => coarse,
    };
    let values = if x.len() == f.len() {
        first
    } else {
        evaluate(eval, s, &x)
    };
    let mut n = x.len();
    // The channels of the families USE_MODE uses (an Fx-only file's Fy may be anything).
    let used: Vec<Channel> = Channel::ALL
        .into_iter()
        .filter(|c| match c {
            Channel::Fx => fam.fx,
            Channel::Fy | Channel::Mz | Channel::Mx => fam.fy_mz,
        })
        .collect();
    let my_used = fam.fx;
    if let Some(i) = values.iter().position(|e| {
        used.iter().any(|c| !c.of(e).is_finite()) || (my_used && !e.my_nm.is_finite())
    }) {
        hit(&mut found.non_finite, f64::NAN, &s.input(x[i]));
        return n;
    }
    // Along a pure sweep only the force it drives and the moments are meaningful to check.
    let channels = used.into_iter().filter(|c| match c {
        Channel::Fx => s.along_kappa || !s.pure(),
        Channel::Fy => !s.along_kappa || !s.pure(),
        Channel::Mz | Channel::Mx => true,
    });
    let fz = s.fz.max(1.0);
    for ch in channels {
        let v: Vec<f64> = values.iter().map(|e| ch.of(e)).collect();
        let scale = if ch.is_force() { fz } else { fz * r0_m };
        // Magnitude.
        let (i_max, v_max) =
            v.iter().enumerate().fold(
                (0, 0.0_f64),
                |b, (i, y)| if y.abs() > b.1.abs() { (i, *y) } else { b },
            );
        let limit = match ch {
            Channel::Fx | Channel::Fy => MU_MAX,
            Channel::Mz => MZ_MAX,
            Channel::Mx => MX_MAX,
        };
        if v_max.abs() > limit * scale {
            hit(
                &mut found.range[ch.index()],
                v_max / scale,
                &s.input(x[i_max]),
            );
        }
        // Spikes and steps.
        let spike_limit = scale
            * if ch.is_force() {
                FORCE_SPIKE
            } else {
                MOMENT_SPIKE
            };
        if let Some(cd) = worst_chord_deviation(&x, &v)
            && cd.d.abs() > spike_limit
        {
            // A step: the chord's ends differ by about twice the deviation (a spike returns to
            // its trend), and the largest jump between neighbours survives bisection.
            let step = (v[cd.k] - v[cd.j]).abs() > 1.5 * cd.d.abs() && {
                let m = (cd.j..cd.k)
                    .max_by(|&a, &b| (v[a + 1] - v[a]).abs().total_cmp(&(v[b + 1] - v[b]).abs()))
                    .unwrap_or(cd.i);
                n += BISECTIONS;
                bisected_jump(eval, s, ch, (x[m], v[m]), (x[m + 1], v[m + 1])) > 0.5 * spike_limit
            };
            let (i, d) = (cd.i, cd.d);
            let (w, is_step) = found.spike[ch.index()].get_or_insert_with(|| (Worst::new(), false));
            if w.count == 0 || (d / scale).abs() > w.value.abs() {
                *is_step = step;
            }
            w.hit(d / scale, &s.input(x[i]), |a, b| a.abs() > b.abs());
        }
        // Sign and grip of the slip force (pure sweeps).
        if ch == swept && s.pure() {
            let i0 = x.partition_point(|v| *v < 0.0).min(x.len() - 1);
            let f0 = v[i0];
            let mut wrong: Option<(usize, f64)> = None;
            let mut grip = 0.0_f64;
            for (i, (xi, vi)) in x.iter().zip(&v).enumerate() {
                let slip_force = vi - f0;
                grip = grip.max(slip_force.abs());
                let against = -slip_force * sign * xi.signum();
                if against > SIGN_TOL * fz && wrong.is_none_or(|(_, w)| against > w) {
                    wrong = Some((i, against));
                }
            }
            let k = usize::from(ch == Channel::Fy);
            if let Some((i, w)) = wrong {
                hit(&mut found.sign[k], w / fz, &s.input(x[i]));
            }
            if grip < MU_MIN * fz {
                hit(&mut found.vanishing[k], grip / fz, &s.input(x[i0]));
            }
        }
    }
    n
}

fn report(found: &Findings, r0_m: f64, l: &mut Linter) {
    let e = Severity::Error;
    if let Some(w) = &found.non_finite {
        l.push(
            e,
            "non-finite",
            format!(
                "NaN or infinite output along {} dense sweeps (first at {})",
                w.count,
                describe(&w.at)
            ),
        );
    }
    for ch in Channel::ALL {
        let i = ch.index();
        let (unit_scale, what) = if ch.is_force() {
            ("Fz", "N")
        } else {
            ("Fz R0", "N m")
        };
        if let Some((w, step)) = &found.spike[i] {
            let limit = if ch.is_force() {
                FORCE_SPIKE
            } else {
                MOMENT_SPIKE
            };
            let value = w.value * w.at.fz_n.max(1.0) * if ch.is_force() { 1.0 } else { r0_m };
            l.push(
                e,
                if *step { "discontinuity" } else { "spike" },
                format!(
                    "{} {} {:.1} {what} ({:.3} {unit_scale}) off its trend within +-{:.1} mrad in {} \
                     sweeps (limit {limit} {unit_scale}), worst at {}",
                    ch.name(),
                    if *step { "jumps by" } else { "has a spike of" },
                    value,
                    w.value,
                    CHORD * 1e3,
                    w.count,
                    describe(&w.at)
                ),
            );
        }
        if let Some(w) = &found.range[i] {
            let (code, limit, what) = match ch {
                Channel::Fx | Channel::Fy => ("friction-range", MU_MAX, "|F|/Fz"),
                Channel::Mz => ("moment-range", MZ_MAX, "|Mz|/(Fz R0)"),
                Channel::Mx => ("moment-range", MX_MAX, "|Mx|/(Fz R0)"),
            };
            l.push(
                e,
                code,
                format!(
                    "{} reaches {:.0} {} ({what} = {:.2} > {limit}) in {} sweeps, worst at {}",
                    ch.name(),
                    w.value.abs() * w.at.fz_n.max(1.0) * if ch.is_force() { 1.0 } else { r0_m },
                    ch.unit(),
                    w.value.abs(),
                    w.count,
                    describe(&w.at)
                ),
            );
        }
    }
    for (k, name, convention) in [
        (0, "Fx", "kappa > 0 must drive Fx up"),
        (1, "Fy", "alpha > 0 must push Fy down (ISO-W)"),
    ] {
        if let Some(w) = &found.sign[k] {
            l.push(
                e,
                "force-sign",
                format!(
                    "pure {name} against the slip by {:.3} Fz in {} sweeps ({convention}), worst at {}",
                    w.value,
                    w.count,
                    describe(&w.at)
                ),
            );
        }
        if let Some(w) = &found.vanishing[k] {
            l.push(
                e,
                "friction-sign",
                format!(
                    "pure {name} has no grip: slip changes it by at most {:.3} Fz in {} sweeps, worst at {}",
                    w.value,
                    w.count,
                    describe(&w.at)
                ),
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chord_deviation_sees_a_narrow_spike_and_not_a_smooth_curve() {
        let x: Vec<f64> = (0..2001).map(|i| -0.2 + 2e-4 * i as f64).collect();
        let smooth: Vec<f64> = x
            .iter()
            .map(|v| 2500.0 * (1.4 * (20.0 * v).atan()).sin())
            .collect();
        let d = worst_chord_deviation(&x, &smooth).unwrap().d;
        assert!(d.abs() < 1.0, "{d}");
        let spiky: Vec<f64> = x
            .iter()
            .zip(&smooth)
            .map(|(v, s)| s - 500.0 / (1.0 + ((v - 0.01) / 2e-4).powi(2)))
            .collect();
        let cd = worst_chord_deviation(&x, &spiky).unwrap();
        let (i, d) = (cd.i, cd.d);
        assert!(d < -400.0, "{d}");
        assert!((x[i] - 0.01).abs() < 1e-9, "{}", x[i]);
    }

    #[test]
    fn grid_has_fine_points_around_its_centres() {
        let g = grid((-0.2, 0.2), &[0.0123]);
        assert!(g.windows(2).all(|w| w[1] > w[0]));
        let near = |c: f64| g.iter().filter(|v| (**v - c).abs() <= FINE_HALF).count();
        assert!(near(0.0) > 190, "{}", near(0.0));
        assert!(near(0.0123) > 190, "{}", near(0.0123));
        assert_eq!(
            zero_crossing(&[-1.0, 1.0, 2.0], &[2.0, -2.0, -3.0]),
            Some(0.0)
        );
    }
}
