//! The view-independent triangle list of a dense mesh row by row, without a traversal (the
//! mesh of SOAR's longest-edge bisection, Lindstrom & Pascucci 2001; seed 004 chapter 4.5).
//!
//! The kept set of a view-independent mesh is closed under the hierarchy (errors are nested, so
//! every kept vertex's parents are kept), and then the mesh is known vertex by vertex: every
//! kept vertex `v` other than the corners `(0, 0)` and `(n, n)` is the apex of the (up to) four
//! triangles its diamond is split into, `(D_k, D_k+1, v)` for the diamond's corners
//! `D_0 .. D_3` counter-clockwise, and each of them is in the mesh exactly when its own split
//! vertex (the midpoint of `D_k D_k+1`) is not kept, or it is a leaf. A centre of a square of
//! side `2s` has the square's corners `v + s (+-1, +-1)`; a midpoint of a side of `2s`, the
//! side's ends and `v + s (0, +-1)` or `v + s (+-1, 0)`. The corners `(n, 0)` and `(0, n)` act
//! as the apexes of the two roots.
//!
//! Row `y` (lowest set bit `t`) holds the midpoints of horizontal sides of `2s` at `x = s mod
//! 2s` for every `s < t`, the centres of squares of side `2t` at `x = t mod 2t` and the
//! midpoints of vertical sides of `2t` at `x = 0 mod 2t`. Each kind is one pass over the row's
//! words of the bitmap, and each of a kind's four triangles is decided for 64 vertices at once:
//! the word of kept vertices of the kind less the word of their split vertices, read at the
//! split's offset. Vertices are numbered by rank: for the 64 columns of one word,
//! `rank(q + x) = rank(q) + popcount(bits(q .. q + 64) & (2^x - 1))`, one window per corner
//! and word. On Big Tujunga (513^2, E = 5 m, 28% of the samples kept) the extraction took
//! 1.36x less time than by the recursive walk, but on sparse meshes a pass pays for every word
//! of the row (`bench-peers/martini/ab_mesh.sh`, BENCHMARKS.md): [`Refiner`](super::Refiner)
//! takes it for dense selections only.

use super::{Slot, ViSquare, IDX};

/// Which of a kind's four triangles lie inside the grid in a row (bit `k`: triangle `k`).
const ALL: u8 = 0b1111;

impl<O: Slot<[u32; 3]>> ViSquare<'_, '_, O> {
    /// Bits `q .. q + 64` of the bitmap as one word, bit `i` for grid index `q + i` (zero
    /// outside the grid; `q` may be negative).
    #[inline(always)]
    fn window(&self, q: i64) -> u64 {
        let (k, o) = (q.div_euclid(64), q.rem_euclid(64) as u32);
        let word = |k: i64| match usize::try_from(k) {
            Ok(k) => self.bits.get(k).copied().unwrap_or(0),
            Err(_) => 0,
        };
        let hi = if o == 0 { 0 } else { word(k + 1) << (64 - o) };
        (word(k) >> o) | hi
    }

    /// Kept vertices before grid index `q` (0 for `q <= 0`). Dense selections only: the rank
    /// prefix of a word without kept vertices is then valid as well.
    #[inline(always)]
    fn rank_before(&self, q: i64) -> u32 {
        match u64::try_from(q) {
            Ok(q) if q > 0 => (self.vertex(q & IDX) >> 32) as u32,
            _ => 0,
        }
    }

    /// Writes the whole mesh of a square grid row by row (see the module's comment): the same
    /// triangles as the walk from the two roots, in another order.
    #[inline(always)]
    pub(super) fn rows(&mut self) {
        let n = self.side;
        // Row 0: midpoints of the bottom side's pieces, the upper halves of their diamonds
        // (triangles 0 and 1); `(n, 0)` is the first root's apex.
        let mut s = 1;
        while s <= n {
            self.kind(0, s, s, false, 0b0011);
            s <<= 1;
        }
        for y in 1..n {
            let t = y & y.wrapping_neg();
            let mut s = 1;
            while s < t {
                self.kind(y, s, s, false, ALL);
                s <<= 1;
            }
            self.kind(y, t, t, true, ALL);
            self.kind(y, t, 0, false, ALL);
        }
        // Row n: the lower halves (triangles 2 and 3); `(0, n)` is the second root's apex.
        let mut s = 1;
        while s < n {
            self.kind(n, s, s, false, 0b1100);
            s <<= 1;
        }
        self.kind(n, n, 0, false, 0b1100);
    }

