//! The longest-edge-bisection hierarchy over a `width x height` grid embedded in the enclosing
//! `(2^k + 1)^2` square, and the classification of hierarchy triangles against the domain.

use crate::Error;

/// Largest supported side of the enclosing square, `2^30` cells.
pub(crate) const MAX_SIDE: u32 = 1 << 30;

/// The bisection hierarchy of a grid: its size and the enclosing square of `2^k` cells.
///
/// The grid `width x height` is embedded at the origin of the square `[0, 2^k]^2` with the
/// smallest `k >= 1` such that both fit. The square is split along its diagonal `(0,0)-(N,N)`
/// into two root triangles that are bisected recursively ("union jack" pattern: each square's
/// diagonal passes through the centre of its parent square). Triangles outside the domain are
/// never emitted and triangles that cross the domain's border are always split, so a mesh covers
/// exactly `[0, width-1] x [0, height-1]`.
///
/// ```
/// use relief_core::refine::RefineGrid;
/// let g = RefineGrid::new(1000, 600).unwrap();
/// assert_eq!((g.width(), g.height(), g.side(), g.levels()), (1000, 600, 1024, 20));
/// assert!(RefineGrid::new(1, 5).is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RefineGrid {
    width: u32,
    height: u32,
    side: u32,
}

/// Where a hierarchy triangle lies relative to the domain.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Class {
    /// All three corners in the domain (the domain is convex, so the triangle is too).
    Inside,
    /// The interior misses the domain.
    Outside,
    /// Anything else: must be split.
    Straddle,
}

/// What [`RefineGrid::walk_edge`] meets.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Edge {
    /// A triangle `(l, r, a)` inside the domain, its split vertex at `level`.
    Inside((i64, i64), (i64, i64), (i64, i64), u32),
    /// The split vertex of a triangle across the domain's edge (maybe outside the domain).
    Split((i64, i64)),
}

impl RefineGrid {
    /// The hierarchy for a `width x height` grid (both at least 2, at most `2^30 + 1`).
    ///
    /// ```
    /// use relief_core::{refine::RefineGrid, Error};
    /// assert_eq!(RefineGrid::new(2, 1), Err(Error::TooSmall { width: 2, height: 1 }));
    /// assert_eq!(RefineGrid::new(2, 2).unwrap().side(), 1);
    /// ```
    pub fn new(width: u32, height: u32) -> Result<RefineGrid, Error> {
        if width < 2 || height < 2 {
            return Err(Error::TooSmall { width, height });
        }
        let cells = width.max(height) - 1;
        if cells > MAX_SIDE {
            return Err(Error::SizeOverflow);
        }
        let side = cells.next_power_of_two();
        (width as usize)
            .checked_mul(height as usize)
            .ok_or(Error::SizeOverflow)?;
        Ok(RefineGrid {
            width,
            height,
            side,
        })
    }

    /// Columns of the grid.
    ///
    /// ```
    /// assert_eq!(relief_core::refine::RefineGrid::new(3, 9).unwrap().width(), 3);
    /// ```
    #[must_use]
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Rows of the grid.
    ///
    /// ```
    /// assert_eq!(relief_core::refine::RefineGrid::new(3, 9).unwrap().height(), 9);
    /// ```
    #[must_use]
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Cells per side of the enclosing square, `N = 2^k`.
    ///
    /// ```
    /// assert_eq!(relief_core::refine::RefineGrid::new(3, 9).unwrap().side(), 8);
    /// ```
    #[must_use]
    pub fn side(&self) -> u32 {
        self.side
    }

    /// Number of vertex levels, `2 k`: the square's centre is level 0, the finest vertices
    /// (midpoints of cell edges) are level `2 k - 1`.
    ///
    /// ```
    /// assert_eq!(relief_core::refine::RefineGrid::new(1025, 1025).unwrap().levels(), 20);
    /// ```
    #[must_use]
    pub fn levels(&self) -> u32 {
        2 * self.side.trailing_zeros()
    }

