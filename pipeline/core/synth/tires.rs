//! The virtual round's tires and their truth models.
//!
//! In: the committed base property file `tires/fsae_demo_pac2002.tir` (a hand-made FSAE-size
//! PAC2002 tire, 16x7.5-10 on a 7 in rim) and the catalogue below (sizes, rims, test plans, per-tire
//! variations). Out: a [`TruthModel`] per tire, rim and nominal pressure: an exact PAC2002
//! coefficient set (written as the truth `.tir`), the vertical truth (stiffness and unloaded radius,
//! static and at speed), and the per-tire thermal law ([`ThermalTruth`]).
//!
//! Pressure enters through MF 6.1-style sensitivities *folded into* PAC2002 coefficients (MF 5.2
//! has no pressure terms), with `dp = (p - p_ref)/p_ref`:
//! - `PDY1, PDY2 *= 1 + PPY3 dp + PPY4 dp^2` and `PDX1, PDX2 *= 1 + PPX3 dp + PPX4 dp^2` (peak mu),
//! - `PKY1 *= 1 + PPY1 dp`, `PKY2 *= 1 + PPY2 dp` (cornering stiffness and its load of maximum),
//! - `PKX1, PKX2 *= 1 + PPX1 dp + PPX2 dp^2` (longitudinal slip stiffness),
//! - `QDZ1, QDZ2 *= 1 - PPZ1 dp` (peak pneumatic trail),
//! - `PTY1 *= 1 + PPTY dp`, `PTX1, PTX2 *= 1 + PPTX dp` (relaxation lengths),
//! - vertical stiffness `Cz *= 1 + PFZ1 dp`, unloaded radius `R0 *= 1 + PPR0 dp`.
//!
//! Each factor multiplies whole terms of the MF 6.1 equations, so at one pressure the result is an
//! ordinary PAC2002 coefficient set the PAC2002 fitter can reproduce to round-off. Across pressures
//! it is not one MF 6.1 model: PAC2002's constant camber shift `PHY3`, its `Mz` trail term and the
//! `PTY*`/`PTX*` relaxation laws have no exact MF 6.1 form, and the radius changes with pressure.
//!
//! [`TruthForm::Mf61`] (`[synth] truth = "mf61"`) replaces this by one MF 6.1 model per tire and
//! rim ([`mf61_truth`]): the reference-pressure PAC2002 set above lifted into MF 6.1
//! (`tir::convert`), with the sensitivities as MF 6.1 pressure terms (`PPX1-4`, `PPY1-4` as above,
//! plus [`MF61_PRESSURE_TERMS`]: `PPY5`, `PPZ1-2`, `PPMX1`, `PFZ1`, `PCFX3`, `PCFY3`), `NOMPRES`
//! the reference pressure, and a radius that does not change with pressure. The machine evaluates
//! it at each sample's true inflation pressure, so a fit of MF 6.1 can recover it exactly.
//!
//! Deliberately not here: the thermal and transient behaviour (see `physics.rs`), file formats.

use serde::{Deserialize, Serialize};

use crate::tire_model::tir::{TirFile, convert};
use crate::tire_model::{Coef, Coefs, MagicFormula, Pac2002, Version};

use super::round::RoundError;

/// The committed base property file every synthetic tire is derived from.
pub const BASE_TIR: &str = include_str!("tires/fsae_demo_pac2002.tir");

/// Reference pressure of the base coefficients, psi.
pub const P_REF_PSI: f64 = 12.0;

/// Reference pressure of the base coefficients, kPa (12 psi).
pub const P_REF_KPA: f64 = P_REF_PSI * KPA_PER_PSI;

/// Reference (test) speed of the truth models: `LONGVL`, m/s (25 mph).
pub const V_REF_MPS: f64 = 11.176;

/// kPa per psi.
pub const KPA_PER_PSI: f64 = 6.894_757_293_168;
/// N per lbf.
pub const N_PER_LBF: f64 = 4.448_221_615_260_5;
/// m per inch.
pub const M_PER_IN: f64 = 0.0254;

