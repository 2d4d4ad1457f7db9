//! Relaxation stage against generated signals: a known sigma law applied to a PAC2002 model with
//! the first-order lag (integrated independently by fine RK4 on the continuous slip program),
//! and the thesis's Table 15 for Equations 14-15.

use super::*;
use crate::fit::segment_data::Channels;
use crate::fit::testkit::{add_noise, blank, fsae_model, key};
use crate::numerics::ode::integrate_sampled;
use crate::numerics::random::SplitMix64;
use crate::tire_model::Coef;

const PT: [f64; 5] = [1.75, 1.5, 2.05, -0.6, 0.1];
const V_MPS: f64 = 11.176;
const LOADS: [f64; 5] = [222.0, 445.0, 667.0, 1112.0, 1557.0];

/// A piecewise-linear slip program through `points` at `rate` per second.
struct Program {
    t: Vec<f64>,
    x: Vec<f64>,
}

impl Program {
    fn new(points: &[f64], rate: f64, hold_s: f64) -> Program {
        let mut t = vec![0.0, hold_s];
        let mut x = vec![points[0], points[0]];
        for w in points.windows(2) {
            t.push(t.last().unwrap() + (w[1] - w[0]).abs() / rate);
            x.push(w[1]);
        }
        Program { t, x }
    }

    fn at(&self, t: f64) -> f64 {
        crate::fit::segment_data::interpolate(
            &self.t,
            &self.x,
            t.clamp(0.0, *self.t.last().unwrap()),
        )
        .unwrap()
    }

    fn duration(&self) -> f64 {
        *self.t.last().unwrap()
    }
}

/// The relaxation input of the test tire ("T" at 83 kPa) with `segments` on `model`, at the
/// model's own unloaded radius and vertical stiffness (`segments` empty: all that pooling rows
/// needs).
fn input<'a>(model: &'a Pac2002, segments: &'a [MeasuredSegment]) -> RelaxationInput<'a> {
    RelaxationInput {
        key: key("T", 83),
        model,
        unloaded_radius_m: model.coefs[Coef::UNLOADED_RADIUS],
        vertical_stiffness_n_per_m: model.coefs[Coef::VERTICAL_STIFFNESS],
        segments,
    }
}

/// The measured segment of `program` on `truth` (grip scaled by `grip`) at `load`, lagged with
/// the truth model's own relaxation length, sampled at `hz`, with force noise `noise_n`.
#[allow(clippy::too_many_arguments)]
fn measured(
    truth: &Pac2002,
    program: &Program,
    dir: Direction,
    kind: SegmentKind,
    load: f64,
    hz: f64,
    noise_n: f64,
    grip: f64,
    seed: u64,
) -> MeasuredSegment {
    measured_at(
        truth, program, dir, kind, load, 0.0, hz, noise_n, grip, seed,
    )
}

/// [`measured`] at inclination `ia_deg`.
#[allow(clippy::too_many_arguments)]
fn measured_at(
    truth: &Pac2002,
    program: &Program,
    dir: Direction,
    kind: SegmentKind,
    load: f64,
    ia_deg: f64,
    hz: f64,
    noise_n: f64,
    grip: f64,
    seed: u64,
) -> MeasuredSegment {
    measured_through(
        truth,
        program,
        dir,
        kind,
        (load, ia_deg, V_MPS),
        hz,
        noise_n,
        grip,
        seed,
        &MeasurementLag::NONE,
    )
}

/// [`measured_at`] at `(load, ia_deg, v_mps)`, the force then passed through the rig's
/// measurement chain `rig` (before the noise).
#[allow(clippy::too_many_arguments)]
fn measured_through(
    truth: &Pac2002,
    program: &Program,
    dir: Direction,
    kind: SegmentKind,
    (load, ia_deg, v_mps): (f64, f64, f64),
    hz: f64,
    noise_n: f64,
    grip: f64,
    seed: u64,
    rig: &MeasurementLag,
) -> MeasuredSegment {
    let mut model = truth.clone();
    model.coefs[Coef::LMUY] = grip;
    model.coefs[Coef::LMUX] = grip;
    let gamma = ia_deg.to_radians();
    let (sk, sa) = truth.relaxation_lengths(load, gamma);
    let sigma = if dir == Direction::Lateral { sa } else { sk };
    let f_ss = |t: f64| {
        let x = program.at(t);
        let (alpha, kappa) = if dir == Direction::Lateral {
            (x, 0.0)
        } else {
            (0.0, x)
        };
        let e = model.eval(
            &SlipInput {
                fz_n: load,
                kappa,
                alpha_rad: alpha,
                gamma_rad: gamma,
                vx_mps: v_mps,
            },
            Mode::Limits,
        );
        if dir == Direction::Lateral {
            e.fy_n
        } else {
            e.fx_n
        }
    };
    let n = (program.duration() * hz).floor() as usize + 1;
    let states = integrate_sampled(
        |t, y: &[f64; 1]| [v_mps / sigma * (f_ss(t) - y[0])],
        0.0,
        [f_ss(0.0)],
        1.0 / hz,
        n,
        20,
    );
    let k = key("T", 83);
    let mut s = blank("seg", kind, &k, "run", 0.0, n, hz, v_mps * 3.6);
    s.nominal.fz_n = Some(load as i64);
    s.nominal.ia_cdeg = Some(crate::segment::ia_cdeg_label(ia_deg));
    s.channels.gamma_rad = vec![gamma; n];
    let mut rng = SplitMix64::new(seed);
    let mut f: Vec<f64> = rig.apply(&s.channels.et_s, states.iter().map(|y| y[0]).collect());
    add_noise(&mut f, noise_n, &mut rng);
    let mut fz = vec![load; n];
    add_noise(&mut fz, 4.0 * noise_n / 6.0, &mut rng);
    let c: &mut Channels = &mut s.channels;
    c.fz_n = fz;
    let x: Vec<f64> = c.et_s.iter().map(|&t| program.at(t)).collect();
    if dir == Direction::Lateral {
        c.alpha_rad = x;
        c.fy_n = f;
    } else {
        c.kappa = x;
        c.fx_n = f;
    }
    s
}

