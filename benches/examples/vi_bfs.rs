//! A yardstick for view-independent extraction (issue 3), not library code: the traversal of
//! `Refiner::triangles_popcnt` on a square grid (the kept-vertex bitmap with its rank prefix,
//! vertices packed with their ranks, the two finest levels without a branch) written six
//! ways over the same bitmap:
//! - *depth first*: the library's recursion up to 2026-12-06 afternoon, each child's split
//!   tested in its own call;
//! - *blocks*: depth first down to subtrees `B` levels above the leaves, then each subtree
//!   level by level, with no data-dependent branch: every triangle of a level is written to
//!   the output and counted only when its split vertex is not kept, and its two children are
//!   written to the next level and counted only when it is (ported to the library with
//!   `B = 10` and reverted, slower there: BENCHMARKS.md);
//! - *by vertex*: no traversal at all: each kept vertex is the apex of up to four triangles of
//!   its diamond, each in the mesh when its own split vertex is not kept (`Vi::by_vertex`);
//! - *depth first, children tested before the call*: the library's recursion from then until
//!   the evening of 2026-12-06 (`walk_known`), which writes a child that does not split without
//!   calling itself (the library now also walks the five finest levels inline, without calls).
//!
//! - *by padded rows* and *by masks* (2026-12-07): by vertex without a branch on the kind of
//!   vertex: rows aligned to words, one pass per kind of vertex in a row; by masks decides each
//!   triangle of a kind for 64 vertices at once and numbers vertices through a grid-sized map
//!   (`Vi::by_padded`, `Vi::by_mask`). `CLASSES=1` prints the kept vertices by level.
//!
//! All of them give the library's triangles (asserted on each case, as sets). The library
//! itself writes dense meshes row by row since 2026-12-07 (by masks without the map, each
//! vertex numbered by its rank: `core/src/refine/select/rows.rs`), so its column is that form
//! where at least a tenth of the samples are kept. Timed: each alone over the same bitmap,
//! fastest of `RUNS`, bitmap and output warm; the library's whole `triangles_popcnt` (selection and vertices included)
//! for scale; and writing the same number of triangles with nothing else, the floor of any
//! extraction into that buffer. Bundled Puget Sound DEM, E = 1, 5, 20 and 50 m.
//!
//! `cargo run --release -p relief-benches --example vi_bfs` (`RUNS=n`, `BLOCK=b` from 1 to 13,
//! default 10; `ONLY=e` one threshold; `RAW=path` a square grid of little-endian `f32` metres,
//! such as the peer script's `prep.py` writes, instead of Puget Sound)

use relief_core::refine::{
    hierarchy_len, preprocess, scratch_len, triangle_bound, Criterion, Refiner,
};
use relief_core::Heightfield;
use std::hint::black_box;
use std::time::Instant;

mod common;

const IDX: u64 = 0xffff_ffff;

/// The traversal state, as the library's `ViSquare` holds it (the output inside, so that the
/// recursion passes no more than the library's does).
struct Vi<'a, 'o> {
    bits: &'a [u64],
    prefix: &'a [u64],
    side: u64,
    o: Out<'o>,
}

struct Out<'o> {
    out: &'o mut [[u32; 3]],
    n: usize,
}

impl Out<'_> {
    #[inline(always)]
    fn put(&mut self, t: [u32; 3]) {
        self.put_if(t, 1);
    }
    /// Writes `t` and counts it when `count` is 1.
    #[inline(always)]
    fn put_if(&mut self, t: [u32; 3], count: usize) {
        if let Some(o) = self.out.get_mut(self.n) {
            *o = t;
        }
        self.n += count;
    }
}

#[inline(always)]
fn tri(a: u64, b: u64, c: u64) -> [u32; 3] {
    [(a >> 32) as u32, (b >> 32) as u32, (c >> 32) as u32]
}

#[inline(always)]
fn mid(l: u64, r: u64) -> u64 {
    ((l & IDX) + (r & IDX)) >> 1
}

impl Vi<'_, '_> {
    #[inline(always)]
    fn word(&self, i: u64) -> u64 {
        self.bits.get((i >> 6) as usize).copied().unwrap_or(0)
    }
    #[inline(always)]
    fn pack(&self, i: u64, word: u64) -> u64 {
        let below = word & ((1u64 << (i & 63)) - 1);
        let r =
            self.prefix.get((i >> 6) as usize).copied().unwrap_or(0) + below.count_ones() as u64;
        (i & IDX) | (r << 32)
    }
    #[inline(always)]
    fn vertex(&self, i: u64) -> u64 {
        self.pack(i, self.word(i))
    }
    #[inline(always)]
    fn split(&self, l: u64, r: u64) -> Option<u64> {
        let im = mid(l, r);
        let word = self.word(im);
        if (word >> (im & 63)) & 1 == 0 {
            return None;
        }
        Some(self.pack(im, word))
    }
    fn roots(&self) -> [(u64, u64, u64); 2] {
        let (n, w) = (self.side, self.side + 1);
        let (c00, c10, c01, c11) = (
            self.vertex(0),
            self.vertex(n),
            self.vertex(n * w),
            self.vertex(n * w + n),
        );
        [(c11, c00, c10), (c00, c11, c01)]
    }