/// Which consortium test plan a tire is run with (`docs/ttc-format.md`, "What a run contains").
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum TestPlan {
    /// Round 4: cornering matrix IA {0,2,4,1,3} x loads {350,150,50,250,100} lb of
    /// -4 -> +12 -> -12 -> +3 deg sweeps, 8 cold-to-warm sweeps, SL sweeps +-0.20.
    Round4,
    /// Rounds 6-9: step steers, 12 cold-to-warm sweeps, +-12 deg sweeps over IA {0,2,4}, IA
    /// sweeps, 15/45 mph sweeps, SL sweeps +-0.15.
    Round9,
}

/// MF 6.1-style pressure sensitivities (see the module docs for where each one acts).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PressureSensitivity {
    pub ppx1: f64,
    pub ppx2: f64,
    pub ppx3: f64,
    pub ppx4: f64,
    pub ppy1: f64,
    pub ppy2: f64,
    pub ppy3: f64,
    pub ppy4: f64,
    pub ppz1: f64,
    pub ppty: f64,
    pub pptx: f64,
    pub pfz1: f64,
    pub ppr0: f64,
}

/// Sensitivities used for every synthetic tire (FSAE-like: grip falls and cornering stiffness
/// rises with pressure, the carcass stiffens).
pub const PRESSURE_SENSITIVITY: PressureSensitivity = PressureSensitivity {
    ppx1: -0.25,
    ppx2: 0.10,
    ppx3: -0.10,
    ppx4: 0.06,
    ppy1: 0.45,
    ppy2: 0.25,
    ppy3: -0.12,
    ppy4: 0.08,
    ppz1: 0.30,
    ppty: -0.10,
    pptx: 0.06,
    pfz1: 0.75,
    ppr0: 0.0045,
};

/// Which model the virtual machine's truth is (`[synth] truth`).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TruthForm {
    /// One PAC2002 set per tested pressure with the pressure sensitivities folded in (the
    /// default; not exactly one MF 6.1 model across pressures).
    #[default]
    Pac2002,
    /// One MF 6.1 model per tire and rim with pressure terms, evaluated at each sample's true
    /// inflation pressure.
    Mf61,
}

impl TruthForm {
    /// `pac2002` or `mf61`.
    pub const fn as_str(self) -> &'static str {
        match self {
            TruthForm::Pac2002 => "pac2002",
            TruthForm::Mf61 => "mf61",
        }
    }

    /// The default form (what older rounds were generated with).
    pub fn is_pac2002(&self) -> bool {
        *self == TruthForm::Pac2002
    }
}

/// The MF 6.1 pressure terms of [`TruthForm::Mf61`] that have no counterpart in
/// [`PressureSensitivity`] (camber stiffness, residual torque, overturning couple, carcass
/// stiffnesses: the relaxation lengths `|Kx/Cx|`, `|Ky/Cy|` follow from them).
pub const MF61_PRESSURE_TERMS: [(Coef, f64); 5] = [
    (Coef::PPY5, -0.2),
    (Coef::PPZ2, -0.15),
    (Coef::PPMX1, 0.1),
    (Coef::PCFX3, 0.2),
    (Coef::PCFY3, 0.4),
];

/// `PRESMIN`, `PRESMAX` of the MF 6.1 truth relative to `NOMPRES`: wide enough that no tested
/// pressure (8-16 psi around 12 psi, plus the servo's wander) is clipped in limits mode.
pub const MF61_PRESSURE_RANGE: (f64, f64) = (0.5, 1.6);

/// The per-tire thermal law: grip multiplier `mu_rel(T)` of the tread surface temperature.
///
/// `mu_rel(T) = 1 - a_cold ((T - t_peak)/(t_peak - t_cold))^2` below `t_peak` and
/// `1 - a_hot ((T - t_peak)/(t_peak - t_cold))^2` above, floored at `MU_REL_FLOOR`, with
/// `a_cold = 1 - 1/(1 + gain_peak_over_cold)` (so `mu_rel(t_peak)/mu_rel(t_cold) = 1 + gain`) and
/// `a_hot = hot_falloff * a_cold`. The machine applies `mu_rel(T)/mu_rel(t_matrix_ref)` as the
/// lateral friction scaling `LMUY` and `mu_rel(T)/mu_rel(t_ref_longitudinal)` as `LMUX`, so the
/// truth `.tir` is the tire at the temperatures its cornering matrix, respectively its
/// drive/brake and combined sweeps, run at.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ThermalTruth {
    /// Temperature of peak grip, degC.
    pub t_peak_c: f64,
    /// Relative rise of peak mu from `t_cold_c` to `t_peak_c`.
    pub gain_peak_over_cold: f64,
    /// Cold reference temperature of the gain: the tread temperature a cold tire starts its
    /// cold-to-warm test with, degC.
    pub t_cold_c: f64,
    /// Fall-off above the peak relative to the rise below it (1 = "at a similar rate").
    pub hot_falloff: f64,
    /// Tread temperature the truth `.tir`'s lateral grip describes (`LMUY` = 1 there), degC.
    pub t_matrix_ref_c: f64,
    /// Tread temperature the truth `.tir`'s longitudinal grip describes (`LMUX` = 1), degC.
    pub t_ref_longitudinal_c: f64,
}

