//! Physical plausibility of a Magic Formula file (PAC2002 / MF 5.2, MF 6.1 / 6.2) over its own
//! operating envelope.
//!
//! In: a [`TirFile`]. Out: a [`LintReport`]: findings with a [`Severity`], a stable kebab-case
//! code and a one-line message naming the worst value and where it occurs, plus the envelope
//! that was sampled.
//!
//! The envelope comes from the range sections: `Fz` in `[max(FZMIN, 0.05 FNOMIN),
//! min(FZMAX, 4 FNOMIN)]`, inclination in `[CAMMIN, CAMMAX]` (at most 15 deg), `kappa` in
//! `[KPUMIN, KPUMAX]` (at most |1|), `alpha` in `[ALPMIN, ALPMAX]` (at most 45 deg): the caps
//! keep "no limit" defaults from sampling meaningless states. MF 6.x files are sampled at three
//! inflation pressures: `PRESMIN`, `NOMPRES`, `PRESMAX` (0.75 and 1.25 `NOMPRES` where the range
//! is unlimited), each point evaluated by the file's own equations. Checks run only for the force
//! families the declared `USE_MODE` uses (1 Fx, 2 Fy + Mz, 3 both uncombined, 4 combined,
//! +10 relaxation; 4 when absent). Two kinds:
//! - `dense`: every channel evaluated through the model's batch API along dense slip sweeps
//!   (MF 6.x: at each sampled pressure; a finding already made at another pressure is not
//!   repeated)
//!   (fine grids around zero slip and the force's zero crossing): spikes and discontinuities,
//!   friction above 4 and moments out of range, the force's sign against the slip (so the
//!   supplier's `PDX1 < 0` with `PKX1 > 0`, which evaluates correctly, passes), non-finite
//!   outputs. Errors.
//! - coefficient rules on a coarse grid:
//!   - errors: `FNOMIN`, `UNLOADED_RADIUS`, `LFZO`, `LONGVL`, a given `VERTICAL_STIFFNESS`
//!     <= 0; inverted ranges; a missing (absent or
//!     zero) defining coefficient of a used family; a shape factor `C <= 0`; a peak factor
//!     `mu_x` or `mu_y` changing sign or vanishing over the envelope (its sign is free), or
//!     `|mu| > 4`; `Kx_kappa <= 0`; `Ky_alpha` changing sign or vanishing; `Ky_alpha > 0` (an
//!     SAE-signed file: ISO-W needs `alpha > 0 -> Fy < 0`); `Gxa` or `Gyk` <= 0; more than
//!     two sign changes of `dF/dslip` along a pure slip sweep (oscillation).
//!   - warnings: oscillation along a combined-slip sweep (at half the slip limits of the other
//!     slip, where fitted data rarely reach); `E > 1` before the clamp (limits and raw mode then
//!     disagree); `C >= 2` (force reverses at large slip); `|RHX1| > 0.05` rad; `Gxa` or `Gyk`
//!     above 1.05 (combined slip raises the force); `FZMAX < FNOMIN`; an inflation pressure
//!     outside 20..1600 kPa (not in Pa?), an `UNLOADED_RADIUS` outside 0.1..1 m, a
//!     `VERTICAL_STIFFNESS` that deflects the tire by less than 1 % or more than 25 % of its
//!     radius at `FNOMIN` (a radius or a stiffness in another unit); for MF 6.x also
//!     `NOMPRES <= 0` (error: the pressure terms divide by it).
//!
//! [`UNDEFINED_MODEL_CODES`] marks the errors that leave the model undefined rather than
//! doubtful.
//!
//! Deliberately not here: reading (see `read.rs`; its warnings are the caller's to print),
//! comparing with measurements (a fitting stage's job).

use std::f64::consts::PI;

mod dense;

/// Largest friction `|F| / Fz` and peak factor `|mu|` the lint accepts.
pub use dense::MU_MAX;

use super::TirFile;
use super::units::PLACEHOLDER;
use crate::tire_model::factors::slip_factors;
use crate::tire_model::pac2002::{MagicFormula, load_with};
use crate::tire_model::params::{Coef, Coef::*, Coefs};
use crate::tire_model::{Mode, Pressures, SlipInput, Version};

/// How bad a finding is.
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Severity {
    /// Suspicious but usable.
    Warning,
    /// The model is physically wrong somewhere in its envelope (or cannot be evaluated).
    Error,
}

impl std::fmt::Display for Severity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Severity::Warning => "warning",
            Severity::Error => "error",
        })
    }
}

/// Codes of the errors that leave the model undefined (as opposed to physically doubtful): a
/// family the `USE_MODE` needs is missing, a quantity the equations divide by is not positive,
/// a range is inverted, or evaluation gives NaN. `tir eval` and `tir convert` refuse such a
/// file unless forced.
pub const UNDEFINED_MODEL_CODES: [&str; 6] = [
    "missing-family",
    "fnomin-not-positive",
    "not-positive",
    "range-inverted",
    "longvl-not-positive",
    "non-finite",
];

/// One problem.
#[derive(Clone, Debug, PartialEq)]
pub struct Finding {
    /// Error or warning.
    pub severity: Severity,
    /// Stable kebab-case code, e.g. `curvature-above-one`.
    pub code: &'static str,
    /// One line: what, the worst value, where.
    pub message: String,
}

impl Finding {
    /// An error that leaves the model undefined ([`UNDEFINED_MODEL_CODES`]).
    pub fn leaves_model_undefined(&self) -> bool {
        self.severity == Severity::Error && UNDEFINED_MODEL_CODES.contains(&self.code)
    }
}

