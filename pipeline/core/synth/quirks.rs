//! Quirks of real rounds the virtual machine can imitate, each with its truth: older rounds'
//! files, test plans off the standard levels, de-identified data.
//!
//! In: a [`QuirksConfig`] (`[synth.quirks]`, everything off by default: the demo round stays
//! clean). Out: changes to the commanded programs ([`apply_to_program`]: scaled slip angles and
//! loads, loads off the standard list), to the machine (loose load control, 50 Hz), to the files
//! ([`apply_to_table`]: no SL, no NFX/NFY, radius channels in a wrong length unit; `.mat` without
//! a `channel` struct) and the truth of the unit errors ([`UnitErrorRow`],
//! `truth/unit_errors.csv`). The segments' truth follows the commanded (quirked) levels.
//!
//! - **Older round** (rounds 1-3): every file at 50 Hz; loose load control, FZ swinging by
//!   `load_swing_frac` around its set-point while the tire slips (a sine of a period between
//!   0.5 and 2 s per run: several swings within every sweep); Calspan's SR but no SL and no
//!   NFX/NFY; RL and RE written in inches where the file declares cm (and in cm where it
//!   declares inches); `.mat` files without the `channel` struct (no unit metadata at all).
//! - **Non-standard levels**: a 16 psi (110 kPa) pressure for every tire, and every load moved
//!   off the consortium's list (50/100/150/200/250/350 lb -> 75/125/175/225/275/400 lb).
//! - **De-identified** (as the consortium publishes example data): commanded slip angles and
//!   loads multiplied by `sa_scale` and `load_scale`.
//! - **Run-order drift** (`[synth.quirks.drift]`, [`super::drift`]): friction and slip stiffness
//!   that settle with the tire's history, so the pressure tested first differs from the others
//!   by more than pressure; the truth of each pressure is the tire as its block saw it.
//! - **Rig turnaround** (as in the consortium's published cornering data): the steer does not
//!   reverse a slip-angle sweep at once. It decelerates over [`TURNAROUND_DECEL_S`] to a creep
//!   ([`TURNAROUND_CREEP_FRAC`] of the sweep rate), creeps for `turnaround_dwell_s` ending
//!   [`TURNAROUND_SHORT_RAD`] short of the extreme, jumps the rest in [`TURNAROUND_JUMP_S`] and
//!   reverses ([`apply_turnarounds`]: the run is longer by the time the turnarounds take). As the
//!   steer slows and again at the jump the rig's structure rings: a damped sine on the measured
//!   `Mz` (`turnaround_ring_mz_nm`) and `Fy` (`turnaround_ring_fy_n`), see
//!   [`super::machine::TurnaroundRing`].
//!
//! Deliberately not here: physics (the truth models are unchanged; the drift's law and the
//! truth under it are in [`super::drift`]), segmentation.

use serde::{Deserialize, Serialize};

use super::dat::{ChannelTable, Container, FileStyle, FileUnits};
use super::drift::RunOrderDrift;
use super::machine::TurnaroundRing;
use super::schedule::{Piece, Program};
use super::tires::N_PER_LBF;

/// Quirks of real rounds to imitate (`[synth.quirks]`), all off by default: older-round files,
/// non-standard levels, de-identified scaling.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct QuirksConfig {
    /// Older-round files: 50 Hz, loose load control, SR without SL or NFX/NFY, radius channels
    /// in a wrong length unit, `.mat` without a `channel` struct.
    pub older_round: bool,
    /// Loose load control of an older round: FZ swings by this fraction of its set-point while
    /// the tire slips, -.
    pub load_swing_frac: f64,
    /// A 16 psi pressure for every tire and loads off the standard list.
    pub nonstandard_levels: bool,
    /// De-identified data: commanded slip angles multiplied by this, -.
    pub sa_scale: f64,
    /// De-identified data: commanded loads multiplied by this, -.
    pub load_scale: f64,
    /// The rig's slip-angle turnarounds: deceleration, a creep short of the extreme, a jump,
    /// and a ringing of the measured `Mz` and `Fy` excited as the steer slows and jumps.
    pub rig_turnaround: bool,
    /// Rig turnaround: how long the steer creeps short of the extreme before it jumps, s.
    pub turnaround_dwell_s: f64,
    /// Rig turnaround: amplitude of the ringing of the measured `Mz` each excitation starts, N m.
    pub turnaround_ring_mz_nm: f64,
    /// Rig turnaround: amplitude of the ringing of the measured `Fy` each excitation starts, N.
    pub turnaround_ring_fy_n: f64,
    /// Run-order drift of friction and slip stiffness (off by default; not written to
    /// `round.toml` when off, so a round without it keeps its bytes).
    #[serde(skip_serializing_if = "RunOrderDrift::is_off")]
    pub drift: RunOrderDrift,
}

