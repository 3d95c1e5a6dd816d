//! `planner merge-recordings`: MCAP files (a device recording, a view recording) merged
//! into one, messages in log-time order.

use crate::ViewError;
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// Merges MCAP files (e.g. a device recording from `haptic-loop run --record` and a view
/// recording) into `out`: every schema, channel and message, messages ordered by log time.
/// Both use `CLOCK_MONOTONIC` ns and distinct topic prefixes (`/device/`, `/view/`), so
/// nothing clashes. Returns the number of messages written.
pub fn merge_mcap(inputs: &[PathBuf], out: &Path) -> Result<u64, ViewError> {
    let mut bufs = Vec::with_capacity(inputs.len());
    for p in inputs {
        bufs.push(std::fs::read(p).map_err(|source| ViewError::File {
            action: "read",
            path: p.clone(),
            source,
        })?);
    }
    let mut messages = Vec::new();
    for (p, buf) in inputs.iter().zip(&bufs) {
        let stream = mcap::MessageStream::new(buf).map_err(read_error("not an MCAP file", p))?;
        for m in stream {
            messages.push(m.map_err(read_error("corrupt MCAP", p))?);
        }
    }
    messages.sort_by_key(|m| m.log_time);
    let file = File::create(out).map_err(|source| ViewError::File {
        action: "create",
        path: out.to_path_buf(),
        source,
    })?;
    let mut w = mcap::WriteOptions::new()
        .compression(Some(mcap::Compression::Lz4))
        .profile("hrrtc")
        .create(BufWriter::new(file))
        .map_err(write_error("write", out))?;
    let mut channel_ids: BTreeMap<(String, String, String, Vec<u8>), u16> = BTreeMap::new();
    let mut seq: BTreeMap<u16, u32> = BTreeMap::new();
    for m in &messages {
        let ch = &m.channel;
        let key = (
            ch.topic.clone(),
            ch.message_encoding.clone(),
            ch.schema
                .as_ref()
                .map(|s| s.name.clone())
                .unwrap_or_default(),
            ch.schema
                .as_ref()
                .map(|s| s.data.to_vec())
                .unwrap_or_default(),
        );
        let id = match channel_ids.get(&key) {
            Some(id) => *id,
            None => {
                let schema_id = match &ch.schema {
                    Some(s) => w
                        .add_schema(&s.name, &s.encoding, &s.data)
                        .map_err(write_error("write", out))?,
                    None => 0,
                };
                let id = w
                    .add_channel(schema_id, &ch.topic, &ch.message_encoding, &ch.metadata)
                    .map_err(write_error("write", out))?;
                channel_ids.insert(key, id);
                id
            }
        };
        let s = seq.entry(id).or_default();
        *s = s.wrapping_add(1);
        w.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: id,
                sequence: *s,
                log_time: m.log_time,
                publish_time: m.publish_time,
            },
            &m.data,
        )
        .map_err(write_error("write", out))?;
    }
    w.finish().map_err(write_error("finish", out))?;
    Ok(messages.len() as u64)
}

fn read_error(what: &'static str, path: &Path) -> impl FnOnce(mcap::McapError) -> ViewError {
    let path = path.to_path_buf();
    move |source| ViewError::McapRead { what, path, source }
}

fn write_error(action: &'static str, path: &Path) -> impl Fn(mcap::McapError) -> ViewError {
    let path = path.to_path_buf();
    move |source| ViewError::McapWrite {
        action,
        path: path.clone(),
        source,
    }
}
