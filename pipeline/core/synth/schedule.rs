//! Test schedules: what the virtual machine is commanded to do in one run file.
//!
//! In: a tire's test plan (Round 4 or Rounds 6-9 style, `docs/ttc-format.md` "What a run
//! contains"), the nominal pressure and the schedule knobs ([`ScheduleConfig`]). Out: a
//! [`Program`]: a list of linear set-point ramps ([`Piece`]s, each marked as test or as dwell)
//! and the segments a correct segmentation must find ([`SegmentPlan`], the truth of
//! `segments.csv`).
//!
//! Set-points are ISO-W (TYDEX W): the consortium's SAE sweep "SA -4 -> +12 -> -12 -> +3 deg" is
//! written here as alpha +4 -> -12 -> +12 -> -3 deg, and combined-slip runs "stored as SA -3, -6"
//! are alpha +3, +6. Loads and pressures are commanded in the consortium's US units (lb, psi) and
//! carried in SI. Deliberately not here: physics, sensors, file formats.

pub use crate::segment::SegmentKind;

use super::tires::{BaseTire, KPA_PER_PSI, N_PER_LBF, TestPlan, V_REF_MPS};

/// m/s per mph.
pub const MPS_PER_MPH: f64 = 0.447_04;

/// What kind of run file a program is (the run guide's `kind`).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum RunKind {
    /// Spring rates, cold-to-warm, conditioning, the slip-angle matrix (+ transient extras).
    Cornering,
    /// Warm-up, then slip-ratio sweeps at slip angles 0, 3, 6 deg.
    DriveBrake,
}

impl RunKind {
    /// The catalog's `kind` value.
    pub const fn as_str(self) -> &'static str {
        match self {
            RunKind::Cornering => "cornering",
            RunKind::DriveBrake => "drive_brake",
        }
    }

    /// The `.mat` `testid` text.
    pub const fn test_id(self) -> &'static str {
        match self {
            RunKind::Cornering => "Cornering",
            RunKind::DriveBrake => "Drive/Brake/Combined",
        }
    }
}

/// Commanded machine state, ISO-W, SI.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct MachineCommand {
    /// Road speed, m/s.
    pub v_mps: f64,
    /// Vertical load, N (> 0).
    pub fz_n: f64,
    /// Inclination angle, rad.
    pub gamma_rad: f64,
    /// Slip angle, rad (ISO-W).
    pub alpha_rad: f64,
    /// Longitudinal slip.
    pub kappa: f64,
}

impl MachineCommand {
    fn lerp(&self, to: &MachineCommand, f: f64) -> MachineCommand {
        let l = |a: f64, b: f64| a + (b - a) * f;
        MachineCommand {
            v_mps: l(self.v_mps, to.v_mps),
            fz_n: l(self.fz_n, to.fz_n),
            gamma_rad: l(self.gamma_rad, to.gamma_rad),
            alpha_rad: l(self.alpha_rad, to.alpha_rad),
            kappa: l(self.kappa, to.kappa),
        }
    }
}

/// A linear ramp of the commanded state.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Piece {
    /// Duration, s.
    pub duration_s: f64,
    /// State at the start.
    pub from: MachineCommand,
    /// State at the end.
    pub to: MachineCommand,
    /// A dwell (cooling, transition): dropped from "run" files, kept in "raw" files.
    pub dwell: bool,
}

/// Nominal levels of a segment (`None` where the level is swept or not applicable).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Nominal {
    /// Nominal pressure, kPa (whole kPa of the commanded psi).
    pub pressure_kpa: f64,
    /// Inclination angle, deg.
    pub ia_deg: Option<f64>,
    /// Load, N (whole N of the commanded lb).
    pub fz_n: Option<f64>,
    /// Slip angle, deg, ISO-W sign.
    pub alpha_deg: Option<f64>,
    /// Road speed, km/h (2 decimals of the commanded mph).
    pub speed_kph: Option<f64>,
}

