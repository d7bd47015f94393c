//! Ray / cell intersection for every surface of CONVENTIONS.md, in heightfield-local `f64`
//! coordinates (grid units horizontally, local height `h * z_scale` vertically).
//!
//! - `triangles`: the ray height minus the surface height is linear on each triangle, so it is
//!   tested at cell entry, at the diagonal crossing and at exit; the first point at or below the
//!   surface wins (testing only entry and exit leaks through the diagonal).
//! - `bilinear`: exact analytic solution of the quadratic along the ray.
//! - `plane`: Henning & Stephenson 2004, section 3, the *linear plane* reconstruction: surface
//!   heights interpolated on the two cell faces the projected ray crosses, linearly interpolated
//!   between them, and a sign test of the two ray-minus-surface differences.
//! - `nearest`: sample boxes (the cell holds four quarter boxes), walls and tops.

use crate::Surface;
use glam::DVec3;

/// A ray in local coordinates with its parameter range already clipped.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LocalRay {
    pub o: DVec3,
    pub d: DVec3,
    /// `1 / d` per horizontal axis (infinite for zero components, never used then).
    pub inv: [f64; 2],
    pub t0: f64,
    pub t1: f64,
}

/// A hit inside a cell: parameter and an unnormalised normal in grid units.
#[derive(Debug, Clone, Copy)]
pub(crate) struct CellHit {
    pub t: f64,
    pub n: DVec3,
}

impl LocalRay {
    #[inline]
    pub fn z(&self, t: f64) -> f64 {
        self.o.z + t * self.d.z
    }

    /// Parameter interval of the ray inside the column `[c, c + 1]` of axis `i` (full line,
    /// unclipped); `(-inf, inf)` for a zero component.
    #[inline]
    pub fn slab(&self, i: usize, c: f64) -> (f64, f64) {
        let (o, d, inv) = match i {
            0 => (self.o.x, self.d.x, self.inv[0]),
            _ => (self.o.y, self.d.y, self.inv[1]),
        };
        if d == 0.0 {
            return (f64::NEG_INFINITY, f64::INFINITY);
        }
        let a = (c - o) * inv;
        let b = (c + 1.0 - o) * inv;
        if a <= b {
            (a, b)
        } else {
            (b, a)
        }
    }

    /// Unclipped parameter interval of the line inside cell `(cx, cy)`.
    #[inline]
    pub fn cell_span(&self, cx: u32, cy: u32) -> (f64, f64) {
        let (ax, bx) = self.slab(0, cx as f64);
        let (ay, by) = self.slab(1, cy as f64);
        (ax.max(ay), bx.min(by))
    }
}

#[inline]
fn unit_normal_tri(h: &[f64; 4], upper: bool) -> DVec3 {
    let [h00, h10, h01, h11] = *h;
    if upper {
        // (x,y) (x+1,y+1) (x,y+1): z = h00 + fx (h11 - h01) + fy (h01 - h00)
        DVec3::new(-(h11 - h01), -(h01 - h00), 1.0)
    } else {
        // (x,y) (x+1,y) (x+1,y+1): z = h00 + fx (h10 - h00) + fy (h11 - h10)
        DVec3::new(-(h10 - h00), -(h11 - h10), 1.0)
    }
}

#[inline]
fn tri_height(h: &[f64; 4], fx: f64, fy: f64, upper: bool) -> f64 {
    let [h00, h10, h01, h11] = *h;
    if upper {
        h00 + fx * (h11 - h01) + fy * (h01 - h00)
    } else {
        h00 + fx * (h10 - h00) + fy * (h11 - h10)
    }
}

#[inline]
fn bilinear(h: &[f64; 4], fx: f64, fy: f64) -> f64 {
    let [h00, h10, h01, h11] = *h;
    let a = h00 + fx * (h10 - h00);
    let b = h01 + fx * (h11 - h01);
    a + fy * (b - a)
}

/// Height of `surface` at cell-local `(fx, fy)` in `[0, 1]^2` (`plane` as `triangles`).
#[inline]
pub(crate) fn surface_at(surface: Surface, h: &[f64; 4], fx: f64, fy: f64) -> f64 {
    match surface {
        Surface::Bilinear => bilinear(h, fx, fy),
        Surface::Nearest => {
            let i = usize::from(fx >= 0.5);
            let j = usize::from(fy >= 0.5);
            h.get(j * 2 + i).copied().unwrap_or(h[0])
        }
        _ => tri_height(h, fx, fy, fy > fx),
    }
}