fn sweep_program() -> Program {
    // ISO-W 4 -> -12 -> 12 -> -3 -> 0 deg at 4 deg/s after a 1 s hold (round-4 shape).
    let pts: Vec<f64> = [0.0, 4.0, -12.0, 12.0, -3.0, 0.0]
        .iter()
        .map(|d: &f64| d.to_radians())
        .collect();
    Program::new(&pts, 4.0_f64.to_radians(), 1.0)
}

fn sigma_alpha(m: &Pac2002, fz: f64) -> f64 {
    m.relaxation_lengths(fz, 0.0).1
}

#[test]
fn lag_of_a_ramp_is_a_time_shift_of_sigma_over_v() {
    let hz = 50.0;
    let t: Vec<f64> = (0..200).map(|i| i as f64 / hz).collect();
    let v = vec![10.0; t.len()];
    let u: Vec<f64> = t.iter().map(|t| 3.0 * t).collect();
    let y = first_order_lag(&t, &v, &u, 0.25);
    // tau = 0.025 s: after the transient y(t) = 3 (t - tau) to round-off.
    let last = t.len() - 1;
    assert!(
        (y[last] - 3.0 * (t[last] - 0.025)).abs() < 1e-12,
        "{}",
        y[last]
    );
}

#[test]
fn noise_free_sweeps_recover_sigma_at_every_load() {
    let model = fsae_model(PT);
    let cfg = RelaxationConfig::default();
    for &load in &LOADS {
        let seg = measured(
            &model,
            &sweep_program(),
            Direction::Lateral,
            SegmentKind::Cornering,
            load,
            50.0,
            0.0,
            1.0,
            1,
        );
        let p = lag_problem(&model, &seg, Direction::Lateral, Method::Sweep, &cfg).unwrap();
        let fit = p.fit(cfg.sigma_range_m).unwrap();
        let truth = sigma_alpha(&model, load);
        let err = fit.sigma_m / truth - 1.0;
        // Noise-free, the only error left is the slip smoothing (+-0.04 s) rounding the kinks of
        // the slip program: 0.3 % low at 222 N, less above.
        assert!(
            err.abs() < 5e-3,
            "Fz {load}: sigma {} vs {truth} ({err:+.2e})",
            fit.sigma_m
        );
        assert!((fit.scale - 1.0).abs() < 1e-3 && fit.converged, "{fit:?}");
    }
}

#[test]
fn noisy_round_4_matrix_pools_inclinations_and_stays_within_five_percent() {
    // Round 4: every load swept at IA 0..4 deg, 50 Hz, the virtual machine's force noise, and
    // each sweep on a tire gripping 0-8 % more than the fitted model (temperature).
    let model = fsae_model(PT);
    let cfg = RelaxationConfig::default();
    let mut segs = Vec::new();
    for (i, &load) in LOADS.iter().enumerate() {
        for ia in 0..5 {
            let grip = 1.0 + 0.02 * ia as f64;
            let seed = 100 + 10 * i as u64 + ia as u64;
            let mut s = measured_at(
                &model,
                &sweep_program(),
                Direction::Lateral,
                SegmentKind::Cornering,
                load,
                ia as f64,
                50.0,
                6.0,
                grip,
                seed,
            );
            s.segment_id = format!("{load}-{ia}");
            segs.push(s);
        }
    }
    let out = run(&[input(&model, &segs)], &cfg);
    assert!(out.failures.is_empty(), "{:?}", out.failures);
    assert_eq!(out.rows.len(), 5);
    for r in &out.rows {
        let truth = sigma_alpha(&model, r.fz_n_mean);
        let err = r.sigma_m / truth - 1.0;
        assert_eq!((r.n_segments, r.ia_cdeg_nom), (5, None));
        assert!(
            err.abs() < 0.05,
            "Fz {:?}: sigma {:.4} vs {truth:.4} ({err:+.3})",
            r.fz_n_nom,
            r.sigma_m
        );
        // The PTY1/PTY2 law over all loads is the steadier estimate.
        let law_err = r.sigma_law_m / truth - 1.0;
        assert!(
            law_err.abs() < 0.03,
            "Fz {:?}: law {:.4} vs {truth:.4}",
            r.fz_n_nom,
            r.sigma_law_m
        );
        // The members' scatter is of the size single-sweep noise predicts (< 10 % at 222 N).
        assert!(r.sigma_spread_m < 0.1 * truth, "{r:?}");
        // The curvature standard error agrees with that scatter (pooled: spread / sqrt(n)).
        let from_spread = r.sigma_spread_m / (r.n_segments as f64).sqrt();
        assert!(
            r.sigma_se_m > from_spread / 3.0 && r.sigma_se_m < 3.0 * from_spread,
            "Fz {:?}: se {:.5} vs spread/sqrt(n) {from_spread:.5}",
            r.fz_n_nom,
            r.sigma_se_m
        );
    }
}

