//! Synthetic data with known answers: rig-inertia sessions ([`inertia`]).
//!
//! In: parameters and a seed. Out: file contents in memory (the command layer writes them).
//! Deliberately no file-system access here.

pub mod inertia;
