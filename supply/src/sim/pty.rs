//! Serving a simulated supply on a pseudo-terminal.

use std::fs::File;
use std::io::{self, ErrorKind, Read, Write};
use std::os::fd::OwnedFd;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use rustix::event::{PollFd, PollFlags, Timespec, poll};
use rustix::fs::{Mode, OFlags};
use rustix::pty::{OpenptFlags, grantpt, openpt, ptsname, unlockpt};
use rustix::termios::{OptionalActions, tcgetattr, tcsetattr};
use serialport::SerialPort;

use super::engine::Engine;
use super::{Device, Dialect, Load, SimConfig};
use crate::error::SupplyError;
use crate::transport::{SerialSettings, open_serial};

/// Longest the server sleeps before it looks at the stop flag again.
const IDLE: Duration = Duration::from_millis(20);
/// Longest the server waits for room to write a reply before dropping it.
const WRITE_WAIT: Duration = Duration::from_millis(200);

/// A simulated supply served on a pseudo-terminal by a background thread.
///
/// The thread owns the master side; the slave path ([`SimulatedSupply::port_path`], such as
/// `/dev/pts/3`) is a terminal that any serial program can open. The simulator also keeps the
/// slave open itself (in raw mode), so the terminal outlives a driver that closes and reopens
/// it. Dropping the handle stops the thread (within some 20 ms) and closes the terminal.
///
/// ```
/// use supply::sim::{Dialect, ResistiveLoad, SimConfig, SimulatedSupply};
/// use supply::{KoradConfig, KoradSupply, SerialSettings, Supply};
///
/// let sim = SimulatedSupply::spawn(Dialect::Korad, ResistiveLoad { resistance_ohm: 10.0 },
///                                  SimConfig::default())?;
/// let mut psu = KoradSupply::open(sim.port_path(), SerialSettings::default(),
///                                 KoradConfig::default())?;
/// psu.apply(12.0, 2.0)?;
/// psu.set_output(true)?;
/// let m = psu.measure()?;
/// assert_eq!((m.voltage_v, m.current_a), (12.0, 1.2));
/// assert!(sim.device().settings().output_on);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct SimulatedSupply {
    device: Device,
    path: String,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    _slave: OwnedFd,
}

impl SimulatedSupply {
    /// Opens a pseudo-terminal and serves a new [`Device`] speaking `dialect` on it.
    pub fn spawn(
        dialect: Dialect,
        load: impl Load + 'static,
        config: SimConfig,
    ) -> io::Result<Self> {
        Self::serve(Device::new(dialect, load, config))
    }

    /// Serves an existing device on a new pseudo-terminal.
    pub fn serve(device: Device) -> io::Result<Self> {
        let master = openpt(OpenptFlags::RDWR | OpenptFlags::NOCTTY | OpenptFlags::CLOEXEC)?;
        grantpt(&master)?;
        unlockpt(&master)?;
        let path = ptsname(&master, Vec::new())?
            .into_string()
            .map_err(|_| io::Error::new(ErrorKind::InvalidData, "pty path is not UTF-8"))?;
        let slave = rustix::fs::open(
            path.as_str(),
            OFlags::RDWR | OFlags::NOCTTY | OFlags::CLOEXEC,
            Mode::empty(),
        )?;
        let mut termios = tcgetattr(&slave)?;
        termios.make_raw();
        tcsetattr(&slave, OptionalActions::Now, &termios)?;
        let flags = rustix::fs::fcntl_getfl(&master)?;
        rustix::fs::fcntl_setfl(&master, flags | OFlags::NONBLOCK)?;

        let stop = Arc::new(AtomicBool::new(false));
        let engine = Engine::new(device.clone());
        let thread = {
            let stop = Arc::clone(&stop);
            thread::Builder::new()
                .name(format!("sim-supply {path}"))
                .spawn(move || serve(File::from(master), engine, &stop))?
        };
        Ok(Self {
            device,
            path,
            stop,
            thread: Some(thread),
            _slave: slave,
        })
    }

    /// The terminal to open, as a serial port path.
    pub fn port_path(&self) -> &str {
        &self.path
    }

    /// The simulated instrument (settings, load, faults, counters).
    pub fn device(&self) -> &Device {
        &self.device
    }

    /// Opens [`SimulatedSupply::port_path`] with `serialport` (default settings).
    pub fn open_port(&self) -> Result<Box<dyn SerialPort>, SupplyError> {
        open_serial(&self.path, SerialSettings::default())
    }
}

impl Drop for SimulatedSupply {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            // The server never panics; if it did, there is nothing more to clean up.
            let _ = t.join();
        }
    }
}

impl std::fmt::Debug for SimulatedSupply {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimulatedSupply")
            .field("path", &self.path)
            .field("device", &self.device)
            .finish_non_exhaustive()
    }
}

fn timespec(d: Duration) -> Timespec {
    Timespec {
        tv_sec: d.as_secs().try_into().unwrap_or(i64::MAX),
        tv_nsec: d.subsec_nanos().into(),
    }
}

/// Waits until `master` has `flags` or `wait` passed; returns the events seen.
fn wait_for(master: &File, flags: PollFlags, wait: Duration) -> PollFlags {
    let mut fds = [PollFd::new(master, flags)];
    match poll(&mut fds, Some(&timespec(wait))) {
        Ok(_) => fds[0].revents(),
        Err(_) => PollFlags::empty(),
    }
}

/// Writes all of `bytes` to the non-blocking master; drops the rest if nobody reads them.
fn write_reply(master: &mut File, mut bytes: &[u8]) {
    let deadline = Instant::now() + WRITE_WAIT;
    while !bytes.is_empty() {
        match master.write(bytes) {
            Ok(n) => bytes = &bytes[n..],
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) if e.kind() == ErrorKind::WouldBlock => {
                let now = Instant::now();
                if now >= deadline {
                    return;
                }
                wait_for(master, PollFlags::OUT, deadline - now);
            }
            Err(_) => return,
        }
    }
}

fn serve(mut master: File, mut engine: Engine, stop: &AtomicBool) {
    let mut buf = [0u8; 256];
    while !stop.load(Ordering::Relaxed) {
        let now = Instant::now();
        let wait = engine.tick_due(now).map_or(IDLE, |d| d.min(IDLE));
        let events = wait_for(&master, PollFlags::IN, wait.max(Duration::from_millis(1)));
        let mut replies = Vec::new();
        if events.contains(PollFlags::IN) {
            match master.read(&mut buf) {
                Ok(n) if n > 0 => replies = engine.feed(&buf[..n], Instant::now()),
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::Interrupted) => {}
                // Hang-up or error: nobody on the other side; do not spin.
                _ => thread::sleep(IDLE),
            }
        } else if events.intersects(PollFlags::HUP | PollFlags::ERR | PollFlags::NVAL) {
            thread::sleep(IDLE);
        }
        replies.extend(engine.tick(Instant::now()));
        if !replies.is_empty() {
            write_reply(&mut master, &replies);
        }
    }
}
