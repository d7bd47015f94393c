//! An indexed binary max-heap of faces keyed by their candidate's error.
//!
//! Each face is in the heap at most once and its key is changed in place when the face is
//! rescanned (as in Garland & Heckbert's implementation and `mapbox/delatin`), so the heap never
//! holds stale entries: it stays as small as the number of faces still above the error target.

/// Marks a face that is not in the heap.
const ABSENT: u32 = u32::MAX;

/// Max-heap of `(error, face)`; ties go to the lower face index, so builds are deterministic.
#[derive(Debug, Default)]
pub(crate) struct FaceHeap {
    /// Heap-ordered `(error, face)` pairs.
    items: Vec<(f64, u32)>,
    /// Position of each face in `items`, or [`ABSENT`].
    pos: Vec<u32>,
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

    /// Sets the key of `face` to `err`, inserting it if absent.
    pub(crate) fn set(&mut self, face: u32, err: f64) {
        let f = face as usize;
        if self.pos.len() <= f {
            self.pos.resize(f + 1, ABSENT);
        }
        let p = self.pos.get(f).copied().unwrap_or(ABSENT);
        if p == ABSENT {
            let i = self.items.len();
            self.items.push((err, face));
            self.place(i, (err, face));
            self.up(i);
        } else {
            let i = p as usize;
            let old = self.items.get(i).map_or(0.0, |e| e.0);
            self.place(i, (err, face));
            if err > old {
                self.up(i);
            } else {
                self.down(i);
            }
        }
    }

    /// Removes `face` if it is in the heap.
    pub(crate) fn remove(&mut self, face: u32) {
        let Some(&p) = self.pos.get(face as usize) else {
            return;
        };
        if p == ABSENT {
            return;
        }
        self.take(p as usize);
    }

    /// Removes and returns the top.
    pub(crate) fn pop(&mut self) -> Option<(f64, u32)> {
        if self.items.is_empty() {
            None
        } else {
            Some(self.take(0))
        }
    }

    /// Removes the item at position `i` (which must exist).
    fn take(&mut self, i: usize) -> (f64, u32) {
        let last = self.items.len() - 1;
        self.items.swap(i, last);
        let out = self.items.pop().unwrap_or((0.0, ABSENT));
        if let Some(p) = self.pos.get_mut(out.1 as usize) {
            *p = ABSENT;
        }
        if i < self.items.len() {
            let moved = self.items[i];
            self.place(i, moved);
            self.up(i);
            self.down(i);
        }
        out
    }

    #[inline(always)]
    fn place(&mut self, i: usize, item: (f64, u32)) {
        if let Some(slot) = self.items.get_mut(i) {
            *slot = item;
        }
        if let Some(p) = self.pos.get_mut(item.1 as usize) {
            *p = i as u32;
        }
    }

    fn up(&mut self, mut i: usize) {
        let item = self.items[i];
        while i > 0 {
            let parent = (i - 1) / 2;
            let pi = self.items[parent];
            if !before(item, pi) {
                break;
            }
            self.place(i, pi);
            i = parent;
        }
        self.place(i, item);
    }

    fn down(&mut self, mut i: usize) {
        let n = self.items.len();
        let item = self.items[i];
        loop {
            let l = 2 * i + 1;
            if l >= n {
                break;
            }
            let r = l + 1;
            let c = if r < n && before(self.items[r], self.items[l]) {
                r
            } else {
                l
            };
            let ci = self.items[c];
            if !before(ci, item) {
                break;
            }
            self.place(i, ci);
            i = c;
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
        for _ in 0..2000 {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let face = (s >> 33) as u32 % 200;
            let op = (s >> 20) % 4;
            if op == 0 {
                h.remove(face);
                want[face as usize] = None;
            } else {
                let err = ((s >> 40) % 50) as f64;
                h.set(face, err);
                want[face as usize] = Some(err);
            }
        }
        let mut expect: Vec<(f64, u32)> = want
            .iter()
            .enumerate()
            .filter_map(|(f, e)| e.map(|e| (e, f as u32)))
            .collect();
        expect.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let mut got = Vec::new();
        while let Some(x) = h.pop() {
            got.push(x);
        }
        assert_eq!(got, expect);
    }
}