/// Lowest grip multiplier the law gives (far outside the tested temperatures).
pub const MU_REL_FLOOR: f64 = 0.3;

impl ThermalTruth {
    /// `a_cold` of the law.
    pub fn a_cold(&self) -> f64 {
        1.0 - 1.0 / (1.0 + self.gain_peak_over_cold)
    }

    /// The grip multiplier `mu_rel(T)` (1 at the peak).
    pub fn mu_rel(&self, t_c: f64) -> f64 {
        let x = (t_c - self.t_peak_c) / (self.t_peak_c - self.t_cold_c);
        let a = if x < 0.0 {
            self.a_cold()
        } else {
            self.a_cold() * self.hot_falloff
        };
        (1.0 - a * x * x).max(MU_REL_FLOOR)
    }

    /// The friction scalings the machine applies, `(LMUX, LMUY)`:
    /// `mu_rel(T)/mu_rel(t_ref_longitudinal)` and `mu_rel(T)/mu_rel(t_matrix_ref)`.
    pub fn grip_scale(&self, t_c: f64) -> (f64, f64) {
        let mu = self.mu_rel(t_c);
        (
            mu / self.mu_rel(self.t_ref_longitudinal_c),
            mu / self.mu_rel(self.t_matrix_ref_c),
        )
    }
}

/// One base tire of the catalogue.
#[derive(Clone, Debug)]
pub struct BaseTire {
    /// Name as the run guide writes it.
    pub name: &'static str,
    /// Name as a `.mat` `tireid` / R9 `Tire_Name=` would write it (before the rim part).
    pub plan: TestPlan,
    /// Unloaded radius at the reference pressure, static, m.
    pub r0_m: f64,
    /// Section width, m.
    pub width_m: f64,
    /// Rim diameter, in (10 or 13).
    pub rim_diameter_in: f64,
    /// Rim widths tested, in.
    pub rims_in: &'static [f64],
    /// Nominal rim width the coefficients refer to, in.
    pub rim_nominal_in: f64,
    /// Static vertical stiffness at the reference pressure and nominal rim, N/m.
    pub cz_n_per_m: f64,
    /// Peak friction factor relative to the base file (both directions).
    pub mu_scale: f64,
    /// Cornering stiffness factor relative to the base file.
    pub ky_scale: f64,
    /// Longitudinal slip stiffness factor relative to the base file.
    pub kx_scale: f64,
    /// Added to `PCY1`.
    pub pcy1_delta: f64,
    /// Relaxation: `PTY1, PTY2, PTX1, PTX2, PTX3` at the reference pressure.
    pub pt: [f64; 5],
    /// Nominal pressures of the cornering/drive-brake runs in test order, psi (repeats allowed).
    pub pressures_psi: &'static [f64],
}

impl BaseTire {
    /// `true` for 10-inch tires (200 lb replaces 350 lb in the load lists).
    pub fn ten_inch(&self) -> bool {
        self.rim_diameter_in < 11.0
    }
}