impl Default for QuirksConfig {
    fn default() -> Self {
        QuirksConfig {
            older_round: false,
            load_swing_frac: 0.2,
            nonstandard_levels: false,
            sa_scale: 1.0,
            load_scale: 1.0,
            rig_turnaround: false,
            turnaround_dwell_s: 0.2,
            turnaround_ring_mz_nm: 20.0,
            turnaround_ring_fy_n: 40.0,
            drift: RunOrderDrift::default(),
        }
    }
}

impl QuirksConfig {
    /// Every quirk on, with the consortium's de-identification scales seen in published data
    /// (slip angles x 0.8125: +-12 deg -> +-9.75 deg) and loads x 1.15, the rig's turnarounds at
    /// their defaults and the typical run-order drift ([`RunOrderDrift::typical`]).
    pub fn all() -> QuirksConfig {
        QuirksConfig {
            older_round: true,
            load_swing_frac: 0.2,
            nonstandard_levels: true,
            sa_scale: 0.8125,
            load_scale: 1.15,
            rig_turnaround: true,
            drift: RunOrderDrift::typical(),
            ..QuirksConfig::default()
        }
    }

    /// The range problem of a value, if any: `(key, value, message)`.
    pub fn invalid(&self) -> Option<(&'static str, f64, &'static str)> {
        let in_range = |v: f64, lo: f64, hi: f64| v.is_finite() && (lo..=hi).contains(&v);
        for (key, v, lo, hi, message) in [
            (
                "quirks.load_swing_frac",
                self.load_swing_frac,
                0.0,
                0.5,
                "must be in 0..0.5",
            ),
            (
                "quirks.sa_scale",
                self.sa_scale,
                0.3,
                2.0,
                "must be in 0.3..2",
            ),
            (
                "quirks.load_scale",
                self.load_scale,
                0.3,
                3.0,
                "must be in 0.3..3",
            ),
            (
                "quirks.turnaround_dwell_s",
                self.turnaround_dwell_s,
                0.0,
                2.0,
                "must be in 0..2",
            ),
            (
                "quirks.turnaround_ring_mz_nm",
                self.turnaround_ring_mz_nm,
                0.0,
                200.0,
                "must be in 0..200",
            ),
            (
                "quirks.turnaround_ring_fy_n",
                self.turnaround_ring_fy_n,
                0.0,
                2000.0,
                "must be in 0..2000",
            ),
        ] {
            if !in_range(v, lo, hi) {
                return Some((key, v, message));
            }
        }
        self.drift.invalid()
    }

    /// The sample rate of a file of `style`, Hz.
    pub fn rate_hz(&self, style: &FileStyle) -> f64 {
        if self.older_round {
            50.0
        } else {
            style.rate_hz()
        }
    }

    /// The pressures a tire is tested at, psi.
    pub fn pressures_psi(&self, planned: &[f64]) -> Vec<f64> {
        let mut p = planned.to_vec();
        if self.nonstandard_levels {
            match p.len() {
                0 | 1 => p.push(NONSTANDARD_PSI),
                n => p[n - 1] = NONSTANDARD_PSI,
            }
        }
        p
    }