    /// Number of samples, `width * height` (the length of every per-vertex array).
    ///
    /// ```
    /// assert_eq!(relief_core::refine::RefineGrid::new(3, 9).unwrap().len(), 27);
    /// ```
    #[must_use]
    #[allow(clippy::len_without_is_empty)]
    pub fn len(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Whether the grid fills the enclosing square (`width = height = 2^k + 1`).
    ///
    /// ```
    /// use relief_core::refine::RefineGrid;
    /// assert!(RefineGrid::new(9, 9).unwrap().is_square());
    /// assert!(!RefineGrid::new(9, 8).unwrap().is_square());
    /// ```
    #[must_use]
    pub fn is_square(&self) -> bool {
        self.width == self.side + 1 && self.height == self.side + 1
    }

    /// Level of the vertex at grid point `(x, y)` (0 for the square's centre, [`Self::levels`]
    /// for the finest), `None` for the square's four corners, which are always in the mesh, and
    /// for points outside the square.
    ///
    /// ```
    /// use relief_core::refine::RefineGrid;
    /// let g = RefineGrid::new(5, 5).unwrap();
    /// assert_eq!(g.level(2, 2), Some(0));
    /// assert_eq!(g.level(2, 0), Some(1));
    /// assert_eq!(g.level(1, 1), Some(2));
    /// assert_eq!(g.level(1, 0), Some(3));
    /// assert_eq!(g.level(4, 4), None);
    /// ```
    #[must_use]
    pub fn level(&self, x: u32, y: u32) -> Option<u32> {
        let (kind, h) = self.kind(x, y)?;
        let k = self.side.trailing_zeros();
        let lh = h.trailing_zeros(); // h = 2^lh, lh in 0..k
                                     // Centre of half-size 2^(k-1) is level 0; each halving adds 2; edges are one deeper.
        let base = 2 * (k - 1 - lh);
        Some(match kind {
            Kind::Centre => base,
            Kind::Edge { .. } => base + 1,
        })
    }

    /// Vertex kind and half-size `h` of grid point `(x, y)`; `None` for corners and outside.
    pub(crate) fn kind(&self, x: u32, y: u32) -> Option<(Kind, u32)> {
        if x > self.side || y > self.side {
            return None;
        }
        let bits = x | y;
        if bits == 0 {
            return None;
        }
        let s = 1u32 << bits.trailing_zeros();
        if s >= self.side {
            return None; // a corner of the square
        }
        let (ox, oy) = ((x / s) & 1 == 1, (y / s) & 1 == 1);
        Some(match (ox, oy) {
            (true, true) => (Kind::Centre, s),
            (true, false) => (Kind::Edge { horizontal: true }, s),
            _ => (Kind::Edge { horizontal: false }, s),
        })
    }

    /// Whether grid point `(x, y)` lies in the domain.
    #[inline(always)]
    pub(crate) fn in_domain(&self, x: i64, y: i64) -> bool {
        x >= 0 && y >= 0 && x < self.width as i64 && y < self.height as i64
    }

    /// Walks the hierarchy's triangles across the domain's edge of a grid that does not fill
    /// its square, in the refinement walks' depth-first order (root `(n, n), (0, 0), (n, 0)`
    /// first, first child `(a, l, m)` first): a triangle outside the domain is dropped, one
    /// across its edge always splits (`visit` gets [`Edge::Split`] with its split vertex), and
    /// one inside goes to `visit` as [`Edge::Inside`] with its level. `visit` returning `false`
    /// ends the walk. Only the triangles across the edge pass here, a number that grows with
    /// the edge's length, not the grid's area; an explicit stack of at most `levels() + 2`
    /// entries (each split replaces its entry by its two children).
    #[inline(always)]
    pub(crate) fn walk_edge(&self, mut visit: impl FnMut(Edge) -> bool) {
        let n = i64::from(self.side);
        let levels = self.levels();
        let mut stack = [((0i64, 0i64), (0i64, 0i64), (0i64, 0i64), 0u32); 64];
        // The first root is visited first: it goes on top.
        stack[0] = ((0, 0), (n, n), (0, n), 0);
        stack[1] = ((n, n), (0, 0), (n, 0), 0);
        let mut sp = 2usize;
        while sp > 0 {
            sp -= 1;
            let Some(&(l, r, a, level)) = stack.get(sp) else {
                break;
            };
            match self.classify([l, r, a]) {
                Class::Outside => {}
                Class::Inside => {
                    if !visit(Edge::Inside(l, r, a, level)) {
                        break;
                    }
                }
                // A leaf cell has integer corners, so it is inside or outside, never across
                // the edge: the level test only bounds the walk.
                Class::Straddle if level < levels => {
                    let m = ((l.0 + r.0) >> 1, (l.1 + r.1) >> 1);
                    if !visit(Edge::Split(m)) {
                        break;
                    }
                    // The second child below the first, which is visited next.
                    let Some([second, first]) = stack.get_mut(sp..sp + 2) else {
                        break;
                    };
                    *second = (r, a, m, level + 1);
                    *first = (a, l, m, level + 1);
                    sp += 2;
                }
                Class::Straddle => {}
            }
        }
    }

    /// Classifies a triangle (corners inside the square) against the domain.
    #[inline(always)]
    pub(crate) fn classify(&self, p: [(i64, i64); 3]) -> Class {
        let (w1, h1) = (self.width as i64 - 1, self.height as i64 - 1);
        let max_x = p[0].0.max(p[1].0).max(p[2].0);
        let max_y = p[0].1.max(p[1].1).max(p[2].1);
        if max_x <= w1 && max_y <= h1 {
            return Class::Inside;
        }
        let min_x = p[0].0.min(p[1].0).min(p[2].0);
        let min_y = p[0].1.min(p[1].1).min(p[2].1);
        if min_x >= w1 || min_y >= h1 {
            Class::Outside
        } else {
            Class::Straddle
        }
    }

    /// The (up to two) triangles of the diamond of vertex `(x, y)`, split by it; `None` entries
    /// for triangles outside the square.
    // The reference for preprocess::shape (tested equal); preprocessing itself uses shape.
    #[allow(dead_code)]
    pub(crate) fn diamond(&self, x: u32, y: u32) -> [Option<[(i64, i64); 3]>; 2] {
        let Some((kind, h)) = self.kind(x, y) else {
            return [None, None];
        };
        let (x, y, h, n) = (x as i64, y as i64, h as i64, self.side as i64);
        let inside = |t: [(i64, i64); 3]| {
            t.iter()
                .all(|&(a, b)| a >= 0 && b >= 0 && a <= n && b <= n)
                .then_some(t)
        };
        match kind {
            Kind::Centre => {
                let (c00, c10, c01, c11) = (
                    (x - h, y - h),
                    (x + h, y - h),
                    (x - h, y + h),
                    (x + h, y + h),
                );
                if main_diagonal(x - h, y - h, 2 * h) {
                    [Some([c00, c10, c11]), Some([c00, c11, c01])]
                } else {
                    [Some([c00, c10, c01]), Some([c10, c11, c01])]
                }
            }
            Kind::Edge { horizontal: true } => {
                let (e0, e1) = ((x - h, y), (x + h, y));
                [inside([e0, e1, (x, y + h)]), inside([e1, e0, (x, y - h)])]
            }
            Kind::Edge { horizontal: false } => {
                let (e0, e1) = ((x, y - h), (x, y + h));
                [inside([e0, e1, (x - h, y)]), inside([e1, e0, (x + h, y)])]
            }
        }
    }

    /// The children of vertex `(x, y)` (midpoints of its diamond's legs) that exist on the
    /// square, as `Some((x, y))`.
    pub(crate) fn children(&self, x: u32, y: u32) -> [Option<(i64, i64)>; 4] {
        let Some((kind, h)) = self.kind(x, y) else {
            return [None; 4];
        };
        let (x, y, h, n) = (x as i64, y as i64, h as i64, self.side as i64);
        let ok = |p: (i64, i64)| (p.0 >= 0 && p.1 >= 0 && p.0 <= n && p.1 <= n).then_some(p);
        match kind {
            Kind::Centre => [
                ok((x - h, y)),
                ok((x + h, y)),
                ok((x, y - h)),
                ok((x, y + h)),
            ],
            Kind::Edge { .. } if h >= 2 => {
                let q = h / 2;
                [
                    ok((x - q, y - q)),
                    ok((x + q, y - q)),
                    ok((x - q, y + q)),
                    ok((x + q, y + q)),
                ]
            }
            Kind::Edge { .. } => [None; 4],
        }
    }
}

/// Whether the `s x s` square at `(x0, y0)` is split along its main diagonal `(x0,y0)-(x0+s,y0+s)`.
#[inline(always)]
pub(crate) fn main_diagonal(x0: i64, y0: i64, s: i64) -> bool {
    // Squares have a size of at least 1; the max keeps a division-by-zero panic path out.
    let s = s.max(1);
    ((x0 / s) + (y0 / s)) % 2 == 0
}

/// The two kinds of vertices of the hierarchy.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    /// Centre of an aligned `2h x 2h` square (split along one of its diagonals).
    Centre,
    /// Midpoint of an axis-aligned edge of length `2h`.
    Edge {
        /// The edge runs along x.
        horizontal: bool,
    },
}
