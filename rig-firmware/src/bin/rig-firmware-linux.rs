//! The rig firmware on a Linux single-board computer (e.g. a Raspberry Pi): HX711 on two
//! sysfs GPIOs, INA226 on `/dev/i2c-N`, the ESC on a sysfs PWM channel, the host on a UART
//! (or a USB gadget serial port), and optionally `/dev/watchdog`.
//!
//! ```text
//! rig-firmware-linux --port /dev/serial0 --baud 115200 --i2c /dev/i2c-1 --ina226-addr 0x40 \
//!     --shunt-ohm 0.002 --max-current-a 20 --hx711-sck 5 --hx711-dout 6 \
//!     --pwm-chip 0 --pwm-channel 0 [--watchdog /dev/watchdog]
//! ```
//!
//! Build: `cargo build -p rig-firmware --features linux --bin rig-firmware-linux`
//! (cross: `--target aarch64-unknown-linux-gnu` or `armv7-unknown-linux-gnueabihf`).

use linux_embedded_hal::{Delay, I2cdev, SysfsPin};
use rig_firmware::drivers::esc::Esc;
use rig_firmware::drivers::hx711::{FixedRate, Gain, Hx711, Rate};
use rig_firmware::drivers::ina226::{DEFAULT_CONFIG, Ina226};
use rig_firmware::{Config, Firmware, Watchdog};
use rig_protocol::Clock;
use rustix::termios::{self, OptionalActions, SpecialCodeIndex};
use std::collections::HashMap;
use std::fs::{File, OpenOptions};
use std::io::{self, Read, Write};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Monotonic clock from `Instant`.
struct LinuxClock(Instant);

impl Clock for LinuxClock {
    fn now_us(&self) -> u64 {
        self.0.elapsed().as_micros() as u64
    }
}

/// `/dev/watchdog`: any write feeds it.
struct DevWatchdog(Option<File>);

impl Watchdog for DevWatchdog {
    fn feed(&mut self) {
        if let Some(f) = self.0.as_mut() {
            let _ = f.write_all(b"\0");
        }
    }
}

/// A sysfs PWM channel (`/sys/class/pwm/pwmchipN/pwmM`), duty in units of 100 ns.
struct SysfsPwm {
    dir: PathBuf,
    max_duty: u16,
}

#[derive(Debug)]
struct PwmError;

impl embedded_hal::pwm::Error for PwmError {
    fn kind(&self) -> embedded_hal::pwm::ErrorKind {
        embedded_hal::pwm::ErrorKind::Other
    }
}

impl SysfsPwm {
    fn open(chip: u32, channel: u32, period_us: u32) -> io::Result<Self> {
        let chip_dir = PathBuf::from(format!("/sys/class/pwm/pwmchip{chip}"));
        let dir = chip_dir.join(format!("pwm{channel}"));
        if !dir.exists() {
            std::fs::write(chip_dir.join("export"), channel.to_string())?;
        }
        std::fs::write(
            dir.join("period"),
            (u64::from(period_us) * 1000).to_string(),
        )?;
        std::fs::write(dir.join("enable"), "1")?;
        let max_duty = u16::try_from(period_us * 10).unwrap_or(u16::MAX);
        Ok(Self { dir, max_duty })
    }
}

impl embedded_hal::pwm::ErrorType for SysfsPwm {
    type Error = PwmError;
}

impl embedded_hal::pwm::SetDutyCycle for SysfsPwm {
    fn max_duty_cycle(&self) -> u16 {
        self.max_duty
    }
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), PwmError> {
        std::fs::write(
            self.dir.join("duty_cycle"),
            (u64::from(duty) * 100).to_string(),
        )
        .map_err(|_| PwmError)
    }
}

fn open_uart(path: &str, baud: u32) -> io::Result<File> {
    let f = OpenOptions::new().read(true).write(true).open(path)?;
    let mut t = termios::tcgetattr(&f)?;
    t.make_raw();
    t.set_speed(baud)?;
    t.special_codes[SpecialCodeIndex::VMIN] = 0;
    t.special_codes[SpecialCodeIndex::VTIME] = 0;
    termios::tcsetattr(&f, OptionalActions::Now, &t)?;
    Ok(f)
}

fn args() -> Result<HashMap<String, String>, String> {
    let mut map = HashMap::new();
    let mut it = std::env::args().skip(1);
    while let Some(k) = it.next() {
        let key = k
            .strip_prefix("--")
            .ok_or_else(|| format!("unexpected argument {k}"))?;
        let v = it.next().ok_or_else(|| format!("--{key} needs a value"))?;
        map.insert(key.to_string(), v);
    }
    Ok(map)
}

