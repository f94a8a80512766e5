//! Motor commands: the ESC outputs a flight controller logs, PWM µs, one series per motor
//! ([`crate::Samples::motor_us`]), so that a rig-measured map can give the rotors' electrical
//! power of a flight logged without a current sensor.
//!
//! What each format gives:
//!
//! - the flight CSV ([`crate::csvlog`]): `motor1_us`, `motor2_us`, … (consecutive from 1, at
//!   most [`MAX_MOTORS`]), as written;
//! - PX4 ULog ([`crate::ulog`]): `actuator_outputs` instance 0, `output[0]`…`output[N−1]`, N
//!   from `CA_ROTOR_COUNT`, else from the vehicle type (`MAV_TYPE`, else
//!   `vehicle_status.system_type`: quadrotor 4, hexarotor 6, octorotor 8);
//! - ArduPilot DataFlash ([`crate::dataflash`]): `RCOU` `C1`…`C14` (ArduCopter 3.x: `Ch1`…),
//!   the motors of the frame ([`ardupilot_motor_numbers`]: `FRAME_CLASS`, else the frame the
//!   firmware names in its `Frame: QUAD` message) on the outputs the log's `SERVOn_FUNCTION`
//!   parameters give `Motor1`…`MotorN` (33–40, 82–85), else motor k on output k;
//! - a MAVLink telemetry log ([`crate::tlog`]): `SERVO_OUTPUT_RAW` of port 0 (`servo1_raw`…,
//!   `servo9_raw`… when the packet carries its extension), the motors as for DataFlash from
//!   `PARAM_VALUE`s (`FRAME_CLASS`, `SERVOn_FUNCTION`; a PX4's `CA_ROTOR_COUNT`), else from
//!   the `HEARTBEAT`'s vehicle type as for ULog.
//!
//! A binary log's commands are used only when every one of them that the flight's samples
//! draw on (those within the battery's span and the one just before and after it) is a PWM
//! pulse width, within [`PWM_RANGE_US`]: a DShot value, a disarmed 0 or a NaN makes the
//! flight's `motor_us` `None`, with a warning that names the output and the value; so does a
//! motor count the log does not give. Nothing is guessed.
//!
//! Alignment: the crate's one rule for a topic logged at its own times (as `altitude_m` and
//! `throttle`): linear interpolation onto the battery's times between the two commands around
//! each battery sample, the first (last) command held before (after) them. A battery sample
//! in a stretch without commands gets the interpolation across it; no value is NaN.

use std::collections::HashMap;
use std::ops::RangeInclusive;

/// Most motors read (the CSV's `motor16_us`; MAVLink's `servo16_raw`).
pub const MAX_MOTORS: usize = 16;

/// Pulse widths read as a PWM motor command, µs: a value outside (DShot's 0–2047 steps, 0 or
/// NaN while disarmed) means the outputs are not PWM.
pub const PWM_RANGE_US: RangeInclusive<f64> = 800.0..=2200.0;

/// The outputs that drive a vehicle's motors, and how that is known.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MotorOutputs {
    /// 1-based output channels, motor 1 first.
    pub channels: Vec<usize>,
    /// How the motors and their outputs are known (`CA_ROTOR_COUNT 4`,
    /// `FRAME_CLASS 1 (quad)`).
    pub origin: String,
}

/// The motors (ArduPilot's `Motor1`…, 1-based) of an ArduPilot frame, by the name
/// `FRAME_CLASS` has in the firmware or the older firmware's `Frame:` message writes (`quad`,
/// `octa_quad`, any case): quad 1–4, hexa and Y6 1–6, octa and octaquad 1–8, tri 1, 2 and 4
/// (its yaw servo on output 7), deca 1–10, dodecahexa 1–12. `None` for a frame whose rotors are
/// not a set of motors on the motor outputs (helicopters; single, coaxial and bicopter frames
/// drive servos beside their motors) or a name not known.
pub fn ardupilot_motor_numbers(frame: &str) -> Option<Vec<usize>> {
    let name: String = frame
        .chars()
        .filter(|c| c.is_ascii_alphanumeric())
        .collect::<String>()
        .to_ascii_lowercase();
    let n = match name.as_str() {
        "quad" => 4,
        "hexa" | "y6" => 6,
        "octa" | "octaquad" => 8,
        "deca" => 10,
        "dodecahexa" => 12,
        "tri" => return Some(vec![1, 2, 4]),
        _ => return None,
    };
    Some((1..=n).collect())
}