    /// The ringing of the measured forces at the rig's turnarounds (`None`: the quirk is off).
    pub fn turnaround_ring(&self) -> Option<TurnaroundRing> {
        self.rig_turnaround.then_some(TurnaroundRing {
            mz_nm: self.turnaround_ring_mz_nm,
            fy_n: self.turnaround_ring_fy_n,
        })
    }

    /// Whether any quirk changes the commanded levels.
    fn moves_levels(&self) -> bool {
        self.nonstandard_levels || self.sa_scale != 1.0 || self.load_scale != 1.0
    }

    /// A commanded load after the level quirks, N.
    pub fn load_n(&self, fz_n: f64) -> f64 {
        let lb = fz_n / N_PER_LBF;
        let lb = if self.nonstandard_levels {
            off_list_lb(lb)
        } else {
            lb
        };
        lb * N_PER_LBF * self.load_scale
    }
}

/// The pressure a non-standard round adds, psi (round 3 tested 10/12/14/16 psi).
pub const NONSTANDARD_PSI: f64 = 16.0;

/// Standard loads and where a non-standard plan puts them, lb (linear in between and beyond).
const OFF_LIST_LB: [(f64, f64); 7] = [
    (0.0, 0.0),
    (50.0, 75.0),
    (100.0, 125.0),
    (150.0, 175.0),
    (200.0, 225.0),
    (250.0, 275.0),
    (350.0, 400.0),
];

fn off_list_lb(lb: f64) -> f64 {
    let k = OFF_LIST_LB
        .iter()
        .position(|p| p.0 >= lb)
        .unwrap_or(OFF_LIST_LB.len() - 1)
        .max(1);
    let ((x0, y0), (x1, y1)) = (OFF_LIST_LB[k - 1], OFF_LIST_LB[k]);
    y0 + (lb - x0) * (y1 - y0) / (x1 - x0)
}

/// The rig's turnaround: how long the steer takes to slow from the sweep rate to its creep, s.
pub const TURNAROUND_DECEL_S: f64 = 0.1;
/// ... its creep rate as a fraction of the sweep rate, -.
pub const TURNAROUND_CREEP_FRAC: f64 = 0.1;
/// ... how far short of the extreme the creep ends, rad.
pub const TURNAROUND_SHORT_RAD: f64 = 0.003;
/// ... how long the jump over the rest takes, s.
pub const TURNAROUND_JUMP_S: f64 = 0.02;
/// Steps of the piecewise-constant deceleration (pieces are linear ramps).
const DECEL_STEPS: usize = 4;

/// Scale and move the commanded slip angles and loads of a program, and its segments' nominal
/// levels with them (the truth is what was commanded); then the rig's turnarounds
/// ([`apply_turnarounds`]).
pub fn apply_to_program(program: &mut Program, q: &QuirksConfig) {
    apply_levels(program, q);
    if q.rig_turnaround {
        apply_turnarounds(program, q.turnaround_dwell_s);
    }
}

/// The rate of a slip-angle-only test ramp, rad/s signed (`None`: not one).
fn alpha_ramp_rate(p: &Piece) -> Option<f64> {
    let (a, b) = (&p.from, &p.to);
    let alpha_only = a.v_mps == b.v_mps
        && a.fz_n == b.fz_n
        && a.gamma_rad == b.gamma_rad
        && a.kappa == b.kappa
        && a.alpha_rad != b.alpha_rad;
    (alpha_only && !p.dwell && p.duration_s > 0.0)
        .then_some((b.alpha_rad - a.alpha_rad) / p.duration_s)
}

