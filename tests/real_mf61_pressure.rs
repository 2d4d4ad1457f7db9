//! Opt-in real-data diagnostic of the MF 6.1 fit's pressure terms: why a pressure left out is
//! predicted worse than in sample (fit_quality `lopo_ratio`), on the pure-slip family of each real
//! file of `shared/real/` (`Fx0` of `drivebrake.mat`, `Fy0` of `cornering.mat`).
//!
//! Prints, per file: what each tested pressure's sweeps hold (loads, inclinations, slip angles,
//! run order, tread temperature, measured pressure) and its PAC2002 fit's friction and slip
//! stiffness; the family's coefficients fitted on every pressure and with each pressure left out;
//! and, at each left-out pressure, the RMSE of the family's channel for: the model fitted on every
//! pressure, the model fitted without it, the two crossed (the pressure terms of one with the
//! other coefficients of the other), the left-out model with only its pressure terms refitted on
//! the left-out pressure (what pressure terms alone could do), and every coefficient of the family
//! refitted on that pressure alone (its floor). Not an assertion: the figures are the point.
//!
//! Ignored by default (GPL data, development only, read where it lies):
//! `cargo test --test integration real_data_mf61_pressure -- --ignored --nocapture`.

use std::collections::BTreeSet;

use tirebase::core::fit::mf61::problem::{FamilyData, Mf61FamilyProblem};
use tirebase::core::fit::mf61::{Mf61Config, Mf61Input, Point, collapse_group, fit, rmse_of};
use tirebase::core::fit::output::Output;
use tirebase::core::fit::pac2002::{Family, SweepKind};
use tirebase::core::numerics::nonlinear_least_squares::{Bounds, Options, minimize};
use tirebase::core::tire_model::{Coef, MagicFormula};

use crate::real::{mf61_groups, real_dir};

/// The family's data among `points` of group `group` (all groups with `None`): its sweep kind,
/// its output measured with a positive weight.
fn family_data(points: &[Point], family: Family, group: Option<usize>) -> FamilyData {
    let (kind, out) = match family {
        Family::Fx0 => (SweepKind::DriveBrake, Output::Fx),
        _ => (SweepKind::Cornering, Output::Fy),
    };
    let mut d = FamilyData::default();
    for p in points {
        if p.kind != kind || group.is_some_and(|g| p.group != g) {
            continue;
        }
        d.push_output(p, out, p.weights[out as usize]);
    }
    d
}

fn rmse(model: &MagicFormula, family: Family, d: &FamilyData) -> f64 {
    rmse_of(model, family.channel(), d)
}

/// `model` with `free` refitted on `d` (unbounded, default options).
fn refit(model: &MagicFormula, free: &[Coef], family: Family, d: &FamilyData) -> MagicFormula {
    let problem = Mf61FamilyProblem::new(model, free, family.channel(), d);
    let start: Vec<f64> = free.iter().map(|c| model.coefs[*c]).collect();
    let out = minimize(
        &problem,
        &start,
        &Bounds::unbounded(free.len()),
        &Options::default(),
    );
    problem.model_at(&out.params)
}

fn levels(v: impl Iterator<Item = f64>, resolution: f64) -> String {
    let set: BTreeSet<i64> = v
        .filter(|x| x.is_finite())
        .map(|x| (x / resolution).round() as i64)
        .collect();
    set.iter()
        .map(|x| format!("{}", *x as f64 * resolution))
        .collect::<Vec<_>>()
        .join("/")
}