    /// The library's `ViSquare::last`: triangle `(l, r, a)` one level above the leaves.
    #[inline(always)]
    fn last(&mut self, l: u64, r: u64, a: u64) {
        let im = mid(l, r);
        let word = self.word(im);
        let kept = (word >> (im & 63)) & 1;
        let m = self.pack(im, word);
        let keep = kept.wrapping_neg();
        let pick = |x: u64, y: u64| ((x & keep) | (y & !keep)) >> 32;
        let first = [pick(a, l) as u32, pick(l, r) as u32, pick(m, a) as u32];
        self.o.put_if(first, 1);
        self.o.put_if(tri(r, a, m), kept as usize);
    }

    /// The two levels above the leaves of triangle `(l, r, a)` split at `m`, as the library
    /// writes them (`depth` 1: both children; 2: [`Self::last`] for each); `false` for a deeper
    /// triangle, which recurses.
    #[inline(always)]
    fn near_leaves(&mut self, l: u64, r: u64, a: u64, m: u64, depth: u32) -> bool {
        match depth {
            1 => {
                self.o.put(tri(a, l, m));
                self.o.put(tri(r, a, m));
            }
            2 => {
                self.last(a, l, m);
                self.last(r, a, m);
            }
            _ => return false,
        }
        true
    }

    /// The library's recursion before 2026-12-06 afternoon (`vi_square_walk!`): each child's
    /// split tested inside its own call.
    #[target_feature(enable = "popcnt")]
    fn dfs(&mut self, l: u64, r: u64, a: u64, depth: u32) {
        let m = match self.split(l, r) {
            Some(m) if depth > 0 => m,
            _ => return self.o.put(tri(l, r, a)),
        };
        if !self.near_leaves(l, r, a, m, depth) {
            self.dfs(a, l, m, depth - 1);
            self.dfs(r, a, m, depth - 1);
        }
    }

    /// The library's recursion since (`walk_known` of `vi_square_walk!`): a triangle known to
    /// split at `m` tests each child's split before calling itself, so a child that does not
    /// split is written without a call (same triangles, same order).
    #[target_feature(enable = "popcnt")]
    fn dfs_known(&mut self, l: u64, r: u64, a: u64, m: u64, depth: u32) {
        if self.near_leaves(l, r, a, m, depth) {
            return;
        }
        for (p, q, c) in [(a, l, m), (r, a, m)] {
            match self.split(p, q) {
                Some(s) => self.dfs_known(p, q, c, s, depth - 1),
                None => self.o.put(tri(p, q, c)),
            }
        }
    }

    /// Depth first down to `block` levels above the leaves, then [`Self::levels`].
    #[target_feature(enable = "popcnt")]
    fn blocks(&mut self, buf: &mut Bufs, t: (u64, u64, u64), depth: u32, block: u32) {
        if depth <= block {
            return self.levels(buf, t, depth);
        }
        let (l, r, a) = t;
        let Some(m) = self.split(l, r) else {
            return self.o.put(tri(l, r, a));
        };
        self.blocks(buf, (a, l, m), depth - 1, block);
        self.blocks(buf, (r, a, m), depth - 1, block);
    }

    /// The subtree of `t` level by level, no data-dependent branch.
    #[target_feature(enable = "popcnt")]
    fn levels(&mut self, buf: &mut Bufs, t: (u64, u64, u64), depth: u32) {
        let (mut cur, mut next) = (&mut buf.a, &mut buf.b);
        cur[0] = [t.0, t.1, t.2];
        let mut nc = 1usize;
        let mut d = depth;
        while d >= 2 {
            let mut nn = 0usize;
            for k in 0..nc {
                let [l, r, a] = cur[k & MASK];
                let im = mid(l, r);
                let word = self.word(im);
                let kept = ((word >> (im & 63)) & 1) as usize;
                let m = self.pack(im, word);
                self.o.put_if(tri(l, r, a), 1 - kept);
                next[nn & MASK] = [a, l, m];
                next[(nn + 1) & MASK] = [r, a, m];
                nn += 2 * kept;
            }
            core::mem::swap(&mut cur, &mut next);
            nc = nn;
            d -= 1;
        }
        // `depth >= 1` (a block is at least one level), so the loop leaves `d == 1`.
        for &[l, r, a] in &cur[..nc.min(CAP)] {
            self.last(l, r, a);
        }
    }
}

impl Vi<'_, '_> {
    /// Whether vertex `i` is kept.
    #[inline(always)]
    fn kept(&self, i: u64) -> u64 {
        (self.word(i) >> (i & 63)) & 1
    }

    /// The rank (vertex number) of grid index `i`.
    #[inline(always)]
    fn rank(&self, i: u64) -> u32 {
        (self.pack(i, self.word(i)) >> 32) as u32
    }