impl std::fmt::Display for Finding {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}[{}]: {}", self.severity, self.code, self.message)
    }
}

/// The sampled operating envelope (SI, ISO-W).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Envelope {
    /// Vertical load range, N.
    pub fz_n: (f64, f64),
    /// Longitudinal slip range.
    pub kappa: (f64, f64),
    /// Slip angle range, rad.
    pub alpha_rad: (f64, f64),
    /// Inclination range, rad.
    pub gamma_rad: (f64, f64),
    /// Speed used, m/s.
    pub vx_mps: f64,
    /// Inflation pressures sampled, Pa (MF 6.x; empty for PAC2002).
    pub pressures_pa: [Option<f64>; 3],
}

/// Everything `lint` found.
#[derive(Clone, Debug, PartialEq)]
pub struct LintReport {
    /// Findings, errors first, then in check order.
    pub findings: Vec<Finding>,
    /// The envelope sampled (`None` when a basic error made sampling meaningless).
    pub envelope: Option<Envelope>,
    /// Number of operating points evaluated.
    pub points: usize,
}

impl LintReport {
    /// Number of errors.
    pub fn errors(&self) -> usize {
        self.findings
            .iter()
            .filter(|f| f.severity == Severity::Error)
            .count()
    }

    /// Number of warnings.
    pub fn warnings(&self) -> usize {
        self.findings.len() - self.errors()
    }
}

/// Which force families the declared `USE_MODE` uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Families {
    fx: bool,
    fy_mz: bool,
    combined: bool,
    relaxation: bool,
}

/// A family and the coefficients without which it is no model at all, per version (MF 6.x's
/// `Ky_alpha` also needs `PKY4`; its relaxation lengths come from the structural stiffnesses).
fn family_keys(version: Version) -> [(&'static str, &'static [Coef]); 6] {
    let mf6 = version.is_mf6();
    [
        ("pure Fx", &[PCX1, PDX1, PKX1]),
        (
            "pure Fy",
            if mf6 {
                &[PCY1, PDY1, PKY1, PKY2, PKY4]
            } else {
                &[PCY1, PDY1, PKY1, PKY2]
            },
        ),
        ("pure Mz", &[QBZ1, QCZ1, QDZ1]),
        ("combined Fx", &[RBX1, RCX1]),
        ("combined Fy", &[RBY1, RCY1]),
        (
            "relaxation",
            if mf6 {
                &[LONGITUDINAL_STIFFNESS, LATERAL_STIFFNESS]
            } else {
                &[PTX1, PTY1, PTY2]
            },
        ),
    ]
}

/// Lint a file over its envelope.
pub fn lint(file: &TirFile) -> LintReport {
    let mut l = Linter {
        findings: Vec::new(),
    };
    let c = &file.coefs;
    let families = l.use_mode(file.use_mode);
    l.missing_families(file, families);
    let basic_ok = l.basics(c, file.version);
    l.scalars(file, families);
    let (envelope, points) = if basic_ok {
        let env = envelope(c, file.version);
        let points = Grid::new(c, file.version, env, families).run(&mut l);
        (Some(env), points)
    } else {
        (None, 0)
    };
    let mut findings = l.findings;
    findings.sort_by_key(|f| std::cmp::Reverse(f.severity));
    LintReport {
        findings,
        envelope,
        points,
    }
}

/// The envelope to sample (see the module docs for the caps).
fn envelope(c: &Coefs<f64>, version: Version) -> Envelope {
    let fz0 = c[FNOMIN];
    let fz_hi = if c[FZMAX].abs() < PLACEHOLDER {
        c[FZMAX].min(4.0 * fz0)
    } else {
        2.0 * fz0
    };
    let fz_lo = c[FZMIN].max(0.05 * fz0).min(fz_hi);
    let cap = |lo: f64, hi: f64, limit: f64| (lo.max(-limit), hi.min(limit));
    let vx = if c[LONGVL] > c[VXLOW] && c[LONGVL] > 0.0 {
        c[LONGVL]
    } else {
        c[VXLOW].max(0.0) + 10.0
    };
    Envelope {
        fz_n: (fz_lo, fz_hi),
        kappa: cap(c[KPUMIN], c[KPUMAX], 1.0),
        alpha_rad: cap(c[ALPMIN], c[ALPMAX], PI / 4.0),
        gamma_rad: cap(c[CAMMIN], c[CAMMAX], PI / 12.0),
        vx_mps: vx,
        pressures_pa: if version.is_mf6() {
            let p0 = c[NOMPRES];
            let finite = |p: f64| p > 0.0 && p < PLACEHOLDER;
            let lo = if finite(c[PRESMIN]) {
                c[PRESMIN]
            } else {
                0.75 * p0
            };
            let hi = if finite(c[PRESMAX]) {
                c[PRESMAX]
            } else {
                1.25 * p0
            };
            [Some(lo), Some(p0), Some(hi)]
        } else {
            [None; 3]
        },
    }
}

struct Linter {
    findings: Vec<Finding>,
}

impl Linter {
    fn push(&mut self, severity: Severity, code: &'static str, message: String) {
        self.findings.push(Finding {
            severity,
            code,
            message,
        });
    }