fn diagnose(file: &str, family: Family) {
    use tirebase::core::tire_model::Coef::*;
    let Some(real) = real_dir() else {
        return;
    };
    let (tire, rim, groups, segments) = mf61_groups(&real, file);
    let pressures: Vec<i64> = groups.iter().map(|g| g.pressure_kpa_nom).collect();
    eprintln!("== {file}: {} at {pressures:?} kPa", family.as_str());
    let kind = if family == Family::Fx0 {
        SweepKind::DriveBrake
    } else {
        SweepKind::Cornering
    };
    // What each pressure's sweeps hold, in file order.
    for (p, segs) in &segments {
        let sweeps: Vec<_> = segs
            .iter()
            .filter(|s| {
                tirebase::core::fit::mf61::Mf61Sweep::from_segment(s, None)
                    .is_some_and(|w| w.kind == kind)
            })
            .collect();
        let mean = |v: &[f64]| {
            let f: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
            f.iter().sum::<f64>() / f.len().max(1) as f64
        };
        eprintln!(
            "  {p} kPa: {} {} sweeps, segment index {}..{}, ET {:.0}..{:.0} s",
            sweeps.len(),
            family.as_str(),
            sweeps.first().map_or(-1, |s| s.segment_index),
            sweeps.last().map_or(-1, |s| s.segment_index),
            sweeps.first().map_or(f64::NAN, |s| s.channels.et_s[0]),
            sweeps
                .last()
                .map_or(f64::NAN, |s| *s.channels.et_s.last().unwrap()),
        );
        for s in &sweeps {
            let c = &s.channels;
            eprintln!(
                "    seg {:>3} ET {:>6.0} Fz {:>6.0} N IA {:>5.2} deg SA {:>6.2} deg p {:>5.1} kPa \
                 V {:>5.1} km/h tread {:>5.1}/{:>5.1}/{:>5.1} C peak|F| {:>6.0} N",
                s.segment_index,
                c.et_s[0],
                mean(&c.fz_n),
                mean(&c.gamma_rad).to_degrees(),
                mean(&c.alpha_rad).to_degrees(),
                mean(&c.pressure_kpa),
                mean(&c.speed_kph),
                c.tread_inner_c.as_deref().map_or(f64::NAN, mean),
                c.tread_centre_c.as_deref().map_or(f64::NAN, mean),
                c.tread_outer_c.as_deref().map_or(f64::NAN, mean),
                if family == Family::Fx0 {
                    c.fx_n.iter().fold(0.0_f64, |m, x| m.max(x.abs()))
                } else {
                    c.fy_n.iter().fold(0.0_f64, |m, x| m.max(x.abs()))
                },
            );
        }
    }
    let pac_coefs: &[Coef] = if family == Family::Fx0 {
        &[PDX1, PDX2, PDX3, PKX1, PKX2, PKX3, PCX1, PEX1, PHX1, PVX1]
    } else {
        &[PDY1, PDY2, PDY3, PKY1, PKY2, PKY3, PCY1, PEY1, PHY1, PVY1]
    };
    for g in &groups {
        if let Some(pac) = &g.pac2002 {
            eprintln!(
                "  PAC2002 at {} kPa (measured {:.1}): {}",
                g.pressure_kpa_nom,
                pac.p_pa / 1e3,
                pac_coefs
                    .iter()
                    .map(|c| format!("{} {:.4}", c.name(), pac.model.coefs[*c]))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }
    let cfg = Mf61Config {
        kfold: 0,
        ..Mf61Config::default()
    };
    let all = Mf61Input {
        tire: tire.clone(),
        rim_in: rim,
        nominal_pa: Mf61Input::nominal_for(&pressures),
        groups: groups.clone(),
    };
    let full = fit(&all, &cfg).expect("MF 6.1 fit");
    let free: Vec<Coef> = full
        .families
        .iter()
        .find(|f| f.family == family)
        .map(|f| f.free.clone())
        .unwrap_or_default();
    let pressure_terms: Vec<Coef> = free
        .iter()
        .copied()
        .filter(|c| c.name().starts_with("PP"))
        .collect();
    eprintln!(
        "  free: {}",
        free.iter().map(|c| c.name()).collect::<Vec<_>>().join(" ")
    );
    for n in full.notes.iter().filter(|n| n.starts_with(family.as_str())) {
        eprintln!("  note: {n}");
    }
    for q in full.family_quality.iter().filter(|q| q.family == family) {
        eprintln!(
            "  {} kPa: in-sample RMSE {:.1}, left-out {:.1?}, ratio {:.2}",
            q.pressure_kpa_nom,
            q.rmse,
            q.lopo_rmse,
            q.lopo_ratio()
        );
    }
    // Every pressure's collapsed points, indexed as the fit indexes its groups (pressure order).
    let mut sorted = groups.clone();
    sorted.sort_by_key(|g| g.pressure_kpa_nom);
    let points: Vec<Point> = sorted
        .iter()
        .enumerate()
        .flat_map(|(gi, g)| {
            collapse_group(&g.sweeps, &cfg.collapse)
                .into_iter()
                .map(move |p| Point { group: gi, ..p })
        })
        .collect();
    let only = Mf61Config {
        leave_one_pressure_out: false,
        ..cfg
    };
    let mut fitted = vec![("all".to_string(), full.model.clone())];
    for (gi, g) in sorted.iter().enumerate() {
        let kept: Vec<_> = sorted
            .iter()
            .filter(|x| x.pressure_kpa_nom != g.pressure_kpa_nom)
            .cloned()
            .collect();
        let kept_kpa: Vec<i64> = kept.iter().map(|x| x.pressure_kpa_nom).collect();
        let input = Mf61Input {
            groups: kept,
            nominal_pa: Mf61Input::nominal_for(&kept_kpa),
            ..all.clone()
        };
        let mut held = fit(&input, &only).expect("fit without one pressure").model;
        held.coefs[PRESMIN] = PRESMIN.default_value();
        held.coefs[PRESMAX] = PRESMAX.default_value();
        let d = family_data(&points, family, Some(gi));
        let mut full_m = full.model.clone();
        full_m.coefs[PRESMIN] = PRESMIN.default_value();
        full_m.coefs[PRESMAX] = PRESMAX.default_value();
        // The two crossed, each referred to the same NOMPRES only when both are.
        let same_nom = held.coefs[NOMPRES] == full_m.coefs[NOMPRES];
        let mut cross_a = full_m.clone();
        let mut cross_b = held.clone();
        for c in &pressure_terms {
            cross_a.coefs[*c] = held.coefs[*c];
            cross_b.coefs[*c] = full_m.coefs[*c];
        }
        let press_only = refit(&held, &pressure_terms, family, &d);
        let mut with_quad = pressure_terms.clone();
        for c in if family == Family::Fx0 {
            [PPX2, PPX4]
        } else {
            [PPY2, PPY4]
        } {
            if !with_quad.contains(&c) {
                with_quad.push(c);
            }
        }
        let floor = refit(&held, &free, family, &d);
        eprintln!(
            "  {} kPa left out (NOMPRES {:.0} kPa): RMSE all-pressure model {:.1}, left-out model \
             {:.1}, all's non-pressure + left-out's pressure terms {:.1}{}, left-out's \
             non-pressure + all's pressure terms {:.1}{}, left-out with its pressure terms \
             refitted here {:.1}, with its pressure terms and quadratic ones refitted here \
             {:.1}, every {} coefficient refitted here {:.1} ({} points)",
            g.pressure_kpa_nom,
            held.coefs[NOMPRES] / 1e3,
            rmse(&full_m, family, &d),
            rmse(&held, family, &d),
            rmse(&cross_a, family, &d),
            if same_nom { "" } else { " (other NOMPRES)" },
            rmse(&cross_b, family, &d),
            if same_nom { "" } else { " (other NOMPRES)" },
            rmse(&press_only, family, &d),
            rmse(&refit(&held, &with_quad, family, &d), family, &d),
            family.as_str(),
            rmse(&floor, family, &d),
            d.len()
        );
        // The left-out model's pressure terms scaled toward neutral, its other coefficients of
        // the family refitted on the training pressures: the left-out error and the training
        // RMSE at each scale.
        let training = {
            let mut t = FamilyData::default();
            for x in (0..sorted.len()).filter(|x| *x != gi) {
                let d = family_data(&points, family, Some(x));
                t.inputs.extend(d.inputs);
                t.pressures.extend(d.pressures);
                t.measured.extend(d.measured);
                t.weights.extend(d.weights);
                t.sweeps.extend(d.sweeps);
                t.groups.extend(d.groups);
            }
            t
        };
        let rest: Vec<Coef> = free
            .iter()
            .copied()
            .filter(|c| !pressure_terms.contains(c))
            .collect();
        let mut line = String::new();
        for scale in [1.0, 0.75, 0.5, 0.25, 0.0] {
            let mut m = held.clone();
            for c in &pressure_terms {
                m.coefs[*c] *= scale;
            }
            let m = refit(&m, &rest, family, &training);
            line += &format!(
                " x{scale}: out {:.1} train {:.1};",
                rmse(&m, family, &d),
                rmse(&m, family, &training)
            );
        }
        eprintln!("    pressure terms scaled:{line}");
        // Per sweep at the left-out pressure: which sweeps carry the error.
        let mut sweeps: Vec<usize> = d.sweeps.clone();
        sweeps.dedup();
        for s in sweeps {
            let idx: Vec<usize> = (0..d.len()).filter(|&i| d.sweeps[i] == s).collect();
            let sub = FamilyData {
                inputs: idx.iter().map(|&i| d.inputs[i]).collect(),
                pressures: idx.iter().map(|&i| d.pressures[i]).collect(),
                measured: idx.iter().map(|&i| d.measured[i]).collect(),
                weights: idx.iter().map(|&i| d.weights[i]).collect(),
                sweeps: idx.iter().map(|&i| d.sweeps[i]).collect(),
                groups: idx.iter().map(|&i| d.groups[i]).collect(),
            };
            let i0 = sub.inputs[0];
            eprintln!(
                "    sweep {s:>3} Fz {:>6.0} IA {:>5.2}: all {:>6.1} left-out {:>6.1} floor {:>6.1}",
                i0.fz_n,
                i0.gamma_rad.to_degrees(),
                rmse(&full_m, family, &sub),
                rmse(&held, family, &sub),
                rmse(&floor, family, &sub),
            );
        }
        fitted.push((format!("without {}", g.pressure_kpa_nom), held));
    }
    let loads = levels(points.iter().map(|p| p.input.fz_n), 100.0);
    eprintln!("  collapsed loads (100 N levels): {loads}");
    let mut show: Vec<Coef> = free.clone();
    show.push(NOMPRES);
    eprintln!(
        "  {:<8} {}",
        "coef",
        fitted
            .iter()
            .map(|(n, _)| format!("{n:>12}"))
            .collect::<String>()
    );
    for c in show {
        eprintln!(
            "  {:<8} {}",
            c.name(),
            fitted
                .iter()
                .map(|(_, m)| format!("{:>12.4}", m.coefs[c]))
                .collect::<String>()
        );
    }
}

#[test]
#[ignore = "needs the real files of shared/real/ (development only); run with --ignored"]
fn real_data_mf61_pressure_diagnostic_fx0() {
    diagnose("drivebrake.mat", Family::Fx0);
}

#[test]
#[ignore = "needs the real files of shared/real/ (development only); run with --ignored"]
fn real_data_mf61_pressure_diagnostic_fy0() {
    diagnose("cornering.mat", Family::Fy0);
}
