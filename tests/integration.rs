//! Integration tests: one test binary, one module per command, each driving the real
//! `tirebase` binary in temp dirs.

mod tir;