/// ArduPilot's `SERVOn_FUNCTION` value of motor `m` (1-based): `Motor1`…`Motor8` are 33–40,
/// `Motor9`…`Motor12` 82–85.
fn servo_function(m: usize) -> Option<f64> {
    match m {
        1..=8 => Some(32.0 + m as f64),
        9..=12 => Some(73.0 + m as f64),
        _ => None,
    }
}

/// ArduPilot's motor outputs: the motors of `frame` (with how it is known, `origin`), each on
/// the output whose `SERVOn_FUNCTION` names it when the log has those parameters, else motor k
/// on output k (firmware before `SERVOn_FUNCTION`). `Err` says why not.
pub(crate) fn ardupilot_outputs(
    params: &HashMap<String, f64>,
    frame: &str,
    origin: &str,
) -> Result<MotorOutputs, String> {
    let motors = ardupilot_motor_numbers(frame).ok_or_else(|| {
        format!("the frame {frame:?} ({origin}) is not one of motors on the motor outputs")
    })?;
    let assigned = (1..=32).any(|n| params.contains_key(&format!("SERVO{n}_FUNCTION")));
    if !assigned {
        return Ok(MotorOutputs {
            channels: motors,
            origin: format!("{origin}; motor k on output k"),
        });
    }
    let mut channels = Vec::with_capacity(motors.len());
    for &m in &motors {
        let function = servo_function(m).unwrap_or(f64::NAN);
        let channel = (1..=32)
            .find(|n| params.get(&format!("SERVO{n}_FUNCTION")) == Some(&function))
            .ok_or_else(|| {
                format!(
                    "no SERVOn_FUNCTION is Motor{m} ({function}) for the frame {frame:?} ({origin})"
                )
            })?;
        channels.push(channel);
    }
    Ok(MotorOutputs {
        channels,
        origin: format!("{origin}; outputs from SERVOn_FUNCTION"),
    })
}

/// The rotor count of a MAVLink vehicle type (`MAV_TYPE`): quadrotor 4, hexarotor 6,
/// octorotor 8; `None` for any other type.
pub fn rotors_of_mav_type(mav_type: u32) -> Option<usize> {
    match mav_type {
        2 => Some(4),
        13 => Some(6),
        14 => Some(8),
        _ => None,
    }
}

/// A PX4 vehicle's motors: `CA_ROTOR_COUNT` (1–16), else the vehicle type's rotors
/// ([`rotors_of_mav_type`]), on the first outputs. `mav_type` is the type with where it came
/// from. `Err` says why not.
pub(crate) fn px4_outputs(
    params: &HashMap<String, f64>,
    mav_type: Option<(u32, &str)>,
) -> Result<MotorOutputs, String> {
    if let Some(&n) = params.get("CA_ROTOR_COUNT") {
        if n >= 1.0 && n <= MAX_MOTORS as f64 && n.fract() == 0.0 {
            return Ok(MotorOutputs {
                channels: (1..=n as usize).collect(),
                origin: format!("CA_ROTOR_COUNT {n}"),
            });
        }
        return Err(format!(
            "CA_ROTOR_COUNT is {n}, not a rotor count of 1–{MAX_MOTORS}"
        ));
    }
    match mav_type {
        Some((t, from)) => match rotors_of_mav_type(t) {
            Some(n) => Ok(MotorOutputs {
                channels: (1..=n).collect(),
                origin: format!("{from} {t}, {n} rotors"),
            }),
            None => Err(format!(
                "no CA_ROTOR_COUNT, and the vehicle type ({from} {t}) is not a quad-, hexa- or octorotor"
            )),
        },
        None => Err("no CA_ROTOR_COUNT and no vehicle type".to_owned()),
    }
}

