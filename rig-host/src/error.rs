//! What can go wrong on the host side ([`HostError`]), how a rig link's errors map onto it
//! ([`LinkError`]), and what state an error leaves the bench in ([`safe_state`]).

use std::path::PathBuf;

use rig_protocol::{ClientError, FaultCause};
use thiserror::Error;

/// How the bench supply was lost (the cause of [`HostError::SupplyLost`]).
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum SupplyLoss {
    /// The monitor thread could not be started.
    #[error("cannot start the monitor thread")]
    MonitorNotStarted(#[source] std::io::Error),
    /// The monitor thread ended.
    #[error("the monitor thread ended")]
    MonitorEnded,
    /// A setting was not answered in time.
    #[error("no answer to a setting within {0:?}")]
    NoAnswer(std::time::Duration),
    /// Consecutive mode polls failed.
    #[error("{polls} consecutive mode polls failed")]
    Polls {
        /// How many.
        polls: u32,
        /// The last poll's error.
        #[source]
        source: std::sync::Arc<supply::SupplyError>,
    },
    /// No supply status arrived during a step.
    #[error("no status during the step")]
    NoStatus,
    /// No fresh mode reading arrived in time.
    #[error("no mode reading within {0:?}")]
    NoMode(std::time::Duration),
    /// The output did not reach the set-point in constant-voltage mode.
    #[error(
        "output not at {voltage_v} V in constant-voltage mode within {timeout:?} (mode {mode:?}, {measurement:?})"
    )]
    NotRegulating {
        /// The set-point, V.
        voltage_v: f64,
        /// How long was waited.
        timeout: std::time::Duration,
        /// The regulation mode seen.
        mode: supply::RegulationMode,
        /// The last measurement.
        measurement: Option<supply::Measurement>,
    },
}

