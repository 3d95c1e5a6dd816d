//! Welding a triangle soup's vertices, and the hash maps with integer keys that mesh
//! processing (topology, repair) builds: the layer both stand on.

use nalgebra::Vector3;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// A fast hasher for the integer keys of mesh processing (vertex coordinate bits, welded vertex ids):
/// std's SipHash resists adversarial keys, which a mesh file is not worth guarding
/// against, at several times the cost on million-triangle meshes.
#[derive(Default)]
pub(crate) struct KeyHasher(u64);

impl Hasher for KeyHasher {
    fn write(&mut self, bytes: &[u8]) {
        let mut chunks = bytes.chunks_exact(8);
        for c in &mut chunks {
            let mut w = [0u8; 8];
            w.copy_from_slice(c);
            self.write_u64(u64::from_le_bytes(w));
        }
        let rest = chunks.remainder();
        if !rest.is_empty() {
            let mut w = [0u8; 8];
            w[..rest.len()].copy_from_slice(rest);
            self.write_u64(u64::from_le_bytes(w));
        }
    }

    fn write_u32(&mut self, x: u32) {
        self.write_u64(u64::from(x));
    }

    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(5) ^ x).wrapping_mul(0x517c_c1b7_2722_0a95);
    }

    fn write_usize(&mut self, x: usize) {
        self.write_u64(x as u64);
    }

    fn finish(&self) -> u64 {
        // MurmurHash3's finaliser: the table takes buckets from the low bits and tags from
        // the high ones, so every key bit must reach both.
        let mut h = self.0;
        h ^= h >> 33;
        h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
        h ^ (h >> 33)
    }
}

/// A hash map with [`KeyHasher`].
pub(crate) type KeyMap<K, V> = HashMap<K, V, BuildHasherDefault<KeyHasher>>;

/// An empty [`KeyMap`] with room for `capacity` entries.
pub(crate) fn key_map<K, V>(capacity: usize) -> KeyMap<K, V> {
    HashMap::with_capacity_and_hasher(capacity, BuildHasherDefault::default())
}

/// The welded index of every vertex: vertices at exactly the same position (with
/// −0 = +0) share one, numbered by first appearance.
pub fn weld(vertices: &[Vector3<f64>]) -> Vec<u32> {
    let key = |c: f64| if c == 0.0 { 0u64 } else { c.to_bits() };
    let mut ids: KeyMap<[u64; 3], u32> = key_map(vertices.len());
    vertices
        .iter()
        .map(|v| {
            let next = ids.len() as u32;
            *ids.entry([key(v.x), key(v.y), key(v.z)]).or_insert(next)
        })
        .collect()
}