#[test]
fn law_fits_weight_rows_by_their_standard_error() {
    // Exact PTY/PTX laws at five loads, the lowest row 20 % off: with weights 1/SE^2 (SE 1 % of
    // sigma, 20 % at the bad row) it barely moves the law; with equal weights it drags it. The
    // PTX law drops its small curvature term (PTX3 = 0.1: 1.5 % at 222 N, within the rows'
    // standard errors) and stays within 3 %.
    let (fz0, r0) = (1112.0, 0.26);
    let (pty1, pty2) = (1.75, 1.5);
    let lat = |fz: f64| pty1 * (2.0 * (fz / (pty2 * fz0)).atan()).sin() * r0;
    let (ptx1, ptx2, ptx3) = (2.05, -0.6, 0.1);
    let lon = |fz: f64| {
        let dfz = (fz - fz0) / fz0;
        fz * (ptx1 + ptx2 * dfz) * (-ptx3 * dfz).exp() * r0 / fz0
    };
    let off = |fz: f64| if fz < 300.0 { 1.2 } else { 1.0 };
    for weighted in [true, false] {
        let w = |sigma: f64, fz: f64| match (weighted, fz < 300.0) {
            (true, true) => (0.2 * sigma).powi(-2),
            (true, false) => (0.01 * sigma).powi(-2),
            (false, _) => 1.0,
        };
        let pts: Vec<(f64, f64, f64, f64)> = LOADS
            .iter()
            .map(|&fz| (fz, r0, lat(fz) * off(fz), w(lat(fz), fz)))
            .collect();
        let (p1, p2, _, _) = fit_pty(&pts, fz0, (0.05, 20.0)).unwrap();
        let law = p1 * (2.0 * (222.0 / (p2 * fz0)).atan()).sin() * r0;
        let err = (law / lat(222.0) - 1.0).abs();
        if weighted {
            assert!(err < 0.01, "weighted PTY law at 222 N off by {err:.4}");
        } else {
            assert!(
                err > 0.02,
                "equal weights should follow the bad row ({err:.4})"
            );
        }
        let pts: Vec<(f64, f64, f64)> = LOADS
            .iter()
            .map(|&fz| (fz, lon(fz) * off(fz), w(lon(fz), fz)))
            .collect();
        let (q1, q2, q3, _, _) = fit_ptx(&pts, fz0, fz0, r0, (-5.0, 5.0)).unwrap();
        let dfz = (222.0 - fz0) / fz0;
        let law = 222.0 * (q1 + q2 * dfz) * (-q3 * dfz).exp() * r0 / fz0;
        let err = (law / lon(222.0) - 1.0).abs();
        if weighted {
            assert_eq!(q3, 0.0, "PTX3 kept without evidence");
            assert!(err < 0.03, "weighted PTX law at 222 N off by {err:.4}");
        }
    }
}

#[test]
fn step_steer_recovers_sigma() {
    let model = fsae_model(PT);
    let cfg = RelaxationConfig::default();
    let pts: Vec<f64> = [0.0, 1.0, 1.0, 0.0]
        .iter()
        .map(|d: &f64| d.to_radians())
        .collect();
    let mut prog = Program::new(&pts[..2], 60.0_f64.to_radians(), 0.5);
    prog.t.push(prog.duration() + 2.0);
    prog.x.push(pts[2]);
    prog.t.push(prog.duration() + 1.0 / 60.0);
    prog.x.push(0.0);
    prog.t.push(prog.duration() + 0.5);
    prog.x.push(0.0);
    let seg = measured(
        &model,
        &prog,
        Direction::Lateral,
        SegmentKind::StepSteer,
        1112.0,
        100.0,
        6.0,
        1.0,
        5,
    );
    let p = lag_problem(&model, &seg, Direction::Lateral, Method::StepSteer, &cfg).unwrap();
    let fit = p.fit(cfg.sigma_range_m).unwrap();
    let truth = sigma_alpha(&model, 1112.0);
    assert!(
        (fit.sigma_m / truth - 1.0).abs() < 0.03,
        "{} vs {truth}",
        fit.sigma_m
    );
}