    /// The mesh by kept vertex, no traversal: every kept vertex `v` other than the corner
    /// `(0, 0)` is the apex of the (up to) four triangles its diamond splits into, `(D_k,
    /// D_k+1, v)` for the diamond's corners `D_0..D_3` counter-clockwise (a centre of a square
    /// of side `2h`: `v + h (+-1, +-1)`; a side's midpoint: `v + h (+-1, 0), (0, +-1)`, where `h`
    /// is the lowest set bit of `x | y`); each is in the mesh when its own split vertex, the
    /// midpoint of `D_k D_k+1`, is not kept (or it is a leaf, a side's midpoint with `h = 1`).
    /// The kept set is closed under the hierarchy (nested errors), so every such triangle's
    /// ancestors split. The corners `(n, 0)` and `(0, n)` act as the apexes of the two roots.
    #[target_feature(enable = "popcnt")]
    fn by_vertex(&mut self) {
        let n = self.side as i64;
        let w = n + 1;
        let (mut y, mut row) = (0i64, 0i64);
        // Diamond corners as grid-index offsets for h = 1: a side's midpoint, a centre.
        let be = [1, w, -1, -w];
        let bc = [1 + w, w - 1, -1 - w, 1 - w];
        for (wi, &word) in self.bits.iter().enumerate() {
            let mut b = word;
            while b != 0 {
                let i = (wi as i64) * 64 + i64::from(b.trailing_zeros());
                b &= b - 1;
                while i >= row + w {
                    y += 1;
                    row += w;
                }
                let x = i - row;
                let xy = x | y;
                let h = xy & xy.wrapping_neg();
                if h == 0 {
                    continue;
                }
                if x == 0 || y == 0 || x == n || y == n {
                    self.vertex_edge(i, x, y);
                    continue;
                }
                let rv = self.rank(i as u64);
                self.vertex_inside(i, x, y, rv, &be, &bc);
            }
        }
    }

    /// [`Self::by_vertex`] for a vertex `i = (x, y)` of rank `rv` inside the grid (every diamond
    /// corner in it); `be`, `bc`: the corners' offsets for `h = 1`.
    #[inline(always)]
    fn vertex_inside(&mut self, i: i64, x: i64, y: i64, rv: u32, be: &[i64; 4], bc: &[i64; 4]) {
        // `c`: 1 for the centre of a square, 0 for the midpoint of a side; `h = 2^tz`.
        let tz = (x | y).trailing_zeros();
        let c = ((x >> tz) & (y >> tz) & 1) as usize;
        let base = if c == 1 { bc } else { be };
        let mut off = [0i64; 4];
        let mut rk = [0u32; 4];
        for k in 0..4 {
            off[k] = base[k] << tz;
            rk[k] = self.rank((i + off[k]) as u64);
        }
        let leaf = ((c == 0) & (tz == 0)) as u64;
        for k in 0..4 {
            let k1 = (k + 1) & 3;
            let split = (i + ((off[k] + off[k1]) >> 1)) as u64;
            let emit = leaf | (self.kept(split) ^ 1);
            self.o.put_if([rk[k], rk[k1], rv], emit as usize);
        }
    }

    /// The same triangles as [`Self::by_vertex`], row by row in the order of their apex `v`,
    /// every level through passes over a row-aligned copy of the bitmap (`pad`, built here),
    /// one pass per kind of vertex in the row, so no branch picks the kind: in row `y` whose
    /// lowest set bit is `t`, the midpoints of horizontal sides of `2s` for each `s < t` (at `x
    /// = s mod 2s`), then the centres of squares of side `2t` (`x = t mod 2t`) and the midpoints
    /// of vertical sides of `2t` (`x = 0 mod 2t`). The finest level (`s = 1`) takes the ranks of
    /// a vertex's left and right neighbours as one less and one more. Rows 0 and `n` go
    /// through [`Self::vertex_edge`].
    #[target_feature(enable = "popcnt")]
    fn by_padded(&mut self, pad: &mut Padded) {
        let n = self.side;
        let w = n + 1;
        let nw = pad.nw;
        for y in 0..w {
            let (bits, base) = (
                &mut pad.bits[y as usize * nw..][..nw],
                &mut pad.base[y as usize * nw..][..nw],
            );
            self.load_into(bits, base, y as i64);
        }
        let pad = &*pad;
        self.edge_rows(pad);
        for y in 1..n {
            if y & 1 == 1 {
                self.pass_fine(pad, y, true);
                self.pass_fine(pad, y, false);
                continue;
            }
            let t = y & y.wrapping_neg();
            self.pass_fine(pad, y, false);
            let mut s = 2;
            while s < t {
                self.pass(pad, y, s, s, false);
                s <<= 1;
            }
            self.pass(pad, y, t, t, true);
            self.pass(pad, y, t, 0, false);
        }
    }