/// A segment of the program: pieces `first..end` (test pieces only) and its nominal levels.
#[derive(Clone, Debug, PartialEq)]
pub struct SegmentPlan {
    pub kind: SegmentKind,
    pub first_piece: usize,
    pub end_piece: usize,
    pub nominal: Nominal,
}

/// One run file's commanded program.
#[derive(Clone, Debug, PartialEq)]
pub struct Program {
    pub kind: RunKind,
    pub pressure_psi: f64,
    pub pieces: Vec<Piece>,
    pub segments: Vec<SegmentPlan>,
    /// Where the rig's structure is set ringing (the rig-turnaround quirk,
    /// [`super::quirks::apply_turnarounds`]): `(t_s, sign)`, in time order; empty otherwise.
    pub rings: Vec<(f64, f64)>,
}

impl Program {
    /// Total duration, s.
    pub fn duration_s(&self) -> f64 {
        self.pieces.iter().map(|p| p.duration_s).sum()
    }

    /// The commanded pressure, kPa.
    pub fn pressure_kpa(&self) -> f64 {
        self.pressure_psi * KPA_PER_PSI
    }
}

/// Schedule knobs (defaults follow `docs/ttc-format.md`).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ScheduleConfig {
    /// Cooling dwell before every matrix sweep, s.
    pub dwell_s: f64,
    /// Slip-angle rate of the matrix sweeps, deg/s.
    pub sweep_rate_deg_s: f64,
    /// Slip-angle rate of the cold-to-warm sweeps, deg/s.
    pub cold_to_warm_rate_deg_s: f64,
    /// Slip-ratio rate of the drive/brake sweeps, 1/s.
    pub slip_rate_per_s: f64,
    /// Hold time of each spring-rate load step, s.
    pub spring_step_s: f64,
}

impl Default for ScheduleConfig {
    fn default() -> Self {
        ScheduleConfig {
            dwell_s: 12.0,
            sweep_rate_deg_s: 4.0,
            cold_to_warm_rate_deg_s: 8.0,
            slip_rate_per_s: 0.15,
            spring_step_s: 1.0,
        }
    }
}

/// Whole newtons of a commanded load in lb.
pub fn nominal_n(lb: f64) -> f64 {
    (lb * N_PER_LBF).round()
}

/// km/h with 2 decimals of a commanded speed in mph.
pub fn nominal_kph(mph: f64) -> f64 {
    (mph * MPS_PER_MPH * 3.6 * 100.0).round() / 100.0
}

/// Builds a program piece by piece from the current commanded state.
struct Builder {
    now: MachineCommand,
    pieces: Vec<Piece>,
    segments: Vec<SegmentPlan>,
    open: Option<(SegmentKind, usize, Nominal)>,
    pressure_kpa_nom: f64,
}

impl Builder {
    fn new(pressure_psi: f64) -> Builder {
        Builder {
            now: MachineCommand {
                v_mps: 0.0,
                fz_n: 50.0 * N_PER_LBF,
                gamma_rad: 0.0,
                alpha_rad: 0.0,
                kappa: 0.0,
            },
            pieces: Vec::new(),
            segments: Vec::new(),
            open: None,
            pressure_kpa_nom: (pressure_psi * KPA_PER_PSI).round(),
        }
    }

    fn ramp(&mut self, to: MachineCommand, duration_s: f64, dwell: bool) {
        if duration_s <= 0.0 {
            self.now = to;
            return;
        }
        self.pieces.push(Piece {
            duration_s,
            from: self.now,
            to,
            dwell,
        });
        self.now = to;
    }

    fn hold(&mut self, duration_s: f64, dwell: bool) {
        self.ramp(self.now, duration_s, dwell);
    }

