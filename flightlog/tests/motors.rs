//! The motor commands (`Samples::motor_us`) of real logs. The numbers expected here were read
//! apart from this crate, by small Python decoders written from the formats' documentation
//! (ULog's message layout, DataFlash's `FMT` records, MAVLink's packets and checksum), and
//! interpolated with `numpy.interp` at the battery's own message times: they check the reader
//! and the alignment rule (linear interpolation onto the battery's times), not copy them.

mod common;

use std::path::{Path, PathBuf};

use flightlog::ulog::ULog;
use flightlog::{Flight, FlightLogError};

/// The shared real logs (beside the repository's clone, as CI has them).
fn real(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/real/flightlogs")
        .join(rel)
}

/// The sample at time `t` s (to 1 µs), by its time.
fn at(f: &Flight, t: f64) -> usize {
    f.samples
        .time_s
        .iter()
        .position(|&x| (x - t).abs() < 1e-5)
        .unwrap_or_else(|| panic!("no sample at {t} s"))
}

/// Each motor's column at sample `k`.
fn commands(f: &Flight, k: usize) -> Vec<f64> {
    f.samples
        .motor_us
        .as_ref()
        .unwrap()
        .iter()
        .map(|c| c[k])
        .collect()
}

fn assert_close(got: &[f64], want: &[f64], tol: f64) {
    assert_eq!(got.len(), want.len(), "{got:?} vs {want:?}");
    for (g, w) in got.iter().zip(want) {
        assert!((g - w).abs() <= tol, "{got:?} vs {want:?}");
    }
}

/// Lowest and highest value of each motor's column.
fn ranges(f: &Flight) -> Vec<[f64; 2]> {
    f.samples
        .motor_us
        .as_ref()
        .unwrap()
        .iter()
        .map(|c| {
            c.iter()
                .fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], &v| {
                    [lo.min(v), hi.max(v)]
                })
        })
        .collect()
}

#[test]
fn arducopter33_rcou_of_a_quad_from_its_frame_message() {
    // APM:Copter 3.3: no FRAME_CLASS, the firmware's "Frame: QUAD" message; RCOU.Ch1–Ch4 in µs,
    // its motor range RC3_MIN–RC3_MAX 1000–1900 µs (the 3.x motors' range).
    let f = Flight::read(&real("dataflash/dronekit_log171_copter33_curr.bin")).unwrap();
    assert!(f.samples.is_consistent());
    let m = f.samples.motor_us.as_ref().unwrap();
    assert_eq!(m.len(), 4);
    assert_eq!(f.samples.len(), 2384);
    // RCOU interpolated at CURR's TimeMS (Python): on the ground, in flight, at the end.
    assert_eq!(commands(&f, at(&f, 50.684)), [1000.0; 4]);
    assert_close(
        &commands(&f, at(&f, 103.123)),
        &[1529.6667, 1419.3810, 1474.0476, 1361.3810],
        1e-3,
    );
    assert_close(
        &commands(&f, at(&f, 153.562)),
        &[1532.0, 1496.5, 1387.5, 1409.0],
        1e-3,
    );
    assert_eq!(
        commands(&f, f.samples.len() - 1),
        [1314.0, 1853.0, 1238.0, 1258.0]
    );
    let want = [
        [1000.0, 1691.1429],
        [1000.0, 1853.0],
        [1000.0, 1799.7619],
        [1000.0, 1808.5714],
    ];
    for (got, want) in ranges(&f).iter().zip(want) {
        assert_close(got, &want, 1e-3);
        // Within the log's RC3_MIN–RC3_MAX.
        assert!(got[0] >= 1000.0 && got[1] <= 1900.0, "{got:?}");
    }
    assert_eq!(
        f.log.motors.as_deref(),
        Some("RCOU.Ch1–Ch4 (frame quad from the log's \"Frame:\" message; motor k on output k)")
    );
}