#[test]
fn run_fits_pty_and_ptx_laws_and_eq_14_15_columns() {
    let model = fsae_model(PT);
    let cfg = RelaxationConfig::default();
    let mut segs = Vec::new();
    for &load in &LOADS {
        segs.push(measured(
            &model,
            &sweep_program(),
            Direction::Lateral,
            SegmentKind::Cornering,
            load,
            50.0,
            0.0,
            1.0,
            1,
        ));
    }
    let kprog = Program::new(&[0.0, 0.2, -0.2, 0.2, 0.0], 0.15, 1.0);
    for &load in &[222.0, 667.0, 1112.0, 1557.0] {
        segs.push(measured(
            &model,
            &kprog,
            Direction::Longitudinal,
            SegmentKind::DriveBrake,
            load,
            50.0,
            0.0,
            1.0,
            2,
        ));
    }
    segs.push(blank(
        "other",
        SegmentKind::Other,
        &key("T", 83),
        "run",
        0.0,
        10,
        50.0,
        40.0,
    ));
    let out = run(&[input(&model, &segs)], &cfg);
    assert!(out.failures.is_empty(), "{:?}", out.failures);
    assert_eq!(out.rows.len(), 9);
    for r in &out.rows {
        let (sk, sa) = model.relaxation_lengths(r.fz_n_mean, 0.0);
        let truth = if r.direction == Direction::Lateral {
            sa
        } else {
            sk
        };
        // Slip smoothing rounds the program's kinks: up to 0.7 % low at 222 N (longitudinal).
        assert!(
            (r.sigma_row_m / truth - 1.0).abs() < 1e-2,
            "{r:?} vs {truth}"
        );
        // Pooled with the law of the other rows: at 222 N (longitudinal) that law is an
        // extrapolation from 667 N up without PTX3 (three loads left), 1.7 % low here.
        assert!((r.sigma_m / truth - 1.0).abs() < 2e-2, "{r:?} vs {truth}");
        let a = ContactLength::default().half_length_m(r.fz_n_mean / 137_800.0, 0.2612);
        assert!((r.contact_half_length_m - a).abs() < 1e-12);
        assert!((r.carcass_stiffness_n_per_m - r.slip_stiffness / (r.sigma_m - a)).abs() < 1e-6);
        if r.direction == Direction::Lateral {
            assert!(
                r.slip_stiffness < 0.0 && r.carcass_stiffness_n_per_m < 0.0,
                "{r:?}"
            );
            assert!(
                (r.slip_rate - 4.0_f64.to_radians()).abs() < 1e-3,
                "{}",
                r.slip_rate
            );
        } else {
            assert!((r.slip_rate - 0.15).abs() < 1e-3, "{}", r.slip_rate);
        }
    }
    let law = &out.laws[0];
    let (pty1, pty2, rms, n) = law.lateral.unwrap();
    assert_eq!(n, 5);
    assert!(
        (pty1 / PT[0] - 1.0).abs() < 5e-3 && (pty2 / PT[1] - 1.0).abs() < 1e-2,
        "{pty1} {pty2}"
    );
    assert!(rms < 1e-3, "{rms}");
    let (ptx1, ptx2, ptx3, _, n) = law.longitudinal.unwrap();
    assert_eq!(n, 4);
    // The truth's PTX3 = 0.1 bends the law by 1.5 % at 222 N, within the rows' 1 % standard
    // error floor: the fit leaves PTX3 at 0 (`PTX3_MIN_CHI2_GAIN`) and pays that 1.5 % there.
    assert_eq!(ptx3, 0.0);
    // PTX1, PTX2 trade off; the law they give must reproduce sigma_kappa over the tested loads.
    let mut m2 = model.clone();
    m2.coefs[Coef::PTX1] = ptx1;
    m2.coefs[Coef::PTX2] = ptx2;
    m2.coefs[Coef::PTX3] = ptx3;
    for fz in [222.0, 445.0, 1112.0, 1557.0] {
        let (a, b) = (
            m2.relaxation_lengths(fz, 0.0).0,
            model.relaxation_lengths(fz, 0.0).0,
        );
        // The rows carry the smoothing bias (up to 0.7 % low at 222 N), the law PTX3's.
        let tol = if fz < 300.0 { 2e-2 } else { 1e-2 };
        assert!((a / b - 1.0).abs() < tol, "Fz {fz}: {a} vs {b}");
    }
}

#[test]
fn a_bad_segment_fails_alone() {
    let model = fsae_model(PT);
    let good = measured(
        &model,
        &sweep_program(),
        Direction::Lateral,
        SegmentKind::Cornering,
        667.0,
        50.0,
        0.0,
        1.0,
        1,
    );
    let mut standing = good.clone();
    standing.segment_id = "standing".into();
    standing
        .channels
        .speed_kph
        .iter_mut()
        .for_each(|v| *v = 0.0);
    let mut short = good.clone();
    short.segment_id = "broken".into();
    short.channels.fy_n.truncate(10);
    let segs = [good, standing, short];
    let out = run(&[input(&model, &segs)], &RelaxationConfig::default());
    assert_eq!(out.rows.len(), 1);
    assert!(
        out.failures
            .iter()
            .any(|f| f.scope.contains("standing") && f.reason.contains("speed"))
    );
    assert!(
        out.failures
            .iter()
            .any(|f| f.scope.contains("broken") && f.reason.contains("fy_n"))
    );
    // One load only: PTY1/PTY2 cannot be fitted, said so.
    assert!(
        out.failures.iter().any(|f| f.scope == "PTY1/PTY2"),
        "{:?}",
        out.failures
    );
}

/// Table 15 (Hoosier 20.5x7.0-13 R25B, 12 psi): `Fz, z, a, CF, sigma(4 deg/s), c_y`.
const TABLE_15: [(f64, f64, f64, f64, f64, f64); 5] = [
    (222.0, 0.0016, 0.0337, -15540.0, 0.1956, -96011.0),
    (445.0, 0.0033, 0.0484, -30109.0, 0.2794, -130349.0),
    (667.0, 0.0049, 0.0599, -42756.0, 0.3353, -155264.0),
    (1112.0, 0.0082, 0.0786, -60997.0, 0.4191, -179156.0),
    (1557.0, 0.0114, 0.0943, -70208.0, 0.4750, -184422.0),
];

#[test]
fn thesis_table_15_a_and_cy_from_z_cf_and_sigma() {
    // R0 of a 20.5 in tire. Tolerances are the table's rounding: z is printed to 0.05 mm, so a
    // carries |da/dz| * 0.05 mm; a itself is printed to 0.05 mm.
    let r0 = 20.5 * 0.0254 / 2.0;
    let contact = ContactLength::default();
    for &(fz, z, a_tab, cf, sigma, cy_tab) in &TABLE_15 {
        let a = contact.half_length_m(z, r0);
        let dadz = contact.q_a1 / (2.0 * (z * r0).sqrt()) + contact.q_a2;
        let tol = dadz * 0.5e-4 + 0.5e-4;
        assert!(
            (a - a_tab).abs() <= tol,
            "Fz {fz}: a {a:.5} vs {a_tab} (tol {tol:.1e})"
        );
        // c_y from Eq. 15 with our a: the rounding of a propagates as c/(sigma - a) * da.
        let cy = carcass_stiffness(cf, sigma, a).unwrap();
        let tol_c = (cy / (sigma - a)).abs() * tol + 0.5;
        assert!(
            (cy - cy_tab).abs() <= tol_c,
            "Fz {fz}: c_y {cy:.0} vs {cy_tab} (tol {tol_c:.0})"
        );
        // And with the table's own a, Eq. 15 reproduces c_y to the printed digits of sigma.
        let cy_direct = carcass_stiffness(cf, sigma, a_tab).unwrap();
        assert!(
            (cy_direct / cy_tab - 1.0).abs() < 5e-4,
            "Fz {fz}: {cy_direct:.0} vs {cy_tab}"
        );
        // Plausibility: a grows like sqrt(z) and stays below sigma (carcass stiffness finite).
        assert!(a < sigma && a > 0.02 && a < 0.1);
    }
    // Deflection is Fz over one vertical stiffness (~136 kN/m) for every row.
    for &(fz, z, ..) in &TABLE_15 {
        assert!(
            (fz / z / 136_200.0 - 1.0).abs() < 0.025,
            "Fz {fz}: {}",
            fz / z
        );
    }
}

