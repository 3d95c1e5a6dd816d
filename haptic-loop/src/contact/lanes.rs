//! SIMD lanes as plain arrays: the contact search and the voxmap's lane look-up write each
//! statement over all [`LANES`] values of a chunk, which the compiler keeps in vector
//! registers.

/// Points processed together: eight `f32` fill an AVX2 register.
pub(super) const LANES: usize = 8;

/// One value per point of a chunk.
pub(super) type Lanes = [f32; LANES];

/// One value per lane. (A plain loop: `std::array::from_fn` is not always inlined, and
/// then nothing vectorises.)
#[inline(always)]
pub(super) fn lanes<T: Copy + Default>(f: impl Fn(usize) -> T) -> [T; LANES] {
    let mut out = [T::default(); LANES];
    for (l, o) in out.iter_mut().enumerate() {
        *o = f(l);
    }
    out
}

/// One value per axis.
#[inline(always)]
pub(super) fn axes<T>(f: impl Fn(usize) -> T) -> [T; 3] {
    [f(0), f(1), f(2)]
}