/// The catalogue: six FSAE tires, each on two rims (12 tire/rim combinations).
pub const CATALOGUE: &[BaseTire] = &[
    BaseTire {
        name: "Hoosier 20.5x7.0-13 R25B",
        plan: TestPlan::Round4,
        r0_m: 0.2604,
        width_m: 0.1778,
        rim_diameter_in: 13.0,
        rims_in: &[7.0, 8.0],
        rim_nominal_in: 7.0,
        cz_n_per_m: 135_000.0,
        mu_scale: 1.0,
        ky_scale: 1.35,
        kx_scale: 1.1,
        pcy1_delta: 0.0,
        pt: [1.75, 1.5, 2.05, -0.6, 0.1],
        pressures_psi: &[12.0, 10.0, 14.0, 8.0, 12.0],
    },
    BaseTire {
        name: "Hoosier 16.0x7.5-10 R25B",
        plan: TestPlan::Round9,
        r0_m: 0.2045,
        width_m: 0.1905,
        rim_diameter_in: 10.0,
        rims_in: &[7.0, 8.0],
        rim_nominal_in: 7.0,
        cz_n_per_m: 100_000.0,
        mu_scale: 1.0,
        ky_scale: 1.0,
        kx_scale: 1.0,
        pcy1_delta: 0.0,
        pt: [1.9, 1.4, 2.2, -0.5, 0.1],
        pressures_psi: &[12.0, 10.0, 14.0, 8.0],
    },
    BaseTire {
        name: "Hoosier 18.0x6.0-10 R25B",
        plan: TestPlan::Round4,
        r0_m: 0.2286,
        width_m: 0.1524,
        rim_diameter_in: 10.0,
        rims_in: &[6.0, 7.0],
        rim_nominal_in: 6.0,
        cz_n_per_m: 110_000.0,
        mu_scale: 0.97,
        ky_scale: 1.05,
        kx_scale: 0.95,
        pcy1_delta: 0.05,
        pt: [1.8, 1.5, 2.1, -0.55, 0.1],
        pressures_psi: &[12.0, 10.0, 14.0, 8.0, 12.0],
    },
    BaseTire {
        name: "Goodyear 20.0x7.0-13 D2696",
        plan: TestPlan::Round9,
        r0_m: 0.2540,
        width_m: 0.1778,
        rim_diameter_in: 13.0,
        rims_in: &[7.0, 8.0],
        rim_nominal_in: 7.0,
        cz_n_per_m: 128_000.0,
        mu_scale: 0.95,
        ky_scale: 1.25,
        kx_scale: 1.05,
        pcy1_delta: -0.05,
        pt: [1.7, 1.6, 2.0, -0.6, 0.1],
        pressures_psi: &[12.0, 10.0, 14.0, 8.0],
    },
    BaseTire {
        name: "Avon 7.0/20.0-13 A45",
        plan: TestPlan::Round4,
        r0_m: 0.2550,
        width_m: 0.1778,
        rim_diameter_in: 13.0,
        rims_in: &[7.0, 8.0],
        rim_nominal_in: 7.0,
        cz_n_per_m: 125_000.0,
        mu_scale: 0.93,
        ky_scale: 1.2,
        kx_scale: 1.0,
        pcy1_delta: 0.03,
        pt: [1.8, 1.45, 2.1, -0.6, 0.1],
        pressures_psi: &[12.0, 10.0, 14.0, 8.0, 12.0],
    },
    BaseTire {
        name: "Hoosier 18.0x7.5-10 LCO",
        plan: TestPlan::Round9,
        r0_m: 0.2286,
        width_m: 0.1905,
        rim_diameter_in: 10.0,
        rims_in: &[7.0, 8.0],
        rim_nominal_in: 7.0,
        cz_n_per_m: 105_000.0,
        mu_scale: 1.03,
        ky_scale: 0.95,
        kx_scale: 1.0,
        pcy1_delta: 0.0,
        pt: [1.85, 1.45, 2.15, -0.5, 0.1],
        pressures_psi: &[12.0, 10.0, 14.0, 8.0],
    },
];

/// Vertical truth of one tire, rim and pressure.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct VerticalTruth {
    /// Vertical stiffness at standstill, N/m.
    pub cz_static_n_per_m: f64,
    /// Vertical stiffness rolling at [`V_REF_MPS`], N/m.
    pub cz_dynamic_n_per_m: f64,
    /// Unloaded radius at standstill, m.
    pub r0_static_m: f64,
    /// Unloaded radius rolling at [`V_REF_MPS`] (centrifugal growth), m.
    pub r0_dynamic_m: f64,
}

/// Relative stiffening of the rolling tire at the reference speed.
pub const CZ_DYNAMIC_GAIN: f64 = 0.06;
/// Centrifugal growth of the unloaded radius at the reference speed, m (scales with V^2).
pub const R0_GROWTH_AT_VREF_M: f64 = 0.0008;

