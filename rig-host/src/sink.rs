//! Where a sweep's completed steps go: the crash-safe [`SweepLog`] or memory
//! ([`MemorySink`]).

use crate::error::HostError;
use crate::log::{LoggedSample, StepRecord, SweepLog};

/// Where completed steps go.
pub trait StepSink {
    /// One completed step and its samples (must be durable when this returns).
    fn step(&mut self, row: &StepRecord, samples: &[LoggedSample]) -> Result<(), HostError>;
    /// A remark.
    fn comment(&mut self, text: &str) -> Result<(), HostError>;
}

impl StepSink for SweepLog {
    fn step(&mut self, row: &StepRecord, samples: &[LoggedSample]) -> Result<(), HostError> {
        self.append_step(row, samples)
    }
    fn comment(&mut self, text: &str) -> Result<(), HostError> {
        SweepLog::comment(self, text)
    }
}

/// Steps kept in memory (benchmarks, tests).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MemorySink {
    /// The steps.
    pub rows: Vec<StepRecord>,
    /// Their samples.
    pub samples: Vec<LoggedSample>,
    /// Remarks.
    pub comments: Vec<String>,
}

impl StepSink for MemorySink {
    fn step(&mut self, row: &StepRecord, samples: &[LoggedSample]) -> Result<(), HostError> {
        self.rows.push(*row);
        self.samples.extend_from_slice(samples);
        Ok(())
    }
    fn comment(&mut self, text: &str) -> Result<(), HostError> {
        self.comments.push(text.to_owned());
        Ok(())
    }
}
