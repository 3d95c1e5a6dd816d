//! Built voxmaps kept on disk, keyed by what they were built from, so that the next start
//! with the same scene loads in a fraction of a second instead of building again.
//!
//! The key is a SHA-256 over the build's inputs: this format's version, the voxel size and
//! layers, and every obstacle (its kind, pose, sizes, and a mesh's vertices, triangles and
//! surface kind). The file (`<key>.voxmap` in the cache folder) holds a header with the key,
//! the grid and the array lengths, then the arrays, then a SHA-256 of everything before it.
//! A file that is truncated, damaged, of another version or of another key is detected,
//! reported, and rebuilt over: it is never loaded wrong. Files are written to a temporary
//! name and renamed, so a build stopped half-way leaves nothing a later start could read.

use super::build::{Obstacle, Surface};
use super::{Voxmap, VoxmapConfig};
use nalgebra::Vector3;
use parry3d_f64::math::Pose;
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What comes first in a cache file.
const MAGIC: &[u8; 8] = b"HRRTCVOX";
/// Bumped whenever the build or the layout changes what a voxmap holds.
const VERSION: u32 = 1;

/// The folder voxmaps are kept in by default: `$XDG_CACHE_HOME/hrrtc/voxmaps` (or the
/// platform's cache folder), `None` where the platform has none.
pub fn default_dir() -> Option<PathBuf> {
    dirs::cache_dir().map(|d| d.join("hrrtc").join("voxmaps"))
}

/// Why a cache file was not used.
#[derive(Debug, thiserror::Error)]
pub enum CacheError {
    /// It could not be read or written.
    #[error("{path}: {error}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the system said.
        error: std::io::Error,
    },
    /// Its content is not a voxmap of this key and version.
    #[error("{path}: {reason}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        reason: String,
    },
}

/// The cache key of building `obstacles` with `config`.
pub fn key(obstacles: &[Obstacle], config: &VoxmapConfig) -> Option<[u8; 32]> {
    let mut h = Sha256::new();
    h.update(MAGIC);
    h.update(VERSION.to_le_bytes());
    h.update(config.voxel_m.to_le_bytes());
    h.update(config.layers_out.to_le_bytes());
    h.update(config.layers_in.to_le_bytes());
    h.update(config.shell_voxels.to_le_bytes());
    h.update((obstacles.len() as u64).to_le_bytes());
    let pose = |h: &mut Sha256, p: &Pose| {
        for x in [p.translation.x, p.translation.y, p.translation.z] {
            h.update(x.to_le_bytes());
        }
        for x in [p.rotation.x, p.rotation.y, p.rotation.z, p.rotation.w] {
            h.update(x.to_le_bytes());
        }
    };
    for o in obstacles {
        match o {
            Obstacle::Shape { pose: p, shape } => {
                pose(&mut h, p);
                if let Some(c) = shape.as_cuboid() {
                    h.update(b"box");
                    for x in [c.half_extents.x, c.half_extents.y, c.half_extents.z] {
                        h.update(x.to_le_bytes());
                    }
                } else if let Some(b) = shape.as_ball() {
                    h.update(b"ball");
                    h.update(b.radius.to_le_bytes());
                } else {
                    // A shape this key cannot describe: never cached.
                    return None;
                }
            }
            Obstacle::Mesh {
                pose: p,
                mesh,
                surface,
            } => {
                pose(&mut h, p);
                h.update(b"mesh");
                match surface {
                    Surface::Solid => h.update(b"solid"),
                    Surface::Shell { thickness_m } => {
                        h.update(b"shell");
                        h.update(thickness_m.to_le_bytes());
                    }
                }
                h.update((mesh.vertices_m.len() as u64).to_le_bytes());
                for v in &mesh.vertices_m {
                    for x in [v.x, v.y, v.z] {
                        h.update(x.to_le_bytes());
                    }
                }
                h.update((mesh.triangles.len() as u64).to_le_bytes());
                for t in &mesh.triangles {
                    for i in t {
                        h.update(i.to_le_bytes());
                    }
                }
            }
        }
    }
    Some(h.finalize().into())
}

/// The file of `key` in `dir`.
pub fn path(dir: &Path, key: &[u8; 32]) -> PathBuf {
    let hex: String = key.iter().map(|b| format!("{b:02x}")).collect();
    dir.join(format!("{hex}.voxmap"))
}

