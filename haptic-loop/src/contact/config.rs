//! What contact rendering is configured with: [`ContactConfig`] and the virtual
//! coupling's gains ([`Coupling`]), derived from the device's specification.

use super::{ContactError, Resolution, VoxmapConfig};
use devices::DeviceSpec;

/// Parameters of contact rendering. Gains of the coupling are not here: they are derived from
/// the device's specification (see [`Coupling::from_spec`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactConfig {
    /// The voxmap's voxel size and distance layers; the pointshell uses the same spacing.
    pub voxmap: VoxmapConfig,
    /// Penalty stiffness per penetrating point, N/m.
    pub point_stiffness_n_per_m: f64,
    /// Total contact damping along the normals, shared among the penetrating points, N·s/m.
    pub contact_damping_n_s_per_m: f64,
    /// Thickness of the proximity layer, in voxels (≤ `voxmap.layers_out` − 1).
    pub proximity_voxels: f64,
    /// Total pre-contact braking damping, shared among the approaching points in the
    /// proximity layer, N·s/m.
    pub braking_n_s_per_m: f64,
    /// Mass of the proxy object, kg. Its inertia follows from its shape at uniform density.
    pub proxy_mass_kg: f64,
    /// Fraction (0, 1] of the device's stable stiffness and damping the coupling uses.
    pub coupling_fraction: f64,
    /// Contact is released only when no point is closer than this to the surface, in
    /// voxels (hysteresis against chatter of the contact flag).
    pub release_voxels: f64,
    /// Which of the pointshell's levels of detail is rendered: a fixed one, or the finest
    /// that fits a per-tick point budget (see [`Resolution`]).
    pub resolution: Resolution,
    /// How far any point of the proxy may travel in one step while some point is within
    /// reach of a surface, in voxels (see `ContactStage::step`): a point entering contact
    /// is found at most this deep, whatever pulls on the proxy.
    pub max_travel_voxels: f64,
}

impl Default for ContactConfig {
    fn default() -> Self {
        Self {
            voxmap: VoxmapConfig::default(),
            point_stiffness_n_per_m: 10_000.0,
            contact_damping_n_s_per_m: 40.0,
            proximity_voxels: 2.0,
            braking_n_s_per_m: 20.0,
            proxy_mass_kg: 0.05,
            coupling_fraction: 0.75,
            release_voxels: 0.25,
            resolution: Resolution::DEFAULT,
            max_travel_voxels: 0.5,
        }
    }
}

impl ContactConfig {
    /// The defaults with voxels (and pointshell spacing) of `voxel_m` metres.
    pub fn with_voxel_m(voxel_m: f64) -> Self {
        Self {
            voxmap: VoxmapConfig {
                voxel_m,
                ..VoxmapConfig::default()
            },
            ..Self::default()
        }
    }

    /// Checks every field; the error names the field.
    pub fn validate(&self) -> Result<(), ContactError> {
        let positive = [
            (self.point_stiffness_n_per_m, "point stiffness (N/m)"),
            (self.proxy_mass_kg, "proxy mass (kg)"),
            (self.coupling_fraction, "coupling fraction"),
            (self.max_travel_voxels, "travel per step (voxels)"),
        ];
        for (v, name) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(ContactError::Parameter {
                    name,
                    need: "> 0",
                    value: v,
                });
            }
        }
        let non_negative = [
            (self.contact_damping_n_s_per_m, "contact damping (N·s/m)"),
            (self.braking_n_s_per_m, "braking damping (N·s/m)"),
            (self.proximity_voxels, "proximity layer (voxels)"),
            (self.release_voxels, "release distance (voxels)"),
        ];
        for (v, name) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ContactError::Parameter {
                    name,
                    need: "≥ 0",
                    value: v,
                });
            }
        }
        if self.coupling_fraction > 1.0 {
            return Err(ContactError::Parameter {
                name: "coupling fraction",
                need: "≤ 1",
                value: self.coupling_fraction,
            });
        }
        self.resolution
            .validate()
            .map_err(ContactError::Resolution)?;
        let layer = f64::from(self.voxmap.layers_out) - 1.0;
        if self.proximity_voxels > layer || self.release_voxels > layer {
            return Err(ContactError::Layers {
                proximity_voxels: self.proximity_voxels,
                release_voxels: self.release_voxels,
                layer_voxels: layer,
            });
        }
        Ok(())
    }
}

/// Spring-damper gains of the virtual coupling, scene side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coupling {
    /// Translational stiffness, N per scene metre.
    pub k_n_per_m: f64,
    /// Translational damping, N·s per scene metre.
    pub b_n_s_per_m: f64,
    /// Rotational stiffness, N·m/rad.
    pub k_nm_per_rad: f64,
    /// Rotational damping, N·m·s/rad.
    pub b_nm_s_per_rad: f64,
}

impl Coupling {
    /// Gains such that the device feels `fraction` of its stable limits: a scene-side
    /// stiffness k is felt as `position_scale·k` per device metre (see `mapping`), so the
    /// translational gains are divided by the scale; rotations are not scaled.
    pub fn from_spec(spec: &DeviceSpec, position_scale: f64, fraction: f64) -> Self {
        Self {
            k_n_per_m: fraction * spec.limits.max_stiffness_n_per_m / position_scale,
            b_n_s_per_m: fraction * spec.limits.max_damping_n_s_per_m / position_scale,
            k_nm_per_rad: fraction * spec.limits.max_rot_stiffness_nm_per_rad,
            b_nm_s_per_rad: fraction * spec.limits.max_rot_damping_nm_s_per_rad,
        }
    }
}
