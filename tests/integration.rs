//! Integration tests.
mod synth;
