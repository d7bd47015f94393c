//! The faces' candidates and an indexed 8-ary max-heap of the faces above the error target.
//!
//! Each face is in the heap at most once and its key is changed in place when the face is
//! rescanned (as in Garland & Heckbert's implementation and `mapbox/delatin`), so the heap never
//! holds stale entries: it stays as small as the number of faces still above the error target.
//! A face's heap position is stored beside its candidate, so a rescan touches one record per face.

/// Marks a face that is not in the heap.
const ABSENT: u32 = u32::MAX;

/// The current candidate of a face: its worst sample.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Candidate {
    /// Largest vertical error over the samples the face covers (0 if it covers only corners).
    pub(crate) err: f64,
    /// The sample where it is reached.
    pub(crate) x: u32,
    pub(crate) y: u32,
    /// A vertex of the face: where spade's point location starts walking.
    pub(crate) hint: u32,
    /// Position in the heap, or [`ABSENT`].
    pos: u32,
}

impl Default for Candidate {
    fn default() -> Self {
        Candidate {
            err: 0.0,
            x: 0,
            y: 0,
            hint: 0,
            pos: ABSENT,
        }
    }
}

/// Heap keys of one node's children: eight errors, aligned to a cache line.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Keys([f64; 8]);

/// Face indices beside [`Keys`].
#[derive(Debug, Clone, Copy)]
struct Ids([u32; 8]);

/// Key of an empty slot: below every error, so it never wins a comparison.
const EMPTY: (f64, u32) = (f64::NEG_INFINITY, ABSENT);

/// Candidates by face index, and the max-heap of `(error, face)` over the faces in it; ties go to
/// the lower face index, so builds are deterministic.
///
/// The heap is 8-ary and stored as structure of arrays: node `i` lives in slot `i + 7`, so the
/// eight children `8i+1 ..= 8i+8` of node `i` fill slot line `i + 1` exactly, and choosing the
/// best child reads one cache line of keys (and half a line of face indices), at a depth of
/// `log8` of the heap size. Slots past the end hold [`EMPTY`].
#[derive(Debug, Default)]
pub(crate) struct FaceHeap {
    keys: Vec<Keys>,
    ids: Vec<Ids>,
    /// Number of nodes.
    len: usize,
    /// Candidate (and heap position) of each face.
    faces: Vec<Candidate>,
}

/// Slot line and lane of node `i`: slot `i + 7`.
#[inline(always)]
fn slot(i: usize) -> (usize, usize) {
    ((i + 7) >> 3, (i + 7) & 7)
}

/// `a` pops before `b`.
#[inline(always)]
fn before(a: (f64, u32), b: (f64, u32)) -> bool {
    a.0 > b.0 || (a.0 == b.0 && a.1 < b.1)
}

impl FaceHeap {
    /// The item of node `i` ([`EMPTY`] past the end).
    #[inline(always)]
    fn get(&self, i: usize) -> (f64, u32) {
        let (l, k) = slot(i);
        match (self.keys.get(l), self.ids.get(l)) {
            (Some(key), Some(id)) => (key.0[k], id.0[k]),
            _ => EMPTY,
        }
    }

    /// Stores `item` in node `i`'s slot (which must exist) without touching the face records.
    #[inline(always)]
    fn store(&mut self, i: usize, item: (f64, u32)) {
        let (l, k) = slot(i);
        if let (Some(key), Some(id)) = (self.keys.get_mut(l), self.ids.get_mut(l)) {
            key.0[k] = item.0;
            id.0[k] = item.1;
        }
    }

    /// Stores `item` in node `i` and records the position in its face.
    #[inline(always)]
    fn place(&mut self, i: usize, item: (f64, u32)) {
        self.store(i, item);
        if let Some(c) = self.faces.get_mut(item.1 as usize) {
            c.pos = i as u32;
        }
    }

    /// The face with the largest error and that error.
    #[inline]
    pub(crate) fn peek(&self) -> Option<(f64, u32)> {
        (self.len > 0).then(|| self.get(0))
    }

    /// The candidate of `face` (default if never set).
    #[inline]
    pub(crate) fn candidate(&self, face: u32) -> Candidate {
        self.faces.get(face as usize).copied().unwrap_or_default()
    }

    /// Largest error over the candidates of `faces`.
    pub(crate) fn max_error(&self, faces: impl Iterator<Item = usize>) -> f64 {
        faces
            .filter_map(|f| self.faces.get(f))
            .fold(0.0, |m, c| m.max(c.err))
    }

    /// Records the candidate of `face`; it is in the heap afterwards iff `queued`.
    pub(crate) fn set(&mut self, face: u32, err: f64, x: u32, y: u32, hint: u32, queued: bool) {
        let f = face as usize;
        if self.faces.len() <= f {
            self.faces.resize(f + 1, Candidate::default());
        }
        let Some(c) = self.faces.get_mut(f) else {
            return;
        };
        let (old, pos) = (c.err, c.pos);
        *c = Candidate {
            err,
            x,
            y,
            hint,
            pos,
        };
        match (pos == ABSENT, queued) {
            (true, true) => {
                let i = self.len;
                self.len += 1;
                // Node `i` is in slot line `(i + 7) / 8`: add lines of empty slots as needed.
                while self.keys.len() <= slot(i).0 + 1 {
                    self.keys.push(Keys([EMPTY.0; 8]));
                    self.ids.push(Ids([EMPTY.1; 8]));
                }
                self.up(i, (err, face));
            }
            (false, true) => {
                let i = pos as usize;
                if err > old {
                    self.up(i, (err, face));
                } else {
                    self.down(i, (err, face));
                }
            }
            (false, false) => {
                self.take(pos as usize);
            }
            (true, false) => {}
        }
    }

