//! Integration tests: one binary, one module per command, each driving the real `tirebase`
//! binary in temporary directories.

mod compare;
mod fit;
mod inertia;
mod ingest;
mod report;
mod run;
mod synth;
mod tir;
