//! Fuzz target: arbitrary bytes -> the `.dat` reader (and the format sniffer in `read_run`).
//!
//! In: any bytes. Out: nothing; the run fails only on a panic, or when an error message is not a
//! single line starting with the source name. Deliberately not here: checking values (the unit
//! tests do that).
#![no_main]

use libfuzzer_sys::fuzz_target;
use tirebase_core::ttc::{read_dat, read_run};

fuzz_target!(|bytes: &[u8]| {
    for result in [read_dat(bytes, "fuzz.dat"), read_run(bytes, "fuzz.dat")] {
        match result {
            Ok(run) => {
                assert!(!run.is_empty());
                assert_eq!(run.tire.fz_n.len(), run.len());
                assert!(run.meta.warnings.iter().all(|w| !w.contains('\n')));
            }
            Err(e) => {
                let message = e.to_string();
                assert!(message.starts_with("fuzz.dat: ") && !message.contains('\n'));
            }
        }
    }
});