impl VerticalTruth {
    /// Unloaded radius at road speed `v_mps` (growth proportional to `V^2`), m.
    pub fn r0_at(&self, v_mps: f64) -> f64 {
        let r = (v_mps / V_REF_MPS).powi(2);
        self.r0_static_m + (self.r0_dynamic_m - self.r0_static_m) * r
    }

    /// Vertical stiffness at road speed `v_mps` (stiffening proportional to `V`), N/m.
    pub fn cz_at(&self, v_mps: f64) -> f64 {
        let r = (v_mps.abs() / V_REF_MPS).min(3.0);
        self.cz_static_n_per_m + (self.cz_dynamic_n_per_m - self.cz_static_n_per_m) * r
    }

    /// Loaded radius under load `fz_n` at speed `v_mps`: `R0(V) - Fz/Cz(V)`, m.
    pub fn loaded_radius(&self, fz_n: f64, v_mps: f64) -> f64 {
        self.r0_at(v_mps) - fz_n.max(0.0) / self.cz_at(v_mps)
    }
}

/// The truth of one tire, rim and nominal pressure.
#[derive(Clone, Debug)]
pub struct TruthModel {
    /// Index into [`CATALOGUE`].
    pub tire_index: usize,
    /// Rim width, in.
    pub rim_in: f64,
    /// Nominal pressure, psi (as commanded).
    pub pressure_psi: f64,
    /// The model at `t_matrix_ref` (the truth `.tir`): PAC2002, or under [`TruthForm::Mf61`] the
    /// tire's MF 6.1 model with `INFLPRES` at this pressure.
    pub model: Pac2002,
    /// Vertical truth.
    pub vertical: VerticalTruth,
}

impl TruthModel {
    /// Nominal pressure, kPa.
    pub fn pressure_kpa(&self) -> f64 {
        self.pressure_psi * KPA_PER_PSI
    }

    /// Effective rolling radius at load `fz_n` and speed `v_mps`, m: the MF-Tyre law
    /// `RE = R0(V) - (Fz0/Cz(V)) (DREFF atan(BREFF Fz/Fz0) + FREFF Fz/Fz0)`.
    pub fn effective_radius(&self, fz_n: f64, v_mps: f64) -> f64 {
        let c = &self.model.coefs;
        let fz0 = c[Coef::FNOMIN];
        let rho = fz_n.max(0.0) / fz0;
        self.vertical.r0_at(v_mps)
            - fz0 / self.vertical.cz_at(v_mps)
                * (c[Coef::DREFF] * (c[Coef::BREFF] * rho).atan() + c[Coef::FREFF] * rho)
    }
}

/// The base coefficients: the embedded property file, read by the `.tir` reader.
pub fn base_coefs() -> Result<Coefs<f64>, RoundError> {
    let (file, _warnings) = TirFile::parse(BASE_TIR).map_err(|e| RoundError::BaseTire {
        message: e.to_string(),
    })?;
    Ok(file.coefs)
}