#[test]
fn arducopter46_rcou_disarmed_at_mot_pwm_min() {
    // ArduCopter 4.6, FRAME_CLASS 1, SERVO1–4_FUNCTION 33–36 (Motor1–4): disarmed, each
    // output at MOT_PWM_MIN 1120 µs in every one of its four RCOU messages.
    let f = Flight::read(&real(
        "dataflash/methodicconfigurator_arducopter46_first80k.bin",
    ))
    .unwrap();
    let m = f.samples.motor_us.as_ref().unwrap();
    assert_eq!(m.len(), 4);
    for c in m {
        assert_eq!(c, &vec![1120.0; f.samples.len()]);
    }
    assert!(
        f.log
            .motors
            .as_deref()
            .is_some_and(|s| s.contains("FRAME_CLASS 1 (quad); outputs from SERVOn_FUNCTION")),
        "{:?}",
        f.log.motors
    );
}

#[test]
fn arduplane_rcou_is_not_read_as_motors() {
    // ArduPlane: its 14 outputs drive servos and a throttle, no frame names motors.
    let f = Flight::read(&real("dataflash/pymavlink_test_arduplane_first64k.BIN")).unwrap();
    assert!(f.samples.motor_us.is_none());
    assert!(
        f.warnings
            .iter()
            .any(|w| w
                .starts_with("RCOU not read as motor commands: the log names no multirotor frame")),
        "{:?}",
        f.warnings
    );
}

#[test]
fn px4_dshot_and_unpowered_outputs_are_refused_with_the_value() {
    // DShot on both flight-review quads (Python: output[0] is 109 in the first message;
    // outputs 0–4 reach at most 970 and 826 µs-equivalents), and the FMU-v3 crash log's
    // instance 0 reads 0 in every output throughout (MAV_TYPE 2: four motors asked for).
    for (file, value) in [
        ("ulog/flightreview_ekf_failure.ulg", "reads 109 at"),
        ("ulog/flightreview_gps_interference.ulg", "reads 109 at"),
        ("ulog/px4ulogrs_esc_status_log.ulg", "reads 0 at"),
    ] {
        let f = Flight::read(&real(file)).unwrap();
        assert!(f.samples.motor_us.is_none(), "{file}");
        assert!(
            f.warnings
                .iter()
                .any(|w| w.starts_with("actuator_outputs.output[0] ")
                    && w.contains(value)
                    && w.contains("outside 800–2200 µs")),
            "{file}: {:?}",
            f.warnings
        );
    }
    // A standard VTOL without CA_ROTOR_COUNT: its motors are not known.
    let f = Flight::read(&real("ulog/pyulog_sample_log_small.ulg")).unwrap();
    assert!(f.samples.motor_us.is_none());
    assert!(
        f.warnings.iter().any(|w| w
            == "actuator_outputs not read as motor commands: no CA_ROTOR_COUNT, and the vehicle type (MAV_TYPE 22) is not a quad-, hexa- or octorotor"),
        "{:?}",
        f.warnings
    );
}

#[test]
fn px4_quad_on_usb_power_has_its_motor_outputs_all_the_same() {
    // The flight is skipped (its battery is not connected), but its outputs are PWM: four
    // (CA_ROTOR_COUNT 4), at PWM_MAIN_DIS1–4 1000 µs disarmed and below PWM_MAIN_MAX1–4
    // 1900 µs. Python: 762 messages, per output highest 1611, 1635, 1639, 1684 µs; message 400
    // at 198.888187 s reads 1496, 1532, 1512, 1539 µs.
    let path = real("ulog/flightreview_battery_disconnected.ulg");
    assert!(matches!(
        Flight::read(&path),
        Err(FlightLogError::NoUsableBattery { .. })
    ));
    let bytes = std::fs::read(&path).unwrap();
    let log = ULog::parse(&bytes, &path).unwrap();
    let m = log
        .motor_commands(&path, Some((2, "MAV_TYPE")))
        .unwrap()
        .unwrap();
    assert_eq!(m.outputs.channels, [1, 2, 3, 4]);
    assert_eq!(m.outputs.origin, "CA_ROTOR_COUNT 4");
    assert_eq!(m.rows.len(), 762);
    assert!((m.time_s[400] - 198.888187).abs() < 1e-9);
    assert_eq!(
        m.rows[400],
        [Some(1496.0), Some(1532.0), Some(1512.0), Some(1539.0)]
    );
    for (k, want_max) in [1611.0, 1635.0, 1639.0, 1684.0].into_iter().enumerate() {
        let col: Vec<f64> = m.rows.iter().map(|r| r[k].unwrap()).collect();
        let lo = col.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = col.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        assert_eq!([lo, hi], [1000.0, want_max], "output {k}");
    }
    assert_eq!(
        m.source(),
        "actuator_outputs instance 0, output[0]–output[3] (CA_ROTOR_COUNT 4)"
    );
}