    /// The kept vertices of row `y` at `x = r mod 2s` (`centre`: centres of squares of side
    /// `2s`, else midpoints of sides of `2s`), each with those of its triangles `tris` allows
    /// (bit `k`) that are in the mesh.
    #[inline(always)]
    fn kind(&mut self, y: u64, s: u64, r: u64, centre: bool, tris: u8) {
        let n = self.side;
        let (si, wi) = (s as i64, n as i64 + 1);
        // The diamond's corners counter-clockwise from the first quadrant, and each triangle's
        // split vertex, as grid-index offsets from the vertex.
        let (corner, split): ([i64; 4], [i64; 4]) = if centre {
            (
                [si * wi + si, si * wi - si, -si * wi - si, -si * wi + si],
                [si * wi, -si, -si * wi, si],
            )
        } else {
            let h = si / 2;
            (
                [si, si * wi, -si, -si * wi],
                [h * wi + h, h * wi - h, -h * wi - h, -h * wi + h],
            )
        };
        let leaf = !centre && s == 1;
        let columns = kind_columns(s, r, 0);
        let words = (n / 64 + 1) as usize;
        let last = (n % 64) as u32;
        for j in 0..words {
            let p = (y * (n + 1)) as i64 + 64 * j as i64;
            let mut of_kind = if 2 * s <= 64 {
                columns
            } else {
                kind_columns(s, r, j)
            };
            // Columns past `x = n` are the next row's.
            let is_last = j + 1 == words;
            if is_last && last != 63 {
                of_kind &= (2u64 << last) - 1;
            }
            let here = self.window(p);
            let kept = here & of_kind;
            if kept == 0 {
                continue;
            }
            // A midpoint at `x = 0` has no left half (triangles 1 and 2), one at `x = n` no
            // right half (triangles 3 and 0).
            let (no_left, no_right) = if centre {
                (0, 0)
            } else {
                (u64::from(j == 0), if is_last { 1u64 << last } else { 0 })
            };
            let inside = [!no_right, !no_left, !no_left, !no_right];
            let rank = self.rank_before(p);
            let mut base = [0u32; 4];
            let mut win = [0u64; 4];
            for k in 0..4 {
                base[k] = self.rank_before(p + corner[k]);
                win[k] = self.window(p + corner[k]);
            }
            for k in 0..4 {
                if tris & (1 << k) == 0 {
                    continue;
                }
                let k1 = (k + 1) & 3;
                let mut emit = kept & inside[k];
                if !leaf {
                    emit &= !self.window(p + split[k]);
                }
                while emit != 0 {
                    let below = (1u64 << emit.trailing_zeros()) - 1;
                    emit &= emit - 1;
                    self.out.put([
                        base[k] + (win[k] & below).count_ones(),
                        base[k1] + (win[k1] & below).count_ones(),
                        rank + (here & below).count_ones(),
                    ]);
                }
            }
        }
    }
}

/// The columns `x = r mod 2s` (`s` a power of two, `r < 2s`) of word `j` of a row, as bits
/// (`x = 64 j + bit`).
#[inline(always)]
fn kind_columns(s: u64, r: u64, j: usize) -> u64 {
    if 2 * s <= 64 {
        // Every `2s`-th bit from `r`: a repeating pattern.
        let mut m = 0u64;
        let mut p = r;
        while p < 64 {
            m |= 1 << p;
            p += 2 * s;
        }
        m
    } else {
        u64::from((64 * j as u64) % (2 * s) == r)
    }
}
