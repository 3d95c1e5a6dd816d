//! A C ABI over the hrrtc services, for C and C++ clients (`libhrrtc_c.so`; declarations
//! in `ipc-types/include/hrrtc_client.h`, the wire types in `ipc-types/include/hrrtc.h`).
//!
//! iceoryx2's own C bindings are not published as a crate, and a C client should not have
//! to reimplement the generational state protocol, so this library wraps the same
//! `ipc_types::services` the Rust processes use: a state reader that follows a restarted
//! haptic loop to its new generation, and a guidance publisher that also notifies the
//! loop's relay. Handles are not thread-safe: use each from the thread that opened it.
//! Errors: functions return NULL or a negative value, and [`hrrtc_last_error`] says why.

use ipc_types::services::{self, GuidanceNotifier, Ipc, Publisher, StateFollower};
use ipc_types::{Guidance, HapticState};
use std::cell::RefCell;
use std::ffi::{CStr, CString, c_char, c_int};

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

fn set_error(message: impl std::fmt::Display) {
    let text = CString::new(message.to_string().replace('\0', " ")).unwrap_or_default();
    LAST_ERROR.with(|e| *e.borrow_mut() = text);
}

/// The namespace argument as a checked `&str`, or the error set.
///
/// # Safety
/// `namespace` is null or a NUL-terminated string valid for reads.
unsafe fn namespace_arg<'a>(namespace: *const c_char) -> Option<&'a str> {
    if namespace.is_null() {
        set_error("namespace is NULL");
        return None;
    }
    // SAFETY: non-null and NUL-terminated by the caller's contract.
    let ns = unsafe { CStr::from_ptr(namespace) };
    let Ok(ns) = ns.to_str() else {
        set_error("namespace is not UTF-8");
        return None;
    };
    if let Err(e) = services::validate_namespace(ns) {
        set_error(format_args!("namespace: {e}"));
        return None;
    }
    Some(ns)
}

fn node(kind: &str) -> Option<iceoryx2::node::Node<Ipc>> {
    match services::create_node(&format!("c_{kind}_{}", std::process::id())) {
        Ok((node, _)) => Some(node),
        Err(e) => {
            set_error(e);
            None
        }
    }
}

/// A reader of the haptic loop's state on one namespace.
pub struct StateReaderHandle {
    follower: StateFollower,
    last_sequence: u64,
    _node: iceoryx2::node::Node<Ipc>,
}

/// The message of the last failure on this thread (empty if none); valid until the next
/// call into this library on this thread.
#[unsafe(no_mangle)]
pub extern "C" fn hrrtc_last_error() -> *const c_char {
    LAST_ERROR.with(|e| e.borrow().as_ptr())
}

/// `CLOCK_MONOTONIC` now, ns: the clock of every timestamp on the wire.
#[unsafe(no_mangle)]
pub extern "C" fn hrrtc_monotonic_ns() -> u64 {
    ipc_types::monotonic_ns()
}

/// Opens the newest generation of `hrrtc/<namespace>/haptic_state/<n>`; NULL on failure.
///
/// # Safety
/// `namespace` is null or a NUL-terminated string.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn hrrtc_state_reader_open(
    namespace: *const c_char,
) -> *mut StateReaderHandle {
    // SAFETY: forwarded caller contract.
    let Some(ns) = (unsafe { namespace_arg(namespace) }) else {
        return std::ptr::null_mut();
    };
    let Some(node) = node("state") else {
        return std::ptr::null_mut();
    };
    match StateFollower::open(&node, ns) {
        Ok(follower) => Box::into_raw(Box::new(StateReaderHandle {
            follower,
            last_sequence: 0,
            _node: node,
        })),
        Err(e) => {
            set_error(e);
            std::ptr::null_mut()
        }
    }
}