    fn use_mode(&mut self, use_mode: Option<i64>) -> Families {
        let mode = use_mode.unwrap_or_else(|| {
            self.push(
                Severity::Warning,
                "use-mode-missing",
                "no USE_MODE; checked as 4 (combined Fx, Fy, Mx, My, Mz)".to_string(),
            );
            4
        });
        let digit = mode.unsigned_abs() % 10;
        if digit > 4 {
            self.push(
                Severity::Warning,
                "use-mode-unknown",
                format!("USE_MODE {mode}: unknown calculation digit {digit}; checked as 4"),
            );
        }
        let digit = if digit > 4 { 4 } else { digit };
        Families {
            fx: matches!(digit, 1 | 3 | 4),
            fy_mz: matches!(digit, 2..=4),
            combined: digit == 4,
            relaxation: mode.unsigned_abs() >= 10,
        }
    }

    fn missing_families(&mut self, file: &TirFile, families: Families) {
        let used = [
            families.fx,
            families.fy_mz,
            families.fy_mz,
            families.combined && families.fx,
            families.combined && families.fy_mz,
            families.relaxation,
        ];
        for ((name, keys), used) in family_keys(file.version).iter().zip(used) {
            if !used {
                continue;
            }
            let missing: Vec<&str> = keys
                .iter()
                .filter(|k| !file.present[**k] || file.coefs[**k].abs() < 1e-300)
                .map(|k| k.name())
                .collect();
            if !missing.is_empty() {
                self.push(
                    Severity::Error,
                    "missing-family",
                    format!(
                        "USE_MODE {} uses {name}, but {} {} absent or zero",
                        file.use_mode.unwrap_or(4),
                        missing.join(", "),
                        if missing.len() == 1 { "is" } else { "are" }
                    ),
                );
            }
        }
    }

    /// Checks without which nothing can be evaluated; false when one fails.
    fn basics(&mut self, c: &Coefs<f64>, version: Version) -> bool {
        let mut ok = true;
        if version.is_mf6() && (c[NOMPRES].is_nan() || c[NOMPRES] <= 0.0) {
            self.push(
                Severity::Error,
                "not-positive",
                format!(
                    "NOMPRES = {} Pa (nominal inflation pressure) must be positive: the {version} \
                     pressure terms divide by it",
                    c[NOMPRES]
                ),
            );
            ok = false;
        }
        for (k, what) in [
            (FNOMIN, "nominal load"),
            (UNLOADED_RADIUS, "unloaded radius"),
            (LFZO, "nominal load scale factor"),
        ] {
            if c[k].is_nan() || c[k] <= 0.0 {
                let code = if k == FNOMIN {
                    "fnomin-not-positive"
                } else {
                    "not-positive"
                };
                self.push(
                    Severity::Error,
                    code,
                    format!("{} = {} ({what}) must be positive", k.name(), c[k]),
                );
                ok = false;
            }
        }
        for (lo, hi) in [
            (KPUMIN, KPUMAX),
            (ALPMIN, ALPMAX),
            (CAMMIN, CAMMAX),
            (FZMIN, FZMAX),
        ] {
            if c[lo].is_nan() || c[hi].is_nan() || c[lo] >= c[hi] {
                self.push(
                    Severity::Error,
                    "range-inverted",
                    format!(
                        "{} = {} is not below {} = {}",
                        lo.name(),
                        c[lo],
                        hi.name(),
                        c[hi]
                    ),
                );
                ok = false;
            }
        }
        ok
    }

    /// Single-coefficient checks.
    fn scalars(&mut self, file: &TirFile, fam: Families) {
        let c = &file.coefs;
        let shape = |l: &mut Self, k: Coef, scale: Coef, used: bool, what: &str| {
            if !used {
                return;
            }
            let v = c[k] * c[scale];
            if v <= 0.0 {
                l.push(
                    Severity::Error,
                    "shape-factor",
                    format!(
                        "{what} = {} * {} = {v} must be positive",
                        k.name(),
                        scale.name()
                    ),
                );
            } else if v >= 2.0 {
                l.push(
                    Severity::Warning,
                    "shape-factor",
                    format!("{what} = {v} >= 2: the force reverses sign at large slip"),
                );
            }
        };
        shape(self, PCX1, LCX, fam.fx, "Cx");
        shape(self, PCY1, LCY, fam.fy_mz, "Cy");
        shape(self, QCZ1, LFZO, fam.fy_mz, "Ct");
        shape(self, RCX1, LFZO, fam.combined && fam.fx, "Cxa");
        shape(self, RCY1, LFZO, fam.combined && fam.fy_mz, "Cyk");
        if fam.combined && fam.fx && c[RHX1].abs() > 0.05 {
            self.push(
                Severity::Warning,
                "rhx1-large",
                format!(
                    "RHX1 = {} rad ({:.1} deg): Gxa peaks away from alpha = 0 and exceeds 1 there",
                    c[RHX1],
                    c[RHX1].to_degrees()
                ),
            );
        }
        if c[FZMAX].abs() < PLACEHOLDER && c[FZMAX] < c[FNOMIN] {
            self.push(
                Severity::Warning,
                "fzmax-below-fnomin",
                format!("FZMAX = {} N is below FNOMIN = {} N", c[FZMAX], c[FNOMIN]),
            );
        }
        if c[LONGVL].is_nan() || c[LONGVL] <= 0.0 {
            self.push(
                Severity::Error,
                "longvl-not-positive",
                format!(
                    "LONGVL = {} m/s (reference speed) must be positive: the speed terms divide by it",
                    c[LONGVL]
                ),
            );
        }
        if file.present[VERTICAL_STIFFNESS]
            && (c[VERTICAL_STIFFNESS].is_nan() || c[VERTICAL_STIFFNESS] <= 0.0)
        {
            self.push(
                Severity::Error,
                "not-positive",
                format!(
                    "VERTICAL_STIFFNESS = {} N/m must be positive",
                    c[VERTICAL_STIFFNESS]
                ),
            );
        }
        let pressures = file.pressures();
        let names = if file.version.is_mf6() {
            ["INFLPRES", "NOMPRES"]
        } else {
            ["IP", "IP_NOM"]
        };
        for (name, p) in names
            .into_iter()
            .zip([pressures.inflation_pa, pressures.nominal_pa])
        {
            if let Some(p) = p.filter(|p| !(PRESSURE_PA.0..=PRESSURE_PA.1).contains(p)) {
                self.push(
                    Severity::Warning,
                    "pressure-units",
                    format!(
                        "{name} = {p} Pa is outside a tire's {}..{} kPa: is [UNITS] PRESSURE right?",
                        PRESSURE_PA.0 / 1e3,
                        PRESSURE_PA.1 / 1e3
                    ),
                );
            }
        }
        let r0 = c[UNLOADED_RADIUS];
        if r0 > 0.0 && !(RADIUS_M.0..=RADIUS_M.1).contains(&r0) {
            self.push(
                Severity::Warning,
                "radius-range",
                format!(
                    "UNLOADED_RADIUS = {r0} m is outside a tire's {}..{} m: is [UNITS] LENGTH right?",
                    RADIUS_M.0, RADIUS_M.1
                ),
            );
        }
        let cz = c[VERTICAL_STIFFNESS];
        if file.present[VERTICAL_STIFFNESS] && cz > 0.0 && r0 > 0.0 && c[FNOMIN] > 0.0 {
            let deflection = c[FNOMIN] / cz / r0;
            if !(DEFLECTION_OF_R0.0..=DEFLECTION_OF_R0.1).contains(&deflection) {
                self.push(
                    Severity::Warning,
                    "stiffness-range",
                    format!(
                        "VERTICAL_STIFFNESS = {cz} N/m deflects the tire by {:.2} % of UNLOADED_RADIUS at FNOMIN, outside {}..{} %",
                        100.0 * deflection,
                        100.0 * DEFLECTION_OF_R0.0,
                        100.0 * DEFLECTION_OF_R0.1
                    ),
                );
            }
        }
    }
}