/// `--key` from the command line (or `default`); `0x` prefixes are hexadecimal.
fn get<T: std::str::FromStr>(
    a: &HashMap<String, String>,
    key: &str,
    default: &str,
) -> Result<T, String> {
    let v = a.get(key).map(String::as_str).unwrap_or(default);
    let decimal = match v.strip_prefix("0x") {
        Some(hex) => u64::from_str_radix(hex, 16).map(|n| n.to_string()).ok(),
        None => Some(v.to_string()),
    };
    decimal
        .and_then(|d| d.parse().ok())
        .ok_or_else(|| format!("bad value for --{key}: {v}"))
}

fn fail(what: &str) -> impl Fn(&dyn std::fmt::Debug) -> String + '_ {
    move |err| format!("{what}: {err:?}")
}

fn run() -> Result<(), String> {
    let a = args()?;
    let port: String = get(&a, "port", "/dev/serial0")?;
    let baud: u32 = get(&a, "baud", "115200")?;
    let mut uart = open_uart(&port, baud).map_err(|x| fail("UART")(&x))?;

    let sck = SysfsPin::new(get(&a, "hx711-sck", "5")?);
    let dout = SysfsPin::new(get(&a, "hx711-dout", "6")?);
    sck.export().map_err(|x| fail("export PD_SCK")(&x))?;
    dout.export().map_err(|x| fail("export DOUT")(&x))?;
    let sck = sck
        .into_output_pin(embedded_hal::digital::PinState::Low)
        .map_err(|x| fail("PD_SCK")(&x))?;
    let dout = dout.into_input_pin().map_err(|x| fail("DOUT")(&x))?;
    let mut adc = Hx711::new(sck, dout, FixedRate, Delay);
    adc.init(Gain::A128, Rate::Sps80)
        .map_err(|x| fail("HX711")(&x))?;

    let i2c_path: String = get(&a, "i2c", "/dev/i2c-1")?;
    let i2c = I2cdev::new(&i2c_path).map_err(|x| fail("I2C")(&x))?;
    let mut ina = Ina226::new(
        i2c,
        get(&a, "ina226-addr", "0x40")?,
        get(&a, "shunt-ohm", "0.002")?,
        get(&a, "max-current-a", "20")?,
    )
    .map_err(|x| fail("INA226")(&x))?;
    ina.init(DEFAULT_CONFIG).map_err(|x| fail("INA226")(&x))?;

    let pwm = SysfsPwm::open(
        get(&a, "pwm-chip", "0")?,
        get(&a, "pwm-channel", "0")?,
        2500,
    )
    .map_err(|x| fail("PWM")(&x))?;
    let esc = Esc::new(pwm, 2500, 1000, 2000).map_err(|x| fail("ESC")(&x))?;

    let watchdog = match a.get("watchdog") {
        Some(p) => DevWatchdog(Some(
            OpenOptions::new()
                .write(true)
                .open(p)
                .map_err(|x| fail("watchdog")(&x))?,
        )),
        None => DevWatchdog(None),
    };
    let cfg = Config {
        board: 1,
        serial_number: get(&a, "serial", "1")?,
        max_current_a: get(&a, "max-current-a", "20")?,
        max_thrust_g: get(&a, "max-thrust-g", "2000")?,
        min_voltage_v: get(&a, "min-voltage-v", "6")?,
        max_voltage_v: get(&a, "max-voltage-v", "26")?,
        ..Config::default()
    };
    let mut fw = Firmware::new(adc, ina, esc, LinuxClock(Instant::now()), watchdog, cfg);
    let mut buf = [0u8; 256];
    let mut out = Vec::with_capacity(1024);
    loop {
        let n = uart.read(&mut buf).unwrap_or(0);
        fw.receive(&buf[..n], &mut |b: &[u8]| out.extend_from_slice(b));
        fw.tick(&mut |b: &[u8]| out.extend_from_slice(b));
        if !out.is_empty() {
            uart.write_all(&out).map_err(|x| fail("UART write")(&x))?;
            out.clear();
        }
        std::thread::sleep(Duration::from_micros(250));
    }
}

fn main() {
    if let Err(msg) = run() {
        eprintln!("rig-firmware-linux: {msg}");
        std::process::exit(1);
    }
}