    /// Dwell transition to a new set-point (load, inclination, speed, slip angle), then settle.
    fn dwell_to(&mut self, v_mps: f64, fz_n: f64, ia_deg: f64, alpha_deg: f64, settle_s: f64) {
        let mut to = self.now;
        let dv = (v_mps - to.v_mps).abs();
        to.v_mps = v_mps;
        to.fz_n = fz_n;
        to.gamma_rad = ia_deg.to_radians();
        to.kappa = 0.0;
        let ramp_s = (dv / 4.0).max(1.0);
        // Slip angle back to zero first, then the rest, then the slip angle of the next test.
        let mut zero_alpha = self.now;
        zero_alpha.alpha_rad = 0.0;
        zero_alpha.kappa = 0.0;
        self.ramp(zero_alpha, 0.5, true);
        to.alpha_rad = 0.0;
        self.ramp(to, ramp_s, true);
        self.hold(settle_s, true);
        to.alpha_rad = alpha_deg.to_radians();
        if alpha_deg != 0.0 {
            self.ramp(to, 0.5 + alpha_deg.abs() / 10.0, true);
        }
    }

    fn begin(&mut self, kind: SegmentKind, nominal: Nominal) {
        debug_assert!(self.open.is_none());
        self.open = Some((kind, self.pieces.len(), nominal));
    }

    fn end(&mut self) {
        let (kind, first_piece, nominal) = self.open.take().expect("segment open");
        self.segments.push(SegmentPlan {
            kind,
            first_piece,
            end_piece: self.pieces.len(),
            nominal,
        });
    }

    fn nominal(&self) -> Nominal {
        Nominal {
            pressure_kpa: self.pressure_kpa_nom,
            ia_deg: None,
            fz_n: None,
            alpha_deg: None,
            speed_kph: None,
        }
    }

    /// Slip-angle sweep through `points_deg` (ISO-W) at `rate` deg/s, as test pieces.
    fn sweep_alpha(&mut self, points_deg: &[f64], rate_deg_s: f64) {
        for &p in points_deg {
            let mut to = self.now;
            to.alpha_rad = p.to_radians();
            let d = (to.alpha_rad - self.now.alpha_rad).abs().to_degrees() / rate_deg_s;
            self.ramp(to, d, false);
        }
    }

    /// Slip-ratio sweep through `points` at `rate` 1/s, as test pieces.
    fn sweep_kappa(&mut self, points: &[f64], rate_per_s: f64) {
        for &p in points {
            let mut to = self.now;
            to.kappa = p;
            let d = (p - self.now.kappa).abs() / rate_per_s;
            self.ramp(to, d, false);
        }
    }

    /// One spring-rate staircase (load steps up, then back to the first) at the current IA.
    fn staircase(&mut self, kind: SegmentKind, loads_lb: &[f64], ia_deg: f64, step_s: f64) {
        let v = self.now.v_mps;
        self.dwell_to(v, loads_lb[0] * N_PER_LBF, ia_deg, 0.0, 1.0);
        let mut nominal = self.nominal();
        nominal.ia_deg = Some(ia_deg);
        nominal.alpha_deg = Some(0.0);
        nominal.speed_kph = Some(if v > 0.0 {
            nominal_kph(v / MPS_PER_MPH)
        } else {
            0.0
        });
        self.begin(kind, nominal);
        self.hold(step_s, false);
        for &lb in &loads_lb[1..] {
            let mut to = self.now;
            to.fz_n = lb * N_PER_LBF;
            self.ramp(to, 0.3, false);
            self.hold(step_s, false);
        }
        self.end();
    }

    fn finish(mut self, kind: RunKind, pressure_psi: f64) -> Program {
        let to = MachineCommand {
            v_mps: 0.0,
            fz_n: 50.0 * N_PER_LBF,
            gamma_rad: 0.0,
            alpha_rad: 0.0,
            kappa: 0.0,
        };
        let s = (self.now.v_mps / 4.0).max(1.0);
        self.ramp(to, s, true);
        self.hold(1.0, true);
        Program {
            kind,
            pressure_psi,
            pieces: self.pieces,
            segments: self.segments,
            rings: Vec::new(),
        }
    }
}

