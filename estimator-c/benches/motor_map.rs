//! Cost of one `hb_motor_power_w` on the host (the C entry point, called from Rust): four and
//! sixteen rotors on a degree-5 map, commands inside its range. `cargo bench -p estimator-c
//! --bench motor_map`.

// The bench calls the C entry points as C does, through raw pointers.
#![allow(unsafe_code)]

use std::hint::black_box;
use std::time::{Duration, Instant};

use estimator::MotorMap;
use hoverbench_online::{
    HB_OK, HbMotorMap, hb_motor_map_init, hb_motor_map_size, hb_motor_power_w,
};

/// A blob with a degree-5 motor map (the fit's default degree) measured from 1 V to 12.6 V of
/// drive.
fn map() -> HbMotorMap {
    let curve = estimator::PolyCurve::new(&[22.36, 29.12, 6.76], 130.0, 130.0, (0.0, 260.0), None)
        .expect("a valid curve");
    let motor = MotorMap::new(
        1000.0,
        2000.0,
        &[27.0, 33.0, 12.0, 2.0, 0.1, -0.02],
        6.8,
        5.8,
        (1.0, 12.6),
        0.01,
    )
    .expect("a valid map");
    let params = estimator::Params {
        motor: Some(motor),
        ..estimator::Params::new(4, curve)
    };
    let mut blob = [0u8; estimator::params::MAX_BLOB_LEN];
    let len = params.encode(&mut blob).expect("an encodable blob");
    let mut map = HbMotorMap::ZEROED;
    // SAFETY: a blob of `len` bytes and a writable map.
    let rc = unsafe { hb_motor_map_init(blob.as_ptr(), len, &mut map) };
    assert_eq!(rc, HB_OK);
    map
}

fn bench(map: &HbMotorMap, motors: usize) {
    // 1000 sets of commands between 1400 and 1700 µs, on a pack falling from 12.4 V to 10.8 V.
    let sets: Vec<(Vec<f64>, f64)> = (0..1000)
        .map(|k| {
            let k = f64::from(k);
            let commands = (0..motors)
                .map(|m| 1550.0 + 150.0 * (0.37 * k + m as f64).sin())
                .collect();
            (commands, 12.4 - 1.6 * k / 1000.0)
        })
        .collect();
    let mut calls = 0u64;
    let mut power_w = 0.0;
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(2) {
        for (commands, volts) in &sets {
            // SAFETY: `motors` commands, a valid map and a writable double.
            let rc = unsafe {
                hb_motor_power_w(
                    black_box(map),
                    black_box(commands.as_ptr()),
                    motors as u32,
                    black_box(*volts),
                    &mut power_w,
                )
            };
            assert_eq!(rc, HB_OK);
            black_box(power_w);
        }
        calls += sets.len() as u64;
    }
    let ns = start.elapsed().as_nanos() as f64 / calls as f64;
    println!("hb_motor_power_w, {motors:>2} rotors, degree 5    {ns:>8.1} ns/call ({calls} calls)");
}

fn main() {
    println!(
        "hb_motor_map: {} bytes (the MotorMap in it: {} bytes)",
        hb_motor_map_size(),
        std::mem::size_of::<MotorMap>()
    );
    let map = map();
    bench(&map, 4);
    bench(&map, 16);
}
