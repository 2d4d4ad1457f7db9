//! Criterion bench of the MF 6.1 fitting stage: one MF 6.1 model of one tire across its four
//! tested pressures (Hoosier 16.0x7.5-10 R25B on a 7 in rim, 8 / 10 / 12 / 14 psi), from a
//! virtual round whose truth is one MF 6.1 model.
//!
//! In: nothing (the tire's runs are rendered in memory, read, segmented and fitted per pressure
//! with PAC2002 first, as the test `fit::mf61::virtual_round` does; not timed). Out: criterion's
//! timing of `tirebase_core::fit::mf61::fit` as the pipeline runs it (the model, its k-fold-by-
//! sweep refits of every family and, with four pressures, one leave-one-pressure-out refit per
//! pressure), with the k-fold refits only, and the model alone, plus one line with the points
//! and solver evaluations. Single thread.
//! Run: `cargo bench -p tirebase-core --bench fit_mf61`.

use criterion::{Criterion, criterion_group, criterion_main};

// The round-to-input support of the MF 6.1 tests, compiled here against the public API.
mod fit {
    pub use tirebase_core::fit::*;
}
mod segment {
    pub use tirebase_core::segment::*;
}
mod synth {
    pub use tirebase_core::synth::*;
}
mod tire_model {
    pub use tirebase_core::tire_model::*;
}
mod ttc {
    pub use tirebase_core::ttc::*;
}
#[allow(dead_code)]
#[path = "../fit/mf61/virtual_input.rs"]
mod virtual_input;

use tirebase_core::fit::mf61::{Mf61Config, fit as fit_mf61};

fn bench_fit(c: &mut Criterion) {
    // One thread, as the pipeline runs one group per worker.
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global()
        .ok();
    let prep = virtual_input::prepare(1, 7.0);
    let with_loo = Mf61Config::default();
    let model_only = Mf61Config {
        leave_one_pressure_out: false,
        kfold: 0,
        ..Mf61Config::default()
    };
    let with_kfold = Mf61Config {
        leave_one_pressure_out: false,
        ..Mf61Config::default()
    };
    let once = fit_mf61(&prep.input, &model_only).expect("fit");
    let sweeps: usize = prep.input.groups.iter().map(|g| g.sweeps.len()).sum();
    eprintln!(
        "MF 6.1 fit of {} pressures, {sweeps} sweeps: {} points over the families, {} solver \
         evaluations, {:.3} s (single run, model only)",
        prep.input.groups.len(),
        once.families.iter().map(|f| f.n).sum::<usize>(),
        once.evaluations,
        once.seconds
    );
    let mut group = c.benchmark_group("fit_mf61_4_pressures");
    group.sample_size(10);
    group.bench_function("model_only", |b| {
        b.iter(|| fit_mf61(&prep.input, &model_only).expect("fit"))
    });
    group.bench_function("with_kfold", |b| {
        b.iter(|| fit_mf61(&prep.input, &with_kfold).expect("fit"))
    });
    group.bench_function("with_kfold_and_leave_one_pressure_out", |b| {
        b.iter(|| fit_mf61(&prep.input, &with_loo).expect("fit"))
    });
    group.finish();
}

criterion_group!(benches, bench_fit);
criterion_main!(benches);