/// Loads of a plan in test order, lb (10-inch tires: 200 lb replaces 350 lb).
fn matrix_loads_lb(tire: &BaseTire) -> Vec<f64> {
    let top = if tire.ten_inch() { 200.0 } else { 350.0 };
    vec![top, 150.0, 50.0, 250.0, 100.0]
}

fn spring_loads_lb(tire: &BaseTire) -> Vec<f64> {
    let top = if tire.ten_inch() { 250.0 } else { 350.0 };
    vec![50.0, 100.0, 150.0, 250.0, top]
}

/// The cold-to-warm test: `n` full +-12 deg cycles at 1112 N (250 lb), IA 0.
fn cold_to_warm(b: &mut Builder, n: usize, rate_deg_s: f64) {
    let v = b.now.v_mps;
    b.dwell_to(v, 250.0 * N_PER_LBF, 0.0, 0.0, 1.0);
    let mut nominal = b.nominal();
    nominal.ia_deg = Some(0.0);
    nominal.fz_n = Some(nominal_n(250.0));
    nominal.speed_kph = Some(nominal_kph(v / MPS_PER_MPH));
    b.begin(SegmentKind::ColdToWarm, nominal);
    b.sweep_alpha(&[12.0], rate_deg_s);
    for _ in 0..n {
        b.sweep_alpha(&[-12.0, 12.0], rate_deg_s);
    }
    b.sweep_alpha(&[0.0], rate_deg_s);
    b.end();
}

/// Spring-rate staircases: static (V = 0) and dynamic (at the test speed), IA 0, 2, 4 each.
fn spring_rates(b: &mut Builder, tire: &BaseTire, cfg: &ScheduleConfig, statics: bool) {
    let loads = spring_loads_lb(tire);
    if statics {
        for ia in [0.0, 2.0, 4.0] {
            b.staircase(SegmentKind::SpringRateStatic, &loads, ia, cfg.spring_step_s);
        }
    }
    let fz = b.now.fz_n;
    b.dwell_to(V_REF_MPS, fz, 0.0, 0.0, 2.0);
    for ia in [0.0, 2.0, 4.0] {
        b.staircase(
            SegmentKind::SpringRateDynamic,
            &loads,
            ia,
            cfg.spring_step_s,
        );
    }
}