/// Puts the motor commands of messages logged at their own times onto the battery's times
/// `at` (see the module's alignment rule). `time_s[i]` is message `i`'s time on the battery's
/// clock, `rows[i][m]` its command for motor `m` (`None`: the message does not carry it);
/// `name(m)` names motor `m`'s field in a warning. `Err` is the warning: a command outside
/// [`PWM_RANGE_US`] among those the samples draw on, or a motor without any.
pub(crate) fn align(
    time_s: &[f64],
    rows: &[Vec<Option<f64>>],
    motors: usize,
    at: &[f64],
    name: &dyn Fn(usize) -> String,
) -> Result<Vec<Vec<f64>>, String> {
    let (Some(&lo), Some(&hi)) = (at.first(), at.last()) else {
        return Err("no battery samples to put motor commands on".to_owned());
    };
    // The messages within the battery's span and the one just before and after it.
    let finite = || time_s.iter().copied().filter(|t| t.is_finite());
    let before = finite()
        .filter(|&t| t < lo)
        .fold(f64::NEG_INFINITY, f64::max);
    let after = finite().filter(|&t| t > hi).fold(f64::INFINITY, f64::min);
    let used = |t: f64| (lo..=hi).contains(&t) || t == before || t == after;
    let mut out = Vec::with_capacity(motors);
    for m in 0..motors {
        let (mut t, mut v) = (Vec::new(), Vec::new());
        for (&ti, row) in time_s.iter().zip(rows) {
            let Some(x) = row.get(m).copied().flatten() else {
                continue;
            };
            if !used(ti) {
                continue;
            }
            if !PWM_RANGE_US.contains(&x) {
                return Err(format!(
                    "{} reads {x} at {:.3} s, outside {}–{} µs (not a PWM pulse: DShot, or 0 or NaN while disarmed): no motor commands read",
                    name(m),
                    ti,
                    PWM_RANGE_US.start(),
                    PWM_RANGE_US.end()
                ));
            }
            t.push(ti);
            v.push(x);
        }
        let column = crate::resample::linear(&t, &v, at).ok_or_else(|| {
            format!(
                "{} has no value during the flight: no motor commands read",
                name(m)
            )
        })?;
        out.push(column);
    }
    Ok(out)
}

/// Motor commands on a flight's times (one column per motor, µs) and where they were read.
pub(crate) type Read = (Vec<Vec<f64>>, String);

