//! The figures against closed forms of the Magic Formula: with the shifts and the camber terms
//! that move the peak switched off, the peak of `D sin(C atan(..))` is `D`, the slope at zero is
//! `B C D = K`, and camber thrust `SVy = PVY3 gamma Fz` against `mu_y (1 - PDY3 gamma^2)` puts the
//! best camber at `|PVY3| / (2 |mu_y| PDY3)`.

use super::*;
use crate::synth::tires::base_coefs;
use crate::tire_model::{Coef, Coefs, Pac2002};

/// The embedded FSAE base tire with every shift and every camber term but `PDY3`, `PVY3` (and
/// `PDX3`) zero.
fn clean_coefs() -> Coefs<f64> {
    use Coef::*;
    let mut c = base_coefs().unwrap();
    for k in [
        PHY1, PHY2, PHY3, PVY1, PVY2, PVY4, PKY3, PEY3, PEY4, PHX1, PHX2, PVX1, PVX2,
    ] {
        c[k] = 0.0;
    }
    c
}

fn cond(loads: &[f64], nominal: f64) -> Conditions {
    Conditions {
        loads_n: loads.to_vec(),
        nominal_load_n: nominal,
        speed_mps: 11.0,
        camber_rad: (0.0, 0.1),
    }
}

fn tire(c: Coefs<f64>, use_mode: Option<i64>) -> Pac2002Tire {
    Pac2002Tire::new(&Pac2002::new(c), use_mode, 2000.0)
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * b.abs().max(1e-300)
}

#[test]
fn peaks_and_stiffnesses_match_the_closed_forms_at_zero_camber() {
    let c = clean_coefs();
    let fz0 = c[Coef::FNOMIN];
    let t = tire(c.clone(), Some(14));
    let cond = cond(&[fz0], fz0);
    let fy = peak_fy(&t, &cond, fz0, 0.0);
    assert!(close(fy, c[Coef::PDY1].abs() * fz0, 1e-9), "{fy}");
    let fx = peak_fx(&t, &cond, fz0, 0.0);
    assert!(close(fx, c[Coef::PDX1].abs() * fz0, 1e-9), "{fx}");
    let kya = c[Coef::PKY1].abs() * fz0 * (2.0 * (1.0 / c[Coef::PKY2]).atan()).sin();
    let ky = cornering_stiffness(&t, &cond, fz0, 0.0);
    assert!(close(ky, kya, 1e-6), "{ky} vs {kya}");
    let kxk = fz0 * c[Coef::PKX1];
    let kx = longitudinal_stiffness(&t, &cond, fz0, 0.0);
    assert!(close(kx, kxk, 1e-6), "{kx} vs {kxk}");
}

#[test]
fn load_sensitivity_is_the_secant_of_the_linear_friction_law() {
    let c = clean_coefs();
    let fz0 = c[Coef::FNOMIN];
    let t = tire(c.clone(), Some(14));
    let loads = [0.5 * fz0, fz0, 1.5 * fz0];
    let mut cond = cond(&loads, fz0);
    cond.camber_rad = (0.0, 0.0);
    let f = evaluate(&t, &cond);
    let mu = |dfz: f64| (c[Coef::PDY1] + c[Coef::PDY2] * dfz).abs();
    for (l, dfz) in f.loads.iter().zip([-0.5, 0.0, 0.5]) {
        assert!(close(l.mu_y_peak, mu(dfz), 1e-9), "{l:?}");
        assert!(close(l.fy_peak_n, mu(dfz) * l.fz_n, 1e-9));
    }
    let secant = (mu(0.5) - mu(-0.5)) / fz0;
    assert!(close(f.mu_y_load_sensitivity_per_n, secant, 1e-7));
    let lateral =
        loads.iter().map(|&l| mu((l - fz0) / fz0) * l).sum::<f64>() / loads.iter().sum::<f64>();
    assert!(close(f.lateral_mu, lateral, 1e-9));
    assert!(close(
        Objective::Lateral.value_of(&t, &cond),
        f.lateral_mu,
        1e-12
    ));
    // A single load: the central difference of the same linear law.
    let mut single = self::cond(&[fz0], fz0);
    single.camber_rad = (0.0, 0.0);
    let one = evaluate(&t, &single);
    let slope = c[Coef::PDY1].signum() * c[Coef::PDY2] / fz0;
    assert!(
        close(one.mu_y_load_sensitivity_per_n, slope, 1e-3),
        "{one:?}"
    );
}

