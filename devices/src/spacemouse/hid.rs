//! HID access through `hidapi` (Linux backend: hidraw via a minimal udev shim, no system
//! package). Enumeration and the reader thread; nothing here runs on the RT thread.

use std::ffi::CString;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::Duration;

use hidapi::{HidApi, HidDevice};

use super::feed::Feed;
use super::report::{self, Model};

/// One SpaceMouse interface found by [`enumerate`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Found {
    /// USB vendor id.
    pub vendor_id: u16,
    /// USB product id.
    pub product_id: u16,
    /// Model name (from our table, else the product string, else "3Dconnexion device").
    pub name: String,
    /// The known model, if in our table.
    pub model: Option<Model>,
    /// hidraw path, e.g. `/dev/hidraw3`.
    pub path: String,
}

/// HID devices could not be listed at all (e.g. no `/sys/class/hidraw`); hidapi's reason.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("cannot list HID devices: {0}")]
pub struct ListError(pub String);

/// Lists attached SpaceMouse interfaces. An error means HID could not be listed at all,
/// not that nothing was found.
pub fn enumerate() -> Result<Vec<Found>, ListError> {
    let api = HidApi::new().map_err(|e| ListError(e.to_string()))?;
    Ok(list(&api))
}

fn list(api: &HidApi) -> Vec<Found> {
    let mut out: Vec<Found> = Vec::new();
    for d in api.device_list() {
        let (v, p) = (d.vendor_id(), d.product_id());
        if !report::is_spacemouse(v, p, d.usage_page(), d.usage()) {
            continue;
        }
        let path = d.path().to_string_lossy().into_owned();
        // One physical device can expose several collections on the same path.
        if out.iter().any(|f| f.path == path) {
            continue;
        }
        let model = report::known_model(v, p).copied();
        let name = match (model, d.product_string()) {
            (Some(m), _) => m.name.to_string(),
            (None, Some(s)) if !s.is_empty() => s.to_string(),
            _ => "3Dconnexion device".to_string(),
        };
        out.push(Found {
            vendor_id: v,
            product_id: p,
            name,
            model,
            path,
        });
    }
    out
}

/// Why the first connection failed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ConnectError {
    /// HID could not be listed.
    Hid(String),
    /// No SpaceMouse is attached.
    NoneFound,
    /// One is attached but could not be opened (usually hidraw permissions).
    CannotOpen {
        /// hidraw path.
        path: String,
        /// hidapi's reason.
        reason: String,
    },
}

fn connect(api: &mut HidApi) -> Result<(Found, HidDevice), ConnectError> {
    api.refresh_devices()
        .map_err(|e| ConnectError::Hid(e.to_string()))?;
    let found = list(api)
        .into_iter()
        .next()
        .ok_or(ConnectError::NoneFound)?;
    let path = CString::new(found.path.clone()).map_err(|_| ConnectError::NoneFound)?;
    let dev = api.open_path(&path).map_err(|e| ConnectError::CannotOpen {
        path: found.path.clone(),
        reason: e.to_string(),
    })?;
    Ok((found, dev))
}

/// The running reader thread.
#[derive(Debug)]
pub(crate) struct Reader {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

/// How long a blocking read waits before checking for stop, and the replug poll period.
const READ_TIMEOUT_MS: i32 = 50;
const REPLUG_POLL: Duration = Duration::from_millis(250);

impl Reader {
    /// Connects to the first SpaceMouse (waiting at most `timeout`) and starts reading it
    /// into `feed`. On unplug the feed is detached and the thread polls for the device to
    /// come back, then attaches again.
    pub(crate) fn start(
        mut feed: Feed,
        timeout: Duration,
    ) -> Result<(Reader, Found), ConnectError> {
        let stop = Arc::new(AtomicBool::new(false));
        let (tx, rx) = mpsc::channel();
        let thread = {
            let stop = stop.clone();
            std::thread::Builder::new()
                .name("spacemouse-hid".into())
                .spawn(move || {
                    let mut api = match HidApi::new() {
                        Ok(a) => a,
                        Err(e) => {
                            let _ = tx.send(Err(ConnectError::Hid(e.to_string())));
                            return;
                        }
                    };
                    let mut dev = match connect(&mut api) {
                        Ok((found, dev)) => {
                            let _ = tx.send(Ok(found));
                            dev
                        }
                        Err(e) => {
                            let _ = tx.send(Err(e));
                            return;
                        }
                    };
                    feed.attach();
                    let mut buf = [0u8; 64];
                    while !stop.load(Ordering::Acquire) {
                        match dev.read_timeout(&mut buf, READ_TIMEOUT_MS) {
                            Ok(0) => {}
                            Ok(n) => {
                                // A malformed report is counted by the feed and skipped.
                                let _ = feed.push(&buf[..n]);
                            }
                            Err(_) => {
                                feed.detach();
                                dev = loop {
                                    if stop.load(Ordering::Acquire) {
                                        return;
                                    }
                                    std::thread::sleep(REPLUG_POLL);
                                    if let Ok((_, d)) = connect(&mut api) {
                                        break d;
                                    }
                                };
                                feed.attach();
                            }
                        }
                    }
                })
                .map_err(|e| {
                    ConnectError::Hid(format!("cannot start the HID reader thread: {e}"))
                })?
        };
        let found = match rx.recv_timeout(timeout) {
            Ok(Ok(found)) => found,
            Ok(Err(e)) => {
                let _ = thread.join();
                return Err(e);
            }
            Err(_) => {
                stop.store(true, Ordering::Release);
                return Err(ConnectError::Hid("timed out listing HID devices".into()));
            }
        };
        Ok((
            Reader {
                stop,
                thread: Some(thread),
            },
            found,
        ))
    }

    /// Stops and joins the thread (at most one read timeout).
    pub(crate) fn stop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Reader {
    fn drop(&mut self) {
        self.stop();
    }
}