/// The cornering run of one pressure.
pub fn cornering_program(tire: &BaseTire, pressure_psi: f64, cfg: &ScheduleConfig) -> Program {
    let mut b = Builder::new(pressure_psi);
    let v = V_REF_MPS;
    let speed_nom = Some(nominal_kph(25.0));
    b.hold(2.0, true);
    spring_rates(&mut b, tire, cfg, true);
    let n_warm = match tire.plan {
        TestPlan::Round4 => 8,
        TestPlan::Round9 => 12,
    };
    cold_to_warm(&mut b, n_warm, cfg.cold_to_warm_rate_deg_s);

    // Conditioning: two +-6 deg cycles at the matrix rate.
    b.dwell_to(v, 250.0 * N_PER_LBF, 0.0, 0.0, 2.0);
    let mut nominal = b.nominal();
    nominal.ia_deg = Some(0.0);
    nominal.fz_n = Some(nominal_n(250.0));
    nominal.speed_kph = speed_nom;
    b.begin(SegmentKind::Conditioning, nominal);
    b.sweep_alpha(&[6.0, -6.0, 6.0, -6.0, 0.0], cfg.sweep_rate_deg_s);
    b.end();

    if tire.plan == TestPlan::Round9 {
        // Step steers SAE -1, +1, +6 deg = ISO-W +1, -1, -6 deg, at 60 deg/s.
        for target in [1.0, -1.0, -6.0] {
            b.dwell_to(v, 250.0 * N_PER_LBF, 0.0, 0.0, 2.0);
            let mut nominal = b.nominal();
            nominal.ia_deg = Some(0.0);
            nominal.fz_n = Some(nominal_n(250.0));
            nominal.alpha_deg = Some(target);
            nominal.speed_kph = speed_nom;
            b.begin(SegmentKind::StepSteer, nominal);
            b.hold(0.5, false);
            b.sweep_alpha(&[target], 60.0);
            b.hold(2.0, false);
            b.sweep_alpha(&[0.0], 60.0);
            b.hold(0.5, false);
            b.end();
        }
    }

    let (ias, shape): (&[f64], &[f64]) = match tire.plan {
        // SAE -4 -> +12 -> -12 -> +3 deg.
        TestPlan::Round4 => (&[0.0, 2.0, 4.0, 1.0, 3.0], &[4.0, -12.0, 12.0, -3.0, 0.0]),
        TestPlan::Round9 => (&[0.0, 2.0, 4.0], &[-12.0, 12.0, 0.0]),
    };
    for &ia in ias {
        for lb in matrix_loads_lb(tire) {
            b.dwell_to(v, lb * N_PER_LBF, ia, 0.0, cfg.dwell_s);
            let mut nominal = b.nominal();
            nominal.ia_deg = Some(ia);
            nominal.fz_n = Some(nominal_n(lb));
            nominal.speed_kph = speed_nom;
            b.begin(SegmentKind::Cornering, nominal);
            b.sweep_alpha(shape, cfg.sweep_rate_deg_s);
            b.end();
        }
    }

    if tire.plan == TestPlan::Round9 {
        b.dwell_to(v, 250.0 * N_PER_LBF, 0.0, 0.0, cfg.dwell_s);
        let mut nominal = b.nominal();
        nominal.fz_n = Some(nominal_n(250.0));
        nominal.alpha_deg = Some(0.0);
        nominal.speed_kph = speed_nom;
        b.begin(SegmentKind::IaSweep, nominal);
        for ia in [-4.0_f64, 4.0, 0.0] {
            let mut to = b.now;
            to.gamma_rad = ia.to_radians();
            let d = (to.gamma_rad - b.now.gamma_rad).abs().to_degrees() / 1.0;
            b.ramp(to, d, false);
        }
        b.end();
        for mph in [15.0, 45.0] {
            b.dwell_to(mph * MPS_PER_MPH, 250.0 * N_PER_LBF, 0.0, 0.0, cfg.dwell_s);
            let mut nominal = b.nominal();
            nominal.ia_deg = Some(0.0);
            nominal.fz_n = Some(nominal_n(250.0));
            nominal.speed_kph = Some(nominal_kph(mph));
            b.begin(SegmentKind::SpeedSweep, nominal);
            b.sweep_alpha(&[-12.0, 12.0, 0.0], cfg.sweep_rate_deg_s);
            b.end();
        }
        b.dwell_to(v, 50.0 * N_PER_LBF, 0.0, 0.0, 2.0);
    }

    // Spring rate again at the end (dynamic, IA 0).
    let loads = spring_loads_lb(tire);
    b.staircase(
        SegmentKind::SpringRateDynamic,
        &loads,
        0.0,
        cfg.spring_step_s,
    );
    b.finish(RunKind::Cornering, pressure_psi)
}

