//! [`ReplayDevice`]: plays an MCAP device recording back, deterministically.

use std::path::Path;

use super::RecordError;
use super::format::{self, ReadJsonOwned, WrenchJson};
use crate::{DeviceError, DeviceSpec, DeviceState, HapticDevice, Wrench};

/// A device that returns a recording's reads in order. The n-th `read` returns the n-th
/// recorded read (its state, timestamp included, or its error), whatever `now_ns` is; past
/// the end it returns [`DeviceError::Disconnected`]. Every written wrench is compared with
/// the recorded one at the same position: [`max_wrench_deviation`](Self::max_wrench_deviation)
/// is the regression measure. Everything is loaded at construction: `read` and `write` do
/// not allocate.
#[derive(Debug)]
pub struct ReplayDevice {
    spec: DeviceSpec,
    reads: Vec<Result<DeviceState, DeviceError>>,
    wrenches: Vec<Wrench>,
    next_read: usize,
    next_write: usize,
    max_deviation: f64,
    open: bool,
}

fn bad(path: &Path, what: String) -> RecordError {
    RecordError::Format {
        path: path.display().to_string(),
        what,
    }
}

impl ReplayDevice {
    /// Loads a recording written by [`super::Recorder`].
    pub fn from_file(path: &Path) -> Result<Self, RecordError> {
        let bytes = std::fs::read(path).map_err(|error| RecordError::Io {
            path: path.display().to_string(),
            error,
        })?;
        Self::from_bytes(&bytes, path)
    }

    /// Loads a recording from memory; `path` only names it in errors.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self, RecordError> {
        let stream = mcap::MessageStream::new(bytes).map_err(|e| RecordError::Mcap {
            path: path.display().to_string(),
            what: e.to_string(),
        })?;
        let mut spec = None;
        let mut reads = Vec::new();
        let mut wrenches = Vec::new();
        for msg in stream {
            let msg = msg.map_err(|e| RecordError::Mcap {
                path: path.display().to_string(),
                what: e.to_string(),
            })?;
            match msg.channel.topic.as_str() {
                format::TOPIC_SPEC => {
                    let s: DeviceSpec = serde_json::from_slice(&msg.data)
                        .map_err(|e| bad(path, format!("{}: {e}", format::TOPIC_SPEC)))?;
                    s.validate()
                        .map_err(|e| bad(path, format!("{}: {e}", format::TOPIC_SPEC)))?;
                    spec.get_or_insert(s);
                }
                format::TOPIC_STATE => {
                    let r: ReadJsonOwned = serde_json::from_slice(&msg.data).map_err(|e| {
                        bad(
                            path,
                            format!("{} message {}: {e}", format::TOPIC_STATE, reads.len()),
                        )
                    })?;
                    let item = match (r.state, r.error) {
                        (Some(s), None) => Ok(s.to_state()),
                        (None, Some(e)) => Err(format::error_from_name(&e).ok_or_else(|| {
                            bad(
                                path,
                                format!("unknown recorded error {e:?} at tick {}", r.tick_ns),
                            )
                        })?),
                        _ => {
                            return Err(bad(
                                path,
                                format!(
                                    "read at tick {} has neither or both of state and error",
                                    r.tick_ns
                                ),
                            ));
                        }
                    };
                    reads.push(item);
                }
                format::TOPIC_WRENCH => {
                    let w: WrenchJson = serde_json::from_slice(&msg.data).map_err(|e| {
                        bad(
                            path,
                            format!("{} message {}: {e}", format::TOPIC_WRENCH, wrenches.len()),
                        )
                    })?;
                    wrenches.push(w.to_wrench());
                }
                // Other topics (a viewer's annotations) are not ours: skip.
                _ => {}
            }
        }
        let spec = spec.ok_or_else(|| bad(path, format!("no {} message", format::TOPIC_SPEC)))?;
        if reads.is_empty() {
            return Err(bad(path, format!("no {} messages", format::TOPIC_STATE)));
        }
        Ok(ReplayDevice {
            spec,
            reads,
            wrenches,
            next_read: 0,
            next_write: 0,
            max_deviation: 0.0,
            open: false,
        })
    }

    /// Reads in the recording.
    pub fn len(&self) -> usize {
        self.reads.len()
    }

    /// True when the recording holds no reads (never, for a loaded recording).
    pub fn is_empty(&self) -> bool {
        self.reads.is_empty()
    }

    /// True once every recorded read was returned.
    pub fn finished(&self) -> bool {
        self.next_read >= self.reads.len()
    }

    /// The recorded wrenches, in order.
    pub fn recorded_wrenches(&self) -> &[Wrench] {
        &self.wrenches
    }

    /// Largest difference (max over components, N or N·m) between a wrench written during
    /// replay and the recorded one at the same position; writes beyond the recording are
    /// not compared.
    pub fn max_wrench_deviation(&self) -> f64 {
        self.max_deviation
    }

    /// Writes compared so far.
    pub fn compared_writes(&self) -> usize {
        self.next_write.min(self.wrenches.len())
    }
}

impl HapticDevice for ReplayDevice {
    fn open(&mut self) -> Result<(), DeviceError> {
        self.next_read = 0;
        self.next_write = 0;
        self.max_deviation = 0.0;
        self.open = true;
        Ok(())
    }

    fn spec(&self) -> &DeviceSpec {
        &self.spec
    }

    fn read(&mut self, _now_ns: u64) -> Result<DeviceState, DeviceError> {
        if !self.open {
            return Err(DeviceError::NotOpen);
        }
        let r = self
            .reads
            .get(self.next_read)
            .copied()
            .unwrap_or(Err(DeviceError::Disconnected));
        self.next_read = self.next_read.saturating_add(1);
        r
    }

    fn write(&mut self, wrench: &Wrench) -> Result<(), DeviceError> {
        if !self.open {
            return Err(DeviceError::NotOpen);
        }
        if let Some(rec) = self.wrenches.get(self.next_write) {
            let d = (wrench.force - rec.force)
                .abs()
                .max()
                .max((wrench.torque - rec.torque).abs().max());
            // NaN compares false: count a non-finite command as an infinite deviation.
            self.max_deviation = if d.is_nan() {
                f64::INFINITY
            } else {
                self.max_deviation.max(d)
            };
        }
        self.next_write = self.next_write.saturating_add(1);
        Ok(())
    }

    fn close(&mut self) {
        self.open = false;
    }
}