#[test]
fn the_best_camber_balances_camber_thrust_against_the_friction_loss() {
    let c = clean_coefs();
    let fz0 = c[Coef::FNOMIN];
    let mu0 = c[Coef::PDY1].abs();
    let (pdy3, pvy3) = (c[Coef::PDY3], c[Coef::PVY3].abs());
    let expected = pvy3 / (2.0 * mu0 * pdy3);
    assert!(
        expected < c[Coef::CAMMAX],
        "the optimum must be inside the file's range"
    );
    let t = tire(c.clone(), Some(14));
    let cond = cond(&[fz0], fz0);
    let f = evaluate(&t, &cond);
    assert!(
        (f.camber_rad - expected).abs() < 1e-5,
        "{} vs {expected}",
        f.camber_rad
    );
    assert!(!f.camber_at_bound);
    let peak = fz0 * (mu0 * (1.0 - pdy3 * expected * expected) + pvy3 * expected);
    assert!(close(f.fy_peak_nominal_n, peak, 1e-9));
    assert!(close(f.camber_gain, peak / (mu0 * fz0) - 1.0, 1e-7));
    // A car range that stops short of the optimum: its upper end, flagged.
    let mut narrow = cond.clone();
    narrow.camber_rad = (0.0, 0.5 * expected);
    let (g, at_bound) = design_camber(&t, &narrow);
    assert!((g - 0.5 * expected).abs() < 1e-9 && at_bound);
}

#[test]
fn envelope_of_an_uncoupled_model_is_the_bounding_rectangle() {
    // RBX1 = RBY1 = 0: no combined-slip weighting, Fx(kappa) and Fy(alpha) independent, so the
    // outline of the grid is the rectangle of the extreme forces over the grid.
    let mut c = clean_coefs();
    c[Coef::RBX1] = 0.0;
    c[Coef::RBY1] = 0.0;
    for k in [
        Coef::RVY1,
        Coef::RVY2,
        Coef::RVY3,
        Coef::RHX1,
        Coef::RHY1,
        Coef::RHY2,
    ] {
        c[k] = 0.0;
    }
    let fz0 = c[Coef::FNOMIN];
    let t = tire(c.clone(), Some(4));
    let mut cond = cond(&[fz0], fz0);
    cond.camber_rad = (0.0, 0.0);
    let r = t.ranges();
    let (mut fx, mut fy) = (Vec::new(), Vec::new());
    for i in 0..ENVELOPE_GRID {
        let u = i as f64 / (ENVELOPE_GRID - 1) as f64;
        let k = r.kappa.0 + u * (r.kappa.1 - r.kappa.0);
        let a = r.alpha_rad.0 + u * (r.alpha_rad.1 - r.alpha_rad.0);
        fx.push(t.eval(&point(&cond, fz0, 0.0, k, 0.0)).fx_n);
        fy.push(t.eval(&point(&cond, fz0, a, 0.0, 0.0)).fy_n);
    }
    let span = |v: &[f64]| {
        v.iter().copied().fold(f64::NEG_INFINITY, f64::max)
            - v.iter().copied().fold(f64::INFINITY, f64::min)
    };
    let f = evaluate(&t, &cond);
    let area = f.envelope_area_n2.unwrap();
    assert!(close(area, span(&fx) * span(&fy), 1e-9), "{area}");
    assert!(close(Objective::Envelope.value_of(&t, &cond), area, 1e-12));
}

#[test]
fn what_the_file_does_not_declare_is_not_reported() {
    let mut c = clean_coefs();
    c[Coef::PTY1] = 1.9;
    c[Coef::PTY2] = 1.4;
    c[Coef::PTX1] = 2.2;
    c[Coef::PTX2] = -0.5;
    let fz0 = c[Coef::FNOMIN];
    let cond = cond(&[fz0], fz0);
    let pure = evaluate(&tire(c.clone(), Some(3)), &cond);
    assert!(pure.envelope_area_n2.is_none());
    assert!(pure.relaxation_lateral_m.is_none() && pure.relaxation_longitudinal_m.is_none());
    assert!(Objective::Envelope.of(&pure).is_nan());
    let full = evaluate(&tire(c.clone(), Some(14)), &cond);
    let (sk, sa) = relaxation_lengths_of(&c, fz0, full.camber_rad);
    assert!(close(full.relaxation_lateral_m.unwrap(), sa, 1e-12));
    assert!(close(full.relaxation_longitudinal_m.unwrap(), sk, 1e-12));
    assert_eq!(
        full.vertical_stiffness_n_per_m,
        Some(c[Coef::VERTICAL_STIFFNESS])
    );
}