#[test]
fn pac2002_sigma_law_cannot_follow_table_15_at_the_lowest_load() {
    // Table 15's sigma grows like sqrt(Fz) (0.196 m at 222 N, 0.475 m at 1557 N); PAC2002's
    // sigma_alpha = PTY1 sin(2 atan(Fz/(PTY2 Fz0))) R0 is linear at low load. The best PTY1/PTY2
    // (Fz0 = 1112 N) stay within 8 % from 445 N up but miss 222 N by 20-30 %: a .tir written from
    // such data under-predicts the low-load relaxation length. This test pins that finding.
    let r0 = 20.5 * 0.0254 / 2.0;
    let pts: Vec<(f64, f64, f64, f64)> = TABLE_15.iter().map(|r| (r.0, r0, r.4, 1.0)).collect();
    let (pty1, pty2, _, _) = fit_pty(&pts, 1112.0, (0.05, 20.0)).unwrap();
    for &(fz, _, s, _) in &pts {
        let m = pty1 * (2.0 * (fz / (pty2 * 1112.0)).atan()).sin() * r0;
        let err = m / s - 1.0;
        if fz < 300.0 {
            assert!(
                (-0.30..-0.20).contains(&err),
                "Fz {fz}: {m:.4} vs {s} ({err:+.3})"
            );
        } else {
            assert!(err.abs() < 0.08, "Fz {fz}: {m:.4} vs {s} ({err:+.3})");
        }
    }
    assert!(
        (1.5..2.0).contains(&pty1) && (1.0..1.5).contains(&pty2),
        "{pty1} {pty2}"
    );
}

#[test]
fn thesis_table_16_longitudinal_a_and_cx() {
    // Table 16: `Fz, z, a, CF, sigma_x, c_x`. Its CF column is labelled N/% but Eq. 15 only
    // reproduces c_x with CF taken as printed (c_x = CF/(sigma - a)): the label or the unit of
    // c_x is off by 100 in the thesis. a is printed to 0.5 mm.
    let rows: [(f64, f64, f64, f64, f64, f64); 4] = [
        (222.0, 0.0016, 0.034, 22348.0, 0.140, 210871.0),
        (667.0, 0.0049, 0.060, 60297.0, 0.363, 198790.0),
        (1112.0, 0.0082, 0.079, 89147.0, 0.531, 197128.0),
        (1557.0, 0.0114, 0.094, 108942.0, 0.699, 180304.0),
    ];
    let r0 = 20.5 * 0.0254 / 2.0;
    let contact = ContactLength::default();
    for (fz, z, a_tab, cf, sigma, cx_tab) in rows {
        let a = contact.half_length_m(z, r0);
        let dadz = contact.q_a1 / (2.0 * (z * r0).sqrt()) + contact.q_a2;
        let tol = dadz * 0.5e-4 + 0.5e-3;
        assert!((a - a_tab).abs() <= tol, "Fz {fz}: a {a:.4} vs {a_tab}");
        // sigma is printed to 0.5 mm: c_x to |c/(sigma - a)| * 0.5 mm, plus the rounding of a.
        let cx = carcass_stiffness(cf, sigma, a).unwrap();
        let tol_c = (cx / (sigma - a)).abs() * (0.5e-3 + dadz * 0.5e-4);
        assert!(
            (cx - cx_tab).abs() <= tol_c,
            "Fz {fz}: c_x {cx:.0} vs {cx_tab} (tol {tol_c:.0})"
        );
    }
}

/// A sweep row whose own estimate is `sigma` with relative standard error `se_rel`.
fn row_at(direction: Direction, fz: f64, sigma: f64, se_rel: f64) -> RelaxationRow {
    RelaxationRow {
        key: key("T", 83),
        fz_n_nom: Some(fz.round() as i64),
        fz_n_mean: fz,
        ia_cdeg_nom: Some(0),
        direction,
        method: Method::Sweep,
        slip_rate: 0.07,
        speed_kph: 40.0,
        sigma_m: sigma,
        sigma_row_m: sigma,
        sigma_spread_m: f64::NAN,
        sigma_se_m: se_rel * sigma,
        sigma_prior_m: f64::NAN,
        pool_weight: 0.0,
        sigma_law_m: f64::NAN,
        deflection_m: 0.002,
        contact_half_length_m: 0.03,
        slip_stiffness: -2.0e4,
        carcass_stiffness_n_per_m: f64::NAN,
        residual_rms_n: 6.0,
        n: 300,
        n_segments: 3,
        model_scale: 1.0,
        model_offset_n: 0.0,
        converged: true,
        at_bound: false,
        measurement_lag_s: 0.0,
        lag_separated: false,
        lag_note: String::new(),
        apparent_lag_s: f64::NAN,
        scale_drift: false,
    }
}