/// Copies the newest state into `out`. Returns 1 when it is new since the last call, 0
/// when it is the same or no loop has written yet (`out->header.sequence` is then 0), -1
/// on bad arguments. Follows a restarted loop to its new generation.
///
/// # Safety
/// `reader` comes from [`hrrtc_state_reader_open`] and is not closed; `out` is null or
/// points to a writable `hrrtc_HapticState`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn hrrtc_state_reader_read(
    reader: *mut StateReaderHandle,
    out: *mut HapticState,
) -> c_int {
    if reader.is_null() || out.is_null() {
        set_error("reader or out is NULL");
        return -1;
    }
    // SAFETY: a live handle from `hrrtc_state_reader_open`, used by one thread.
    let r = unsafe { &mut *reader };
    let state = r.follower.get();
    let new = state.header.sequence != r.last_sequence && state.header.sequence != 0;
    r.last_sequence = state.header.sequence;
    if let Err(e) = r.follower.after_read(new) {
        // A newer generation exists but did not open; the follower tries again later.
        set_error(e);
    }
    // SAFETY: `out` is non-null and writable by the caller's contract.
    unsafe { out.write(state) };
    c_int::from(new)
}

/// The generation the reader reads.
///
/// # Safety
/// `reader` comes from [`hrrtc_state_reader_open`] and is not closed.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn hrrtc_state_reader_generation(reader: *const StateReaderHandle) -> u32 {
    if reader.is_null() {
        return 0;
    }
    // SAFETY: a live handle by the caller's contract.
    unsafe { (*reader).follower.generation() }
}

/// Closes a reader (NULL is ignored).
///
/// # Safety
/// `reader` comes from [`hrrtc_state_reader_open`] and is not used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn hrrtc_state_reader_close(reader: *mut StateReaderHandle) {
    if !reader.is_null() {
        // SAFETY: created by `Box::into_raw` in `hrrtc_state_reader_open`, closed once.
        drop(unsafe { Box::from_raw(reader) });
    }
}

/// A publisher of guidance to the haptic loop on one namespace.
pub struct GuidancePublisherHandle {
    publisher: Publisher<Guidance>,
    notifier: GuidanceNotifier,
    _node: iceoryx2::node::Node<Ipc>,
}

/// Opens a guidance publisher on `hrrtc/<namespace>/guidance` (and its event); NULL on
/// failure.
///
/// # Safety
/// `namespace` is null or a NUL-terminated string.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn hrrtc_guidance_publisher_open(
    namespace: *const c_char,
) -> *mut GuidancePublisherHandle {
    // SAFETY: forwarded caller contract.
    let Some(ns) = (unsafe { namespace_arg(namespace) }) else {
        return std::ptr::null_mut();
    };
    let Some(node) = node("guidance") else {
        return std::ptr::null_mut();
    };
    let ports = services::publisher::<Guidance>(&node, ns)
        .and_then(|p| services::guidance_notifier(&node, ns).map(|n| (p, n)));
    match ports {
        Ok((publisher, notifier)) => Box::into_raw(Box::new(GuidancePublisherHandle {
            publisher,
            notifier,
            _node: node,
        })),
        Err(e) => {
            set_error(e);
            std::ptr::null_mut()
        }
    }
}

/// Sends `*guidance` as it is (the caller fills the header: sequence from 1, timestamp
/// from [`hrrtc_monotonic_ns`]) and wakes the loop's relay. Returns 0, or -1 on failure.
/// The loop itself rejects (and counts) samples it cannot trust.
///
/// # Safety
/// `publisher` comes from [`hrrtc_guidance_publisher_open`] and is not closed;
/// `guidance` is null or points to a readable `hrrtc_Guidance`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn hrrtc_guidance_publish(
    publisher: *mut GuidancePublisherHandle,
    guidance: *const Guidance,
) -> c_int {
    if publisher.is_null() || guidance.is_null() {
        set_error("publisher or guidance is NULL");
        return -1;
    }
    // SAFETY: a live handle and a readable sample by the caller's contract; `Guidance` is
    // plain old data, any bit pattern is a value.
    let (p, g) = unsafe { (&*publisher, guidance.read()) };
    if let Err(e) = p.publisher.send_copy(g) {
        set_error(format_args!("guidance send: {e:?}"));
        return -1;
    }
    // A lost notification costs only latency: the relay also polls.
    let _ = p.notifier.notify();
    0
}

/// Closes a publisher (NULL is ignored).
///
/// # Safety
/// `publisher` comes from [`hrrtc_guidance_publisher_open`] and is not used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn hrrtc_guidance_publisher_close(publisher: *mut GuidancePublisherHandle) {
    if !publisher.is_null() {
        // SAFETY: created by `Box::into_raw` in `hrrtc_guidance_publisher_open`, closed once.
        drop(unsafe { Box::from_raw(publisher) });
    }
}
