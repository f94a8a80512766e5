//! The simulated rig behind a real pseudo-terminal, a host-side port for ptys, a wall clock,
//! and a proxy that corrupts bytes between two ptys.
//!
//! [`PtyRig::spawn`] runs a [`SimRig`] on its own thread, paced against the wall clock at
//! `speed` × real time, and serves the protocol on the slave side of a pty whose path it
//! reports — a host opens that path like any serial port. [`HostPort`] is a minimal raw-mode
//! port for tests and tools until the serial drivers of `rig-host` exist;
//! [`CorruptingProxy`] sits between two ptys and flips bits and drops bytes (never touching
//! frame delimiters, so each corrupted frame is exactly one frame a decoder must reject).

use crate::noise::Rng64;
use crate::presets::Preset;
use crate::rig::{STEP_US, SimRig};
use crate::world::Truth;
use rig_protocol::client::Transport;
use rig_protocol::frame::DecoderStats;
use rig_protocol::{Clock, FaultSet, RigState, Sample};
use rustix::event::{PollFd, PollFlags, poll};
use rustix::fs::{Mode, OFlags};
use rustix::io::Errno;
use rustix::termios::{OptionalActions, SpecialCodeIndex};
use std::io;
use std::os::fd::{AsFd, OwnedFd};
use std::os::unix::ffi::OsStringExt;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

fn to_io(e: Errno) -> io::Error {
    io::Error::from_raw_os_error(e.raw_os_error())
}

fn set_raw(fd: impl AsFd) -> io::Result<()> {
    let mut t = rustix::termios::tcgetattr(&fd).map_err(to_io)?;
    t.make_raw();
    t.special_codes[SpecialCodeIndex::VMIN] = 0;
    t.special_codes[SpecialCodeIndex::VTIME] = 0;
    rustix::termios::tcsetattr(&fd, OptionalActions::Now, &t).map_err(to_io)
}

/// A pty pair: the master end, and the path of the slave end.
#[derive(Debug)]
pub struct Pty {
    master: OwnedFd,
    path: PathBuf,
    // Keeps the slave open so the master never sees EIO while no host is connected.
    _slave: OwnedFd,
}

impl Pty {
    /// Opens a new pty pair in raw mode with a non-blocking master.
    pub fn open() -> io::Result<Self> {
        use rustix::pty::{OpenptFlags, grantpt, openpt, ptsname, unlockpt};
        let master = openpt(OpenptFlags::RDWR | OpenptFlags::NOCTTY | OpenptFlags::CLOEXEC)
            .map_err(to_io)?;
        grantpt(&master).map_err(to_io)?;
        unlockpt(&master).map_err(to_io)?;
        let name = ptsname(&master, Vec::new()).map_err(to_io)?;
        let path = PathBuf::from(std::ffi::OsString::from_vec(name.into_bytes()));
        let slave = rustix::fs::open(
            &path,
            OFlags::RDWR | OFlags::NOCTTY | OFlags::CLOEXEC | OFlags::NONBLOCK,
            Mode::empty(),
        )
        .map_err(to_io)?;
        set_raw(&slave)?;
        rustix::fs::fcntl_setfl(&master, OFlags::NONBLOCK | OFlags::RDWR).map_err(to_io)?;
        Ok(Self {
            master,
            path,
            _slave: slave,
        })
    }

