//! The contact sums' 6×6 matrices kept as 21 numbers: the force pass adds to them point by
//! point, the implicit step expands them once per tick.

use nalgebra::{Matrix3, Matrix6};

/// Σ w·JJᵀ for J = [n; r×n], kept as the three 3×3 blocks (21 numbers): the per-point cost
/// of the implicit step's contact stiffness is 21 multiply-adds instead of a 6×6 update.
/// Layout: `nn` and `mm` upper triangles row-major, `mn` = Σ w·m nᵀ row-major.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub(super) struct JtJ {
    pub nn: [f64; 6],
    pub mn: [f64; 9],
    pub mm: [f64; 6],
}

impl JtJ {
    /// `(1 − t)·self + t·other`, entry by entry.
    pub(super) fn lerp(&self, other: &Self, t: f64) -> Self {
        let mix = |a: f64, b: f64| a + t * (b - a);
        Self {
            nn: std::array::from_fn(|i| mix(self.nn[i], other.nn[i])),
            mn: std::array::from_fn(|i| mix(self.mn[i], other.mn[i])),
            mm: std::array::from_fn(|i| mix(self.mm[i], other.mm[i])),
        }
    }

    /// `scale · Σ w JJᵀ` as a 6×6 matrix ([force; torque] order).
    // Inline: in its own module it is no longer in the contact step's codegen unit, and a
    // call returns the 288-byte matrix through memory (measured with callgrind).
    #[inline]
    pub(super) fn matrix(&self, scale: f64) -> Matrix6<f64> {
        let sym = |v: &[f64; 6]| Matrix3::new(v[0], v[1], v[2], v[1], v[3], v[4], v[2], v[4], v[5]);
        let nn = sym(&self.nn) * scale;
        let mm = sym(&self.mm) * scale;
        let mn = Matrix3::from_row_slice(&self.mn) * scale;
        let mut out = Matrix6::zeros();
        out.fixed_view_mut::<3, 3>(0, 0).copy_from(&nn);
        out.fixed_view_mut::<3, 3>(3, 0).copy_from(&mn);
        out.fixed_view_mut::<3, 3>(0, 3).copy_from(&mn.transpose());
        out.fixed_view_mut::<3, 3>(3, 3).copy_from(&mm);
        out
    }
}
