//! Fuzz the mission plan language (`estimator::plan::parse_plan`): no input may panic or
//! overflow the stack, however deeply nested.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = estimator::plan::parse_plan(text);
    }
});