/// Writes `v` as the voxmap of `key` into `dir` (created if missing).
pub fn store(dir: &Path, key: &[u8; 32], v: &Voxmap) -> Result<PathBuf, CacheError> {
    let target = path(dir, key);
    let io = |error| CacheError::Io {
        path: target.clone(),
        error,
    };
    std::fs::create_dir_all(dir).map_err(io)?;
    let mut bytes =
        Vec::with_capacity(256 + v.index.len() * 4 + v.block_distance.len() * 2 + v.data.len() * 2);
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&VERSION.to_le_bytes());
    bytes.extend_from_slice(key);
    for x in [v.origin.x, v.origin.y, v.origin.z, v.h] {
        bytes.extend_from_slice(&x.to_le_bytes());
    }
    for n in v.blocks {
        bytes.extend_from_slice(&(n as u64).to_le_bytes());
    }
    bytes.extend_from_slice(&v.layers_out.to_le_bytes());
    for n in [v.index.len(), v.block_distance.len(), v.data.len()] {
        bytes.extend_from_slice(&(n as u64).to_le_bytes());
    }
    for x in &v.index {
        bytes.extend_from_slice(&x.to_le_bytes());
    }
    for x in &v.block_distance {
        bytes.extend_from_slice(&x.to_le_bytes());
    }
    for x in &v.data {
        bytes.extend_from_slice(&x.to_le_bytes());
    }
    let digest: [u8; 32] = Sha256::digest(&bytes).into();
    bytes.extend_from_slice(&digest);
    // A temporary name first: a reader never sees half a file.
    let partial = target.with_extension(format!("partial{}", std::process::id()));
    std::fs::write(&partial, &bytes).map_err(|error| CacheError::Io {
        path: partial.clone(),
        error,
    })?;
    std::fs::rename(&partial, &target).map_err(io)?;
    Ok(target)
}

/// Reads the voxmap of `key` from `dir`: `Ok(None)` when there is no such file, an error
/// when there is one that cannot be used (the caller rebuilds and writes over it).
pub fn load(dir: &Path, key: &[u8; 32]) -> Result<Option<Voxmap>, CacheError> {
    let file = path(dir, key);
    let started = Instant::now();
    let bytes = match std::fs::read(&file) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(error) => return Err(CacheError::Io { path: file, error }),
    };
    let invalid = |reason: String| CacheError::Invalid {
        path: file.clone(),
        reason,
    };
    if bytes.len() < 32 {
        return Err(invalid(format!("{} bytes: truncated", bytes.len())));
    }
    let (body, digest) = bytes.split_at(bytes.len() - 32);
    if Sha256::digest(body).as_slice() != digest {
        return Err(invalid("checksum mismatch: truncated or damaged".into()));
    }
    let mut r = Reader { bytes: body, at: 0 };
    let short = || "shorter than its header says".to_owned();
    if r.take(8).ok_or_else(short).map_err(invalid)? != MAGIC {
        return Err(invalid("not a voxmap cache file".into()));
    }
    let version = r.u32().ok_or_else(short).map_err(invalid)?;
    if version != VERSION {
        return Err(invalid(format!(
            "format version {version}, this build reads {VERSION}"
        )));
    }
    if r.take(32).ok_or_else(short).map_err(invalid)? != key {
        return Err(invalid("built from other inputs (key mismatch)".into()));
    }
    let f = |r: &mut Reader| r.u64().map(f64::from_bits);
    let (ox, oy, oz, h) = (|| Some((f(&mut r)?, f(&mut r)?, f(&mut r)?, f(&mut r)?)))()
        .ok_or_else(short)
        .map_err(invalid)?;
    let blocks = (|| Some([r.u64()? as usize, r.u64()? as usize, r.u64()? as usize]))()
        .ok_or_else(short)
        .map_err(invalid)?;
    let layers_out = r.u32().ok_or_else(short).map_err(invalid)?;
    let lens = (|| Some([r.u64()? as usize, r.u64()? as usize, r.u64()? as usize]))()
        .ok_or_else(short)
        .map_err(invalid)?;
    let total = blocks.iter().try_fold(1usize, |a, &b| a.checked_mul(b));
    if total != Some(lens[0]) || lens[1] != lens[0] || lens[2] % super::BLOCK_NODES != 0 {
        return Err(invalid("inconsistent sizes".into()));
    }
    if !(h.is_finite() && h > 0.0 && [ox, oy, oz].iter().all(|x| x.is_finite())) {
        return Err(invalid("a bad grid".into()));
    }
    let index: Vec<u32> = r
        .array(lens[0], u32::from_le_bytes)
        .ok_or_else(short)
        .map_err(invalid)?;
    let block_distance: Vec<u16> = r
        .array(lens[1], u16::from_le_bytes)
        .ok_or_else(short)
        .map_err(invalid)?;
    let data: Vec<i16> = r
        .array(lens[2], i16::from_le_bytes)
        .ok_or_else(short)
        .map_err(invalid)?;
    if r.at != body.len() {
        return Err(invalid("longer than its header says".into()));
    }
    let stored = (lens[2] / super::BLOCK_NODES) as u32;
    if index.iter().any(|&c| c >= super::FIRST + stored) {
        return Err(invalid("a block index out of range".into()));
    }
    let mut voxmap = Voxmap::from_parts(
        Vector3::new(ox, oy, oz),
        h,
        blocks,
        index,
        block_distance,
        data,
        layers_out,
    );
    voxmap.report.loaded_in = Some(started.elapsed());
    Ok(Some(voxmap))
}