/// Inflation pressures of tires (a bicycle's to an aircraft's), Pa.
const PRESSURE_PA: (f64, f64) = (2.0e4, 1.6e6);
/// Unloaded radii of tires (a kart's to a tractor's), m.
const RADIUS_M: (f64, f64) = (0.1, 1.0);
/// Deflection at the nominal load, `FNOMIN / VERTICAL_STIFFNESS`, as a fraction of the unloaded
/// radius (tires sit at 3-9 %).
const DEFLECTION_OF_R0: (f64, f64) = (0.01, 0.25);

/// Worst value of one quantity over the grid, and where.
#[derive(Clone, Copy)]
struct Worst {
    count: usize,
    value: f64,
    at: SlipInput,
}

impl Worst {
    fn new() -> Worst {
        Worst {
            count: 0,
            value: f64::NAN,
            at: SlipInput::default(),
        }
    }

    /// Record a violation; `worse(a, b)` says whether `a` is worse than the stored `b`.
    fn hit(&mut self, value: f64, at: &SlipInput, worse: impl Fn(f64, f64) -> bool) {
        if self.count == 0 || worse(value, self.value) {
            self.value = value;
            self.at = *at;
        }
        self.count += 1;
    }
}

fn describe(p: &SlipInput) -> String {
    format!(
        "Fz = {:.0} N, gamma = {:.2} deg, kappa = {:.3}, alpha = {:.2} deg",
        p.fz_n,
        p.gamma_rad.to_degrees(),
        p.kappa,
        p.alpha_rad.to_degrees()
    )
}

/// The sampled grid and its accumulators.
struct Grid<'a> {
    c: &'a Coefs<f64>,
    version: Version,
    env: Envelope,
    fam: Families,
}

const N_FZ: usize = 7;
const N_GAMMA: usize = 5;
const N_SLIP: usize = 161;
const N_COMBINED: usize = 41;

fn linspace(range: (f64, f64), n: usize) -> impl Iterator<Item = f64> {
    (0..n).map(move |i| range.0 + (range.1 - range.0) * i as f64 / (n - 1) as f64)
}

impl<'a> Grid<'a> {
    fn new(c: &'a Coefs<f64>, version: Version, env: Envelope, fam: Families) -> Self {
        Grid {
            c,
            version,
            env,
            fam,
        }
    }

    fn input(&self, fz: f64, gamma: f64, kappa: f64, alpha: f64) -> SlipInput {
        SlipInput {
            fz_n: fz,
            kappa,
            alpha_rad: alpha,
            gamma_rad: gamma,
            vx_mps: self.env.vx_mps,
        }
    }

    /// Run every grid check; returns the number of points evaluated.
    fn run(&self, l: &mut Linter) -> usize {
        let model = MagicFormula::with_version(self.c.clone(), self.version);
        let mut acc = Accumulators::default();
        let mut points = 0;
        // PAC2002 has no pressure: one pass (the pressure is ignored).
        let pressures: Vec<f64> = if self.version.is_mf6() {
            self.env.pressures_pa.iter().flatten().copied().collect()
        } else {
            vec![f64::NAN]
        };
        for &p in &pressures {
            for fz in linspace(self.env.fz_n, N_FZ) {
                for gamma in linspace(self.env.gamma_rad, N_GAMMA) {
                    points += self.factors_at(fz, gamma, p, &mut acc);
                    points += self.sweeps_at(&model, fz, gamma, p, &mut acc);
                }
            }
        }
        acc.report(l, self.fam);
        let dense_start = l.findings.len();
        for &p in &pressures {
            let eval = |inputs: &[SlipInput], out: &mut [crate::tire_model::Evaluation<f64>]| {
                model.eval_batch_at(inputs, Pressures::Uniform(p), Mode::Limits, out)
            };
            let before = l.findings.len();
            points += dense::run(
                &eval,
                &self.env,
                self.fam,
                self.c[UNLOADED_RADIUS],
                N_FZ,
                N_GAMMA,
                l,
            );
            if self.version.is_mf6() {
                // One finding per code: the first pressure that shows it, named.
                let mut new: Vec<Finding> = l.findings.drain(before..).collect();
                new.retain(|f| {
                    !l.findings[dense_start..before]
                        .iter()
                        .any(|g| g.code == f.code)
                });
                for f in &mut new {
                    f.message = format!("{} (at {:.1} kPa)", f.message, p / 1e3);
                }
                l.findings.extend(new);
            }
        }
        points
    }

