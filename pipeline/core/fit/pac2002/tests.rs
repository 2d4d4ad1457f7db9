//! Validation of the PAC2002 fitting stage on rounds generated from known truths (issue 5).
//!
//! Truths: the `fsae-demo` reference tire and perturbed variants (one with the lateral signs
//! mirrored). Rounds: TTC layout from [`super::synthetic`]. Accuracy: RMS error of the fitted
//! model against the truth over the tested envelope, % of the truth's peak per channel.

use super::synthetic::{
    EnvelopeErrors, Rng, RoundSpec, envelope_errors, fsae_demo, truth_relaxation, ttc_round,
};
use super::*;
use crate::tire_model::{Coef::*, Coefs};

fn report(name: &str, fit: &Pac2002Fit, e: &EnvelopeErrors) {
    eprintln!(
        "== {name}: USE_MODE {}, {} evaluations, {:.3} s",
        fit.use_mode, fit.evaluations, fit.seconds
    );
    for f in &fit.families {
        match &f.quality {
            Some(q) => eprintln!(
                "  {:4} n {:5} rmse {:10.4} ({:7.4} % of peak) r2 {:.6} samples {:6} \
                 sample_rmse {:9.3} init_rmse {:9.3} it {:4} {:>18} evals {:4} {:.3} s",
                f.family.as_str(),
                q.n,
                q.rmse,
                q.rmse_pct_of_peak,
                q.r2,
                q.n_samples,
                q.sample_rmse,
                q.initial_rmse,
                q.iterations,
                q.termination.as_str(),
                q.evaluations,
                q.seconds
            ),
            None => eprintln!("  {:4} {:?}", f.family.as_str(), f.status),
        }
    }
    for n in &fit.notes {
        eprintln!("  note: {n}");
    }
    let fmt = |v: [f64; 4]| {
        format!(
            "Fx {:.4} Fy {:.4} Mz {:.4} Mx {:.4}",
            v[0], v[1], v[2], v[3]
        )
    };
    eprintln!("  envelope % of peak: cornering   {}", fmt(e.cornering));
    eprintln!("  envelope % of peak: drive/brake {}", fmt(e.drive_brake));
    eprintln!("  envelope % of peak: combined    {}", fmt(e.combined));
    eprintln!("  envelope % of peak: all         {}", fmt(e.all));
}

/// A variant of the reference tire: every fitted coefficient scaled by `1 + 0.15 u`, `u` uniform
/// in [-1, 1] (seeded), shifts and camber terms included.
fn perturbed(seed: u64) -> Coefs<f64> {
    let mut c = fsae_demo();
    let mut rng = Rng::new(seed);
    for family in Family::FIT_ORDER {
        if family == Family::My || family == Family::Mx {
            continue;
        }
        for coef in family.coefficients() {
            c[*coef] *= 1.0 + 0.15 * (2.0 * rng.uniform() - 1.0);
        }
    }
    c
}

/// The reference tire with its lateral behaviour mirrored in sign conventions: `PDY1 > 0` and
/// `PKY1 > 0` (a tire whose data would come out with a positive cornering stiffness).
fn mirrored_lateral() -> Coefs<f64> {
    let mut c = fsae_demo();
    c[PDY1] = -c[PDY1];
    c[PKY1] = -c[PKY1];
    c
}

fn truths() -> Vec<(&'static str, Coefs<f64>)> {
    vec![
        ("fsae-demo", fsae_demo()),
        ("perturbed-1", perturbed(11)),
        ("perturbed-2", perturbed(29)),
        ("mirrored-lateral", mirrored_lateral()),
    ]
}

/// Issue 5 "Done when" 1: noise-free, lag-free sweeps: every fitted model reproduces its truth
/// within 0.1 % of peak (RMS over the tested envelope) for Fx, Fy and Mz.
#[test]
fn fit_noise_free_reproduces_truth_within_0_1_percent() {
    for (name, truth) in truths() {
        let input = ttc_round(&truth, &RoundSpec::ideal());
        let fit = fit(&input, &FitConfig::default()).expect("fit");
        let e = envelope_errors(&truth, &fit.model);
        report(name, &fit, &e);
        assert_eq!(fit.use_mode, 4, "{name}");
        for (k, channel) in ["Fx", "Fy", "Mz"].iter().enumerate() {
            assert!(
                e.all[k] <= 0.1,
                "{name}: {channel} RMS error {:.4} % of peak > 0.1 %",
                e.all[k]
            );
        }
    }
}