/// Rows at the round's loads following the model's own laws, each scaled by `factor(direction,
/// load index)`, with relative standard error `se_rel(direction, load index)`.
fn law_rows(
    model: &Pac2002,
    factor: impl Fn(Direction, usize) -> f64,
    se_rel: impl Fn(Direction, usize) -> f64,
) -> Vec<RelaxationRow> {
    let mut rows = Vec::new();
    for direction in [Direction::Lateral, Direction::Longitudinal] {
        for (k, fz) in [222.0, 445.0, 667.0, 1112.0, 1557.0]
            .into_iter()
            .enumerate()
        {
            let (sk, sa) = model.relaxation_lengths(fz, 0.0);
            let truth = if direction == Direction::Lateral {
                sa
            } else {
                sk
            };
            rows.push(row_at(
                direction,
                fz,
                truth * factor(direction, k),
                se_rel(direction, k),
            ));
        }
    }
    rows
}

#[test]
fn a_noisy_row_leans_on_the_law_of_its_neighbours() {
    let model = fsae_model(PT);
    let input = input(&model, &[]);
    let cfg = RelaxationConfig::default();
    // The lowest lateral load is 6 % low with a 4 % standard error; the rest are exact (0.5 %).
    let mut rows = law_rows(
        &model,
        |d, k| {
            if d == Direction::Lateral && k == 0 {
                0.94
            } else {
                1.0
            }
        },
        |d, k| {
            if d == Direction::Lateral && k == 0 {
                0.04
            } else {
                0.005
            }
        },
    );
    pool_with_law(&input, &mut rows, &cfg);
    let low = &rows[0];
    let truth = model.relaxation_lengths(222.0, 0.0).1;
    assert!((low.sigma_row_m / truth - 0.94).abs() < 1e-12, "{low:?}");
    assert!((low.sigma_prior_m / truth - 1.0).abs() < 1e-3, "{low:?}");
    assert!(low.pool_weight > 0.8, "{low:?}");
    assert!((low.sigma_m / truth - 1.0).abs() < 0.01, "{low:?}");
    let c = low.slip_stiffness / (low.sigma_m - low.contact_half_length_m);
    assert!((low.carcass_stiffness_n_per_m / c - 1.0).abs() < 1e-12);
    for r in &rows[1..] {
        let (sk, sa) = model.relaxation_lengths(r.fz_n_mean, 0.0);
        let t = if r.direction == Direction::Lateral {
            sa
        } else {
            sk
        };
        // Exact rows pooled with imperfect priors: the noisy row pulls the lateral law a little
        // (0.6 % at 445 N), and the longitudinal law of four loads keeps PTX3 = 0 (the 1 %
        // floor of the law's weights), extrapolating 2.1 % low to 1557 N.
        assert!((r.sigma_m / t - 1.0).abs() < 1e-2, "{r:?}");
    }

    // Rows that stray from the law by +-6 % with 1 % standard errors: the law is no prior worth
    // leaning on, and every row keeps most of its own estimate.
    let mut rows = law_rows(
        &model,
        |d, k| {
            let sign = if (k + usize::from(d == Direction::Longitudinal)) % 2 == 0 {
                1.0
            } else {
                -1.0
            };
            1.0 + 0.06 * sign
        },
        |_, _| 0.01,
    );
    pool_with_law(&input, &mut rows, &cfg);
    for r in &rows {
        assert!(r.pool_weight < 0.1, "{r:?}");
        assert!((r.sigma_m / r.sigma_row_m - 1.0).abs() < 0.01, "{r:?}");
    }
}

#[test]
fn pooling_keeps_table_15_rows_the_law_cannot_follow() {
    // The real round-4 tire of Table 15: sigma grows like sqrt(Fz), which PAC2002's law misses
    // by 20-30 % at 222 N (see the test above). Pooled with the law of the other rows, each row
    // must keep its own value: the held-out rows stray far from the law, so the prior's
    // variance is large and no row leans on it.
    let mut model = fsae_model(PT);
    model.coefs[Coef::FNOMIN] = 1112.0;
    model.coefs[Coef::UNLOADED_RADIUS] = 20.5 * 0.0254 / 2.0;
    let input = RelaxationInput {
        vertical_stiffness_n_per_m: 136_200.0,
        ..input(&model, &[])
    };
    let mut rows: Vec<RelaxationRow> = TABLE_15
        .iter()
        .map(|&(fz, _, _, _, sigma, _)| {
            let se = if fz < 300.0 { 0.03 } else { 0.01 };
            row_at(Direction::Lateral, fz, sigma, se)
        })
        .collect();
    pool_with_law(&input, &mut rows, &RelaxationConfig::default());
    for r in &rows {
        assert!(r.sigma_prior_m.is_finite(), "{r:?}");
        assert!(r.pool_weight < 0.1, "{r:?}");
        assert!((r.sigma_m / r.sigma_row_m - 1.0).abs() < 0.02, "{r:?}");
    }
}

/// Sweeps at 15, 25 and 45 mph through a rig chain `rig` (every load at 25 mph, 1112 N also at
/// 15 and 45 mph), with the virtual machine's force noise.
fn three_speed_round(model: &Pac2002, rig: &MeasurementLag) -> Vec<MeasuredSegment> {
    let mph = 0.44704;
    let mut segs = Vec::new();
    let mut runs: Vec<(f64, f64)> = LOADS.iter().map(|&l| (l, 25.0 * mph)).collect();
    runs.push((1112.0, 15.0 * mph));
    runs.push((1112.0, 45.0 * mph));
    for (i, &(load, v)) in runs.iter().enumerate() {
        for rep in 0..2 {
            let mut s = measured_through(
                model,
                &sweep_program(),
                Direction::Lateral,
                SegmentKind::Cornering,
                (load, 0.0, v),
                50.0,
                6.0,
                1.0,
                300 + 10 * i as u64 + rep,
                rig,
            );
            s.segment_id = format!("{load}-{v:.1}-{rep}");
            segs.push(s);
        }
    }
    segs
}

