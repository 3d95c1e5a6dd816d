//! [`Recorder`]: a device wrapper that records to MCAP off the RT thread.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::Duration;

use super::RecordError;
use super::format::{self, ReadJson, StateJson, WrenchJson};
use crate::{DeviceError, DeviceSpec, DeviceState, HapticDevice, Wrench};

/// One event from the RT thread; `Copy`, so pushing it never allocates.
#[derive(Debug, Clone, Copy)]
enum Event {
    Read(u64, Result<DeviceState, DeviceError>),
    Write(u64, Wrench),
}

/// What a finished recording holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RecordStats {
    /// `read` results written.
    pub reads: u64,
    /// Wrenches written.
    pub wrenches: u64,
    /// Events dropped because the ring was full (the writer thread fell behind).
    pub dropped: u64,
}

struct Writer {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<Result<RecordStats, RecordError>>>,
    specs: mpsc::Sender<String>,
}

/// Records `D`'s reads and commanded wrenches to an MCAP file while passing everything
/// through unchanged.
pub struct Recorder<D> {
    inner: D,
    ring: rtrb::Producer<Event>,
    writer: Option<Writer>,
    dropped: Arc<AtomicU64>,
    last_tick_ns: u64,
}

impl<D> std::fmt::Debug for Recorder<D> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recorder")
            .field("dropped", &self.dropped.load(Ordering::Relaxed))
            .finish()
    }
}

/// Ring capacity in events: 8 s of 1 kHz reads and writes before anything drops.
const RING_EVENTS: usize = 16_384;

fn mcap_err(path: &Path, e: impl std::fmt::Display) -> RecordError {
    RecordError::Mcap {
        path: path.display().to_string(),
        what: e.to_string(),
    }
}

impl<D: HapticDevice> Recorder<D> {
    /// Creates `path` (truncating it) and starts the writer thread. The spec is written at
    /// each `open`.
    pub fn create(inner: D, path: &Path) -> Result<Self, RecordError> {
        let file = File::create(path).map_err(|error| RecordError::Io {
            path: path.display().to_string(),
            error,
        })?;
        let mut mcap = mcap::WriteOptions::new()
            .compression(None)
            .profile("hrrtc")
            .create(BufWriter::new(file))
            .map_err(|e| mcap_err(path, e))?;
        let no_meta = BTreeMap::new();
        let mut channel = |topic: &str, name: &str, schema: &str| -> Result<u16, RecordError> {
            let schema_id = mcap
                .add_schema(name, "jsonschema", schema.as_bytes())
                .map_err(|e| mcap_err(path, e))?;
            mcap.add_channel(schema_id, topic, "json", &no_meta)
                .map_err(|e| mcap_err(path, e))
        };
        let spec_ch = channel(format::TOPIC_SPEC, "hrrtc.DeviceSpec", format::SCHEMA_SPEC)?;
        let state_ch = channel(format::TOPIC_STATE, "hrrtc.DeviceRead", format::SCHEMA_READ)?;
        let wrench_ch = channel(
            format::TOPIC_WRENCH,
            "hrrtc.DeviceWrench",
            format::SCHEMA_WRENCH,
        )?;

        let (producer, mut consumer) = rtrb::RingBuffer::<Event>::new(RING_EVENTS);
        let stop = Arc::new(AtomicBool::new(false));
        let dropped = Arc::new(AtomicU64::new(0));
        let (spec_tx, spec_rx) = mpsc::channel::<String>();
        let path_buf: PathBuf = path.to_path_buf();
        let thread = {
            let stop = stop.clone();
            let dropped = dropped.clone();
            std::thread::Builder::new()
                .name("device-recorder".into())
                .spawn(move || -> Result<RecordStats, RecordError> {
                    let path = path_buf.as_path();
                    let mut stats = RecordStats::default();
                    let mut seq = [0u32; 3];
                    let mut write = |mcap: &mut mcap::Writer<BufWriter<File>>,
                                     ch: u16,
                                     k: usize,
                                     t: u64,
                                     body: &[u8]|
                     -> Result<(), RecordError> {
                        seq[k] = seq[k].wrapping_add(1);
                        mcap.write_to_known_channel(
                            &mcap::records::MessageHeader {
                                channel_id: ch,
                                sequence: seq[k],
                                log_time: t,
                                publish_time: t,
                            },
                            body,
                        )
                        .map_err(|e| mcap_err(path, e))
                    };
                    let mut last_t = 0u64;
                    loop {
                        let stopping = stop.load(Ordering::Acquire);
                        while let Ok(spec) = spec_rx.try_recv() {
                            write(&mut mcap, spec_ch, 0, last_t, spec.as_bytes())?;
                        }
                        while let Ok(ev) = consumer.pop() {
                            match ev {
                                Event::Read(t, r) => {
                                    last_t = t;
                                    let msg = ReadJson {
                                        tick_ns: t,
                                        state: r.as_ref().ok().map(StateJson::from),
                                        error: r.err().map(format::error_name),
                                    };
                                    let body =
                                        serde_json::to_vec(&msg).map_err(|e| mcap_err(path, e))?;
                                    write(&mut mcap, state_ch, 1, t, &body)?;
                                    stats.reads += 1;
                                }
                                Event::Write(t, w) => {
                                    let body = serde_json::to_vec(&WrenchJson::from((t, &w)))
                                        .map_err(|e| mcap_err(path, e))?;
                                    write(&mut mcap, wrench_ch, 2, t, &body)?;
                                    stats.wrenches += 1;
                                }
                            }
                        }
                        if stopping {
                            break;
                        }
                        std::thread::sleep(Duration::from_millis(5));
                    }
                    mcap.finish().map_err(|e| mcap_err(path, e))?;
                    stats.dropped = dropped.load(Ordering::Relaxed);
                    Ok(stats)
                })
                .map_err(|error| RecordError::Io {
                    path: path.display().to_string(),
                    error,
                })?
        };
        Ok(Recorder {
            inner,
            ring: producer,
            writer: Some(Writer {
                stop,
                thread: Some(thread),
                specs: spec_tx,
            }),
            dropped,
            last_tick_ns: 0,
        })
    }

