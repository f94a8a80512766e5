//! The comment block that opens a sweep log: the sweep, the rig, its calibration, the
//! supply and the settings ([`sweep_header`]).

use rig_protocol::Identity;

use crate::config::SweepConfig;
use crate::log::LogHeader;
use crate::settle::SettlePolicy;

/// The comment block of a sweep log.
pub fn sweep_header(
    config: &SweepConfig,
    identity: &Identity,
    calibration_points: u8,
    calibration: &str,
    supply_identity: &str,
) -> LogHeader {
    let mut h = LogHeader::default();
    h.push("hoverbench", "sweep log");
    h.push("sweep", config.kind.describe());
    let fw = identity.firmware_version;
    h.push(
        "rig",
        format!(
            "serial 0x{:08x}, board {}, firmware {}.{}.{}, protocol {}, throttle {}-{} us",
            identity.serial_number,
            identity.board,
            fw[0],
            fw[1],
            fw[2],
            identity.protocol_version,
            identity.throttle_min_us,
            identity.throttle_max_us
        ),
    );
    h.push("calibration_points", calibration_points.to_string());
    h.push("calibration", calibration);
    h.push("supply", supply_identity);
    h.push("supply_voltage_v", format!("{}", config.voltage_v));
    h.push("current_limit_a", format!("{}", config.current_limit_a));
    let settle = match config.settle {
        SettlePolicy::Adaptive(a) => format!(
            "adaptive: window {} s, >= {} samples, |slope| <= {} se or drift <= {} of mean",
            a.window_s, a.min_samples, a.z, a.relative_floor
        ),
        SettlePolicy::FixedDwell { dwell_s, samples } => {
            format!("fixed dwell {dwell_s} s, then {samples} samples")
        }
    };
    h.push("settle", settle);
    h.push("tolerance_g", format!("{}", config.tolerance_g));
    h.push("stream_rate_hz", config.stream_rate_hz.to_string());
    h.push(
        "tool",
        format!("hoverbench rig-host {}", env!("CARGO_PKG_VERSION")),
    );
    h.push(
        "started",
        humantime::format_rfc3339_seconds(std::time::SystemTime::now()).to_string(),
    );
    h
}
