//! Criterion benchmarks of the PAC2002 evaluator: time per point of a combined-slip evaluation
//! (all five outputs) over a batch of 10^5 points, and of a coefficient Jacobian.
//!
//! Run: `cargo bench -p tirebase-core` (about a minute). In: the bundled FSAE demo tire and
//! 10^5 seeded random points over an FSAE envelope (continuous load, as measured data has). Out: criterion's report; divide the batch time by 10^5 (or read
//! the throughput line) for ns per point. Single thread. Not a correctness check: the unit and
//! property tests are.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
// `Coefs`, `SlipInput`, `SplitMix64` and `tir` are used by the included test-support module via
// `super::`.
use tirebase_core::numerics::random::SplitMix64;
use tirebase_core::tire_model::{Channel, Coef, Coefs, Evaluation, Mode, Pac2002, SlipInput, tir};

#[path = "../tire_model/test_support.rs"]
mod test_support;

const N_POINTS: usize = 100_000;

fn fsae_tire() -> Pac2002 {
    Pac2002::new(test_support::coefs_from_tir(test_support::FSAE_DEMO_TIR))
}

fn combined(c: &mut Criterion) {
    let tire = fsae_tire();
    let points = test_support::random_points(N_POINTS, 7, tire.coefs[Coef::FNOMIN]);
    let mut out = vec![Evaluation::default(); N_POINTS];
    let mut group = c.benchmark_group("combined_eval_1e5");
    group.throughput(Throughput::Elements(N_POINTS as u64));
    group.sample_size(20);
    group.bench_function("eval_batch_limits", |b| {
        b.iter(|| tire.eval_batch(black_box(&points), Mode::Limits, &mut out))
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