    /// Path of the slave end (what a host opens).
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// Reads what is available from a non-blocking fd; `Ok(0)` when nothing is.
fn read_nb(fd: impl AsFd, buf: &mut [u8]) -> io::Result<usize> {
    match rustix::io::read(fd, buf) {
        Ok(n) => Ok(n),
        Err(Errno::AGAIN) | Err(Errno::IO) | Err(Errno::INTR) => Ok(0),
        Err(e) => Err(to_io(e)),
    }
}

/// Writes as much as the fd takes without blocking; returns the count.
fn write_nb(fd: impl AsFd, buf: &[u8]) -> io::Result<usize> {
    match rustix::io::write(fd, buf) {
        Ok(n) => Ok(n),
        Err(Errno::AGAIN) | Err(Errno::IO) | Err(Errno::INTR) => Ok(0),
        Err(e) => Err(to_io(e)),
    }
}

fn wait_readable(fds: &[&OwnedFd], timeout: Duration) -> io::Result<()> {
    let mut pfds: Vec<PollFd<'_>> = fds.iter().map(|f| PollFd::new(*f, PollFlags::IN)).collect();
    let ts = rustix::event::Timespec {
        tv_sec: timeout.as_secs() as _,
        tv_nsec: timeout.subsec_nanos() as _,
    };
    match poll(&mut pfds, Some(&ts)) {
        Ok(_) | Err(Errno::INTR) => Ok(()),
        Err(e) => Err(to_io(e)),
    }
}

/// A raw-mode, non-blocking host-side port on a pty (or any tty) path.
#[derive(Debug)]
pub struct HostPort {
    fd: OwnedFd,
    read_timeout: Duration,
}

impl HostPort {
    /// Opens `path` in raw mode. Reads wait up to `read_timeout` for the first byte.
    pub fn open(path: &Path, read_timeout: Duration) -> io::Result<Self> {
        let fd = rustix::fs::open(
            path,
            OFlags::RDWR | OFlags::NOCTTY | OFlags::CLOEXEC | OFlags::NONBLOCK,
            Mode::empty(),
        )
        .map_err(to_io)?;
        set_raw(&fd)?;
        Ok(Self { fd, read_timeout })
    }
}

impl Transport for HostPort {
    type Error = io::Error;

    fn write_all(&mut self, mut bytes: &[u8]) -> io::Result<()> {
        let deadline = Instant::now() + Duration::from_secs(2);
        while !bytes.is_empty() {
            let n = write_nb(&self.fd, bytes)?;
            bytes = &bytes[n..];
            if n == 0 {
                if Instant::now() > deadline {
                    return Err(io::Error::new(io::ErrorKind::TimedOut, "pty write stalled"));
                }
                std::thread::sleep(Duration::from_micros(200));
            }
        }
        Ok(())
    }

    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = read_nb(&self.fd, buf)?;
        if n > 0 {
            return Ok(n);
        }
        wait_readable(&[&self.fd], self.read_timeout)?;
        read_nb(&self.fd, buf)
    }
}

/// A [`Clock`] on the host's monotonic clock, optionally scaled (a host talking to a
/// simulated rig running at `speed` × real time waits in rig time with `scale = speed`).
#[derive(Debug, Clone, Copy)]
pub struct WallClock {
    start: Instant,
    scale: f64,
}

impl WallClock {
    /// Real time.
    pub fn new() -> Self {
        Self::scaled(1.0)
    }

    /// `scale` × real time.
    pub fn scaled(scale: f64) -> Self {
        Self {
            start: Instant::now(),
            scale,
        }
    }
}

impl Default for WallClock {
    fn default() -> Self {
        Self::new()
    }
}

impl Clock for WallClock {
    fn now_us(&self) -> u64 {
        (self.start.elapsed().as_secs_f64() * 1e6 * self.scale) as u64
    }
}

/// How a [`PtyRig`] runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PtyRigOptions {
    /// Simulated time per real time (1.0 = real time).
    pub speed: f64,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// Record every sample sent (see [`PtyRigSnapshot::sent_samples`]).
    pub record_samples: bool,
}

impl Default for PtyRigOptions {
    fn default() -> Self {
        Self {
            speed: 1.0,
            seed: 1,
            record_samples: false,
        }
    }
}

/// Something to change on the running simulated bench.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BenchCommand {
    /// Set the supply voltage, V.
    SetSupplyVoltage(f64),
    /// Put a known mass on the load cell (0 removes it), g.
    PlaceMass(f64),
}

/// State of a running [`PtyRig`], refreshed by its thread.
#[derive(Debug, Clone, Default)]
pub struct PtyRigSnapshot {
    /// Simulated time, µs.
    pub sim_time_us: u64,
    /// Firmware safety state.
    pub state: RigState,
    /// Latched faults.
    pub faults: FaultSet,
    /// Frames the firmware received and dropped.
    pub rx_stats: DecoderStats,
    /// Bytes for the host dropped because nobody read the pty.
    pub tx_bytes_dropped: u64,
    /// Rig time given up because the thread fell behind the wall clock, µs.
    pub slipped_us: u64,
    /// Ground truth.
    pub truth: Option<Truth>,
    /// Samples sent, if recording.
    pub sent_samples: Vec<Sample>,
}