/// The drive/brake run of one pressure.
pub fn drive_brake_program(tire: &BaseTire, pressure_psi: f64, cfg: &ScheduleConfig) -> Program {
    let mut b = Builder::new(pressure_psi);
    let v = V_REF_MPS;
    let speed_nom = Some(nominal_kph(25.0));
    b.hold(2.0, true);
    spring_rates(&mut b, tire, cfg, false);
    cold_to_warm(&mut b, 4, cfg.cold_to_warm_rate_deg_s);
    let (k, loads): (f64, Vec<f64>) = match tire.plan {
        TestPlan::Round4 => (0.20, {
            let top = if tire.ten_inch() { 200.0 } else { 350.0 };
            vec![top, 150.0, 250.0, 50.0]
        }),
        TestPlan::Round9 => (0.15, {
            let top = if tire.ten_inch() { 200.0 } else { 350.0 };
            vec![top, 150.0, 250.0, 50.0]
        }),
    };
    for sa in [0.0, 3.0, 6.0] {
        for ia in [0.0, 2.0, 4.0] {
            for &lb in &loads {
                b.dwell_to(v, lb * N_PER_LBF, ia, sa, cfg.dwell_s);
                let mut nominal = b.nominal();
                nominal.ia_deg = Some(ia);
                nominal.fz_n = Some(nominal_n(lb));
                nominal.alpha_deg = Some(sa);
                nominal.speed_kph = speed_nom;
                let kind = if sa == 0.0 {
                    SegmentKind::DriveBrake
                } else {
                    SegmentKind::Combined
                };
                b.begin(kind, nominal);
                b.sweep_kappa(&[k, -k, k, 0.0], cfg.slip_rate_per_s);
                b.end();
            }
        }
    }
    if tire.plan == TestPlan::Round9 {
        for mph in [15.0, 45.0] {
            b.dwell_to(mph * MPS_PER_MPH, 250.0 * N_PER_LBF, 0.0, 0.0, cfg.dwell_s);
            let mut nominal = b.nominal();
            nominal.ia_deg = Some(0.0);
            nominal.fz_n = Some(nominal_n(250.0));
            nominal.alpha_deg = Some(0.0);
            nominal.speed_kph = Some(nominal_kph(mph));
            b.begin(SegmentKind::SpeedSweep, nominal);
            b.sweep_kappa(&[k, -k, k, 0.0], cfg.slip_rate_per_s);
            b.end();
        }
    }
    b.finish(RunKind::DriveBrake, pressure_psi)
}

impl Program {
    /// The commanded state at time `t_s` and the index of the piece it falls in, walking forward
    /// from `hint` (pass the previous result; time must not decrease).
    pub fn command_at(&self, t_s: f64, hint: &mut (usize, f64)) -> (MachineCommand, usize) {
        let (ref mut i, ref mut start) = *hint;
        while *i + 1 < self.pieces.len() && t_s >= *start + self.pieces[*i].duration_s {
            *start += self.pieces[*i].duration_s;
            *i += 1;
        }
        let p = &self.pieces[*i];
        let f = ((t_s - *start) / p.duration_s).clamp(0.0, 1.0);
        (p.from.lerp(&p.to, f), *i)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::tires::CATALOGUE;

    #[test]
    fn round4_cornering_has_the_25_sweep_matrix_and_sensible_length() {
        let p = cornering_program(&CATALOGUE[0], 12.0, &ScheduleConfig::default());
        let n = |k| p.segments.iter().filter(|s| s.kind == k).count();
        assert_eq!(n(SegmentKind::Cornering), 25);
        assert_eq!(n(SegmentKind::SpringRateStatic), 3);
        assert_eq!(n(SegmentKind::SpringRateDynamic), 4);
        assert_eq!(n(SegmentKind::ColdToWarm), 1);
        let test_s: f64 = p
            .pieces
            .iter()
            .filter(|x| !x.dwell)
            .map(|x| x.duration_s)
            .sum();
        assert!((350.0..700.0).contains(&test_s), "{test_s} s of test");
        for s in &p.segments {
            assert!(
                p.pieces[s.first_piece..s.end_piece]
                    .iter()
                    .all(|x| !x.dwell)
            );
        }
    }

    #[test]
    fn round9_plans_have_every_extra_kind() {
        let p = cornering_program(&CATALOGUE[1], 10.0, &ScheduleConfig::default());
        for k in [
            SegmentKind::StepSteer,
            SegmentKind::IaSweep,
            SegmentKind::SpeedSweep,
        ] {
            assert!(p.segments.iter().any(|s| s.kind == k), "{k:?}");
        }
        let d = drive_brake_program(&CATALOGUE[1], 10.0, &ScheduleConfig::default());
        let n = |k| d.segments.iter().filter(|s| s.kind == k).count();
        assert_eq!(n(SegmentKind::DriveBrake), 12);
        assert_eq!(n(SegmentKind::Combined), 24);
    }
}
