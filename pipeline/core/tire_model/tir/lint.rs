//! Lint (in progress).