/// First point of `[ta, tb]` where the ray is at or below `surface` inside cell `(cx, cy)` with
/// corner heights `h = [h00, h10, h01, h11]` (local). `ta <= tb` must hold.
#[inline]
pub(crate) fn intersect(
    surface: Surface,
    ray: &LocalRay,
    cx: u32,
    cy: u32,
    h: &[f64; 4],
    ta: f64,
    tb: f64,
) -> Option<CellHit> {
    // Cell-local origin keeps precision far from the grid origin.
    let px = ray.o.x - cx as f64;
    let py = ray.o.y - cy as f64;
    let (dx, dy) = (ray.d.x, ray.d.y);
    let fx = |t: f64| px + t * dx;
    let fy = |t: f64| py + t * dy;
    match surface {
        Surface::Bilinear => bilinear_hit(ray, h, px, py, ta, tb),
        Surface::Nearest => nearest_hit(ray, h, px, py, ta, tb),
        Surface::Plane => {
            let (sa, sb) = ray.cell_span(cx, cy);
            if !(sa.is_finite() && sb.is_finite()) || sb <= sa {
                // No face crossing to interpolate between (vertical ray): the plane through three
                // samples at this point, i.e. the triangles surface.
                return triangles_hit(ray, h, px, py, ta, tb);
            }
            let ha = bilinear(h, fx(sa).clamp(0.0, 1.0), fy(sa).clamp(0.0, 1.0));
            let hb = bilinear(h, fx(sb).clamp(0.0, 1.0), fy(sb).clamp(0.0, 1.0));
            let s = |t: f64| ha + (hb - ha) * ((t - sa) / (sb - sa));
            let fa = ray.z(ta) - s(ta);
            let mid = 0.5 * (ta + tb);
            let upper = fy(mid) > fx(mid);
            let n = unit_normal_tri(h, upper);
            if fa <= 0.0 {
                return Some(CellHit { t: ta, n });
            }
            let fb = ray.z(tb) - s(tb);
            if fb <= 0.0 {
                let t = ta + (tb - ta) * (fa / (fa - fb));
                return Some(CellHit {
                    t: t.max(ta).min(tb),
                    n,
                });
            }
            None
        }
        // Triangles, and any surface added later, fall back to the reference surface.
        _ => triangles_hit(ray, h, px, py, ta, tb),
    }
}

/// `ray/simd.rs` (`leaves_triangles8`) takes this test in AVX-512 lanes with the same operations
/// in the same order: keep the two in step.
#[inline]
fn triangles_hit(
    ray: &LocalRay,
    h: &[f64; 4],
    px: f64,
    py: f64,
    ta: f64,
    tb: f64,
) -> Option<CellHit> {
    let (dx, dy) = (ray.d.x, ray.d.y);
    // g(t) = fx - fy: the diagonal crossing splits [ta, tb] in at most two pieces.
    let g0 = px - py;
    let gd = dx - dy;
    let mut cuts = [ta, tb, tb];
    let mut n = 2;
    if gd != 0.0 {
        let td = -g0 / gd;
        if td > ta && td < tb {
            cuts = [ta, td, tb];
            n = 3;
        }
    }
    let mut k = 0;
    while k + 1 < n {
        let (a, b) = (cuts[k], cuts[k + 1]);
        let mid = 0.5 * (a + b);
        let upper = (py + mid * dy) > (px + mid * dx);
        let f = |t: f64| {
            let x = (px + t * dx).clamp(0.0, 1.0);
            let y = (py + t * dy).clamp(0.0, 1.0);
            ray.z(t) - tri_height(h, x, y, upper)
        };
        let fa = f(a);
        if fa <= 0.0 {
            return Some(CellHit {
                t: a,
                n: unit_normal_tri(h, upper),
            });
        }
        let fb = f(b);
        if fb <= 0.0 {
            let t = a + (b - a) * (fa / (fa - fb));
            return Some(CellHit {
                t: t.max(a).min(b),
                n: unit_normal_tri(h, upper),
            });
        }
        k += 1;
    }
    None
}

