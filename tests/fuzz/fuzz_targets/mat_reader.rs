//! Fuzz target: arbitrary bytes -> the MAT-file decoder and the TTC `.mat` reader.
//!
//! In: any bytes. Out: nothing; the run fails only on a panic, or when an error message is not a
//! single line starting with the source name. Deliberately not here: checking values.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tirebase_core::ttc::mat::parse_mat;
use tirebase_core::ttc::read_mat;

fuzz_target!(|bytes: &[u8]| {
    if let Err(e) = parse_mat(bytes, "fuzz.mat") {
        let message = e.to_string();
        assert!(message.starts_with("fuzz.mat: ") && !message.contains('\n'));
    }
    match read_mat(bytes, "fuzz.mat") {
        Ok(run) => {
            assert_eq!(run.tire.fz_n.len(), run.len());
            assert!(run.meta.warnings.iter().all(|w| !w.contains('\n')));
        }
        Err(e) => {
            let message = e.to_string();
            assert!(message.starts_with("fuzz.mat: ") && !message.contains('\n'));
        }
    }
});