#[test]
fn a_model_without_one_direction_reports_nan_for_it_and_the_other_as_usual() {
    let c = clean_coefs();
    let fz0 = c[Coef::FNOMIN];
    let cond = cond(&[0.5 * fz0, fz0], fz0);
    let both = evaluate(&tire(c.clone(), Some(3)), &cond);
    let fx_only = evaluate(&tire(c.clone(), Some(1)), &cond);
    for f in [
        fx_only.lateral_mu,
        fx_only.mu_y_load_sensitivity_per_n,
        fx_only.cornering_stiffness_n_per_rad,
        fx_only.fy_peak_nominal_n,
        fx_only.camber_gain,
    ]
    .into_iter()
    .chain(
        fx_only
            .loads
            .iter()
            .flat_map(|l| [l.fy_peak_n, l.mu_y_peak, l.cornering_stiffness_n_per_rad]),
    ) {
        assert!(f.is_nan(), "{fx_only:?}");
    }
    assert!(fx_only.camber_at_bound);
    assert!(
        Objective::Lateral
            .value_of(&tire(c.clone(), Some(1)), &cond)
            .is_nan()
    );
    // Its longitudinal figures are those of the full model at the same camber.
    let at = |g: f64| peak_fx(&tire(c.clone(), Some(3)), &cond, fz0, g);
    assert!(close(
        fx_only.loads[1].fx_peak_n,
        at(fx_only.camber_rad),
        1e-12
    ));
    assert!(fx_only.longitudinal_mu.is_finite() && fx_only.longitudinal_stiffness_n > 0.0);
    let fy_only = evaluate(&tire(c.clone(), Some(2)), &cond);
    for f in [
        fy_only.longitudinal_mu,
        fy_only.mu_x_load_sensitivity_per_n,
        fy_only.longitudinal_stiffness_n,
    ]
    .into_iter()
    .chain(
        fy_only
            .loads
            .iter()
            .flat_map(|l| [l.fx_peak_n, l.mu_x_peak]),
    ) {
        assert!(f.is_nan(), "{fy_only:?}");
    }
    assert_eq!(fy_only.camber_rad, both.camber_rad);
    assert_eq!(fy_only.lateral_mu, both.lateral_mu);
    assert!(
        Objective::Longitudinal
            .value_of(&tire(c, Some(12)), &cond)
            .is_nan()
    );
}

fn relaxation_lengths_of(c: &Coefs<f64>, fz: f64, gamma: f64) -> (f64, f64) {
    crate::tire_model::pac2002::relaxation_lengths(c, fz, gamma)
}

#[test]
fn loads_above_the_tested_range_extrapolate_and_are_flagged() {
    let mut c = clean_coefs();
    c[Coef::FZMAX] = 1200.0;
    let model = Pac2002::new(c.clone());
    let t = Pac2002Tire::new(&model, Some(14), 1500.0);
    let cond = cond(&[600.0, 1500.0], 1000.0);
    let f = evaluate(&t, &cond);
    assert_eq!(f.extrapolated_loads_n, vec![1500.0]);
    let mu = (c[Coef::PDY1] + c[Coef::PDY2] * (1500.0 - 1100.0) / 1100.0).abs();
    let (g, _) = design_camber(&t, &cond);
    let at_g = peak_fy(&t, &cond, 1500.0, g);
    assert!(close(f.loads[1].fy_peak_n, at_g, 1e-12));
    // At zero camber the extrapolated load follows the model's load law, not the clipped one.
    assert!(close(peak_fy(&t, &cond, 1500.0, 0.0), mu * 1500.0, 1e-9));
    assert_eq!(
        t.ranges().fz_n.1,
        1200.0,
        "the tested range is still reported"
    );
}

#[test]
fn conditions_are_validated_by_name() {
    let ok = cond(&[300.0, 700.0], 700.0);
    assert!(ok.validate().is_ok());
    let mut bad = ok.clone();
    bad.loads_n = vec![700.0, 300.0];
    assert!(
        bad.validate()
            .unwrap_err()
            .to_string()
            .contains("ascending")
    );
    let mut bad = ok.clone();
    bad.loads_n.clear();
    assert!(bad.validate().is_err());
    let mut bad = ok.clone();
    bad.camber_rad = (0.05, 0.01);
    assert!(bad.validate().unwrap_err().to_string().contains("camber"));
    let mut bad = ok;
    bad.speed_mps = 0.0;
    assert!(bad.validate().unwrap_err().to_string().contains("speed"));
}