/// A simulated rig served on a pty by a background thread; stops when dropped.
#[derive(Debug)]
pub struct PtyRig {
    path: PathBuf,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<io::Result<()>>>,
    snapshot: Arc<Mutex<PtyRigSnapshot>>,
    commands: mpsc::Sender<BenchCommand>,
}

const MAX_PENDING_TX: usize = 64 * 1024;
/// Most simulation steps between two reads of host input.
const MAX_STEPS_PER_PASS: u32 = 20;
/// Largest backlog of rig time the thread catches up on; beyond it rig time slips, µs.
const MAX_LAG_US: u64 = 50_000;

impl PtyRig {
    /// Starts the rig; returns once the pty exists.
    pub fn spawn(preset: Preset, options: PtyRigOptions) -> io::Result<Self> {
        Self::spawn_inner(preset, options, None)
    }

    /// Starts the rig with its bus fed by an external supply model (for instance a simulated
    /// bench supply served on its own pty, so that the supply's set-point, current limit and
    /// output switch really act on the rig); see [`crate::world::ExternalBus`].
    /// [`BenchCommand::SetSupplyVoltage`] is then ignored: the external supply owns the bus.
    pub fn spawn_with_bus(
        preset: Preset,
        options: PtyRigOptions,
        bus: Box<dyn crate::world::ExternalBus>,
    ) -> io::Result<Self> {
        Self::spawn_inner(preset, options, Some(bus))
    }

    fn spawn_inner(
        preset: Preset,
        options: PtyRigOptions,
        bus: Option<Box<dyn crate::world::ExternalBus>>,
    ) -> io::Result<Self> {
        let pty = Pty::open()?;
        let path = pty.path().to_path_buf();
        // Fail early (on this thread) if the preset does not bring the board up.
        SimRig::new(&preset, options.seed).map_err(io::Error::other)?;
        let stop = Arc::new(AtomicBool::new(false));
        let snapshot = Arc::new(Mutex::new(PtyRigSnapshot::default()));
        let (commands, rx) = mpsc::channel();
        let thread = {
            let stop = stop.clone();
            let snapshot = snapshot.clone();
            std::thread::Builder::new()
                .name("sim-rig".into())
                .spawn(move || serve(pty, preset, options, bus, stop, snapshot, rx))?
        };
        Ok(Self {
            path,
            stop,
            thread: Some(thread),
            snapshot,
            commands,
        })
    }

    /// The pty path a host opens.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The latest state.
    pub fn snapshot(&self) -> PtyRigSnapshot {
        self.snapshot.lock().map(|s| s.clone()).unwrap_or_default()
    }

    /// Changes something on the bench.
    pub fn command(&self, command: BenchCommand) {
        let _ = self.commands.send(command);
    }

    /// Whether the serving thread is still running.
    pub fn is_running(&self) -> bool {
        self.thread.as_ref().is_some_and(|t| !t.is_finished())
    }

    /// Stops the thread and reports how it ended.
    pub fn stop(mut self) -> io::Result<()> {
        self.shutdown()
    }

    /// Waits until the thread ends (it runs until stopped or it fails).
    pub fn join(mut self) -> io::Result<()> {
        match self.thread.take() {
            Some(t) => t
                .join()
                .map_err(|_| io::Error::other("sim-rig thread panicked"))?,
            None => Ok(()),
        }
    }

    fn shutdown(&mut self) -> io::Result<()> {
        self.stop.store(true, Ordering::SeqCst);
        match self.thread.take() {
            Some(t) => t
                .join()
                .map_err(|_| io::Error::other("sim-rig thread panicked"))?,
            None => Ok(()),
        }
    }
}

impl Drop for PtyRig {
    fn drop(&mut self) {
        let _ = self.shutdown();
    }
}