/// The truth model of catalogue tire `tire_index` on rim `rim_in` at `pressure_psi`.
pub fn truth_model(
    base: &Coefs<f64>,
    tire_index: usize,
    rim_in: f64,
    pressure_psi: f64,
) -> TruthModel {
    let tire = &CATALOGUE[tire_index];
    let s = PRESSURE_SENSITIVITY;
    let dp = (pressure_psi * KPA_PER_PSI - P_REF_KPA) / P_REF_KPA;
    let rim = rim_in - tire.rim_nominal_in;
    let mut c = base.clone();
    use Coef::*;

    // Size.
    c[UNLOADED_RADIUS] = tire.r0_m;
    c[WIDTH] = tire.width_m;
    c[RIM_RADIUS] = tire.rim_diameter_in * 0.5 * M_PER_IN;
    c[RIM_WIDTH] = rim_in * M_PER_IN;
    c[ASPECT_RATIO] = ((tire.r0_m - c[RIM_RADIUS]) / tire.width_m * 100.0).round() / 100.0;
    c[LONGVL] = V_REF_MPS;

    // Per-tire and per-rim character: a wider rim stiffens the tire and costs a little grip.
    let mu = tire.mu_scale * (1.0 - 0.01 * rim);
    for k in [PDY1, PDY2, PDX1, PDX2] {
        c[k] *= mu;
    }
    c[PKY1] *= tire.ky_scale * (1.0 + 0.05 * rim);
    c[PKX1] *= tire.kx_scale * (1.0 + 0.02 * rim);
    c[PKX2] *= tire.kx_scale * (1.0 + 0.02 * rim);
    c[PCY1] += tire.pcy1_delta;
    let [pty1, pty2, ptx1, ptx2, ptx3] = tire.pt;
    c[PTY1] = pty1 * (1.0 - 0.03 * rim);
    c[PTY2] = pty2;
    c[PTX1] = ptx1;
    c[PTX2] = ptx2;
    c[PTX3] = ptx3;

    // Pressure (module docs).
    let mu_y = 1.0 + s.ppy3 * dp + s.ppy4 * dp * dp;
    let mu_x = 1.0 + s.ppx3 * dp + s.ppx4 * dp * dp;
    let kx = 1.0 + s.ppx1 * dp + s.ppx2 * dp * dp;
    c[PDY1] *= mu_y;
    c[PDY2] *= mu_y;
    c[PDX1] *= mu_x;
    c[PDX2] *= mu_x;
    c[PKY1] *= 1.0 + s.ppy1 * dp;
    c[PKY2] *= 1.0 + s.ppy2 * dp;
    c[PKX1] *= kx;
    c[PKX2] *= kx;
    c[QDZ1] *= 1.0 - s.ppz1 * dp;
    c[QDZ2] *= 1.0 - s.ppz1 * dp;
    c[PTY1] *= 1.0 + s.ppty * dp;
    c[PTX1] *= 1.0 + s.pptx * dp;
    c[PTX2] *= 1.0 + s.pptx * dp;

    let vertical = vertical_truth(tire, rim, dp, s.ppr0);
    // The truth file describes the rolling tire at LONGVL.
    c[UNLOADED_RADIUS] = vertical.r0_dynamic_m;
    c[VERTICAL_STIFFNESS] = vertical.cz_dynamic_n_per_m;

    TruthModel {
        tire_index,
        rim_in,
        pressure_psi,
        model: Pac2002::new(c),
        vertical,
    }
}

/// The vertical truth of `tire` at `rim` in off its nominal rim and relative pressure `dp`, with
/// the unloaded radius changing by `ppr0 dp`.
fn vertical_truth(tire: &BaseTire, rim: f64, dp: f64, ppr0: f64) -> VerticalTruth {
    let r0_static = tire.r0_m * (1.0 + ppr0 * dp);
    let cz_static = tire.cz_n_per_m * (1.0 + PRESSURE_SENSITIVITY.pfz1 * dp) * (1.0 + 0.03 * rim);
    VerticalTruth {
        cz_static_n_per_m: cz_static,
        cz_dynamic_n_per_m: cz_static * (1.0 + CZ_DYNAMIC_GAIN),
        r0_static_m: r0_static,
        r0_dynamic_m: r0_static + R0_GROWTH_AT_VREF_M,
    }
}

/// The MF 6.1 truth of catalogue tire `tire_index` on rim `rim_in` ([`TruthForm::Mf61`]): the
/// reference-pressure PAC2002 truth lifted into MF 6.1 with the pressure terms of
/// [`PRESSURE_SENSITIVITY`] and [`MF61_PRESSURE_TERMS`]; `NOMPRES = INFLPRES` = [`P_REF_KPA`],
/// `PRESMIN`/`PRESMAX` from [`MF61_PRESSURE_RANGE`].
pub fn mf61_truth(
    base: &Coefs<f64>,
    tire_index: usize,
    rim_in: f64,
) -> Result<MagicFormula, RoundError> {
    use Coef::*;
    let reference = truth_model(base, tire_index, rim_in, P_REF_PSI);
    let p_ref = P_REF_KPA * 1e3;
    let file = TirFile::from_coefs(reference.model.coefs);
    let mut c = convert::convert(&file, Version::Mf61, Some(p_ref))
        .map_err(|e| RoundError::BaseTire {
            message: format!("lifting into MF 6.1: {e}"),
        })?
        .file
        .coefs;
    let s = PRESSURE_SENSITIVITY;
    for (k, v) in [
        (PPX1, s.ppx1),
        (PPX2, s.ppx2),
        (PPX3, s.ppx3),
        (PPX4, s.ppx4),
        (PPY1, s.ppy1),
        (PPY2, s.ppy2),
        (PPY3, s.ppy3),
        (PPY4, s.ppy4),
        (PPZ1, s.ppz1),
        (PFZ1, s.pfz1),
    ]
    .into_iter()
    .chain(MF61_PRESSURE_TERMS)
    {
        c[k] = v;
    }
    c[PRESMIN] = MF61_PRESSURE_RANGE.0 * p_ref;
    c[PRESMAX] = MF61_PRESSURE_RANGE.1 * p_ref;
    Ok(MagicFormula::with_version(c, Version::Mf61))
}

