//! Integration tests: one binary, one module per command, each driving the real `tirebase`
//! binary in temporary directories through the shared [`harness`] (the binary, temp stores, the
//! demo round generated once per test process).

mod compare;
mod fit;
mod harness;
mod inertia;
mod ingest;
mod mf61_run;
mod real;
mod real_mf61_pressure;
mod real_quality;
mod report;
mod run;
mod run_inputs;
mod synth;
mod tir;