fn serve(
    pty: Pty,
    preset: Preset,
    options: PtyRigOptions,
    bus: Option<Box<dyn crate::world::ExternalBus>>,
    stop: Arc<AtomicBool>,
    snapshot: Arc<Mutex<PtyRigSnapshot>>,
    commands: mpsc::Receiver<BenchCommand>,
) -> io::Result<()> {
    let mut rig = SimRig::new(&preset, options.seed).map_err(io::Error::other)?;
    let external = bus.is_some();
    if let Some(bus) = bus {
        rig.set_external_bus(bus);
    }
    if options.record_samples {
        rig.record_samples();
    }
    let speed = if options.speed.is_finite() && options.speed > 0.0 {
        options.speed
    } else {
        1.0
    };
    // Rig time = (wall time since `start`) × speed − slip. If the thread falls behind (a
    // starved CPU), it does not burst through the backlog with the host unheard — which
    // would trip the host timeout — but slips: rig time pauses instead.
    let start = Instant::now();
    let mut slip_us = 0u64;
    let target =
        |slip: u64| ((start.elapsed().as_secs_f64() * 1e6 * speed) as u64).saturating_sub(slip);
    let mut buf = [0u8; 4096];
    let mut pending: Vec<u8> = Vec::new();
    let mut dropped = 0u64;
    let mut published = 0usize;
    while !stop.load(Ordering::Relaxed) {
        while let Ok(c) = commands.try_recv() {
            match c {
                BenchCommand::SetSupplyVoltage(v) if !external => rig.set_supply_voltage(v),
                BenchCommand::SetSupplyVoltage(_) => {}
                BenchCommand::PlaceMass(g) => rig.place_mass_g(g),
            }
        }
        loop {
            let n = read_nb(&pty.master, &mut buf)?;
            if n == 0 {
                break;
            }
            rig.receive(&buf[..n]);
        }
        let mut target_us = target(slip_us);
        if target_us > rig.now_us() + MAX_LAG_US {
            slip_us += target_us - rig.now_us() - MAX_LAG_US;
            target_us = target(slip_us);
        }
        let mut steps = 0;
        loop {
            let n = rig.read_output(&mut buf);
            pending.extend_from_slice(&buf[..n]);
            if !pending.is_empty() {
                let w = write_nb(&pty.master, &pending)?;
                pending.drain(..w);
                if pending.len() > MAX_PENDING_TX {
                    dropped += pending.len() as u64;
                    pending.clear();
                }
            }
            if rig.now_us() + STEP_US > target_us || steps >= MAX_STEPS_PER_PASS {
                break;
            }
            rig.advance(STEP_US);
            steps += 1;
        }
        if let Ok(mut s) = snapshot.lock() {
            let fw = rig.firmware();
            s.sim_time_us = rig.now_us();
            s.state = fw.state();
            s.faults = fw.faults();
            s.rx_stats = fw.rx_stats();
            s.tx_bytes_dropped = dropped;
            s.slipped_us = slip_us;
            s.truth = Some(rig.truth());
            let sent = rig.sent_samples();
            s.sent_samples.extend_from_slice(&sent[published..]);
            published = sent.len();
        }
        let behind = rig.now_us() + STEP_US <= target(slip_us);
        if !behind {
            wait_readable(&[&pty.master], Duration::from_micros(500))?;
        }
    }
    Ok(())
}

/// How one direction of traffic is damaged.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Corruption {
    /// Probability that a non-delimiter byte has bits flipped.
    pub flip_probability: f64,
    /// Probability that a non-delimiter byte is dropped.
    pub drop_probability: f64,
}

impl Corruption {
    /// No damage.
    pub const NONE: Corruption = Corruption {
        flip_probability: 0.0,
        drop_probability: 0.0,
    };
}

/// How a [`CorruptingProxy`] damages traffic.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProxyOptions {
    /// Rig → host.
    pub to_host: Corruption,
    /// Host → rig.
    pub to_rig: Corruption,
    /// Seed.
    pub seed: u64,
}

/// Counters of a [`CorruptingProxy`]. A frame is counted when its delimiter passes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ProxyStats {
    /// Non-empty frames passed towards the host.
    pub frames_to_host: u64,
    /// Of those, frames damaged.
    pub corrupted_to_host: u64,
    /// Non-empty frames passed towards the rig.
    pub frames_to_rig: u64,
    /// Of those, frames damaged.
    pub corrupted_to_rig: u64,
    /// Bytes with flipped bits.
    pub bytes_flipped: u64,
    /// Bytes dropped.
    pub bytes_dropped: u64,
}

struct Damage {
    rng: Rng64,
    flip: f64,
    drop: f64,
    frame_len: usize,
    frame_damaged: bool,
}

