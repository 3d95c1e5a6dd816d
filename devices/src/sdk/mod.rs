//! Haptic arms through their vendor SDKs, loaded at run time with `libloading`, so that
//! building needs no SDK: Force Dimension DHD ([`dhd`]) and 3D Systems OpenHaptics HD
//! ([`hd`]).
//!
//! Each backend converts units and frames at the edge. Our arm **device base frame** is
//! right-handed with X to the operator's right, Y away from the operator and Z up (the
//! scene's convention), origin at the vendor's workspace centre; positions in m, forces in
//! N, torques in N·m. The end-effector orientation is expressed with the same relabelling
//! on both sides (`C · R_vendor · Cᵀ`), so the handle at its rest orientation reads as
//! identity.

pub mod dhd;
pub mod hd;

use std::ffi::OsStr;
use std::path::PathBuf;

use libloading::Library;
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use thiserror::Error;

/// Why a vendor library could not be used. Rich (allocates): for `open`-time reporting.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum SdkError {
    /// The shared library could not be loaded.
    #[error("cannot load {library}: {reason}. {hint}")]
    Load {
        /// Library name or path tried.
        library: String,
        /// The dynamic loader's message.
        reason: String,
        /// What to check.
        hint: &'static str,
    },
    /// The library lacks a function we need (wrong library or too old an SDK).
    #[error("{library} has no symbol {symbol} (wrong library or SDK too old)")]
    Symbol {
        /// Library name or path.
        library: String,
        /// Missing C symbol.
        symbol: &'static str,
    },
}

/// Loads `path` (a file path, or a bare name searched by the dynamic loader).
fn load(path: &OsStr, hint: &'static str) -> Result<Library, SdkError> {
    // SAFETY: loading runs the library's initialisers. We load only the vendor SDK the user
    // pointed us at (or its standard name); that is the trust the vendor's own tools need.
    unsafe { Library::new(path) }.map_err(|e| SdkError::Load {
        library: path.to_string_lossy().into_owned(),
        reason: e.to_string(),
        hint,
    })
}

/// Copies the function pointer named `symbol` out of `lib`.
///
/// # Safety
/// `T` must be the exact C signature of `symbol`, and the returned pointer must not be
/// called after `lib` is dropped.
unsafe fn sym<T: Copy>(lib: &Library, library: &str, symbol: &'static str) -> Result<T, SdkError> {
    let mut name = Vec::with_capacity(symbol.len() + 1);
    name.extend_from_slice(symbol.as_bytes());
    name.push(0);
    // SAFETY: the caller guarantees `T` matches the symbol's C type.
    unsafe { lib.get::<T>(&name) }
        .map(|s| *s)
        .map_err(|_| SdkError::Symbol {
            library: library.to_string(),
            symbol,
        })
}

/// The library to load: `explicit`, else the environment variable `env`, else `default`
/// (searched on `LD_LIBRARY_PATH` and the loader cache).
pub fn library_path(explicit: Option<PathBuf>, env: &str, default: &str) -> PathBuf {
    explicit
        .or_else(|| std::env::var_os(env).map(PathBuf::from))
        .unwrap_or_else(|| PathBuf::from(default))
}

/// A vendor base frame relabelled into ours: `ours = C · vendor` for vectors.
#[derive(Debug, Clone, Copy)]
pub(crate) struct FrameMap {
    c: Matrix3<f64>,
}

impl FrameMap {
    pub(crate) const fn new(c: Matrix3<f64>) -> Self {
        FrameMap { c }
    }

    /// A vector (position, velocity, force, torque) from the vendor frame into ours.
    pub(crate) fn to_ours(self, v: Vector3<f64>) -> Vector3<f64> {
        self.c * v
    }

    /// A vector from our frame into the vendor's.
    pub(crate) fn to_vendor(self, v: Vector3<f64>) -> Vector3<f64> {
        self.c.transpose() * v
    }

    /// An end-effector rotation matrix from the vendor frame into ours; `None` if it is not
    /// a rotation (bad data from the device).
    pub(crate) fn rotation_to_ours(self, r: Matrix3<f64>) -> Option<UnitQuaternion<f64>> {
        if !r.iter().all(|x| x.is_finite()) {
            return None;
        }
        let m = self.c * r * self.c.transpose();
        // Orthonormal within sensor rounding; re-orthonormalise through the quaternion.
        let err = (m.transpose() * m - Matrix3::identity()).abs().max();
        if err > 1e-3 || m.determinant() < 0.0 {
            return None;
        }
        Some(UnitQuaternion::from_rotation_matrix(
            &Rotation3::from_matrix_unchecked(m),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_maps_are_proper_rotations() {
        for f in [dhd::FRAME, hd::FRAME] {
            assert!((f.c.determinant() - 1.0).abs() < 1e-12);
            let v = Vector3::new(0.1, -0.2, 0.3);
            assert!((f.to_vendor(f.to_ours(v)) - v).norm() < 1e-15);
            let q = f.rotation_to_ours(Matrix3::identity()).unwrap();
            assert!(q.angle() < 1e-12);
        }
        assert!(dhd::FRAME.rotation_to_ours(Matrix3::zeros()).is_none());
        let mirror = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0));
        assert!(dhd::FRAME.rotation_to_ours(mirror).is_none());
    }

    #[test]
    fn missing_library_error_names_it_and_what_to_check() {
        let e = load(OsStr::new("/nonexistent/libdhd.so"), "set HRRTC_DHD_LIB")
            .expect_err("no such file");
        let text = e.to_string();
        assert!(text.contains("/nonexistent/libdhd.so") && text.contains("HRRTC_DHD_LIB"));
    }
}