    /// The finest level of row `y`: the centres at odd `x` of an odd row (`centres`), or
    /// the leaf midpoints (even `x` of an odd row, odd `x` of an even row).
    #[inline(always)]
    fn pass_fine(&mut self, pad: &Padded, y: u64, centres: bool) {
        let n = self.side;
        let nw = pad.nw;
        let row = |yy: u64| (yy as usize) * nw;
        let (cu, up, dn) = (row(y), row(y - 1), row(y + 1));
        let mask = if centres == (y & 1 == 1) { ODD } else { !ODD };
        for j in 0..nw {
            let mut b = pad.bits[cu + j] & mask;
            while b != 0 {
                let x = (j as u64) * 64 + u64::from(b.trailing_zeros());
                b &= b - 1;
                let rv = pad.rank(cu, x);
                if centres {
                    let (ru, rd) = (pad.rank(up, x - 1), pad.rank(dn, x - 1));
                    let (ku, kd) = (pad.kept(up, x), pad.kept(dn, x));
                    let (kl, kr) = (pad.kept(cu, x - 1), pad.kept(cu, x + 1));
                    let c = [rd + 1 + kd as u32, rd, ru, ru + 1 + ku as u32];
                    self.o.put_if([c[0], c[1], rv], (kd ^ 1) as usize);
                    self.o.put_if([c[1], c[2], rv], (kl ^ 1) as usize);
                    self.o.put_if([c[2], c[3], rv], (ku ^ 1) as usize);
                    self.o.put_if([c[3], c[0], rv], (kr ^ 1) as usize);
                } else {
                    let (ru, rd) = (pad.rank(up, x), pad.rank(dn, x));
                    let (left, right) = ((x != 0) as usize, (x != n) as usize);
                    let (rl, rr) = (rv.wrapping_sub(1), rv + 1);
                    self.o.put_if([rr, rd, rv], right);
                    self.o.put_if([rd, rl, rv], left);
                    self.o.put_if([rl, ru, rv], left);
                    self.o.put_if([ru, rr, rv], right);
                }
            }
        }
    }

    /// The kept vertices of row `y` at `x = r mod 2s` (`s >= 2`): centres of squares of side
    /// `2s` (`centre`) or midpoints of sides of `2s`, each with its up to four triangles.
    #[inline(always)]
    fn pass(&mut self, pad: &Padded, y: u64, s: u64, r: u64, centre: bool) {
        let n = self.side;
        let nw = pad.nw;
        let row = |yy: u64| (yy as usize) * nw;
        let (cu, up, dn) = (row(y), row(y - s), row(y + s));
        let h = s / 2;
        let (uh, dh) = (row(y - h), row(y + h));
        let pm = kind_mask(s, r, 0);
        for j in 0..nw {
            let m = if 2 * s <= 64 { pm } else { kind_mask(s, r, j) };
            let mut b = pad.bits[cu + j] & m;
            while b != 0 {
                let x = (j as u64) * 64 + u64::from(b.trailing_zeros());
                b &= b - 1;
                let rv = pad.rank(cu, x);
                if centre {
                    let c = [
                        pad.rank(dn, x + s),
                        pad.rank(dn, x - s),
                        pad.rank(up, x - s),
                        pad.rank(up, x + s),
                    ];
                    let k = [
                        pad.kept(dn, x),
                        pad.kept(cu, x - s),
                        pad.kept(up, x),
                        pad.kept(cu, x + s),
                    ];
                    for q in 0..4 {
                        self.o
                            .put_if([c[q], c[(q + 1) & 3], rv], (k[q] ^ 1) as usize);
                    }
                } else {
                    let (left, right) = ((x != 0) as u64, (x != n) as u64);
                    let c = [
                        pad.rank(cu, x.wrapping_add(s)),
                        pad.rank(dn, x),
                        pad.rank(cu, x.wrapping_sub(s)),
                        pad.rank(up, x),
                    ];
                    let k = [
                        pad.kept(dh, x.wrapping_add(h)),
                        pad.kept(dh, x.wrapping_sub(h)),
                        pad.kept(uh, x.wrapping_sub(h)),
                        pad.kept(uh, x.wrapping_add(h)),
                    ];
                    let v = [right, left, left, right];
                    for q in 0..4 {
                        self.o
                            .put_if([c[q], c[(q + 1) & 3], rv], (v[q] & (k[q] ^ 1)) as usize);
                    }
                }
            }
        }
    }

    /// Row `y` of the bitmap into `bits`, aligned to word 0, with the rank of each word's
    /// first bit in `base`.
    #[inline(always)]
    fn load_into(&self, bits: &mut [u64], base: &mut [u32], y: i64) {
        let w = self.side + 1;
        let s = y as u64 * w;
        let (q, o) = ((s >> 6) as usize, s & 63);
        let word = |k: usize| self.bits.get(k).copied().unwrap_or(0);
        let mut acc = self.prefix.get(q).copied().unwrap_or(0)
            + (word(q) & ((1u64 << o) - 1)).count_ones() as u64;
        let nw = bits.len();
        let last = w - 64 * (nw as u64 - 1);
        for j in 0..nw {
            let lo = word(q + j) >> o;
            let hi = if o == 0 {
                0
            } else {
                word(q + j + 1) << (64 - o)
            };
            let mut v = lo | hi;
            if j == nw - 1 && last < 64 {
                v &= (1u64 << last) - 1;
            }
            bits[j] = v;
            base[j] = acc as u32;
            acc += v.count_ones() as u64;
        }
    }

