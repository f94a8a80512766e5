//! Fuzz `params.toml` (`ParamsFile::from_toml_str` and `to_params`): no input may panic, and
//! a file that parses renders to TOML that parses back to the same file.
#![no_main]

use estimator::file::ParamsFile;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(file) = ParamsFile::from_toml_str(text) {
        let _ = file.to_params();
        let back = ParamsFile::from_toml_str(&file.to_toml_string())
            .expect("a rendered params.toml parses");
        assert_eq!(format!("{file:?}"), format!("{back:?}"));
    }
});
