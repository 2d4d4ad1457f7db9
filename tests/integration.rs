//! Integration tests: one binary, one module per command, each driving the real `tirebase`
//! binary in temporary directories.

mod inertia;
mod ingest;
mod synth;
mod tir;