    /// The same triangles as [`Self::by_padded`], but each triangle's decision made for 64
    /// vertices at once (a word of the kept vertices of a kind, less the word of their split
    /// vertices, shifted into place) and vertices numbered through `idx`, a map from grid index
    /// to vertex number filled here in one pass over the kept vertices (which the vertex
    /// writes make anyway): a triangle is then three loads and a store.
    #[target_feature(enable = "popcnt")]
    fn by_mask(&mut self, pad: &mut Padded, idx: &mut [u32]) {
        let n = self.side;
        let w = n + 1;
        let nw = pad.nw;
        let mut r = 0u32;
        for y in 0..w {
            let (bits, base) = (
                &mut pad.bits[y as usize * nw..][..nw],
                &mut pad.base[y as usize * nw..][..nw],
            );
            self.load_into(bits, base, y as i64);
            let row = y as usize * w as usize;
            for (j, &word) in bits.iter().enumerate() {
                let mut b = word;
                while b != 0 {
                    let x = j * 64 + b.trailing_zeros() as usize;
                    b &= b - 1;
                    if let Some(v) = idx.get_mut(row + x) {
                        *v = r;
                    }
                    r += 1;
                }
            }
        }
        let pad = &*pad;
        let idx = &*idx;
        self.edge_rows(pad);
        for y in 1..n {
            let t = y & y.wrapping_neg();
            if t == 1 {
                self.mask_pass(pad, idx, y, 1, 1, true);
                self.mask_pass(pad, idx, y, 1, 0, false);
                continue;
            }
            let mut s = 1;
            while s < t {
                self.mask_pass(pad, idx, y, s, s, false);
                s <<= 1;
            }
            self.mask_pass(pad, idx, y, t, t, true);
            self.mask_pass(pad, idx, y, t, 0, false);
        }
    }

    /// One kind of vertex of row `y` (`x = r mod 2s`): centres of squares of side `2s`
    /// (`centre`) or midpoints of sides of `2s`, their triangles decided a word at a time.
    #[inline(always)]
    fn mask_pass(&mut self, pad: &Padded, idx: &[u32], y: u64, s: u64, r: u64, centre: bool) {
        let n = self.side;
        let w = n + 1;
        let nw = pad.nw;
        let row = |yy: u64| (yy as usize) * nw;
        let si = s as i64;
        let wi = w as i64;
        // Corners counter-clockwise as grid-index offsets, and each triangle's split vertex as
        // (row, column shift); a leaf has none.
        let (off, split): ([i64; 4], [(u64, i64); 4]) = if centre {
            (
                [si * wi + si, si * wi - si, -si * wi - si, -si * wi + si],
                [(y + s, 0), (y, -si), (y - s, 0), (y, si)],
            )
        } else {
            let h = si / 2;
            let (yd, yu) = (y + s / 2, y - s / 2);
            (
                [si, si * wi, -si, -si * wi],
                [(yd, h), (yd, -h), (yu, -h), (yu, h)],
            )
        };
        let leaf = !centre && s == 1;
        let cu = row(y);
        let cur = &pad.bits[cu..cu + nw];
        // Each split row as a slice, with the shift as whole words and bits.
        let mut srow: [&[u64]; 4] = [cur; 4];
        let mut sq = [0i64; 4];
        let mut so = [0u32; 4];
        for k in 0..4 {
            let (sy, dx) = split[k];
            let b = row(sy).min(pad.bits.len());
            srow[k] = &pad.bits[b..(b + nw).min(pad.bits.len())];
            sq[k] = dx.div_euclid(64);
            so[k] = dx.rem_euclid(64) as u32;
        }
        let pm = kind_mask(s, r, 0);
        for (j, &cw) in cur.iter().enumerate() {
            let m = if 2 * s <= 64 { pm } else { kind_mask(s, r, j) };
            let kw = cw & m;
            if kw == 0 {
                continue;
            }
            // Vertices at x = 0 and x = n lack their left and right halves.
            let first = if j == 0 { !1u64 } else { !0 };
            let lastx = n as usize;
            let last = if lastx / 64 == j {
                !(1u64 << (lastx % 64))
            } else {
                !0
            };
            let valid = [last, first, first, last];
            let p0 = (y * w) as i64 + 64 * j as i64;
            for k in 0..4 {
                let k1 = (k + 1) & 3;
                let mut e = kw;
                if !centre {
                    e &= valid[k];
                }
                if !leaf {
                    let q = j as i64 + sq[k];
                    let get = |i: i64| srow[k].get(i as usize).copied().unwrap_or(0);
                    let o = so[k];
                    let sh = (get(q) >> o) | if o == 0 { 0 } else { get(q + 1) << (64 - o) };
                    e &= !sh;
                }
                while e != 0 {
                    let x = i64::from(e.trailing_zeros());
                    e &= e - 1;
                    let p = p0 + x;
                    let at = |o: i64| idx.get((p + o) as usize).copied().unwrap_or(0);
                    self.o.put([at(off[k]), at(off[k1]), at(0)]);
                }
            }
        }
    }