/// The truth of one tire, rim and nominal pressure under [`TruthForm::Mf61`]: `model` (the
/// tire's [`mf61_truth`]) with `INFLPRES` at `pressure_psi`; the vertical stiffness follows
/// `PFZ1`, the unloaded radius does not change with pressure (MF 6.1 has no term for it).
pub fn truth_model_mf61(
    model: &MagicFormula,
    tire_index: usize,
    rim_in: f64,
    pressure_psi: f64,
) -> TruthModel {
    let tire = &CATALOGUE[tire_index];
    let dp = (pressure_psi * KPA_PER_PSI - P_REF_KPA) / P_REF_KPA;
    let mut model = model.clone();
    model.coefs[Coef::INFLPRES] = pressure_psi * KPA_PER_PSI * 1e3;
    TruthModel {
        tire_index,
        rim_in,
        pressure_psi,
        model,
        vertical: vertical_truth(tire, rim_in - tire.rim_nominal_in, dp, 0.0),
    }
}

/// Relative rise of peak grip from the cold tire (`t_cold_c`) to the optimum.
pub const GAIN_PEAK_OVER_COLD: f64 = 0.35;

/// A thermal law before calibration: peak at `t_peak_c`, truth at the peak.
pub fn thermal_truth(t_peak_c: f64, t_cold_c: f64) -> ThermalTruth {
    ThermalTruth {
        t_peak_c,
        gain_peak_over_cold: GAIN_PEAK_OVER_COLD,
        t_cold_c,
        hot_falloff: 1.0,
        t_matrix_ref_c: t_peak_c,
        t_ref_longitudinal_c: t_peak_c,
    }
}

impl ThermalTruth {
    /// Centre the law on the temperatures the fitted sweeps run at. `lateral` and
    /// `longitudinal` are `(temperature, weight)` samples of the cornering matrix, respectively
    /// of the drive/brake and combined sweeps (weights `|F|/Fz`, so near-peak samples count
    /// most). The peak moves to the weighted mean cornering-matrix temperature; each reference
    /// temperature moves (on the cold side) to where `mu_rel` equals the weighted mean `mu_rel`
    /// of its sweeps, so the mean grip scaling over them is 1 and the truth `.tir` carries no
    /// thermal bias.
    pub fn centred_on(&self, lateral: &[(f64, f64)], longitudinal: &[(f64, f64)]) -> ThermalTruth {
        let w_sum: f64 = lateral.iter().map(|x| x.1).sum();
        if w_sum <= 0.0 {
            return *self;
        }
        let mean_t = lateral.iter().map(|(t, w)| t * w).sum::<f64>() / w_sum;
        let mut out = *self;
        out.t_peak_c = (mean_t * 10.0).round() / 10.0;
        out.t_matrix_ref_c = out.reference_for(lateral);
        out.t_ref_longitudinal_c = out.reference_for(longitudinal);
        out
    }

