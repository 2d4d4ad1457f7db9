//! Integration tests: one binary, one module per command, each driving the real `tirebase`
//! binary in temporary directories.

mod compare;
mod fit;
mod inertia;
mod ingest;
mod real;
mod real_quality;
mod report;
mod run;
mod run_inputs;
mod synth;
mod tir;
