//! An oriented box and the two tests the trees of them need: whether two boxes overlap
//! (the 15 separating axes of Gottschalk, Lin and Manocha's OBBTree) and a lower bound of
//! their distance along the same axes. The ground both [`super::obb_tree`] and
//! [`super::solid`] stand on.

use parry3d_f64::math::{Matrix, Vector};

/// An oriented box: `center` + `axes · (x, y, z)` for |x| ≤ half.x …, in the mesh frame.
#[derive(Debug, Clone, Copy)]
pub struct Obb {
    pub center: Vector,
    /// Orthonormal columns.
    pub axes: Matrix,
    pub half: Vector,
}

/// Slack added to |B| and to the extents so rounding never separates touching boxes.
const EPS: f64 = 1e-12;

/// The boxes `a` (frame 1) and `b` (frame 2, `x1 = r·x2 + t`) overlap: no separating axis
/// among the 15 of Gottschalk's test.
pub fn overlap(a: &Obb, b: &Obb, r: &Matrix, t: &Vector) -> bool {
    // b's axes and centre in a's box frame.
    let at = a.axes.transpose();
    let m = at * (*r * b.axes);
    let d = at * (*r * b.center + *t - a.center);
    let abs_m = Matrix::from_cols(
        m.x_axis.abs() + Vector::splat(EPS),
        m.y_axis.abs() + Vector::splat(EPS),
        m.z_axis.abs() + Vector::splat(EPS),
    );
    let (ha, hb) = (a.half + Vector::splat(EPS), b.half + Vector::splat(EPS));
    // a's face axes.
    let eb = abs_m * hb;
    if d.x.abs() > ha.x + eb.x || d.y.abs() > ha.y + eb.y || d.z.abs() > ha.z + eb.z {
        return false;
    }
    // b's face axes.
    let db = m.transpose() * d;
    let ea = abs_m.transpose() * ha;
    if db.x.abs() > hb.x + ea.x || db.y.abs() > hb.y + ea.y || db.z.abs() > hb.z + ea.z {
        return false;
    }
    // The nine cross products a_i × b_j (Gottschalk's table; m[(i, j)] = a_i · b_j).
    let mm = |i: usize, j: usize| m.col(j)[i];
    let am = |i: usize, j: usize| abs_m.col(j)[i];
    for i in 0..3 {
        let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
        for j in 0..3 {
            let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
            let dist = (d[i2] * mm(i1, j) - d[i1] * mm(i2, j)).abs();
            let ra = ha[i1] * am(i2, j) + ha[i2] * am(i1, j);
            let rb = hb[j1] * am(i, j2) + hb[j2] * am(i, j1);
            if dist > ra + rb {
                return false;
            }
        }
    }
    true
}

/// A lower bound of the distance between the boxes (m): their largest gap along the 15
/// axes of [`overlap`] (0 when they overlap along all of them).
pub fn gap(a: &Obb, b: &Obb, r: &Matrix, t: &Vector) -> f64 {
    let at = a.axes.transpose();
    let m = at * (*r * b.axes);
    let d = at * (*r * b.center + *t - a.center);
    let abs_m = Matrix::from_cols(m.x_axis.abs(), m.y_axis.abs(), m.z_axis.abs());
    let (ha, hb) = (a.half, b.half);
    let mut g = (d.abs() - ha - abs_m * hb).max_element();
    g = g.max(((m.transpose() * d).abs() - hb - abs_m.transpose() * ha).max_element());
    let mm = |i: usize, j: usize| m.col(j)[i];
    let am = |i: usize, j: usize| abs_m.col(j)[i];
    for i in 0..3 {
        let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
        for j in 0..3 {
            // |a_i × b_j| = sin of their angle; near-parallel pairs add nothing.
            let len = (1.0 - mm(i, j) * mm(i, j)).max(0.0).sqrt();
            if len < 1e-6 {
                continue;
            }
            let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
            let dist = (d[i2] * mm(i1, j) - d[i1] * mm(i2, j)).abs();
            let ra = ha[i1] * am(i2, j) + ha[i2] * am(i1, j);
            let rb = hb[j1] * am(i, j2) + hb[j2] * am(i, j1);
            g = g.max((dist - ra - rb) / len);
        }
    }
    g.max(0.0)
}