/// Little-endian fields read in order.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Option<&[u8]> {
        let end = self.at.checked_add(n)?;
        let s = self.bytes.get(self.at..end)?;
        self.at = end;
        Some(s)
    }

    fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }

    fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }

    fn array<T, const W: usize>(&mut self, n: usize, from: fn([u8; W]) -> T) -> Option<Vec<T>> {
        let raw = self.take(n.checked_mul(W)?)?;
        Some(
            raw.chunks_exact(W)
                .map(|c| from(c.try_into().expect("chunks of W bytes")))
                .collect(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use parry3d_f64::shape::SharedShape;
    use scene::MeshData;
    use std::sync::Arc;

    fn obstacles() -> Vec<Obstacle> {
        vec![
            Obstacle::Shape {
                pose: Pose::translation(0.0, 0.0, -0.01),
                shape: SharedShape::cuboid(0.05, 0.05, 0.01),
            },
            Obstacle::Mesh {
                pose: Pose::translation(0.0, 0.0, 0.03),
                mesh: Arc::new(MeshData::bumpy_sphere("sphere", 0.02, 10, 20)),
                surface: Surface::Solid,
            },
        ]
    }

    fn config() -> VoxmapConfig {
        VoxmapConfig {
            voxel_m: 0.002,
            ..VoxmapConfig::default()
        }
    }

    fn same(a: &Voxmap, b: &Voxmap) {
        assert_eq!(a.origin, b.origin);
        assert_eq!((a.h, a.blocks, a.layers_out), (b.h, b.blocks, b.layers_out));
        assert_eq!(a.index, b.index);
        assert_eq!(a.block_distance, b.block_distance);
        assert_eq!(a.data, b.data);
    }

    #[test]
    fn a_stored_voxmap_loads_identical_and_damage_is_detected() {
        let dir = std::env::temp_dir().join(format!("hrrtc-voxcache-{}", std::process::id()));
        let (o, c) = (obstacles(), config());
        let v = Voxmap::build_obstacles(&o, &c, &Default::default()).unwrap();
        let k = key(&o, &c).unwrap();
        assert!(load(&dir, &k).unwrap().is_none(), "nothing there yet");
        let file = store(&dir, &k, &v).unwrap();
        same(&load(&dir, &k).unwrap().unwrap(), &v);
        let good = std::fs::read(&file).unwrap();
        // One byte flipped anywhere, the file truncated, another key's file under this name.
        for at in [0, 9, 50, good.len() / 2, good.len() - 1] {
            let mut bad = good.clone();
            bad[at] ^= 0x10;
            std::fs::write(&file, &bad).unwrap();
            assert!(load(&dir, &k).is_err(), "byte {at} flipped");
        }
        std::fs::write(&file, &good[..good.len() - 100]).unwrap();
        assert!(matches!(load(&dir, &k), Err(CacheError::Invalid { .. })));
        let other = key(&o[..1], &c).unwrap();
        store(&dir, &other, &v).unwrap();
        std::fs::rename(path(&dir, &other), &file).unwrap();
        let e = load(&dir, &k).unwrap_err().to_string();
        assert!(e.contains("key mismatch"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn the_key_follows_every_input() {
        let (o, c) = (obstacles(), config());
        let k = key(&o, &c).unwrap();
        assert_eq!(key(&o, &c), Some(k));
        let finer = VoxmapConfig {
            voxel_m: 0.001,
            ..c
        };
        assert_ne!(key(&o, &finer), Some(k));
        let layers = VoxmapConfig { layers_in: 7, ..c };
        assert_ne!(key(&o, &layers), Some(k));
        let mut moved = o.clone();
        if let Obstacle::Shape { pose, .. } = &mut moved[0] {
            pose.translation.x += 1e-9;
        }
        assert_ne!(key(&moved, &c), Some(k));
        let mut bent = o.clone();
        if let Obstacle::Mesh { mesh, .. } = &mut bent[1] {
            let mut m = (**mesh).clone();
            m.vertices_m[3].z += 1e-9;
            *mesh = Arc::new(m);
        }
        assert_ne!(key(&bent, &c), Some(k));
        let mut shell = o.clone();
        if let Obstacle::Mesh { surface, .. } = &mut shell[1] {
            *surface = Surface::Shell { thickness_m: 0.004 };
        }
        assert_ne!(key(&shell, &c), Some(k));
    }
}