#[inline]
fn bilinear_hit(
    ray: &LocalRay,
    h: &[f64; 4],
    px: f64,
    py: f64,
    ta: f64,
    tb: f64,
) -> Option<CellHit> {
    let [h00, h10, h01, h11] = *h;
    let (b1, b2, c) = (h10 - h00, h01 - h00, h00 - h10 - h01 + h11);
    let (ux, uy) = (ray.d.x, ray.d.y);
    // Local coordinates at ta; s = t - ta.
    let ax = px + ta * ux;
    let ay = py + ta * uy;
    let s0 = h00 + b1 * ax + b2 * ay + c * ax * ay;
    let s1 = b1 * ux + b2 * uy + c * (ax * uy + ay * ux);
    let s2 = c * ux * uy;
    let f0 = ray.z(ta) - s0;
    let f1 = ray.d.z - s1;
    let f2 = -s2;
    let normal = |s: f64| {
        let x = (ax + s * ux).clamp(0.0, 1.0);
        let y = (ay + s * uy).clamp(0.0, 1.0);
        DVec3::new(-(b1 + c * y), -(b2 + c * x), 1.0)
    };
    if f0 <= 0.0 {
        return Some(CellHit {
            t: ta,
            n: normal(0.0),
        });
    }
    let len = tb - ta;
    let f = |s: f64| f0 + s * (f1 + s * f2);
    let fl = f(len);
    let root = if fl <= 0.0 {
        // Exactly one crossing in (0, len].
        first_root(f0, f1, f2, len).unwrap_or(len)
    } else if f2 > 0.0 {
        // Convex: it may dip below between two positive ends.
        let sv = -f1 / (2.0 * f2);
        if sv > 0.0 && sv < len && f(sv) <= 0.0 {
            first_root(f0, f1, f2, sv).unwrap_or(sv)
        } else {
            return None;
        }
    } else {
        return None;
    };
    let s = root.max(0.0).min(len);
    Some(CellHit {
        t: ta + s,
        n: normal(s),
    })
}

/// Smallest root of `f0 + f1 s + f2 s^2` in `[0, hi]` (numerically stable form), given
/// `f0 > 0` and a sign change in the interval.
#[inline]
fn first_root(f0: f64, f1: f64, f2: f64, hi: f64) -> Option<f64> {
    let scale = f0.abs() + f1.abs() * hi + f2.abs() * hi * hi;
    if f2.abs() * hi * hi <= 1e-12 * scale {
        if f1 == 0.0 {
            return None;
        }
        return Some(-f0 / f1);
    }
    let disc = (f1 * f1 - 4.0 * f2 * f0).max(0.0);
    let sq = libm::sqrt(disc);
    let qq = -0.5 * (f1 + if f1 >= 0.0 { sq } else { -sq });
    let r1 = if f2 != 0.0 { qq / f2 } else { f64::INFINITY };
    let r2 = if qq != 0.0 { f0 / qq } else { f64::INFINITY };
    let tol = 1e-9 * hi.max(f64::MIN_POSITIVE);
    let ok = |r: f64| r.is_finite() && r >= -tol && r <= hi + tol;
    match (ok(r1), ok(r2)) {
        (true, true) => Some(r1.min(r2)),
        (true, false) => Some(r1),
        (false, true) => Some(r2),
        _ => None,
    }
}

#[inline]
fn nearest_hit(
    ray: &LocalRay,
    h: &[f64; 4],
    px: f64,
    py: f64,
    ta: f64,
    tb: f64,
) -> Option<CellHit> {
    let (dx, dy) = (ray.d.x, ray.d.y);
    // Split at fx = 0.5 and fy = 0.5 (sample box walls).
    let mut cuts = [ta, tb, tb, tb];
    let mut walls = [DVec3::ZERO; 4];
    let mut n = 1;
    let mut add = |t: f64, w: DVec3, cuts: &mut [f64; 4], walls: &mut [DVec3; 4]| {
        if t > ta && t < tb && n < 3 {
            cuts[n] = t;
            walls[n] = w;
            n += 1;
        }
    };
    if dx != 0.0 {
        add(
            (0.5 - px) / dx,
            DVec3::new(-dx.signum(), 0.0, 0.0),
            &mut cuts,
            &mut walls,
        );
    }
    if dy != 0.0 {
        add(
            (0.5 - py) / dy,
            DVec3::new(0.0, -dy.signum(), 0.0),
            &mut cuts,
            &mut walls,
        );
    }
    if n == 3 && cuts[2] < cuts[1] {
        cuts.swap(1, 2);
        walls.swap(1, 2);
    }
    cuts[n] = tb;
    // The entry wall: the face whose slab entry is latest; a ray starting inside hits the top.
    walls[0] = DVec3::Z;
    let mut k = 0;
    while k < n {
        let (a, b) = (cuts[k], cuts[k + 1]);
        let mid = 0.5 * (a + b);
        let i = usize::from(px + mid * dx >= 0.5);
        let j = usize::from(py + mid * dy >= 0.5);
        let hq = h.get(j * 2 + i).copied().unwrap_or(h[0]);
        let za = ray.z(a);
        if za <= hq {
            return Some(CellHit { t: a, n: walls[k] });
        }
        if ray.z(b) <= hq && ray.d.z < 0.0 {
            let t = a + (hq - za) / ray.d.z;
            return Some(CellHit {
                t: t.max(a).min(b),
                n: DVec3::Z,
            });
        }
        k += 1;
    }
    None
}
