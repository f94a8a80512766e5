//! Fuzz battery catalogues (`import::Table::parse` then `Table::catalogue`): no input may
//! panic; every accepted pack has a positive, finite mass and energy.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(table) = import::Table::parse(data, "fuzz.csv") else {
        return;
    };
    if let Ok(packs) = table.catalogue() {
        for p in packs {
            assert!(p.mass_g.is_finite() && p.mass_g > 0.0, "{p:?}");
            assert!(p.energy_wh.is_finite() && p.energy_wh > 0.0, "{p:?}");
        }
    }
});