    /// Rows 0 and `n` of the padded bitmap through [`Self::vertex_edge`].
    #[inline(always)]
    fn edge_rows(&mut self, pad: &Padded) {
        let (n, nw) = (self.side, pad.nw);
        for y in [0, n] {
            for j in 0..nw {
                let mut b = pad.bits[y as usize * nw + j];
                while b != 0 {
                    let x = (j as u64) * 64 + u64::from(b.trailing_zeros());
                    b &= b - 1;
                    if (x | y) != 0 {
                        self.vertex_edge((y * (n + 1) + x) as i64, x as i64, y as i64);
                    }
                }
            }
        }
    }

    /// [`Self::by_vertex`] for a vertex on the grid's edge.
    #[inline(never)]
    fn vertex_edge(&mut self, i: i64, x: i64, y: i64) {
        let n = self.side as i64;
        let w = n + 1;
        let xy = x | y;
        let h = xy & xy.wrapping_neg();
        // 1 for the centre of a square, 0 for the midpoint of a side.
        let c = (((x & h) != 0) & ((y & h) != 0)) as i64;
        let e = [(h, 0), (0, h), (-h, 0), (0, -h)];
        let leaf = ((1 - c) & (h == 1) as i64) as u64;
        let mut inside = [0u64; 4];
        let mut idx = [0u64; 4];
        let mut rk = [0u32; 4];
        for k in 0..4 {
            let k1 = (k + 1) & 3;
            let (px, py) = (x + e[k].0 + c * e[k1].0, y + e[k].1 + c * e[k1].1);
            inside[k] = ((px as u64 <= n as u64) & (py as u64 <= n as u64)) as u64;
            idx[k] = (py * w + px) as u64;
            rk[k] = self.rank(idx[k]);
        }
        let rv = self.rank(i as u64);
        for k in 0..4 {
            let k1 = (k + 1) & 3;
            let split = (idx[k] + idx[k1]) >> 1;
            let emit = inside[k] & inside[k1] & (leaf | (self.kept(split) ^ 1));
            self.o.put_if([rk[k], rk[k1], rv], emit as usize);
        }
    }
}

/// Entries a level buffer holds: blocks of up to 13 levels.
const CAP: usize = 1 << 12;
const MASK: usize = CAP - 1;

struct Bufs {
    a: Box<[[u64; 3]; CAP]>,
    b: Box<[[u64; 3]; CAP]>,
}

