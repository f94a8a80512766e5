//! Fuzz the estimator's binary parameter blob (`Params::decode`, what firmware reads with
//! `include_bytes!`): no input may panic, and what decodes must re-encode to a blob that
//! decodes to the same parameters.
#![no_main]

use estimator::params::{MAX_BLOB_LEN, Params};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(p) = Params::decode(data) {
        let mut buf = [0u8; MAX_BLOB_LEN];
        let n = p.encode(&mut buf).expect("a decoded blob re-encodes");
        let again = Params::decode(&buf[..n]).expect("a re-encoded blob decodes");
        assert_eq!(format!("{p:?}"), format!("{again:?}"));
    }
});