    /// The recorded device.
    pub fn inner(&self) -> &D {
        &self.inner
    }

    /// Mutable access to the recorded device (tests inject faults through it).
    pub fn inner_mut(&mut self) -> &mut D {
        &mut self.inner
    }

    /// Events dropped so far because the writer fell behind.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }

    /// Closes the device, drains the ring and finishes the file. Works through `&mut`
    /// so a recorder owned by a loop can be finished in place; later calls return zeros.
    pub fn finish(&mut self) -> Result<RecordStats, RecordError> {
        self.inner.close();
        self.stop_writer().unwrap_or(Ok(RecordStats::default()))
    }

    fn stop_writer(&mut self) -> Option<Result<RecordStats, RecordError>> {
        let mut w = self.writer.take()?;
        w.stop.store(true, Ordering::Release);
        let t = w.thread.take()?;
        Some(t.join().unwrap_or_else(|_| {
            Err(RecordError::Format {
                path: String::new(),
                what: "the recorder thread panicked".into(),
            })
        }))
    }

    fn push(&mut self, e: Event) {
        if self.ring.push(e).is_err() {
            self.dropped.fetch_add(1, Ordering::Relaxed);
        }
    }
}

fn spec_json(spec: &DeviceSpec) -> String {
    serde_json::to_string(spec).unwrap_or_else(|_| "{}".into())
}

impl<D: HapticDevice> HapticDevice for Recorder<D> {
    fn open(&mut self) -> Result<(), DeviceError> {
        self.inner.open()?;
        if let Some(w) = &self.writer {
            let _ = w.specs.send(spec_json(self.inner.spec()));
        }
        Ok(())
    }

    fn spec(&self) -> &DeviceSpec {
        self.inner.spec()
    }

    fn read(&mut self, now_ns: u64) -> Result<DeviceState, DeviceError> {
        let r = self.inner.read(now_ns);
        self.last_tick_ns = now_ns;
        self.push(Event::Read(now_ns, r));
        r
    }

    fn write(&mut self, wrench: &Wrench) -> Result<(), DeviceError> {
        self.push(Event::Write(self.last_tick_ns, *wrench));
        self.inner.write(wrench)
    }

    fn close(&mut self) {
        self.inner.close();
    }
}

impl<D> Drop for Recorder<D> {
    fn drop(&mut self) {
        if let Some(mut w) = self.writer.take() {
            w.stop.store(true, Ordering::Release);
            if let Some(t) = w.thread.take() {
                let _ = t.join();
            }
        }
    }
}
