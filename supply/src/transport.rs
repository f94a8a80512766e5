//! Byte transports the drivers talk through, and opening a serial port.

use std::io::{self, Read, Write};
use std::time::Duration;

use serialport::{ClearBuffer, SerialPort};

use crate::error::SupplyError;

/// A bidirectional byte stream with a read timeout: a serial port, a pseudo-terminal, or an
/// in-memory link to a simulated supply ([`crate::sim::InProcessTransport`]).
///
/// `read` waits at most the timeout last set for at least one byte, and then returns the bytes
/// that have arrived; when none did it returns `Err` of kind [`io::ErrorKind::TimedOut`] or
/// [`io::ErrorKind::WouldBlock`], or `Ok(0)` — the drivers treat all three as "nothing yet"
/// and keep their own deadline. Any other error is a broken transport.
pub trait Transport: Read + Write {
    /// Sets how long one `read` may wait for the first byte.
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()>;
    /// Discards whatever has been received and not read (a stale or late reply), so that the
    /// next reply read belongs to the next command.
    fn discard_input(&mut self) -> io::Result<()>;
}

impl<T: Transport + ?Sized> Transport for &mut T {
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        (**self).set_read_timeout(timeout)
    }
    fn discard_input(&mut self) -> io::Result<()> {
        (**self).discard_input()
    }
}

impl Transport for Box<dyn SerialPort> {
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        self.set_timeout(timeout).map_err(io::Error::from)
    }
    fn discard_input(&mut self) -> io::Result<()> {
        self.clear(ClearBuffer::Input).map_err(io::Error::from)
    }
}

#[cfg(unix)]
impl Transport for serialport::TTYPort {
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        self.set_timeout(timeout).map_err(io::Error::from)
    }
    fn discard_input(&mut self) -> io::Result<()> {
        self.clear(ClearBuffer::Input).map_err(io::Error::from)
    }
}

/// Serial line settings for [`open_serial`]: 8 data bits, no parity, one stop bit, no flow
/// control — what both dialects use — at `baud_rate`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SerialSettings {
    /// Baud rate (KA3005P: 9600; Rigol DP800 over USB-serial: 9600 by default).
    pub baud_rate: u32,
}

impl Default for SerialSettings {
    fn default() -> Self {
        Self { baud_rate: 9600 }
    }
}

/// Opens a serial port (a USB-serial adapter, a USB CDC device, or the slave side of a
/// pseudo-terminal such as [`crate::sim::SimulatedSupply::port_path`]) for a driver.
pub fn open_serial(
    path: &str,
    settings: SerialSettings,
) -> Result<Box<dyn SerialPort>, SupplyError> {
    serialport::new(path, settings.baud_rate)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(serialport::FlowControl::None)
        .timeout(Duration::from_millis(10))
        .open()
        .map_err(|source| SupplyError::Open {
            path: path.to_owned(),
            source,
        })
}