fn main() {
    assert!(std::is_x86_feature_detected!("popcnt"));
    let runs = common::runs(30);
    let block: u32 = std::env::var("BLOCK")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10);
    // RAW=path: a square grid of little-endian f32 heights in metres (what the peer script's
    // prep.py writes, e.g. Big Tujunga at 513^2) instead of the bundled Puget Sound DEM.
    let raw = std::env::var("RAW").ok();
    let dem = common::puget();
    let (samples, w, h, scale, name) = match &raw {
        Some(path) => {
            let bytes = std::fs::read(path).expect("RAW file");
            let s: Vec<f32> = bytes
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect();
            let side = (s.len() as f64).sqrt() as u32;
            assert_eq!((side * side) as usize, s.len(), "RAW must be a square grid");
            (s, side, side, Default::default(), path.as_str())
        }
        None => (
            dem.samples.clone(),
            dem.width,
            dem.height,
            dem.scale,
            "Puget",
        ),
    };
    let hf = Heightfield::with_scale(&samples, w, h, scale).unwrap();
    let n = hierarchy_len(w, h);
    let (mut ef, mut rf) = (vec![0.0f32; n], vec![0.0f32; n]);
    // The errors a second time, for the bitmap (the hierarchy borrows the first copy).
    let (mut errs, mut rads) = (vec![0.0f32; n], vec![0.0f32; n]);
    preprocess(&hf, &mut errs, &mut rads).unwrap();
    let full = preprocess(&hf, &mut ef, &mut rf).unwrap();
    let mut scratch = vec![0u64; scratch_len(w, h)];
    let mut verts = vec![[0.0f32; 3]; n];
    let mut grid_verts = vec![[0u16; 2]; n];
    let mut tris = vec![[0u32; 3]; triangle_bound(w, h)];
    let side = (w - 1) as u64;
    let levels = 2 * side.trailing_zeros();
    let words = n.div_ceil(64);
    assert!((1..=13).contains(&block), "BLOCK must be 1..=13");
    let mut bufs = Bufs {
        a: Box::new([[0; 3]; CAP]),
        b: Box::new([[0; 3]; CAP]),
    };
    println!("{name} {w}x{h}, block {block}, fastest of {runs}, ms");
    println!("| E (m) | triangles | library `triangles_popcnt` (whole) | the same, grid-coordinate vertices | the same, AVX-512 build | depth first | blocks | depth first / blocks | by vertex | writes only | depth first, children tested before the call | by padded rows | by masks |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    // ONLY=e: that threshold alone.
    let only: Option<f32> = std::env::var("ONLY").ok().and_then(|v| v.parse().ok());
    for e in [1.0f32, 5.0, 20.0, 50.0] {
        if only.is_some_and(|o| o != e) {
            continue;
        }
        let r = Refiner::new(&full, &hf, Criterion::MaxError(e)).unwrap();
        let mut lib = f64::INFINITY;
        let mut c = Default::default();
        for _ in 0..runs {
            let s = Instant::now();
            // SAFETY: popcnt checked above.
            c = black_box(unsafe { r.triangles_popcnt(&mut scratch, &mut verts, &mut tris) })
                .unwrap();
            lib = lib.min(s.elapsed().as_secs_f64() * 1e3);
        }
        // The same with grid-coordinate vertices, martini's and pymartini's output format.
        // Alternated with the AVX-512 build where the CPU has it (its selection fills the
        // bitmap a word at a time; the walk is the same).
        let avx512 =
            std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("avx512bw");
        let (mut lib_grid, mut lib_wide) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..runs {
            let s = Instant::now();
            // SAFETY: popcnt checked above.
            let cg = unsafe { r.triangles_popcnt(&mut scratch, &mut grid_verts, &mut tris) };
            assert_eq!(black_box(cg).unwrap(), c);
            lib_grid = lib_grid.min(s.elapsed().as_secs_f64() * 1e3);
            if avx512 {
                let s = Instant::now();
                // SAFETY: popcnt, AVX-512F and AVX-512BW checked.
                let cg = unsafe { r.triangles_avx512(&mut scratch, &mut grid_verts, &mut tris) };
                assert_eq!(black_box(cg).unwrap(), c);
                lib_wide = lib_wide.min(s.elapsed().as_secs_f64() * 1e3);
            }
        }
        let nt = c.triangles;
        // The kept set: the corners and every vertex whose error exceeds E.
        let mut bits = vec![0u64; words];
        for (i, &err) in errs.iter().enumerate() {
            let (x, y) = (i % w as usize, i / w as usize);
            let corner = (x == 0 || x == w as usize - 1) && (y == 0 || y == h as usize - 1);
            if err > e || corner {
                bits[i >> 6] |= 1 << (i & 63);
            }
        }
        let mut prefix = vec![0u64; words];
        let mut acc = 0u64;
        for (p, b) in prefix.iter_mut().zip(&bits) {
            *p = acc;
            acc += b.count_ones() as u64;
        }
        assert_eq!(
            acc as usize, c.vertices,
            "kept set differs from the library's"
        );
        let (bits, prefix) = (&bits[..], &prefix[..]);
        fn make<'a, 'o>(
            bits: &'a [u64],
            prefix: &'a [u64],
            side: u64,
            o: &'o mut [[u32; 3]],
        ) -> Vi<'a, 'o> {
            Vi {
                bits,
                prefix,
                side,
                o: Out { out: o, n: 0 },
            }
        }
        let mut want = tris[..nt].to_vec();
        let mut o1 = vec![[0u32; 3]; nt + 2];
        let mut o2 = vec![[0u32; 3]; nt + 2];
        let mut o3 = vec![[0u32; 3]; nt + 2];
        let nw = (w as usize).div_ceil(64);
        let mut pad = Padded {
            bits: vec![0; nw * w as usize],
            base: vec![0; nw * w as usize],
            nw,
        };
        let mut o5 = vec![[0u32; 3]; nt + 2];
        let mut run_pad = |o: &mut [[u32; 3]]| {
            let mut vi = make(bits, prefix, side, o);
            // SAFETY: popcnt checked above.
            unsafe { vi.by_padded(&mut pad) };
            vi.o.n
        };
        let mut pad2 = Padded {
            bits: vec![0; nw * w as usize],
            base: vec![0; nw * w as usize],
            nw,
        };
        let mut idx = vec![0u32; (w * h) as usize];
        let mut o6 = vec![[0u32; 3]; nt + 2];
        let mut run_mask = |o: &mut [[u32; 3]]| {
            let mut vi = make(bits, prefix, side, o);
            // SAFETY: popcnt checked above.
            unsafe { vi.by_mask(&mut pad2, &mut idx) };
            vi.o.n
        };
        let run_dfs = |o: &mut [[u32; 3]]| {
            let mut vi = make(bits, prefix, side, o);
            for (l, r, a) in vi.roots() {
                // SAFETY: popcnt checked above.
                unsafe { vi.dfs(l, r, a, levels) };
            }
            vi.o.n
        };
        let run_known = |o: &mut [[u32; 3]]| {
            let mut vi = make(bits, prefix, side, o);
            for (l, r, a) in vi.roots() {
                match vi.split(l, r) {
                    // SAFETY: popcnt checked above.
                    Some(m) if levels > 0 => unsafe { vi.dfs_known(l, r, a, m, levels) },
                    _ => vi.o.put(tri(l, r, a)),
                }
            }
            vi.o.n
        };
        let mut run_blocks = |o: &mut [[u32; 3]]| {
            let mut vi = make(bits, prefix, side, o);
            for t in vi.roots() {
                // SAFETY: popcnt checked above.
                unsafe { vi.blocks(&mut bufs, t, levels, block) };
            }
            vi.o.n
        };
        let run_vertex = |o: &mut [[u32; 3]]| {
            let mut vi = make(bits, prefix, side, o);
            // SAFETY: popcnt checked above.
            unsafe { vi.by_vertex() };
            vi.o.n
        };
        want.sort_unstable();
        // The library writes dense meshes row by row since 2026-12-07, so every form is
        // compared as a set.
        let same_set = |n: usize, o: &[[u32; 3]], form: &str| {
            assert_eq!(n, nt, "{form}: other count");
            let mut got = o[..nt].to_vec();
            got.sort_unstable();
            assert!(got == want, "{form} gives other triangles");
        };
        same_set(run_dfs(&mut o1), &o1, "depth first");
        same_set(run_known(&mut o1), &o1, "known splits");
        same_set(run_blocks(&mut o2), &o2, "blocks");
        same_set(run_vertex(&mut o3), &o3, "by vertex");
        same_set(run_pad(&mut o5), &o5, "by padded rows");
        same_set(run_mask(&mut o6), &o6, "by masks");
        if std::env::var("CLASSES").is_ok() {
            // Kept vertices of the finest level (odd x or y) and of the coarser ones.
            let (mut fine, mut coarse) = (0usize, 0usize);
            for (i, &e2) in errs.iter().enumerate() {
                let (x, y) = (i % w as usize, i / w as usize);
                if e2 > e {
                    if (x | y) & 1 == 1 {
                        fine += 1;
                    } else {
                        coarse += 1;
                    }
                }
            }
            eprintln!(
                "E {e}: kept vertices of the finest level {fine}, of coarser levels {coarse}"
            );
        }
        let (mut td, mut tb, mut tf, mut tv, mut tk, mut tp, mut tm) = (
            f64::INFINITY,
            f64::INFINITY,
            f64::INFINITY,
            f64::INFINITY,
            f64::INFINITY,
            f64::INFINITY,
            f64::INFINITY,
        );
        for _ in 0..runs {
            let s = Instant::now();
            black_box(run_dfs(&mut o1));
            td = td.min(s.elapsed().as_secs_f64() * 1e3);
            let s = Instant::now();
            black_box(run_known(&mut o1));
            tk = tk.min(s.elapsed().as_secs_f64() * 1e3);
            let s = Instant::now();
            black_box(run_blocks(&mut o2));
            tb = tb.min(s.elapsed().as_secs_f64() * 1e3);
            let s = Instant::now();
            black_box(run_vertex(&mut o3));
            tv = tv.min(s.elapsed().as_secs_f64() * 1e3);
            let s = Instant::now();
            black_box(run_pad(&mut o5));
            tp = tp.min(s.elapsed().as_secs_f64() * 1e3);
            let s = Instant::now();
            black_box(run_mask(&mut o6));
            tm = tm.min(s.elapsed().as_secs_f64() * 1e3);
            let s = Instant::now();
            for (k, t) in o2[..nt].iter_mut().enumerate() {
                *t = [k as u32; 3];
            }
            black_box(&mut o2);
            tf = tf.min(s.elapsed().as_secs_f64() * 1e3);
        }
        println!(
            "| {e} | {nt} | {lib:.3} | {lib_grid:.3} | {lib_wide:.3} | {td:.3} | {tb:.3} | {:.2} | {tv:.3} | {tf:.3} | {tk:.3} | {tp:.3} | {tm:.3} |",
            td / tb
        );
    }
}

