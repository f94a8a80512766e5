//! Fuzz the flight metadata reader (`flights.toml`, sidecars): arbitrary text must never
//! panic it, and metadata it accepts is valid and survives a write and re-read.
#![no_main]

use std::path::Path;

use flightlog::FlightMeta;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(meta) = FlightMeta::parse(text, Path::new("fuzz.toml")) {
        assert!(meta.validate(Path::new("fuzz.toml"), None).is_ok());
        let written = toml::to_string(&meta).expect("metadata writes as TOML");
        let back = FlightMeta::parse(&written, Path::new("again.toml")).expect("re-reads");
        assert_eq!(back.entries(), meta.entries());
        let _ = FlightMeta::resolve(&[flightlog::MetaLayer::new(
            meta,
            flightlog::MetaSource::Sidecar {
                path: "fuzz.toml".into(),
            },
        )]);
    }
});
