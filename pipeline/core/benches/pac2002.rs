//! Criterion benchmarks of the Magic Formula evaluator: time per point of a combined-slip
//! evaluation (all five outputs) over a batch of 10^5 points, PAC2002 and MF 6.1 side by side,
//! and of a coefficient Jacobian.
//!
//! Run: `cargo bench -p tirebase-core --bench pac2002` (about a minute). In: the bundled FSAE demo
//! tire (PAC2002, and lifted into MF 6.1 at 83 kPa with pressure terms) and 10^5 seeded random
//! points over an FSAE envelope (continuous load, as measured data has; MF 6.1 with a pressure per
//! point, 55-97 kPa). Out: criterion's report; divide the batch time by 10^5 (or read the
//! throughput line) for ns per point. Single thread. Not a correctness check: the unit and
//! property tests are.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
// `Coefs`, `MagicFormula`, `SlipInput`, `SplitMix64` and `tir` are used by the included
// test-support module via `super::`.
use tirebase_core::numerics::random::SplitMix64;
use tirebase_core::tire_model::{
    Channel, Coef, Coefs, Evaluation, MagicFormula, Mode, Pac2002, Pressures, SlipInput, Version,
    tir,
};

#[path = "../tire_model/test_support.rs"]
mod test_support;

const N_POINTS: usize = 100_000;

fn fsae_tire() -> Pac2002 {
    Pac2002::new(test_support::coefs_from_tir(test_support::FSAE_DEMO_TIR))
}

/// The FSAE demo tire lifted into MF 6.1 at 83 kPa, with pressure terms (so every pressure factor
/// of the MF 6.1 equations is evaluated, not multiplied by zero terms).
fn fsae_tire_mf61() -> MagicFormula {
    let file = tir::TirFile::from_coefs(fsae_tire().coefs);
    let mut c = tir::convert::convert(&file, Version::Mf61, Some(83e3))
        .expect("lift into MF 6.1")
        .file
        .coefs;
    for (k, v) in [
        (Coef::PPX1, -0.25),
        (Coef::PPX2, 0.10),
        (Coef::PPX3, -0.10),
        (Coef::PPX4, 0.06),
        (Coef::PPY1, 0.45),
        (Coef::PPY2, 0.25),
        (Coef::PPY3, -0.12),
        (Coef::PPY4, 0.08),
        (Coef::PPY5, -0.2),
        (Coef::PPZ1, 0.30),
        (Coef::PPZ2, -0.15),
        (Coef::PPMX1, 0.1),
    ] {
        c[k] = v;
    }
    c[Coef::PRESMIN] = 40e3;
    c[Coef::PRESMAX] = 130e3;
    MagicFormula::with_version(c, Version::Mf61)
}

fn combined(c: &mut Criterion) {
    let tire = fsae_tire();
    let tire61 = fsae_tire_mf61();
    let points = test_support::random_points(N_POINTS, 7, tire.coefs[Coef::FNOMIN]);
    let pressures: Vec<f64> = (0..N_POINTS)
        .map(|i| 55e3 + 42e3 * ((i as f64 * 0.618_033_988_75).fract()))
        .collect();
    let mut out = vec![Evaluation::default(); N_POINTS];
    let mut group = c.benchmark_group("combined_eval_1e5");
    group.throughput(Throughput::Elements(N_POINTS as u64));
    group.sample_size(20);
    group.bench_function("eval_batch_limits", |b| {
        b.iter(|| tire.eval_batch(black_box(&points), Mode::Limits, &mut out))
    });
    // The same points through the MF 6.1 form of the same tire, each at its own pressure.
    group.bench_function("mf61_eval_batch_limits", |b| {
        b.iter(|| {
            tire61.eval_batch_at(
                black_box(&points),
                Pressures::PerPoint(black_box(&pressures)),
                Mode::Limits,
                &mut out,
            )
        })
    });
    // The scalar path (standard-library elementary functions, one point at a time): the
    // "before" figure the batch evaluator is measured against.
    group.bench_function("scalar_eval_loop_limits", |b| {
        b.iter(|| {
            for (p, slot) in black_box(&points).iter().zip(out.iter_mut()) {
                *slot = tire.eval(p, Mode::Limits);
            }
        })
    });
    group.finish();
}

/// Points in the Jacobian benchmark (a fit's data set is 10^3..10^5 points; the cost is linear).
const N_JAC_POINTS: usize = 10_000;

fn jacobian(c: &mut Criterion) {
    let tire = fsae_tire();
    let points = test_support::random_points(N_JAC_POINTS, 11, tire.coefs[Coef::FNOMIN]);
    // The 18 Fy0 family coefficients plus LMUY and LKY: 20 free coefficients.
    let mut free = Channel::Fy0.family().to_vec();
    free.extend([Coef::LMUY, Coef::LKY]);
    assert_eq!(free.len(), 20);
    let mut values = vec![0.0; N_JAC_POINTS];
    let mut jac = vec![0.0; N_JAC_POINTS * free.len()];
    let mut group = c.benchmark_group("jacobian_1e4");
    group.throughput(Throughput::Elements(N_JAC_POINTS as u64));
    group.sample_size(20);
    group.bench_function("fy0_20_coefs", |b| {
        b.iter(|| {
            tire.jacobian_into(
                Channel::Fy0,
                black_box(&free),
                black_box(&points),
                Mode::Limits,
                &mut values,
                &mut jac,
            )
        })
    });
    group.bench_function("fy0_values_only", |b| {
        b.iter(|| tire.channel_into(Channel::Fy0, black_box(&points), Mode::Limits, &mut values))
    });
    group.finish();
}

criterion_group!(benches, combined, jacobian);
criterion_main!(benches);