/// Every failure of the host side, with its context.
#[derive(Debug, Error)]
pub enum HostError {
    /// A serial port could not be opened or listed.
    #[error("{}", port_label(path))]
    Port {
        /// The port path (empty when listing).
        path: String,
        /// The serial library's error.
        #[source]
        source: serialport::Error,
    },
    /// The link to the rig broke (the port vanished, a write failed).
    #[error("link to the rig lost during {during}")]
    LinkLost {
        /// What the host was doing.
        during: &'static str,
        /// The protocol client's error (a transport error).
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The rig did not answer, or refused a command.
    #[error("rig {during}")]
    Rig {
        /// What the host was doing.
        during: &'static str,
        /// The protocol client's error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The handshake with the rig failed.
    #[error("handshake with the rig on {path} (is it a hoverbench rig?)")]
    Handshake {
        /// The port.
        path: String,
        /// The protocol client's error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The rig latched a fault.
    #[error("rig fault: {cause:?}{}", reading(*.value, *.limit))]
    Fault {
        /// Why.
        cause: FaultCause,
        /// The offending reading, when the rig reported one.
        value: Option<f32>,
        /// The limit it crossed, when the rig reported one.
        limit: Option<f32>,
    },
    /// The bench supply failed.
    #[error("the bench supply failed {during}")]
    Supply {
        /// What the host was doing.
        during: &'static str,
        /// The driver's error.
        #[source]
        source: Box<supply::SupplyError>,
    },
    /// The bench supply stopped answering its monitor.
    #[error("bench supply monitor")]
    SupplyLost(#[source] SupplyLoss),
    /// Something took longer than allowed.
    #[error("timeout: {what} after {seconds:.1} s of rig time")]
    Timeout {
        /// What.
        what: String,
        /// How long was waited, s (rig time).
        seconds: f64,
    },
    /// The operator or a signal stopped the session.
    #[error("interrupted")]
    Interrupted,
    /// Reading or writing a file failed.
    #[error("I/O error on {}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        #[source]
        source: std::io::Error,
    },
    /// `--resume` found a log that does not belong to this sweep.
    #[error("cannot resume {path}: {reason}")]
    Resume {
        /// The log.
        path: PathBuf,
        /// Why not.
        reason: String,
    },
    /// A sweep log could not be read back for the fit.
    #[error("reading the sweep log back")]
    Import {
        /// The log.
        path: PathBuf,
        /// The reader's error.
        #[source]
        source: Box<import::ImportError>,
    },
    /// The fit failed.
    #[error("{what}")]
    Fit {
        /// What was fitted.
        what: String,
        /// The fit's error.
        #[source]
        source: Box<fit::FitError>,
    },
    /// Another run holds the session folder.
    #[error(
        "{} is in use by another hoverbench run (its .lock is held): wait for it to finish or stop it; two runs would interleave their rows",
        dir.display()
    )]
    Locked {
        /// The session folder.
        dir: PathBuf,
    },
    /// The sweeps could not be fitted.
    #[error("fitting the session's sweeps")]
    SweepFit(#[from] fit::sweeps::SweepFitError),
    /// An output file could not be written.
    #[error(transparent)]
    Write(#[from] outfile::WriteError),
    /// An argument or setting is out of range.
    #[error("invalid setting: {0}")]
    Invalid(String),
    /// The session folder cannot be used: a file is in its place, or it cannot be created.
    #[error("cannot use {} as the session folder", dir.display())]
    SessionDir {
        /// The folder.
        dir: PathBuf,
        /// Why (a file in its place: `NotADirectory`; else the OS's error creating it).
        #[source]
        source: std::io::Error,
    },
    /// A summary could not be encoded as JSON.
    #[error("encoding {what} as JSON")]
    Json {
        /// What was encoded.
        what: &'static str,
        /// The encoder's error.
        #[source]
        source: serde_json::Error,
    },
}

/// What a port error is about: the port, or the listing (no path).
fn port_label(path: &str) -> String {
    if path.is_empty() {
        "listing the serial ports".to_owned()
    } else {
        format!("serial port {path}")
    }
}

/// ` (value V, limit L)` of a fault, the parts the rig reported.
fn reading(value: Option<f32>, limit: Option<f32>) -> String {
    match (value, limit) {
        (Some(v), Some(l)) => format!(" (value {v}, limit {l})"),
        (Some(v), None) => format!(" (value {v})"),
        (None, Some(l)) => format!(" (limit {l})"),
        (None, None) => String::new(),
    }
}

impl HostError {
    /// Wraps an I/O error with its file.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }
}

/// What the sweep needs to know about a rig connection's errors.
pub trait LinkError: std::error::Error + Send + Sync + 'static {
    /// Whether the transport failed (as opposed to a timeout or a refusal).
    fn is_transport(&self) -> bool;
    /// Whether the rig refused a command because a fault is latched.
    fn is_faulted(&self) -> bool;
}

impl<E: std::fmt::Debug + Send + Sync + 'static> LinkError for ClientError<E> {
    fn is_transport(&self) -> bool {
        matches!(self, ClientError::Transport(_))
    }
    fn is_faulted(&self) -> bool {
        matches!(
            self,
            ClientError::Nack {
                reason: rig_protocol::NackReason::Faulted,
                ..
            }
        )
    }
}

/// Maps a rig client's error to [`HostError::LinkLost`] (the transport failed) or
/// [`HostError::Rig`], keeping it as the source.
pub(crate) fn rig_err<E: LinkError>(during: &'static str) -> impl Fn(E) -> HostError {
    move |e| {
        if e.is_transport() {
            HostError::LinkLost {
                during,
                source: Box::new(e),
            }
        } else {
            HostError::Rig {
                during,
                source: Box::new(e),
            }
        }
    }
}

/// What state an error leaves the bench in, after the runner's safe stop (one sentence for
/// the operator).
pub fn safe_state(e: &HostError) -> &'static str {
    match e {
        HostError::LinkLost { .. } => {
            "the link to the rig is gone, so its firmware watchdog cuts the throttle within 250 ms; \
             the supply output was switched off"
        }
        HostError::SupplyLost(_) | HostError::Supply { .. } => {
            "throttle set to zero and rig disarmed; the supply did not answer: check that its \
             output is off"
        }
        _ => "throttle set to zero, rig disarmed and supply output switched off",
    }
}
