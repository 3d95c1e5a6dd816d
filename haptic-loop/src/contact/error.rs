//! Why contact rendering could not be set up. Every message names the parameter or part.

use super::voxmap::VoxmapError;

/// Why the contact model or stage could not be built.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ContactError {
    /// A contact parameter is out of its range.
    #[error("contact: {name} must be {need}, got {value}")]
    Parameter {
        /// The parameter with its unit, e.g. `point stiffness (N/m)`.
        name: &'static str,
        /// The range it must be in, e.g. `> 0`.
        need: &'static str,
        /// The value given.
        value: f64,
    },
    /// The proximity or release distance does not fit in the voxmap's stored layers.
    #[error(
        "contact: proximity ({proximity_voxels}) and release ({release_voxels}) must fit in the stored layers outside minus one ({layer_voxels} voxels)"
    )]
    Layers {
        /// Proximity layer, voxels.
        proximity_voxels: f64,
        /// Release distance, voxels.
        release_voxels: f64,
        /// Stored layers outside minus one, voxels.
        layer_voxels: f64,
    },
    /// The resolution (level of detail or point budget) is out of range; the message says
    /// which value.
    #[error("contact: {0}")]
    Resolution(String),
    /// The voxmap of the obstacles could not be built.
    #[error(transparent)]
    Voxmap(#[from] VoxmapError),
    /// The pointshell spacing is not a positive number (m).
    #[error("pointshell: spacing must be positive, got {0} m")]
    Spacing(f64),
    /// A part of the moving object is too large to sample at this spacing.
    #[error(
        "pointshell: part {part} spans {cells:.0} cells at {spacing_mm} mm spacing; use a larger spacing"
    )]
    PartTooLarge {
        /// Index of the part in the moving object.
        part: usize,
        /// Cells its bounding box spans.
        cells: f64,
        /// Spacing, mm.
        spacing_mm: f64,
    },
    /// The moving object has no surface point to sample.
    #[error("pointshell: the moving object has no surface to sample")]
    NoSurface,
    /// A mesh of the scene without a surface to render (no triangle with an area, invalid
    /// data), or one built in code and never repaired that is not closed and outward: the
    /// voxmap's signs and the pointshell's inward normals would be wrong, so contact is
    /// refused rather than rendered wrong.
    #[error(
        "contact: mesh {source_file} ({field}) cannot be rendered: {reason}; repair it (`planner scenes check --fix FILE` says what it can repair) or run without contact (--no-contact)"
    )]
    Mesh {
        /// The part, e.g. `obstacles[2]`.
        field: String,
        /// The mesh file.
        source_file: String,
        /// Why it cannot be rendered.
        reason: String,
    },
    /// The build was stopped (its progress's cancel flag was set).
    #[error("contact: the pointshell's build was stopped")]
    Cancelled,
    /// The moving object has no volume (no mass properties for the proxy).
    #[error("contact: the moving object has no volume")]
    NoVolume,
}