/// Every reversal of a slip-angle sweep (a test ramp followed by one back) as the rig runs it:
/// the approach ramp cruises, decelerates over [`TURNAROUND_DECEL_S`] to a creep of
/// [`TURNAROUND_CREEP_FRAC`] of its rate, creeps for `dwell_s` up to [`TURNAROUND_SHORT_RAD`]
/// short of the extreme and jumps there in [`TURNAROUND_JUMP_S`]; the return ramp is unchanged.
/// The program gets longer by the time this takes; segments keep their pieces. The program's
/// ring excitations ([`Program::rings`]) are the starts of the deceleration and of the jump,
/// signed by the approach direction.
pub fn apply_turnarounds(program: &mut Program, dwell_s: f64) {
    let old = std::mem::take(&mut program.pieces);
    let mut map = Vec::with_capacity(old.len() + 1);
    let mut t = 0.0;
    for (i, p) in old.iter().enumerate() {
        map.push(program.pieces.len());
        let rates = (alpha_ramp_rate(p), old.get(i + 1).and_then(alpha_ramp_rate));
        let reversal = match rates {
            (Some(r), Some(next)) => (r * next < 0.0 && old[i + 1].from == p.to).then_some(r),
            _ => None,
        };
        let Some(rate) = reversal else {
            program.pieces.push(*p);
            t += p.duration_s;
            continue;
        };
        let (sign, r) = (rate.signum(), rate.abs());
        let creep = TURNAROUND_CREEP_FRAC * r;
        let step_s = TURNAROUND_DECEL_S / DECEL_STEPS as f64;
        let step_rates: Vec<f64> = (0..DECEL_STEPS)
            .map(|k| r - (r - creep) * (k as f64 + 0.5) / DECEL_STEPS as f64)
            .collect();
        let decel: f64 = step_rates.iter().sum::<f64>() * step_s;
        let total = (p.to.alpha_rad - p.from.alpha_rad).abs();
        let cruise = total - TURNAROUND_SHORT_RAD - decel - creep * dwell_s;
        if cruise <= 0.0 {
            program.pieces.push(*p);
            t += p.duration_s;
            continue;
        }
        let mut at = p.from;
        let mut push = |pieces: &mut Vec<Piece>, t: &mut f64, dist: f64, duration_s: f64| {
            let mut to = at;
            to.alpha_rad += sign * dist;
            pieces.push(Piece {
                duration_s,
                from: at,
                to,
                dwell: false,
            });
            at = to;
            *t += duration_s;
        };
        push(&mut program.pieces, &mut t, cruise, cruise / r);
        program.rings.push((t, sign));
        for &v in &step_rates {
            push(&mut program.pieces, &mut t, v * step_s, step_s);
        }
        if dwell_s > 0.0 {
            push(&mut program.pieces, &mut t, creep * dwell_s, dwell_s);
        }
        program.rings.push((t, sign));
        push(
            &mut program.pieces,
            &mut t,
            TURNAROUND_SHORT_RAD,
            TURNAROUND_JUMP_S,
        );
        // The jump ends exactly at the extreme (no rounding drift into the return ramp).
        if let Some(last) = program.pieces.last_mut() {
            last.to = p.to;
        }
    }
    map.push(program.pieces.len());
    for seg in &mut program.segments {
        seg.first_piece = map[seg.first_piece];
        seg.end_piece = map[seg.end_piece];
    }
}

fn apply_levels(program: &mut Program, q: &QuirksConfig) {
    if !q.moves_levels() {
        return;
    }
    for piece in &mut program.pieces {
        for c in [&mut piece.from, &mut piece.to] {
            c.alpha_rad *= q.sa_scale;
            c.fz_n = q.load_n(c.fz_n);
        }
    }
    for seg in &mut program.segments {
        seg.nominal.alpha_deg = seg.nominal.alpha_deg.map(|a| a * q.sa_scale);
        seg.nominal.fz_n = seg.nominal.fz_n.map(|f| q.load_n(f).round());
    }
}

/// One radius channel written in a wrong unit (a row of `truth/unit_errors.csv`).
#[derive(Clone, Debug, PartialEq)]
pub struct UnitErrorRow {
    pub file: String,
    pub channel: &'static str,
    /// The unit the file declares (or, without unit metadata, the reader's SI default).
    pub declared: &'static str,
    /// The unit the values are really in.
    pub actual: &'static str,
    /// What the values must be multiplied by to be in the declared unit.
    pub factor: f64,
}