#[test]
fn mission_planner_tlog_servo_outputs_of_a_quad() {
    // ArduCopter quad (HEARTBEAT type 2; its parameters have FRAME, not FRAME_CLASS): the
    // SERVO_OUTPUT_RAW packets pass their checksum with CRC_EXTRA 222 (else none would be
    // read), servo1–4_raw interpolated at SYS_STATUS's times of reception (Python), within
    // RC3_MIN–RC3_MAX 968–2060 µs.
    let f = Flight::read(&common::data("tlog/dronekit+dronekit-python/flight.tlog")).unwrap();
    assert!(f.samples.is_consistent());
    assert_eq!(f.samples.len(), 2227);
    assert_eq!(commands(&f, 0), [968.0; 4]);
    assert_close(
        &commands(&f, 1000),
        &[1490.2249, 1529.6124, 1529.7751, 1585.1292],
        1e-3,
    );
    assert_close(
        &commands(&f, 2000),
        &[1559.6521, 1576.5256, 1411.4996, 1423.6580],
        1e-3,
    );
    let want = [
        [968.0, 1867.0683],
        [968.0, 1975.2529],
        [968.0, 1824.3914],
        [968.0, 1783.7342],
    ];
    for (got, want) in ranges(&f).iter().zip(want) {
        assert_close(got, &want, 1e-3);
        assert!(got[0] >= 968.0 && got[1] <= 2060.0, "{got:?}");
    }
    assert_eq!(
        f.log.motors.as_deref(),
        Some(
            "SERVO_OUTPUT_RAW.servo1_raw–servo4_raw (HEARTBEAT type 2, quadrotor; motor k on output k)"
        )
    );
}

#[test]
fn an_ardusub_tlog_has_no_motors_to_name() {
    let f = Flight::read(&common::data(
        "tlog/clydemcqueen+ardusub_log_tools/small.tlog",
    ))
    .unwrap();
    assert!(f.samples.motor_us.is_none());
    assert!(
        f.warnings
            .iter()
            .any(|w| w.starts_with("SERVO_OUTPUT_RAW not read as motor commands: no FRAME_CLASS")),
        "{:?}",
        f.warnings
    );
}

#[test]
fn csv_motor_columns_read_as_written() {
    let csv = "time_s,voltage_v,motor1_us,motor2_us,motor3_us,motor4_us\n\
               0,16.8,1000,1000,1000,1000\n0.5,16.7,1450.5,1460,1440,1455\n\
               1,16.6,1500,1510,1490,1505\n";
    let f = Flight::parse(
        csv.as_bytes(),
        Path::new("quad.csv"),
        flightlog::LogFormat::Csv,
    )
    .unwrap();
    let m = f.samples.motor_us.as_ref().unwrap();
    assert_eq!(m.len(), 4);
    assert_eq!(m[0], [1000.0, 1450.5, 1500.0]);
    assert_eq!(m[3], [1000.0, 1455.0, 1505.0]);
    assert!(f.warnings.is_empty(), "{:?}", f.warnings);
    let s = flightlog::FlightSummary::of(&f);
    let motors = s.motors.unwrap();
    assert_eq!(
        (motors.outputs, motors.range_us),
        (4, Some([1000.0, 1510.0]))
    );
    assert_eq!(motors.source, None);
}
