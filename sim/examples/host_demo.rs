//! Talks to a rig on a serial port or pty (e.g. one started by `hoverbench sim-rig`): identify,
//! tare, arm, step the throttle and print the samples.
//!
//! `cargo run -p sim --example host_demo -- /dev/pts/N [SPEED]` — pass the rig's `--speed` so
//! the host's keep-alives follow the rig clock.

use rig_protocol::{Client, ClientConfig, Rig};
use sim::pty::{HostPort, WallClock};
use std::time::{Duration, Instant};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args().nth(1).ok_or("usage: host_demo PORT")?;
    let speed: f64 = std::env::args().nth(2).map_or(Ok(1.0), |s| s.parse())?;
    let port = HostPort::open(path.as_ref(), Duration::from_millis(2))?;
    let clock = WallClock::scaled(speed);
    let mut rig = Client::connect(port, clock, ClientConfig::default())?;
    let run = |rig: &mut Client<HostPort, WallClock>| -> Result<(), rig_protocol::ClientError<std::io::Error>> {
        // (samples below: one second of rig time per throttle step)
        println!("{:?}", rig.identify()?);
        println!("tare offset {} counts", rig.tare(16)?);
        rig.start_stream(20)?;
        rig.arm()?;
        for throttle_us in [1300u16, 1500, 1000] {
            rig.set_throttle(throttle_us)?;
            let end = Instant::now() + Duration::from_secs_f64(1.0 / speed);
            while Instant::now() < end {
                if let Some(s) = rig.next_sample()? {
                    println!(
                        "t={:>9} µs  throttle={} µs  thrust={:7.2} g  {:6.3} A  {:6.3} V",
                        s.time_us, s.throttle_us, s.thrust_g, s.current_a, s.voltage_v
                    );
                }
            }
        }
        rig.disarm()?;
        println!("{:?}", rig.status()?);
        Ok(())
    };
    run(&mut rig)?;
    Ok(())
}
