//! Serial links: the rig's byte transport over a serial port (or a pseudo-terminal), a scaled
//! host clock, and the list of serial ports with their USB ids.

use std::io::{self, Read, Write};
use std::time::{Duration, Instant};

use rig_protocol::{Clock, Transport};
use serialport::{SerialPort, SerialPortType};

use crate::error::HostError;

/// Baud rate of the rig link (a USB CDC device ignores it; a UART bridge needs it).
pub const RIG_BAUD: u32 = 921_600;

/// The rig's byte transport over a serial port: [`rig_protocol::Transport`] for
/// [`rig_protocol::Client`]. Reads wait briefly (the port's timeout) and return `Ok(0)` when
/// nothing arrived; any other error means the port is gone.
pub struct SerialLink {
    port: Box<dyn SerialPort>,
    path: String,
}

impl std::fmt::Debug for SerialLink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SerialLink")
            .field("path", &self.path)
            .finish()
    }
}

impl SerialLink {
    /// Opens `path` (8N1, no flow control) with reads waiting up to `read_timeout`.
    pub fn open(path: &str, read_timeout: Duration) -> Result<Self, HostError> {
        let builder = serialport::new(path, RIG_BAUD)
            .data_bits(serialport::DataBits::Eight)
            .parity(serialport::Parity::None)
            .stop_bits(serialport::StopBits::One)
            .flow_control(serialport::FlowControl::None)
            .timeout(read_timeout);
        let err = |source| HostError::Port {
            path: path.to_owned(),
            source,
        };
        #[cfg(unix)]
        let port: Box<dyn SerialPort> = {
            let mut p = builder.open_native().map_err(err)?;
            // A pseudo-terminal stays open on the simulator's side between two host sessions
            // (a killed host, then `--resume`): do not lock it against the next one.
            if path.starts_with("/dev/pts/") {
                p.set_exclusive(false).map_err(err)?;
            }
            Box::new(p)
        };
        #[cfg(not(unix))]
        let port = builder.open().map_err(err)?;
        Ok(Self {
            port,
            path: path.to_owned(),
        })
    }

    /// Drops whatever has arrived and not been read (waits for a quiet 20 ms, at most 1 s).
    pub fn discard_input(&mut self) {
        let _ = self.port.clear(serialport::ClearBuffer::Input);
        let mut buf = [0u8; 4096];
        let end = Instant::now() + Duration::from_secs(1);
        let mut quiet_since = Instant::now();
        while Instant::now() < end && quiet_since.elapsed() < Duration::from_millis(20) {
            match Transport::read(self, &mut buf) {
                Ok(0) => {}
                Ok(_) => quiet_since = Instant::now(),
                Err(_) => return,
            }
        }
    }

    /// The port path.
    pub fn path(&self) -> &str {
        &self.path
    }
}

/// Whether a port error only means "nothing yet" (no room to write, no byte to read within
/// the port's timeout, a signal): the caller tries again.
fn no_data_yet(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut | io::ErrorKind::Interrupted
    )
}

impl Transport for SerialLink {
    type Error = io::Error;

    fn write_all(&mut self, bytes: &[u8]) -> Result<(), io::Error> {
        let deadline = Instant::now() + Duration::from_secs(2);
        let mut rest = bytes;
        while !rest.is_empty() {
            match self.port.write(rest) {
                Ok(0) => {}
                Ok(n) => rest = &rest[n..],
                Err(e) if no_data_yet(&e) => {}
                Err(e) => return Err(e),
            }
            if !rest.is_empty() && Instant::now() > deadline {
                return Err(io::Error::new(
                    io::ErrorKind::TimedOut,
                    "serial write stalled",
                ));
            }
        }
        Ok(())
    }

    fn read(&mut self, buf: &mut [u8]) -> Result<usize, io::Error> {
        match self.port.read(buf) {
            Ok(n) => Ok(n),
            Err(e) if no_data_yet(&e) => Ok(0),
            Err(e) => Err(e),
        }
    }
}