impl Damage {
    /// Passes `input` into `out`, damaging it; updates (frames, corrupted, flipped, dropped).
    fn apply(&mut self, input: &[u8], out: &mut Vec<u8>, c: &mut (u64, u64, u64, u64)) {
        for &b in input {
            if b == 0 {
                if self.frame_len > 0 {
                    c.0 += 1;
                    if self.frame_damaged {
                        c.1 += 1;
                    }
                }
                self.frame_len = 0;
                self.frame_damaged = false;
                out.push(0);
                continue;
            }
            self.frame_len += 1;
            let r = self.rng.uniform();
            if r < self.drop {
                self.frame_damaged = true;
                c.3 += 1;
            } else if r < self.drop + self.flip {
                let mut mask = (self.rng.next_u64() & 0xFF) as u8;
                if mask == 0 || b ^ mask == 0 {
                    mask = if b == 1 { 2 } else { 1 };
                }
                self.frame_damaged = true;
                c.2 += 1;
                out.push(b ^ mask);
            } else {
                out.push(b);
            }
        }
    }
}

/// A man in the middle between a rig's pty and a new pty for the host.
#[derive(Debug)]
pub struct CorruptingProxy {
    path: PathBuf,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<io::Result<()>>>,
    stats: Arc<Mutex<ProxyStats>>,
}

impl CorruptingProxy {
    /// Connects to the rig at `upstream` and offers a new pty for the host.
    pub fn spawn(upstream: &Path, options: ProxyOptions) -> io::Result<Self> {
        let rig_side = HostPort::open(upstream, Duration::from_millis(1))?;
        let host_side = Pty::open()?;
        let path = host_side.path().to_path_buf();
        let stop = Arc::new(AtomicBool::new(false));
        let stats = Arc::new(Mutex::new(ProxyStats::default()));
        let thread = {
            let stop = stop.clone();
            let stats = stats.clone();
            std::thread::Builder::new()
                .name("corrupting-proxy".into())
                .spawn(move || proxy(rig_side, host_side, options, stop, stats))?
        };
        Ok(Self {
            path,
            stop,
            thread: Some(thread),
            stats,
        })
    }

    /// The pty path the host opens.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Counters so far.
    pub fn stats(&self) -> ProxyStats {
        self.stats.lock().map(|s| *s).unwrap_or_default()
    }
}

impl Drop for CorruptingProxy {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn proxy(
    rig: HostPort,
    host: Pty,
    o: ProxyOptions,
    stop: Arc<AtomicBool>,
    stats: Arc<Mutex<ProxyStats>>,
) -> io::Result<()> {
    let mut rng = Rng64::new(o.seed);
    let mut damage = |c: Corruption| Damage {
        rng: Rng64::new(rng.next_u64()),
        flip: c.flip_probability,
        drop: c.drop_probability,
        frame_len: 0,
        frame_damaged: false,
    };
    let mut to_host = damage(o.to_host);
    let mut to_rig = damage(o.to_rig);
    let mut buf = [0u8; 4096];
    let (mut up, mut down) = (Vec::new(), Vec::new());
    let (mut ch, mut cr) = ((0, 0, 0, 0), (0, 0, 0, 0));
    while !stop.load(Ordering::Relaxed) {
        let n = read_nb(&rig.fd, &mut buf)?;
        to_host.apply(&buf[..n], &mut down, &mut ch);
        let m = read_nb(&host.master, &mut buf)?;
        to_rig.apply(&buf[..m], &mut up, &mut cr);
        if !down.is_empty() {
            let w = write_nb(&host.master, &down)?;
            down.drain(..w);
        }
        if !up.is_empty() {
            let w = write_nb(&rig.fd, &up)?;
            up.drain(..w);
        }
        if let Ok(mut s) = stats.lock() {
            *s = ProxyStats {
                frames_to_host: ch.0,
                corrupted_to_host: ch.1,
                frames_to_rig: cr.0,
                corrupted_to_rig: cr.1,
                bytes_flipped: ch.2 + cr.2,
                bytes_dropped: ch.3 + cr.3,
            };
        }
        if n == 0 && m == 0 && down.is_empty() && up.is_empty() {
            wait_readable(&[&rig.fd, &host.master], Duration::from_millis(1))?;
        }
    }
    Ok(())
}