    /// Factor checks over the combined (kappa, alpha) grid at one load and inclination.
    fn factors_at(&self, fz: f64, gamma: f64, pressure: f64, acc: &mut Accumulators) -> usize {
        let mut n = 0;
        for kappa in linspace(self.env.kappa, N_COMBINED) {
            for alpha in linspace(self.env.alpha_rad, N_COMBINED) {
                let p = self.input(fz, gamma, kappa, alpha);
                let l = load_with(self.c, &p, Mode::Raw, self.version, pressure);
                let f = slip_factors(self.c, &l);
                acc.point(&p, &f);
                n += 1;
            }
        }
        n
    }

    /// Slip sweeps at one load and inclination: pure and combined, oscillation.
    fn sweeps_at(
        &self,
        model: &MagicFormula,
        fz: f64,
        gamma: f64,
        pressure: f64,
        acc: &mut Accumulators,
    ) -> usize {
        let (k_lo, k_hi) = self.env.kappa;
        let (a_lo, a_hi) = self.env.alpha_rad;
        let mut n = 0;
        let mut sweep = |other: f64, along_kappa: bool, acc: &mut Accumulators| {
            let range = if along_kappa {
                self.env.kappa
            } else {
                self.env.alpha_rad
            };
            let mut values = Vec::with_capacity(N_SLIP);
            let mut first = None;
            for s in linspace(range, N_SLIP) {
                let p = if along_kappa {
                    self.input(fz, gamma, s, other)
                } else {
                    self.input(fz, gamma, other, s)
                };
                first.get_or_insert(p);
                let e = model.eval_at(&p, pressure, Mode::Limits);
                values.push(if along_kappa { e.fx_n } else { e.fy_n });
            }
            n += values.len();
            if let Some(p) = first {
                acc.oscillation(&values, &p, along_kappa, other);
            }
        };
        if self.fam.fx {
            sweep(0.0, true, acc);
            if self.fam.combined {
                sweep(0.5 * a_lo, true, acc);
                sweep(0.5 * a_hi, true, acc);
            }
        }
        if self.fam.fy_mz {
            sweep(0.0, false, acc);
            if self.fam.combined {
                sweep(0.5 * k_lo, false, acc);
                sweep(0.5 * k_hi, false, acc);
            }
        }
        n
    }
}

/// Violations collected over the grid.
struct Accumulators {
    e_above_one: [Worst; 4],
    mux_sign: (Option<f64>, Worst),
    muy_sign: (Option<f64>, Worst),
    /// `|mu_x|`, `|mu_y|` above [`dense::MU_MAX`].
    mu_high: [Worst; 2],
    kya_sign: (Option<f64>, Worst),
    kxk: Worst,
    kya_positive: Worst,
    g_low: [Worst; 2],
    g_high: [Worst; 2],
    /// Pure x, pure y, combined x, combined y.
    oscillation: [Worst; 4],
}

impl Default for Accumulators {
    fn default() -> Self {
        let w = Worst::new();
        Accumulators {
            e_above_one: [w; 4],
            mux_sign: (None, w),
            muy_sign: (None, w),
            mu_high: [w; 2],
            kya_sign: (None, w),
            kxk: w,
            kya_positive: w,
            g_low: [w; 2],
            g_high: [w; 2],
            oscillation: [w; 4],
        }
    }
}

const E_NAMES: [&str; 4] = ["Ex", "Ey", "Exa", "Eyk"];

/// Record `value` when its sign differs from the first sign seen (or is zero).
fn sign_flip(state: &mut (Option<f64>, Worst), value: f64, p: &SlipInput) {
    let s = value.signum();
    match state.0 {
        _ if value == 0.0 || value.is_nan() => state.1.hit(value, p, |_, _| false),
        None => state.0 = Some(s),
        Some(first) if first != s => state.1.hit(value, p, |a, b| a.abs() > b.abs()),
        Some(_) => {}
    }
}

impl Accumulators {
    fn point(&mut self, p: &SlipInput, f: &crate::tire_model::factors::SlipFactors) {
        let above = |a: f64, b: f64| a > b;
        let below = |a: f64, b: f64| a < b;
        for (i, e) in [f.fx0.e, f.fy0.e, f.gxa.e, f.gyk.e].into_iter().enumerate() {
            if e > 1.0 {
                self.e_above_one[i].hit(e, p, above);
            }
        }
        sign_flip(&mut self.mux_sign, f.mux, p);
        sign_flip(&mut self.muy_sign, f.muy, p);
        for (i, mu) in [f.mux, f.muy].into_iter().enumerate() {
            if mu.abs() > dense::MU_MAX {
                self.mu_high[i].hit(mu, p, |a, b| a.abs() > b.abs());
            }
        }
        sign_flip(&mut self.kya_sign, f.kya_n_per_rad, p);
        if f.kxk_n.is_nan() || f.kxk_n <= 0.0 {
            self.kxk.hit(f.kxk_n, p, below);
        }
        if f.kya_n_per_rad > 0.0 {
            self.kya_positive.hit(f.kya_n_per_rad, p, above);
        }
        for (i, g) in [f.gxa.g, f.gyk.g].into_iter().enumerate() {
            if g.is_nan() || g <= 0.0 {
                self.g_low[i].hit(g, p, below);
            } else if g > 1.05 {
                self.g_high[i].hit(g, p, above);
            }
        }
    }