/// Older-round file contents: no SL, NFX, NFY; RL and RE in the other length unit. Returns the
/// unit errors injected.
pub fn apply_to_table(
    table: &mut ChannelTable,
    style: &FileStyle,
    file: &str,
    q: &QuirksConfig,
) -> Vec<UnitErrorRow> {
    if !q.older_round {
        return Vec::new();
    }
    table
        .columns
        .retain(|c| !matches!(c.name.as_str(), "SL" | "NFX" | "NFY"));
    let declared_in = style.units == FileUnits::UsCustomary && style.container == Container::Dat;
    let (declared, actual, values_per_declared) = if declared_in {
        ("in", "cm", 2.54)
    } else {
        ("cm", "in", 1.0 / 2.54)
    };
    let mut out = Vec::new();
    for name in ["RL", "RE"] {
        if let Some(c) = table.column_mut(name) {
            c.values.iter_mut().for_each(|v| *v *= values_per_declared);
            out.push(UnitErrorRow {
                file: file.to_string(),
                channel: name,
                declared,
                actual,
                factor: 1.0 / values_per_declared,
            });
        }
    }
    out
}

/// `truth/unit_errors.csv`.
pub fn unit_errors_csv(rows: &[UnitErrorRow]) -> String {
    let mut s = String::from("file,channel,declared_unit,actual_unit,factor\n");
    for r in rows {
        s.push_str(&format!(
            "{},{},{},{},{}\n",
            r.file, r.channel, r.declared, r.actual, r.factor
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standard_loads_move_off_the_list_and_scale() {
        let q = QuirksConfig {
            nonstandard_levels: true,
            ..QuirksConfig::default()
        };
        for (lb, want) in [(50.0, 75.0), (250.0, 275.0), (350.0, 400.0), (300.0, 337.5)] {
            assert!(
                (q.load_n(lb * N_PER_LBF) / N_PER_LBF - want).abs() < 1e-9,
                "{lb}"
            );
        }
        let d = QuirksConfig {
            load_scale: 1.15,
            ..QuirksConfig::default()
        };
        assert!((d.load_n(1000.0) - 1150.0).abs() < 1e-9);
        assert_eq!(q.pressures_psi(&[12.0, 10.0]), vec![12.0, 16.0]);
        assert!(QuirksConfig::default().invalid().is_none());
        assert!(QuirksConfig::all().invalid().is_none());
    }

    /// The rig turnaround quirk: every reversal of a sweep between two test ramps is run as a
    /// deceleration, a creep ending 0.003 rad short of the extreme for `turnaround_dwell_s`, and
    /// a jump; the segments keep their pieces and levels, the extremes stay where they were, the
    /// program gets longer by the turnarounds, and each reversal sets the rig ringing twice.
    #[test]
    fn rig_turnarounds_decelerate_creep_and_jump() {
        use crate::synth::schedule::{ScheduleConfig, SegmentKind, cornering_program};
        use crate::synth::tires::CATALOGUE;
        let plain = cornering_program(&CATALOGUE[0], 12.0, &ScheduleConfig::default());
        let mut p = plain.clone();
        let q = QuirksConfig {
            rig_turnaround: true,
            ..QuirksConfig::default()
        };
        apply_to_program(&mut p, &q);
        assert_eq!(p.segments.len(), plain.segments.len());
        let alpha_at = |prog: &Program, t: f64| {
            let mut hint = (0, 0.0);
            prog.command_at(t, &mut hint).0.alpha_rad
        };
        let mut reversals = 0;
        for (a, b) in plain.segments.iter().zip(&p.segments) {
            assert_eq!((a.kind, a.nominal), (b.kind, b.nominal));
            let span = |prog: &Program, s: &super::super::schedule::SegmentPlan| {
                let t0: f64 = prog.pieces[..s.first_piece]
                    .iter()
                    .map(|x| x.duration_s)
                    .sum();
                let d: f64 = prog.pieces[s.first_piece..s.end_piece]
                    .iter()
                    .map(|x| x.duration_s)
                    .sum();
                (t0, d)
            };
            let ((t0a, da), (t0b, db)) = (span(&plain, a), span(&p, b));
            let path = |prog: &Program, t0: f64, d: f64| -> Vec<f64> {
                (0..=(d * 100.0) as usize)
                    .map(|k| alpha_at(prog, t0 + k as f64 * 0.01))
                    .collect()
            };
            let (pa, pb) = (path(&plain, t0a, da), path(&p, t0b, db));
            let piece_extreme = |prog: &Program, s: &super::super::schedule::SegmentPlan| {
                prog.pieces[s.first_piece..s.end_piece]
                    .iter()
                    .fold(0.0f64, |m, x| m.max(x.to.alpha_rad.abs()))
            };
            assert!((piece_extreme(&plain, a) - piece_extreme(&p, b)).abs() < 1e-12);
            if a.kind != SegmentKind::Cornering {
                continue;
            }
            // Each reversal takes 0.1 s + dwell + 0.02 s, minus the time its distance took at
            // the approach's rate.
            let mut longer = 0.0;
            let mut here = 0;
            let mut extremes: Vec<f64> = Vec::new();
            for w in plain.pieces[a.first_piece..a.end_piece].windows(2) {
                let (Some(r), Some(next)) = (alpha_ramp_rate(&w[0]), alpha_ramp_rate(&w[1])) else {
                    continue;
                };
                if r * next < 0.0 {
                    let r = r.abs();
                    let slow = r * (1.0 + TURNAROUND_CREEP_FRAC) / 2.0 * TURNAROUND_DECEL_S
                        + TURNAROUND_CREEP_FRAC * r * q.turnaround_dwell_s
                        + TURNAROUND_SHORT_RAD;
                    longer +=
                        TURNAROUND_DECEL_S + q.turnaround_dwell_s + TURNAROUND_JUMP_S - slow / r;
                    here += 1;
                    extremes.push(w[0].to.alpha_rad.abs());
                }
            }
            assert!(here >= 2, "{here}");
            assert!((db - da - longer).abs() < 1e-9, "{da} -> {db}");
            // The creep: the time spent 0.0029..0.0045 rad short of a reversal's extreme (the
            // creep spans 0.003 + 0.1 * rate * dwell .. 0.003), against the plain sweep's passes
            // there; a segment's sweeps may reverse at more than one slip angle.
            let creeping = |v: &[f64], e: f64| {
                let n = v
                    .iter()
                    .filter(|x| (0.0029..0.0045).contains(&(e - x.abs())))
                    .count();
                n as f64 * 0.01
            };
            extremes.sort_by(f64::total_cmp);
            extremes.dedup_by(|x, y| (*x - *y).abs() < 1e-9);
            let (cb, ca) = extremes.iter().fold((0.0, 0.0), |(cb, ca), &e| {
                (cb + creeping(&pb, e), ca + creeping(&pa, e))
            });
            assert!(
                cb > ca + here as f64 * 0.9 * q.turnaround_dwell_s,
                "{cb} vs {ca}"
            );
            reversals += here;
        }
        assert!(reversals > 0);
        let all = plain
            .pieces
            .windows(2)
            .filter(|w| {
                matches!((alpha_ramp_rate(&w[0]), alpha_ramp_rate(&w[1])),
                    (Some(a), Some(b)) if a * b < 0.0)
            })
            .count();
        assert!(all >= reversals, "{all} {reversals}");
        assert_eq!(p.rings.len(), 2 * all);
        assert!(p.rings.windows(2).all(|w| w[0].0 < w[1].0));
        // The ringing: a damped sine from each excitation, nothing before.
        let r = [(1.0, -1.0)];
        assert_eq!(TurnaroundRing::unit_at(&r, 0.99), 0.0);
        let quarter = 0.25 / super::super::machine::RING_HZ;
        let want = -(-quarter / super::super::machine::RING_DECAY_S).exp();
        assert!((TurnaroundRing::unit_at(&r, 1.0 + quarter) - want).abs() < 1e-12);
    }
}
