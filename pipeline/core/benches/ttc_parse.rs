//! Throughput of the TTC readers on generated files (never real data).
//!
//! In: a 100 000-row round-8 style `.dat` (US customary, 21 channels, ~15 MB) and the same run
//! as `.mat` (uncompressed and zlib). Out: criterion timings with bytes-per-second throughput:
//! `dat/read_dat` is parse + unit conversion + frame change into a `RunTable`; `dat/std_parse`
//! is a baseline that only splits cells and calls `str::parse::<f64>` (no validation, no
//! conversion). Deliberately not here: Parquet writing (the ingest bench in the root crate).

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use tirebase_core::ttc::example::{ExampleStyle, example_dat, example_mat};
use tirebase_core::ttc::mat::Compression;
use tirebase_core::ttc::{read_dat, read_mat};

const ROWS: usize = 100_000;

/// The naive baseline: split lines and tabs, `str::parse` every cell, sum.
fn std_parse_sum(bytes: &[u8]) -> f64 {
    let text = std::str::from_utf8(bytes).expect("ASCII");
    text.lines()
        .skip(3)
        .flat_map(|line| line.split('\t'))
        .map(|cell| cell.parse::<f64>().unwrap_or(0.0))
        .sum()
}

fn bench_dat(c: &mut Criterion) {
    let bytes = example_dat(ExampleStyle::R8Uscs, ROWS, false);
    let mut group = c.benchmark_group("dat");
    group.throughput(Throughput::Bytes(bytes.len() as u64));
    group.sample_size(20);
    group.bench_function("read_dat", |b| {
        b.iter(|| read_dat(black_box(&bytes), "bench.dat").expect("valid"))
    });
    group.bench_function("std_parse", |b| b.iter(|| std_parse_sum(black_box(&bytes))));
    group.finish();
}

fn bench_mat(c: &mut Criterion) {
    let mut group = c.benchmark_group("mat");
    group.sample_size(20);
    for (label, compression) in [("plain", Compression::None), ("zlib", Compression::Zlib)] {
        let bytes = example_mat(ROWS, compression);
        group.throughput(Throughput::Bytes(bytes.len() as u64));
        group.bench_function(label, |b| {
            b.iter(|| read_mat(black_box(&bytes), "bench.mat").expect("valid"))
        });
    }
    group.finish();
}

criterion_group!(benches, bench_dat, bench_mat);
criterion_main!(benches);
