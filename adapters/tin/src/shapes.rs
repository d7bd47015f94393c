//! The samples small lattice triangles cover, by shape, computed once per shape.
//!
//! Near full resolution most of a greedy TIN's triangles span a few samples, and rasterising
//! each one row by row (three edge divisions per row, trimming the corners off every span) costs
//! more in branches than reading its handful of samples. A triangle's covered samples relative
//! to its first corner depend only on its shape (the two other corners relative to the first),
//! so for shapes within a small box the list of covered samples other than the corners is
//! rasterised once, by the same [`for_each_span`], and reused by every triangle of that shape.

use crate::scan::for_each_span;

/// Largest corner offset handled: `|dx| <= K`, `0 <= dy <= K`.
const K: i64 = 7;
/// Number of offsets `(dx, dy)` of one corner: `(2K + 1) (K + 1)`.
const SIDE: usize = ((2 * K + 1) * (K + 1)) as usize;
/// Marks a shape whose samples are not listed yet.
const UNSET: u32 = u32::MAX;

/// Covered samples by shape, filled in as shapes are met.
#[derive(Debug)]
pub(crate) struct Shapes {
    /// Per shape: `start << 8 | len` into `offsets`, or [`UNSET`].
    index: Vec<u32>,
    /// Sample offsets `(dx, dy)` from the first corner, in row order (`dy`, then `dx`).
    offsets: Vec<(i8, u8)>,
}

impl Default for Shapes {
    fn default() -> Self {
        Shapes {
            index: vec![UNSET; SIDE * SIDE],
            offsets: Vec::new(),
        }
    }
}

/// Index of corner offset `(dx, dy)` among the [`SIDE`] offsets, if within the box.
#[inline(always)]
fn offset_key(d: (i64, i64)) -> Option<usize> {
    if d.0.abs() <= K && (0..=K).contains(&d.1) {
        Some(((d.0 + K) * (K + 1) + d.1) as usize)
    } else {
        None
    }
}

impl Shapes {
    /// The samples other than the corners covered by the triangle `(0, 0)`, `d1`, `d2`, as
    /// offsets from `(0, 0)` in row order (`dy`, then `dx`: the order in which the span scan
    /// meets them); `None` if a corner lies outside the box of listed shapes. The corners must
    /// be sorted by `(y, x)`, so `d1` and `d2` have `dy >= 0`.
    #[inline]
    pub(crate) fn samples(&mut self, d1: (i64, i64), d2: (i64, i64)) -> Option<&[(i8, u8)]> {
        let key = offset_key(d1)? * SIDE + offset_key(d2)?;
        let mut packed = *self.index.get(key)?;
        if packed == UNSET {
            packed = self.rasterise(d1, d2);
            if let Some(slot) = self.index.get_mut(key) {
                *slot = packed;
            }
        }
        let (start, len) = ((packed >> 8) as usize, (packed & 0xff) as usize);
        self.offsets.get(start..start + len)
    }

    /// Lists the shape's samples at the end of `offsets`; returns its packed index entry.
    #[cold]
    fn rasterise(&mut self, d1: (i64, i64), d2: (i64, i64)) -> u32 {
        let start = self.offsets.len();
        let corners = [(0, 0), d1, d2];
        for_each_span((0, 0), d1, d2, |y, lo, hi| {
            for x in lo..=hi {
                if !corners.contains(&(x, y)) {
                    // Within the box: |x| <= K and 0 <= y <= K.
                    self.offsets.push((x as i8, y as u8));
                }
            }
        });
        // At most (K + 1) (2K + 1) = 120 samples: the length fits in 8 bits.
        ((start as u32) << 8) | (self.offsets.len() - start) as u32
    }
}
