//! Criterion bench of the PAC2002 fitting stage: one full fit (every family) of one tire and
//! pressure, on a TTC-like round generated from the `fsae-demo` truth with realistic noise,
//! spikes and lag (61 sweeps, ~68k samples).
//!
//! In: nothing (the round is generated in memory). Out: criterion's timing of
//! `tirebase_core::fit::pac2002::fit`, plus one line with the solver evaluations per fit.
//! Run: `cargo bench -p tirebase-core --bench fit_pac2002`.

use criterion::{Criterion, criterion_group, criterion_main};

// The test-data generator of the fit module, compiled here against the public API.
mod tire_model {
    pub use tirebase_core::tire_model::*;
}
mod fit {
    pub mod pac2002 {
        pub use tirebase_core::fit::pac2002::*;
    }
}
mod numerics {
    pub use tirebase_core::numerics::*;
}
#[allow(dead_code)]
#[path = "../fit/pac2002/synthetic.rs"]
mod synthetic;

use tirebase_core::fit::pac2002::{FitConfig, fit as fit_pac2002};

fn bench_full_fit(c: &mut Criterion) {
    let input = synthetic::ttc_round(
        &synthetic::fsae_demo(),
        &synthetic::RoundSpec::realistic(13),
    );
    let once = fit_pac2002(&input, &FitConfig::default()).expect("fit");
    eprintln!(
        "full fit: {} solver evaluations, {:.3} s (single run)",
        once.evaluations, once.seconds
    );
    let mut group = c.benchmark_group("fit_pac2002");
    group.sample_size(10);
    group.bench_function("full_fit_noisy_round", |b| {
        b.iter(|| fit_pac2002(&input, &FitConfig::default()).expect("fit"))
    });
    group.finish();
}

criterion_group!(benches, bench_full_fit);
criterion_main!(benches);