/// Issue 18: the same three-speed round without any rig lag. The search over the lag starts at
/// 0, so noise finds some small lag; it must not be kept: the lag is 0, not separated, and the
/// note says why.
#[test]
fn no_rig_lag_is_not_separated_from_noise() {
    let model = fsae_model(PT);
    let segs = three_speed_round(&model, &MeasurementLag::NONE);
    let out = run(&[input(&model, &segs)], &RelaxationConfig::default());
    assert!(out.failures.is_empty(), "{:?}", out.failures);
    let lag = &out.measurement_lags[0];
    eprintln!("{}", lag.note);
    assert!(!lag.identified && lag.lag.lag_s == 0.0, "{lag:?}");
    assert!(lag.note.starts_with("not separated"), "{lag:?}");
    assert_eq!(lag.speeds_kph.len(), 3, "{lag:?}");
    for r in &out.rows {
        assert!(!r.lag_separated && r.measurement_lag_s == 0.0 && r.lag_note == lag.note);
    }
}

/// Issue 18: a rig lag in time (a 20 ms delay, or a 15 ms first-order filter) beside the tire's
/// relaxation length. Sweeps at two or more speeds at one load separate the two: the lag within
/// 10 % and every row's sigma within 5 % of the truth, the same at every speed. The same data
/// with the lag left in sigma (one assumed lag of 0) are off by about `V lag`.
#[test]
fn rig_lag_is_separated_from_relaxation_with_two_speeds() {
    let model = fsae_model(PT);
    for (form, lag_s) in [(LagForm::Delay, 0.020), (LagForm::FirstOrder, 0.015)] {
        let rig = MeasurementLag { form, lag_s };
        let segs = three_speed_round(&model, &rig);
        let cfg = RelaxationConfig {
            measurement_lag_form: form,
            ..RelaxationConfig::default()
        };
        let out = run(&[input(&model, &segs)], &cfg);
        assert!(out.failures.is_empty(), "{:?}", out.failures);
        let lag = &out.measurement_lags[0];
        let worst = out
            .rows
            .iter()
            .map(|r| r.sigma_row_m / sigma_alpha(&model, r.fz_n_mean) - 1.0)
            .fold(0.0_f64, |a, e| if e.abs() > a.abs() { e } else { a });
        eprintln!(
            "{form:?} {lag_s} s: identified {:.4} s, worst row sigma {worst:+.4}; {}",
            lag.lag.lag_s, lag.note
        );
        assert!(lag.identified && !lag.at_bound, "{lag:?}");
        assert!(
            (lag.lag.lag_s / lag_s - 1.0).abs() < 0.1,
            "{form:?}: lag {:.4} s vs {lag_s}",
            lag.lag.lag_s
        );
        assert_eq!(lag.speeds_kph.len(), 3, "{lag:?}");
        assert_eq!(out.rows.len(), 7);
        for r in &out.rows {
            let truth = sigma_alpha(&model, r.fz_n_mean);
            assert!(r.lag_separated && r.measurement_lag_s == lag.lag.lag_s);
            assert!(
                (r.sigma_row_m / truth - 1.0).abs() < 0.05,
                "{form:?} Fz {:?} at {:.0} km/h: sigma {:.4} vs {truth:.4}",
                r.fz_n_nom,
                r.speed_kph,
                r.sigma_row_m
            );
        }
        // Without a second speed the lag cannot be told apart: assumed (0), sigma carries it.
        let one_speed: Vec<MeasuredSegment> = segs
            .iter()
            .filter(|s| (s.channels.speed_kph[0] - 40.2).abs() < 1.0)
            .cloned()
            .collect();
        let out = run(&[input(&model, &one_speed)], &cfg);
        assert!(!out.measurement_lags[0].identified);
        for r in &out.rows {
            let truth = sigma_alpha(&model, r.fz_n_mean);
            let extra = r.sigma_row_m - truth;
            let expected = r.speed_kph / 3.6 * lag_s;
            assert!(
                (extra / expected - 1.0).abs() < 0.25,
                "{form:?} Fz {:?}: sigma {:.4} - truth {truth:.4} vs V lag {expected:.4}",
                r.fz_n_nom,
                r.sigma_row_m
            );
        }
    }
}

/// `seg`'s measured force with the grip falling by `loss` (a fraction) over the segment in
/// proportion to the slip it has accumulated (`int |slip| dt`, a stand-in for the heat a sweep
/// puts into the tread): the return pass of every half-cycle is weaker than its outbound pass,
/// nonlinearly in time.
fn with_grip_loss(mut seg: MeasuredSegment, dir: Direction, loss: f64) -> MeasuredSegment {
    let c = &mut seg.channels;
    let slip = if dir == Direction::Lateral {
        &c.alpha_rad
    } else {
        &c.kappa
    };
    let mut acc = vec![0.0; slip.len()];
    for i in 1..slip.len() {
        acc[i] = acc[i - 1] + slip[i].abs() * (c.et_s[i] - c.et_s[i - 1]);
    }
    let total = *acc.last().unwrap();
    let f = if dir == Direction::Lateral {
        &mut c.fy_n
    } else {
        &mut c.fx_n
    };
    for (f, a) in f.iter_mut().zip(&acc) {
        *f *= 1.0 - loss * a / total;
    }
    seg
}

/// The signed shift of the steady-state force that best aligns it with the measured one, s.
fn apparent_lag(p: &LagProblem) -> f64 {
    scalar::minimize(&|d| p.shifted_cost(d), -0.3, 0.3, &LAG_SEARCH)
        .unwrap()
        .x
}