    /// The cold-side temperature whose `mu_rel` is the weighted mean `mu_rel` of `samples`.
    fn reference_for(&self, samples: &[(f64, f64)]) -> f64 {
        let w_sum: f64 = samples.iter().map(|x| x.1).sum();
        if w_sum <= 0.0 {
            return self.t_peak_c;
        }
        let mean_mu = samples
            .iter()
            .map(|(t, w)| self.mu_rel(*t) * w)
            .sum::<f64>()
            / w_sum;
        let x = ((1.0 - mean_mu) / self.a_cold()).max(0.0).sqrt();
        let t = self.t_peak_c - x * (self.t_peak_c - self.t_cold_c);
        (t * 10.0).round() / 10.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tire_model::{Mode, SlipInput};

    fn truths() -> Vec<TruthModel> {
        let base = base_coefs().unwrap();
        let mut out = Vec::new();
        for (i, t) in CATALOGUE.iter().enumerate() {
            for &rim in t.rims_in {
                for &p in [8.0, 10.0, 12.0, 14.0].iter() {
                    out.push(truth_model(&base, i, rim, p));
                }
            }
        }
        out
    }

    #[test]
    fn pressure_really_changes_the_tire() {
        let base = base_coefs().unwrap();
        let lo = truth_model(&base, 0, 7.0, 8.0);
        let hi = truth_model(&base, 0, 7.0, 14.0);
        let at = |m: &TruthModel, deg: f64| {
            m.model
                .eval(
                    &SlipInput {
                        fz_n: 1112.0,
                        alpha_rad: deg.to_radians(),
                        vx_mps: V_REF_MPS,
                        ..Default::default()
                    },
                    Mode::Limits,
                )
                .fy_n
        };
        let peak_ratio = at(&lo, 10.0) / at(&hi, 10.0);
        let slope_ratio = at(&lo, 0.5) / at(&hi, 0.5);
        assert!(peak_ratio > 1.03, "peak ratio {peak_ratio}");
        assert!(slope_ratio < 0.95, "stiffness ratio {slope_ratio}");
        assert!(hi.vertical.cz_static_n_per_m > 1.3 * lo.vertical.cz_static_n_per_m);
    }

    /// Lint-style sanity of every truth model over the tested envelope: C > 0, every E <= 1
    /// before clamping, combined-slip weights positive, no oscillation of Fy(alpha) or Fx(kappa).
    #[test]
    fn every_truth_model_is_physically_sane() {
        use crate::tire_model::pac2002::{gxa, load, pure_fx0, pure_fy0};
        for t in truths() {
            let c = &t.model.coefs;
            assert!(c[Coef::PCY1] > 0.0 && c[Coef::PCX1] > 0.0 && c[Coef::QCZ1] > 0.0);
            for fz in [200.0, 445.0, 1112.0, 1600.0] {
                let dfz = (fz - c[Coef::FNOMIN]) / c[Coef::FNOMIN];
                let ex = c[Coef::PEX1] + c[Coef::PEX2] * dfz + c[Coef::PEX3] * dfz * dfz;
                assert!(ex * (1.0 + c[Coef::PEX4]) <= 1.0, "Ex {ex}");
                for g in [0.0, 2.0_f64.to_radians(), 4.0_f64.to_radians()] {
                    let ey = (c[Coef::PEY1] + c[Coef::PEY2] * dfz)
                        * (1.0 + (c[Coef::PEY3] + c[Coef::PEY4] * g).abs());
                    assert!(ey <= 1.0, "Ey {ey}");
                    for i in 0..=26 {
                        let inp = SlipInput {
                            fz_n: fz,
                            alpha_rad: f64::to_radians(-13.0 + i as f64),
                            gamma_rad: g,
                            vx_mps: V_REF_MPS,
                            kappa: 0.0,
                        };
                        let gx = gxa(c, &load(c, &inp, Mode::Limits));
                        assert!(gx > 0.0, "Gxa {gx}");
                    }
                    // Fy falls monotonically (ISO-W, PKY1 < 0) from -13 to +13 deg except at
                    // most a gentle fall-off beyond the peak: check the linear region slope sign
                    // and that the peak exceeds the value at 13 deg by less than 15 %.
                    let fy_at = |deg: f64| {
                        let inp = SlipInput {
                            fz_n: fz,
                            alpha_rad: f64::to_radians(deg),
                            gamma_rad: g,
                            vx_mps: V_REF_MPS,
                            kappa: 0.0,
                        };
                        pure_fy0(c, &load(c, &inp, Mode::Limits)).fy0
                    };
                    let peak = (0..=130)
                        .map(|i| fy_at(i as f64 * 0.1).abs())
                        .fold(0.0, f64::max);
                    assert!(fy_at(1.0) < fy_at(-1.0));
                    assert!(fy_at(13.0).abs() > 0.85 * peak, "Fy drops too much");
                    for k in [-0.2, -0.1, 0.1, 0.2] {
                        let inp = SlipInput {
                            fz_n: fz,
                            kappa: k,
                            gamma_rad: g,
                            vx_mps: V_REF_MPS,
                            alpha_rad: 0.0,
                        };
                        let fx = pure_fx0(c, &load(c, &inp, Mode::Limits)).fx0;
                        assert!(fx * k > 0.0, "Fx({k}) = {fx}");
                    }
                }
            }
        }
    }
}
