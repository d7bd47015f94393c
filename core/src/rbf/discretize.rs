//! CPU discretization of the RBF approximation into a cascade raster (Cornel, Horváth, Waser
//! 2022, section 4, last paragraph: eq. 2 evaluated at every visible texel). This is the
//! reference the GPU pass is checked against.

use super::cascade::Cascade;
use super::weight::Rbf;
use crate::Error;

/// Evaluates `rbf` at the centre of every visible texel of `cascade` (`mask` from
/// [`Cascade::mask`]) into `values`, and the cascade's blending weight there into `weights`
/// (all three `resolution^2` long, row-major). Texels that are not visible get value 0 and
/// weight 0. Returns the number of visible texels.
///
/// Each value is exactly [`Rbf::eval`] at [`Cascade::texel_center`]. Errors:
/// [`Error::BufferTooSmall`] when a buffer is too short. Work: visible texels times the size of
/// their influence sets.
///
/// ```
/// use relief_core::{Camera, Scale, rbf::*};
/// let cells = [Cell::new(0, 0, 32, 5.0), Cell::new(32, 0, 32, 5.0),
///              Cell::new(0, 32, 32, 5.0), Cell::new(32, 32, 32, 5.0)];
/// let mut index = vec![0; 64 * 64];
/// let grid = AdaptiveGrid::new(64, 64, &cells, &mut index).unwrap();
/// let opts = RbfOptions::default();
/// let mut o = vec![0; InfluenceSets::offsets_len(&grid)];
/// let mut e = vec![0; InfluenceSets::entries_len(&grid, &opts).unwrap()];
/// let sets = InfluenceSets::build(&grid, &opts, &mut o, &mut e).unwrap();
/// let rbf = Rbf::new(grid, sets, &opts).unwrap();
/// let cam = Camera::new(glam::Vec3::new(-10.0, 30.0, 20.0), glam::Vec3::new(30.0, 30.0, 0.0), 60.0, 64, 64).unwrap();
/// let c = fit_cascades(&cam, rbf.grid(), &Scale::default(), (5.0, 5.0), &CascadeOptions::default().with_resolution(32), None).unwrap();
/// let (mut mask, mut v, mut w) = (vec![0u8; 1024], vec![0f32; 1024], vec![0f32; 1024]);
/// c.cascades[0].mask(&mut mask).unwrap();
/// let n = discretize(&rbf, &c.cascades[0], &mask, &mut v, &mut w).unwrap();
/// assert!(n > 0);
/// assert!(v.iter().zip(&mask).all(|(&v, &m)| if m == 1 { v == 5.0 } else { v == 0.0 }));
/// ```
pub fn discretize(
    rbf: &Rbf<'_>,
    cascade: &Cascade,
    mask: &[u8],
    values: &mut [f32],
    weights: &mut [f32],
) -> Result<usize, Error> {
    let t = cascade.resolution as usize;
    let n = t.checked_mul(t).ok_or(Error::SizeOverflow)?;
    if t == 0 {
        return Ok(0);
    }
    let too_small = |actual: usize| Error::BufferTooSmall { needed: n, actual };
    let mask = mask.get(..n).ok_or(too_small(mask.len()))?;
    let values_len = values.len();
    let values = values.get_mut(..n).ok_or(too_small(values_len))?;
    let weights_len = weights.len();
    let weights = weights.get_mut(..n).ok_or(too_small(weights_len))?;
    let mut count = 0usize;
    let rows = mask
        .chunks_exact(t)
        .zip(values.chunks_exact_mut(t).zip(weights.chunks_exact_mut(t)));
    for (j, (mrow, (vrow, wrow))) in rows.enumerate() {
        let cells = mrow.iter().zip(vrow.iter_mut().zip(wrow.iter_mut()));
        for (i, (&m, (v, w))) in cells.enumerate() {
            if m == 0 {
                *v = 0.0;
                *w = 0.0;
                continue;
            }
            let p = cascade.texel_center(i as u32, j as u32);
            *v = rbf.eval(p).unwrap_or(0.0);
            *w = cascade.blend_weight(i as u32, j as u32);
            count += 1;
        }
    }
    Ok(count)
}