    /// Removes and returns the top.
    #[cfg(test)]
    pub(crate) fn pop(&mut self) -> Option<(f64, u32)> {
        if self.len == 0 {
            None
        } else {
            Some(self.take(0))
        }
    }

    /// Takes `face` out of the heap (keeping its candidate); nothing if it is not in it.
    pub(crate) fn remove(&mut self, face: u32) {
        if let Some(pos) = self.faces.get(face as usize).map(|c| c.pos) {
            if pos != ABSENT {
                self.take(pos as usize);
            }
        }
    }

    /// Removes the item at node `i < len`.
    fn take(&mut self, i: usize) -> (f64, u32) {
        let out = self.get(i);
        self.len -= 1;
        let last = self.get(self.len);
        self.store(self.len, EMPTY);
        if i < self.len {
            // Refill the hole with the last item and restore the order both ways.
            self.down(i, last);
            let j = self
                .faces
                .get(last.1 as usize)
                .map_or(i, |c| c.pos as usize);
            self.up(j, last);
        }
        if let Some(c) = self.faces.get_mut(out.1 as usize) {
            c.pos = ABSENT;
        }
        out
    }

    /// Moves `item`, to be stored at `i`, towards the root.
    fn up(&mut self, mut i: usize, item: (f64, u32)) {
        while i > 0 {
            let parent = (i - 1) / 8;
            let p = self.get(parent);
            if !before(item, p) {
                break;
            }
            self.place(i, p);
            i = parent;
        }
        self.place(i, item);
    }

    /// Moves `item`, to be stored at `i`, towards the leaves.
    fn down(&mut self, mut i: usize, item: (f64, u32)) {
        // The children of node `i` are the slot line `i + 1`; empty slots never win.
        while let (Some(keys), Some(ids)) = (self.keys.get(i + 1), self.ids.get(i + 1)) {
            // A tournament over lane numbers: three rounds of independent, branch-free picks.
            let (k, ids) = (&keys.0, &ids.0);
            let lane = |j: usize| (k[j & 7], ids[j & 7]);
            let pick = |a: usize, b: usize| {
                let (ka, ia) = lane(a);
                let (kb, ib) = lane(b);
                let b_first = (kb > ka) | ((kb == ka) & (ib < ia));
                a ^ ((a ^ b) & usize::from(b_first).wrapping_neg())
            };
            let (q0, q1, q2, q3) = (pick(0, 1), pick(2, 3), pick(4, 5), pick(6, 7));
            let j = pick(pick(q0, q1), pick(q2, q3));
            let best = (lane(j).0, lane(j).1, j);
            if !before((best.0, best.1), item) {
                break;
            }
            self.place(i, (best.0, best.1));
            i = 8 * i + 1 + best.2;
        }
        self.place(i, item);
    }
}

#[cfg(test)]
mod tests {
    use super::FaceHeap;

    #[test]
    fn pops_in_order_after_updates_and_removals() {
        let mut h = FaceHeap::default();
        let mut s = 12345u64;
        let mut want = vec![None; 200];
        for _ in 0..5000 {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let face = (s >> 33) as u32 % 200;
            let err = ((s >> 40) % 50) as f64;
            let queued = !(s >> 20).is_multiple_of(4);
            h.set(face, err, face, 2 * face, 3 * face, queued);
            want[face as usize] = queued.then_some(err);
            assert_eq!(h.candidate(face).err, err);
        }
        let mut expect: Vec<(f64, u32)> = want
            .iter()
            .enumerate()
            .filter_map(|(f, e)| e.map(|e| (e, f as u32)))
            .collect();
        expect.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let mut got = Vec::new();
        while let Some(x) = h.pop() {
            let c = h.candidate(x.1);
            assert_eq!((c.x, c.y, c.hint), (x.1, 2 * x.1, 3 * x.1));
            got.push(x);
        }
        assert_eq!(got, expect);
    }

    /// Interleaved pops, updates and removals against a brute-force model, over heaps deep
    /// enough for several levels of slot lines.
    #[test]
    fn matches_a_brute_force_model() {
        let mut h = FaceHeap::default();
        let mut model: Vec<Option<f64>> = vec![None; 3000];
        let mut s = 99u64;
        for step in 0..100_000 {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            if s.is_multiple_of(7) {
                let best = model
                    .iter()
                    .enumerate()
                    .filter_map(|(f, e)| e.map(|e| (e, f as u32)))
                    .reduce(|a, b| if b.0 > a.0 { b } else { a });
                assert_eq!(h.peek(), best, "step {step}");
                assert_eq!(h.pop(), best);
                if let Some((_, f)) = best {
                    model[f as usize] = None;
                }
            } else {
                let face = ((s >> 33) % 3000) as u32;
                let err = ((s >> 45) % 1000) as f64;
                let queued = !(s >> 20).is_multiple_of(5);
                h.set(face, err, face, 0, 0, queued);
                model[face as usize] = queued.then_some(err);
            }
            assert_eq!(h.len, model.iter().flatten().count());
        }
        assert!(h.len > 1000, "{}", h.len);
    }
}