/// The host's monotonic clock scaled to the rig's time: a simulated rig running at `speed` ×
/// real time keeps its 250 ms watchdog in rig time, so the host waits, times out and sends
/// keep-alives in rig time too (`speed = 1` for hardware).
#[derive(Debug, Clone, Copy)]
pub struct ScaledClock {
    start: Instant,
    speed: f64,
}

impl ScaledClock {
    /// A clock running `speed` × real time (non-positive or non-finite: real time).
    pub fn new(speed: f64) -> Self {
        Self {
            start: Instant::now(),
            speed: if speed.is_finite() && speed > 0.0 {
                speed
            } else {
                1.0
            },
        }
    }

    /// The scale factor.
    pub fn speed(&self) -> f64 {
        self.speed
    }
}

impl Clock for ScaledClock {
    fn now_us(&self) -> u64 {
        (self.start.elapsed().as_secs_f64() * 1e6 * self.speed) as u64
    }
}

/// A serial port found on this machine.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct PortInfo {
    /// Its path (`/dev/ttyACM0`, `COM3`).
    pub path: String,
    /// `usb`, `pci`, `bluetooth` or `unknown`.
    pub kind: &'static str,
    /// USB vendor id.
    pub vid: Option<u16>,
    /// USB product id.
    pub pid: Option<u16>,
    /// USB serial number.
    pub serial_number: Option<String>,
    /// USB manufacturer.
    pub manufacturer: Option<String>,
    /// USB product name.
    pub product: Option<String>,
}

/// The serial ports of this machine with their USB ids (no libudev: what the OS reports
/// without it).
pub fn list_ports() -> Result<Vec<PortInfo>, HostError> {
    let ports = serialport::available_ports().map_err(|source| HostError::Port {
        path: String::new(),
        source,
    })?;
    let mut out: Vec<PortInfo> = ports
        .into_iter()
        .map(|p| {
            let mut info = PortInfo {
                path: p.port_name,
                kind: "unknown",
                vid: None,
                pid: None,
                serial_number: None,
                manufacturer: None,
                product: None,
            };
            match p.port_type {
                SerialPortType::UsbPort(u) => {
                    info.kind = "usb";
                    info.vid = Some(u.vid);
                    info.pid = Some(u.pid);
                    info.serial_number = u.serial_number;
                    info.manufacturer = u.manufacturer;
                    info.product = u.product;
                }
                SerialPortType::PciPort => info.kind = "pci",
                SerialPortType::BluetoothPort => info.kind = "bluetooth",
                SerialPortType::Unknown => {}
            }
            info
        })
        .collect();
    out.sort_by(|a, b| a.path.cmp(&b.path));
    Ok(out)
}

/// A protocol client on a serial link, waiting in rig time.
pub type RigClient = rig_protocol::Client<SerialLink, ScaledClock>;

/// Opens the rig at `path`, whose clock runs `speed` × real time (1 for hardware, the
/// simulator's `--speed` otherwise), and completes the protocol handshake.
pub fn connect_rig(path: &str, speed: f64) -> Result<RigClient, HostError> {
    let mut link = SerialLink::open(path, Duration::from_millis(1))?;
    // Bytes a previous host left unread (samples, fault reports) are stale.
    link.discard_input();
    let clock = ScaledClock::new(speed);
    // A simulator faster than real time can be starved of CPU and slip behind the host's
    // scaled clock: give it more (rig) time to answer. Keep-alives stay as they are (the
    // rig's watchdog is in rig time, and a slipping rig only sees them more often).
    let defaults = rig_protocol::ClientConfig::default();
    let config = rig_protocol::ClientConfig {
        response_timeout_us: (defaults.response_timeout_us as f64 * clock.speed().max(1.0)) as u64,
        retries: defaults.retries.max(4),
        ..defaults
    };
    rig_protocol::Client::connect(link, clock, config).map_err(|e| HostError::Handshake {
        path: path.to_owned(),
        source: Box::new(e),
    })
}