/// Lowest and highest command over every motor, µs (`None` without any).
pub fn range_us(motor_us: &[Vec<f64>]) -> Option<[f64; 2]> {
    let mut it = motor_us.iter().flatten().copied();
    let first = it.next()?;
    Some(it.fold([first, first], |[lo, hi], v| [lo.min(v), hi.max(v)]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_name_their_motors() {
        assert_eq!(ardupilot_motor_numbers("QUAD"), Some(vec![1, 2, 3, 4]));
        assert_eq!(
            ardupilot_motor_numbers("octa_quad").map(|m| m.len()),
            Some(8)
        );
        assert_eq!(ardupilot_motor_numbers("y6").map(|m| m.len()), Some(6));
        assert_eq!(ardupilot_motor_numbers("tri"), Some(vec![1, 2, 4]));
        assert_eq!(
            ardupilot_motor_numbers("dodecahexa").map(|m| m.len()),
            Some(12)
        );
        for f in [
            "heli",
            "singlecopter",
            "coaxcopter",
            "bicopter",
            "heli_quad",
            "",
        ] {
            assert_eq!(ardupilot_motor_numbers(f), None, "{f}");
        }
    }

    #[test]
    fn servo_functions_place_the_motors() {
        let mut p: HashMap<String, f64> = HashMap::new();
        let o = ardupilot_outputs(&p, "quad", "FRAME_CLASS 1").unwrap();
        assert_eq!(o.channels, [1, 2, 3, 4]);
        // Motors moved to outputs 5–8, output 1–4 for servos.
        for (n, f) in [
            (1, 4.0),
            (2, 19.0),
            (5, 33.0),
            (6, 34.0),
            (7, 35.0),
            (8, 36.0),
        ] {
            p.insert(format!("SERVO{n}_FUNCTION"), f);
        }
        let o = ardupilot_outputs(&p, "quad", "FRAME_CLASS 1").unwrap();
        assert_eq!(o.channels, [5, 6, 7, 8]);
        let e = ardupilot_outputs(&p, "hexa", "FRAME_CLASS 2").unwrap_err();
        assert!(e.contains("Motor5 (37)"), "{e}");
        assert!(ardupilot_outputs(&p, "heli", "FRAME_CLASS 6").is_err());
    }

    #[test]
    fn px4_counts_rotors_from_its_parameters_else_its_type() {
        let mut p = HashMap::new();
        let o = px4_outputs(&p, Some((13, "MAV_TYPE"))).unwrap();
        assert_eq!(o.channels, [1, 2, 3, 4, 5, 6]);
        assert!(px4_outputs(&p, Some((22, "MAV_TYPE"))).is_err());
        assert!(px4_outputs(&p, None).is_err());
        p.insert("CA_ROTOR_COUNT".to_owned(), 3.0);
        assert_eq!(
            px4_outputs(&p, Some((2, "MAV_TYPE"))).unwrap().channels,
            [1, 2, 3]
        );
        p.insert("CA_ROTOR_COUNT".to_owned(), 0.0);
        assert!(px4_outputs(&p, Some((2, "MAV_TYPE"))).is_err());
    }

    #[test]
    fn alignment_interpolates_holds_and_refuses_what_is_not_pwm() {
        let name = |m: usize| format!("out{m}");
        let t = [0.0, 1.0, 2.0, 10.0];
        let rows = [
            vec![Some(1000.0), Some(1100.0)],
            vec![Some(1200.0), None],
            vec![Some(1400.0), Some(1300.0)],
            // Beyond the one message after the flight: not drawn on, not checked.
            vec![Some(0.0), Some(0.0)],
        ];
        let at = [-1.0, 0.5, 1.5, 1.9];
        let m = align(&t, &rows[..], 2, &at, &name).unwrap();
        assert_eq!(m[0], [1000.0, 1100.0, 1300.0, 1380.0]);
        // Motor 2 lacks message 1: interpolated across the gap.
        assert_eq!(m[1], [1100.0, 1150.0, 1250.0, 1290.0]);
        // Only the message just after the flight is checked: the 0 at 10 s is not for a
        // flight that ends at 1 s, and refuses the outputs of one that ends at 2.5 s.
        let m1 = align(&t, &rows[..], 2, &[0.0, 1.0], &name).unwrap();
        assert_eq!(m1[1], [1100.0, 1200.0]);
        let e = align(&t, &rows[..], 2, &[0.0, 2.5], &name).unwrap_err();
        assert!(e.starts_with("out0 reads 0 at 10.000 s"), "{e}");
        let nan = vec![vec![Some(f64::NAN)], vec![Some(1500.0)]];
        let e = align(&[0.0, 1.0], &nan, 1, &[0.0, 1.0], &name).unwrap_err();
        assert!(e.contains("reads NaN"), "{e}");
        let none = vec![vec![None], vec![None]];
        let e = align(&[0.0, 1.0], &none, 1, &[0.0, 1.0], &name).unwrap_err();
        assert!(e.contains("no value during the flight"), "{e}");
        assert_eq!(range_us(&m), Some([1000.0, 1380.0]));
    }
}