/// The columns `x = r mod 2s` of word `j` of a row-aligned bitmap row.
fn kind_mask(s: u64, r: u64, j: usize) -> u64 {
    if 2 * s <= 64 {
        let mut m = 0u64;
        let mut p = r;
        while p < 64 {
            m |= 1 << p;
            p += 2 * s;
        }
        m
    } else {
        ((64 * j as u64) % (2 * s) == r) as u64
    }
}

/// Bits at odd positions of a row-aligned word (rows start at bit 0, so `x` odd).
const ODD: u64 = 0xaaaa_aaaa_aaaa_aaaa;

/// The bitmap with each row aligned to a word (`nw` words a row), and the rank of each word's
/// first bit.
struct Padded {
    bits: Vec<u64>,
    base: Vec<u32>,
    nw: usize,
}

impl Padded {
    /// Rank of `x` in the row starting at word `row`.
    #[inline(always)]
    fn rank(&self, row: usize, x: u64) -> u32 {
        let j = row.wrapping_add((x >> 6) as usize);
        let b = self.bits.get(j).copied().unwrap_or(0);
        self.base.get(j).copied().unwrap_or(0) + (b & ((1u64 << (x & 63)) - 1)).count_ones()
    }
    /// Whether `x` of the row starting at word `row` is kept.
    #[inline(always)]
    fn kept(&self, row: usize, x: u64) -> u64 {
        let j = row.wrapping_add((x >> 6) as usize);
        (self.bits.get(j).copied().unwrap_or(0) >> (x & 63)) & 1
    }
}