    /// More than two sign changes of dF along a sweep (a normal curve has at most its two
    /// peaks).
    fn oscillation(&mut self, values: &[f64], p: &SlipInput, along_kappa: bool, other: f64) {
        let scale = values.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        let tol = 1e-9 * scale.max(1.0);
        let mut changes = 0;
        let mut last = 0.0;
        for w in values.windows(2) {
            let d = w[1] - w[0];
            if d.abs() <= tol {
                continue;
            }
            let s = d.signum();
            if last != 0.0 && s != last {
                changes += 1;
            }
            last = s;
        }
        if changes > 2 {
            let i = usize::from(!along_kappa) + if other == 0.0 { 0 } else { 2 };
            self.oscillation[i].hit(changes as f64, p, |a, b| a > b);
        }
    }

    fn report(&self, l: &mut Linter, fam: Families) {
        use Severity::{Error, Warning};
        let e_used = [
            fam.fx,
            fam.fy_mz,
            fam.combined && fam.fx,
            fam.combined && fam.fy_mz,
        ];
        for ((w, name), used) in self.e_above_one.iter().zip(E_NAMES).zip(e_used) {
            if used && w.count > 0 {
                l.push(
                    Warning,
                    "curvature-above-one",
                    format!(
                        "{name} > 1 before clamping at {} grid points (max {:.4} at {}); limits and raw mode differ there",
                        w.count,
                        w.value,
                        describe(&w.at)
                    ),
                );
            }
        }
        let mut err = |w: &Worst, used: bool, code: &'static str, what: &str| {
            if used && w.count > 0 {
                l.push(
                    Error,
                    code,
                    format!(
                        "{what} at {} grid points (worst {:.6} at {})",
                        w.count,
                        w.value,
                        describe(&w.at)
                    ),
                );
            }
        };
        err(
            &self.mux_sign.1,
            fam.fx,
            "friction-sign",
            "mu_x changes sign or vanishes",
        );
        err(
            &self.mu_high[0],
            fam.fx,
            "friction-range",
            "peak factor |mu_x| > 4",
        );
        err(
            &self.mu_high[1],
            fam.fy_mz,
            "friction-range",
            "peak factor |mu_y| > 4",
        );
        err(
            &self.muy_sign.1,
            fam.fy_mz,
            "friction-sign",
            "mu_y changes sign or vanishes",
        );
        err(&self.kxk, fam.fx, "stiffness-sign", "Kx_kappa <= 0");
        err(
            &self.kya_sign.1,
            fam.fy_mz,
            "stiffness-sign",
            "Ky_alpha changes sign or vanishes",
        );
        err(
            &self.kya_positive,
            fam.fy_mz,
            "stiffness-sign",
            "Ky_alpha > 0: alpha > 0 gives Fy > 0 (SAE-signed coefficients? PAC2002 is ISO-W)",
        );
        let c_fx = fam.combined && fam.fx;
        let c_fy = fam.combined && fam.fy_mz;
        err(
            &self.g_low[0],
            c_fx,
            "combined-weight",
            "Gxa <= 0 (Fx flips sign with slip angle)",
        );
        err(
            &self.g_low[1],
            c_fy,
            "combined-weight",
            "Gyk <= 0 (Fy flips sign with slip ratio)",
        );
        err(
            &self.oscillation[0],
            fam.fx,
            "oscillation",
            "pure Fx oscillates along kappa (> 2 sign changes of dFx/dkappa)",
        );
        err(
            &self.oscillation[1],
            fam.fy_mz,
            "oscillation",
            "pure Fy oscillates along alpha (> 2 sign changes of dFy/dalpha)",
        );
        for (w, used, what) in [
            (
                &self.oscillation[2],
                c_fx,
                "combined Fx oscillates along kappa",
            ),
            (
                &self.oscillation[3],
                c_fy,
                "combined Fy oscillates along alpha",
            ),
        ] {
            if used && w.count > 0 {
                l.push(
                    Warning,
                    "oscillation",
                    format!(
                        "{what} at half the other slip's limit ({} sweeps, {} sign changes of the slope at {})",
                        w.count,
                        w.value,
                        describe(&w.at)
                    ),
                );
            }
        }
        for (w, used, name) in [
            (&self.g_high[0], c_fx, "Gxa"),
            (&self.g_high[1], c_fy, "Gyk"),
        ] {
            if used && w.count > 0 {
                l.push(
                    Warning,
                    "combined-weight",
                    format!(
                        "{name} > 1.05 at {} grid points (max {:.4} at {}): combined slip raises the force",
                        w.count,
                        w.value,
                        describe(&w.at)
                    ),
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FSAE: &str =
        include_str!("../../../../tests/fixtures/reference/fsae-demo/fsae_demo_pac2002.tir");
    const MFEVAL: &str = include_str!(
        "../../../../tests/fixtures/reference/mfeval-sample/MagicFormula52_Parameters.tir"
    );

    fn lint_text(text: &str) -> LintReport {
        lint(&TirFile::parse(text).unwrap().0)
    }

    fn codes(r: &LintReport, severity: Severity) -> Vec<&'static str> {
        r.findings
            .iter()
            .filter(|f| f.severity == severity)
            .map(|f| f.code)
            .collect()
    }

    const MF61: &str = include_str!(
        "../../../../tests/fixtures/reference/mfeval-mf6/MagicFormula61_Parameters.tir"
    );

    /// Issue 19: an MF 6.1 file is linted by its own equations at three pressures; MFeval's
    /// sample has no errors; a missing PKY4 (Ky = 0 in MF 6.x) and NOMPRES = 0 are errors.
    #[test]
    fn mf61_sample_lints_at_three_pressures() {
        let r = lint_text(MF61);
        let env = r.envelope.unwrap();
        assert_eq!(
            env.pressures_pa,
            [Some(200_000.0), Some(260_000.0), Some(400_000.0)]
        );
        assert_eq!(r.errors(), 0, "{:#?}", r.findings);
        let no_pky4 = MF61.replace(
            "PKY4                     =    2.7364",
            "PKY4                     =    0",
        );
        let r = lint_text(&no_pky4);
        assert!(
            r.findings
                .iter()
                .any(|f| f.code == "missing-family" && f.message.contains("PKY4")),
            "{:#?}",
            r.findings
        );
        let no_nompres = MF61.replace(
            "NOMPRES                  =    260000",
            "NOMPRES                  =    0",
        );
        let r = lint_text(&no_nompres);
        assert!(
            r.findings.iter().any(|f| f.message.contains("NOMPRES")),
            "{:#?}",
            r.findings
        );
        assert!(r.envelope.is_none());
    }

    #[test]
    fn fsae_demo_is_clean() {
        let r = lint_text(FSAE);
        assert!(r.findings.is_empty(), "{:#?}", r.findings);
        assert!(r.points > 50_000, "{}", r.points);
        let env = r.envelope.unwrap();
        assert_eq!(env.fz_n, (100.0, 2500.0));
    }

    #[test]
    fn mfeval_sample_has_warnings_only() {
        let r = lint_text(MFEVAL);
        for f in &r.findings {
            println!("{f}");
        }
        assert_eq!(r.errors(), 0, "{:#?}", r.findings);
        let w = codes(&r, Severity::Warning);
        assert!(w.contains(&"curvature-above-one"), "{:#?}", r.findings);
        let ex = r
            .findings
            .iter()
            .find(|f| f.message.starts_with("Ex > 1"))
            .expect("the sample's Ex = 1.31 at 2 Fz0 (docs section 3)");
        assert!(ex.message.contains("max 1."), "{}", ex.message);
    }

    fn with(text: &str, key: &str, value: &str) -> String {
        let mut out = String::new();
        for line in text.lines() {
            if line.split('=').next().map(str::trim) == Some(key) {
                out.push_str(&format!("{key} = {value}\n"));
            } else {
                out.push_str(line);
                out.push('\n');
            }
        }
        out
    }

    #[test]
    fn each_problem_is_found() {
        let cases = [
            ("FNOMIN", "-1100", "fnomin-not-positive"),
            ("PCY1", "-1.45", "shape-factor"),
            ("PDX2", "-40", "friction-sign"),
            ("PDY2", "-40", "friction-sign"),
            ("PKY2", "-1.75", "stiffness-sign"),
            ("PKX1", "-52", "stiffness-sign"),
            ("RBX1", "0", "missing-family"),
            ("RCY1", "-1.05", "shape-factor"),
            ("KPUMIN", "0.5", "range-inverted"),
            ("PCY1", "3.9", "oscillation"),
            ("PKY1", "42", "stiffness-sign"),
            ("RCX1", "3.5", "combined-weight"),
        ];
        // A stiff tire, so that Cy = 3.9 reaches 3 pi / 2 inside the slip range.
        let stiff = with(FSAE, "PKY1", "-300");
        assert_eq!(lint_text(&stiff).errors(), 0);
        for (key, value, code) in cases {
            let base = if key == "PCY1" && value == "3.9" {
                &stiff
            } else {
                FSAE
            };
            let r = lint_text(&with(base, key, value));
            assert!(
                codes(&r, Severity::Error).contains(&code),
                "{key} = {value}: expected {code}, got {:#?}",
                r.findings
            );
        }
        let warnings = [
            ("RHX1", "0.2", "rhx1-large"),
            ("PEY1", "1.5", "curvature-above-one"),
            ("FZMAX", "900", "fzmax-below-fnomin"),
            ("PCX1", "2.2", "shape-factor"),
            // Issue 17: a radius read in cm as m, a stiffness from such radii.
            ("UNLOADED_RADIUS", "0.031", "radius-range"),
            ("VERTICAL_STIFFNESS", "1e7", "stiffness-range"),
        ];
        for (key, value, code) in warnings {
            let r = lint_text(&with(FSAE, key, value));
            assert!(
                codes(&r, Severity::Warning).contains(&code),
                "{key} = {value}: expected {code}, got {:#?}",
                r.findings
            );
        }
    }

    /// Issue 17: an inflation pressure in psi or kPa where Pa is declared is flagged.
    #[test]
    fn a_pressure_outside_a_tires_range_is_flagged() {
        let mut file = TirFile::parse(FSAE).unwrap().0;
        file.pressure.inflation_pa = Some(82_737.0);
        assert!(lint(&file).findings.is_empty());
        for p in [12.0, 12_000.0, 82_737.0e3] {
            file.pressure.inflation_pa = Some(p);
            let r = lint(&file);
            assert_eq!(codes(&r, Severity::Warning), ["pressure-units"], "{p}");
        }
    }

    const SUPPLIER: &str =
        include_str!("../../../../tests/fixtures/tir/pac2002_supplier_layout.tir");

    /// Issue 18: the supplier stores `PDX1 < 0` with `PKX1 > 0` (and `PDY1 < 0, PKY1 < 0`):
    /// the forces evaluate with the right signs, so the lint has no error for it.
    #[test]
    fn supplier_sign_conventions_pass() {
        for (name, text) in [
            ("supplier layout", SUPPLIER.to_string()),
            ("supplier layout, PDX1 < 0", with(SUPPLIER, "PDX1", "-2.35")),
            ("fsae-demo, PDX1 < 0", with(FSAE, "PDX1", "-2.55")),
            (
                "fsae-demo, PDX1 < 0 and PDY1 > 0",
                with(&with(FSAE, "PDX1", "-2.55"), "PDY1", "2.5"),
            ),
        ] {
            let r = lint_text(&text);
            assert_eq!(r.errors(), 0, "{name}: {:#?}", r.findings);
        }
    }

    /// Issue 18: the degenerate aligning-moment fit (QBZ10 = 3.1e5, QDZ6 = -218, QEZ1..3 of
    /// order 100-500) is a narrow residual-torque spike near alpha = 0 that every fit point
    /// straddled; the dense sweeps see it.
    #[test]
    fn planted_residual_torque_spike_is_caught() {
        let mut t = SUPPLIER.to_string();
        for (k, v) in [
            ("QBZ10", "3.1e5"),
            ("QDZ6", "-218"),
            ("QEZ1", "120"),
            ("QEZ2", "-480"),
            ("QEZ3", "310"),
        ] {
            t = with(&t, k, v);
        }
        let r = lint_text(&t);
        let spike = r
            .findings
            .iter()
            .find(|f| f.code == "spike" && f.message.starts_with("Mz"))
            .unwrap_or_else(|| panic!("no Mz spike: {:#?}", r.findings));
        assert_eq!(spike.severity, Severity::Error);
        println!("{spike}");
        assert!(
            codes(&r, Severity::Error).contains(&"moment-range"),
            "{:#?}",
            r.findings
        );
        // A cornering stiffness so large that Fy steps from +D to -D within microradians.
        let r = lint_text(&with(SUPPLIER, "PKY1", "-1e6"));
        assert!(
            r.findings
                .iter()
                .any(|f| f.code == "discontinuity" && f.message.starts_with("Fy")),
            "{:#?}",
            r.findings
        );
    }

    /// Issue 18: a planted sign flip (the slip stiffness changing sign inside the load range)
    /// and a planted mu of 6 are errors.
    #[test]
    fn planted_sign_flip_and_mu_of_six_are_caught() {
        // Kx/Fz = PKX1 + PKX2 dfz = 47 - 80 dfz changes sign at dfz = 0.59 (1430 N).
        let r = lint_text(&with(SUPPLIER, "PKX2", "-80"));
        let e = codes(&r, Severity::Error);
        assert!(e.contains(&"force-sign"), "{:#?}", r.findings);
        let r = lint_text(&with(SUPPLIER, "PDX1", "6.0"));
        let e = codes(&r, Severity::Error);
        assert!(e.contains(&"friction-range"), "{:#?}", r.findings);
        assert!(
            r.findings
                .iter()
                .any(|f| f.code == "friction-range" && f.message.starts_with("Fx")),
            "the evaluated force says it too: {:#?}",
            r.findings
        );
        // The degenerate fit of the issue: PCX1 on its 0.3 bound with PDX1 = 6.4.
        let r = lint_text(&with(&with(SUPPLIER, "PCX1", "0.3"), "PDX1", "-6.4"));
        assert!(
            codes(&r, Severity::Error).contains(&"friction-range"),
            "{:#?}",
            r.findings
        );
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig { cases: 24, ..Default::default() })]

        /// Any finite coefficient vector lints without panicking, and every finding is one line.
        #[test]
        fn random_coefficients_never_panic(
            values in proptest::collection::vec(
                proptest::prop_oneof![-1e3..1e3f64, proptest::num::f64::NORMAL],
                crate::tire_model::params::N_COEFS,
            ),
            use_mode in -15i64..15,
        ) {
            let mut coefs = Coefs::defaults();
            coefs.0.copy_from_slice(&values);
            let mut file = TirFile::from_coefs(coefs);
            file.use_mode = Some(use_mode);
            let report = lint(&file);
            for f in &report.findings {
                proptest::prop_assert!(!f.to_string().contains('\n'), "{}", f);
            }
        }
    }

    #[test]
    fn use_mode_decides_the_families() {
        // A USE_MODE 2 file (Fy + Mz) with every Fx coefficient zero is fine.
        let mut t = with(FSAE, "USE_MODE", "2");
        for k in ["PCX1", "PDX1", "PKX1", "RBX1", "RCX1"] {
            t = with(&t, k, "0");
        }
        let r = lint_text(&t);
        assert_eq!(r.errors(), 0, "{:#?}", r.findings);
        // The same file declared USE_MODE 14 lacks Fx, combined Fx and relaxation.
        let r = lint_text(&with(&t, "USE_MODE", "14"));
        let missing: Vec<&str> = r
            .findings
            .iter()
            .filter(|f| f.code == "missing-family")
            .map(|f| f.message.as_str())
            .collect();
        assert_eq!(missing.len(), 3, "{missing:#?}");
        assert!(missing.iter().any(|m| m.contains("relaxation")));
    }
}
