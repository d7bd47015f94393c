//! The faces' candidates and an indexed 4-ary max-heap of the faces above the error target.
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

/// Candidates by face index, and the max-heap of `(error, face)` over the faces in it; ties go to
/// the lower face index, so builds are deterministic.
#[derive(Debug, Default)]
pub(crate) struct FaceHeap {
    /// Heap-ordered `(error, face)` pairs, 4 children per node.
    items: Vec<(f64, u32)>,
    /// Candidate (and heap position) of each face.
    faces: Vec<Candidate>,
}

/// `a` pops before `b`.
#[inline(always)]
fn before(a: (f64, u32), b: (f64, u32)) -> bool {
    a.0 > b.0 || (a.0 == b.0 && a.1 < b.1)
}

impl FaceHeap {
    /// The face with the largest error and that error.
    #[inline]
    pub(crate) fn peek(&self) -> Option<(f64, u32)> {
        self.items.first().copied()
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
                let i = self.items.len();
                self.items.push((err, face));
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
    pub(crate) fn pop(&mut self) -> Option<(f64, u32)> {
        if self.items.is_empty() {
            None
        } else {
            Some(self.take(0))
        }
    }

    /// Removes the item at position `i`.
    fn take(&mut self, i: usize) -> (f64, u32) {
        let Some(last) = self.items.pop() else {
            return (0.0, ABSENT);
        };
        let out = if i < self.items.len() {
            let out = self.items.get(i).copied().unwrap_or(last);
            // Refill the hole with the last item and restore the order both ways.
            self.down(i, last);
            let j = self
                .faces
                .get(last.1 as usize)
                .map_or(i, |c| c.pos as usize);
            self.up(j, last);
            out
        } else {
            last
        };
        if let Some(c) = self.faces.get_mut(out.1 as usize) {
            c.pos = ABSENT;
        }
        out
    }

    #[inline(always)]
    fn place(&mut self, i: usize, item: (f64, u32)) {
        if let Some(slot) = self.items.get_mut(i) {
            *slot = item;
        }
        if let Some(c) = self.faces.get_mut(item.1 as usize) {
            c.pos = i as u32;
        }
    }

    /// Moves `item`, to be stored at `i`, towards the root.
    fn up(&mut self, mut i: usize, item: (f64, u32)) {
        while i > 0 {
            let parent = (i - 1) / 4;
            let Some(&p) = self.items.get(parent) else {
                break;
            };
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
        loop {
            let first = 4 * i + 1;
            let end = (first + 4).min(self.items.len());
            let Some(kids) = self.items.get(first..end) else {
                break;
            };
            let Some((k, &best)) =
                kids.iter()
                    .enumerate()
                    .reduce(|a, b| if before(*b.1, *a.1) { b } else { a })
            else {
                break;
            };
            if !before(best, item) {
                break;
            }
            self.place(i, best);
            i = first + k;
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
}