/// The signature of the real cornering file (100 Hz, 40 km/h): every return pass weaker than
/// its outbound pass, also where the force is saturated, and little lag, so that with a
/// constant scale the force seems to lead the slip and `sigma` sits on its lower bound. Here
/// 8 % of grip is lost over a sweep with the truth's relaxation lengths, and 12 % with a
/// lateral one of 0.03 m (the real file's loss, and its lag at 1653 N); a scale drifting in
/// time separates the loss (proportional to the force) from the lag (proportional to its
/// rate).
#[test]
fn grip_lost_through_a_sweep_is_not_read_as_a_lead() {
    let full = fsae_model(PT);
    let mut short = full.clone();
    short.coefs[Coef::PTY1] *= 0.03 / sigma_alpha(&full, 667.0);
    let kprog = || Program::new(&[0.0, 0.2, -0.2, 0.2, 0.0], 0.15, 1.0);
    for (model, dir, load, program, loss, tol) in [
        (
            &full,
            Direction::Lateral,
            667.0,
            sweep_program(),
            0.08,
            0.03,
        ),
        (
            &full,
            Direction::Lateral,
            1557.0,
            sweep_program(),
            0.08,
            0.03,
        ),
        (&full, Direction::Longitudinal, 1112.0, kprog(), 0.08, 0.03),
        (
            &short,
            Direction::Lateral,
            667.0,
            sweep_program(),
            0.12,
            0.2,
        ),
    ] {
        let kind = if dir == Direction::Lateral {
            SegmentKind::Cornering
        } else {
            SegmentKind::DriveBrake
        };
        let seg = with_grip_loss(
            measured(model, &program, dir, kind, load, 100.0, 6.0, 1.0, 7),
            dir,
            loss,
        );
        let (sk, sa) = model.relaxation_lengths(load, 0.0);
        let truth = if dir == Direction::Lateral { sa } else { sk };
        let fit_with = |nuisance: Nuisance| {
            let cfg = RelaxationConfig {
                nuisance,
                ..RelaxationConfig::default()
            };
            let p = lag_problem(model, &seg, dir, Method::Sweep, &cfg).unwrap();
            (p.fit(cfg.sigma_range_m).unwrap(), apparent_lag(&p))
        };
        let (constant, lead) = fit_with(Nuisance::ScaleOffset);
        let (drifting, lag) = fit_with(Nuisance::ScaleDriftOffset);
        let (ec, ed) = (
            constant.sigma_m / truth - 1.0,
            drifting.sigma_m / truth - 1.0,
        );
        eprintln!(
            "{dir:?} {load} N: truth {truth:.4} m; constant scale {:.4} m ({ec:+.3}, shift \
             {:+.1} ms), drifting {:.4} m ({ed:+.3}, shift {:+.1} ms)",
            constant.sigma_m,
            1e3 * lead,
            drifting.sigma_m,
            1e3 * lag
        );
        // The drifting scale recovers the truth, and the shift says the force lags.
        assert!(
            ed.abs() < tol && ed.abs() < ec.abs(),
            "{drifting:?} vs {truth}"
        );
        assert!(lag > 0.0, "{lag}");
        if truth < 0.1 {
            // The real signature, reproduced: a constant scale reads the loss as a lead.
            assert!(
                constant.at_bound && lead < 0.0,
                "{constant:?}, shift {lead}"
            );
        }
    }
}

/// A slip channel recorded later than the force (or data aligned past the tire's lag) makes
/// the force lead the recorded slip: `sigma` has no positive value to find, so the row reports
/// NaN on the lower bound, and `apparent_lag_s` the signed shift the data show, `sigma/V - d`.
#[test]
fn a_force_that_leads_the_slip_is_reported_as_a_negative_apparent_lag() {
    let model = fsae_model(PT);
    let load = 1112.0;
    let sigma = sigma_alpha(&model, load);
    let late_s = sigma / V_MPS + 0.03;
    let clean: Vec<MeasuredSegment> = (0..3)
        .map(|k| {
            let mut s = measured(
                &model,
                &sweep_program(),
                Direction::Lateral,
                SegmentKind::Cornering,
                load,
                100.0,
                6.0,
                1.0,
                11 + k,
            );
            s.segment_id = format!("seg{k}");
            s
        })
        .collect();
    let segs: Vec<MeasuredSegment> = clean
        .iter()
        .cloned()
        .map(|mut s| {
            let c = &mut s.channels;
            c.alpha_rad = shifted(&c.et_s, &c.alpha_rad, late_s);
            s
        })
        .collect();
    let out = run(&[input(&model, &segs)], &RelaxationConfig::default());
    assert_eq!(out.rows.len(), 1, "{:?}", out.failures);
    let r = &out.rows[0];
    assert!(
        r.at_bound && r.sigma_m.is_nan() && r.sigma_row_m.is_nan(),
        "{r:?}"
    );
    // The slip smoothing (+-0.04 s) and the sweep's kinks leave a few ms.
    assert!(
        (r.apparent_lag_s + 0.03).abs() < 0.004,
        "apparent lag {} s, expected -0.030",
        r.apparent_lag_s
    );
    // Without the late channel the same rows measure the tire's own lag as a positive shift.
    let out = run(&[input(&model, &clean)], &RelaxationConfig::default());
    let r = &out.rows[0];
    assert!(
        !r.at_bound && (r.sigma_row_m / sigma - 1.0).abs() < 0.05,
        "{r:?}"
    );
    assert!(
        (r.apparent_lag_s - sigma / V_MPS).abs() < 0.1 * sigma / V_MPS,
        "apparent lag {} s, sigma/V {} s",
        r.apparent_lag_s,
        sigma / V_MPS
    );
}
