//! A crack checker for triangle meshes over a rectangular domain (std): every interior edge shared
//! by exactly two triangles with opposite directions, no degenerate or flipped triangle
//! (counter-clockwise seen from +z), areas summing to the domain, and no T-junctions (no vertex on
//! the inside of another triangle's edge).

use std::collections::{HashMap, HashSet};

/// What [`check_mesh`] accepts.
#[derive(Debug, Clone, Copy)]
pub struct CheckOptions {
    /// Domain `[0, extent.0] x [0, extent.1]` in world units.
    pub extent: (f64, f64),
    /// Grid spacing `(dx, dy)`: vertices must lie on grid points, which makes the T-junction test
    /// exact (lattice points along every edge are looked up).
    pub spacing: (f64, f64),
    /// Allow holes (culled regions): boundary edges inside the domain and a total area below the
    /// domain's are then accepted; T-junctions, overlaps and flips are still errors.
    pub allow_holes: bool,
    /// Check T-junctions (default on). Lazy culling may leave T-junctions outside the view.
    pub t_junctions: bool,
}

impl CheckOptions {
    /// Options for a `width x height` grid with spacing `dx, dy`: no holes, T-junctions checked.
    pub fn grid(width: u32, height: u32, dx: f64, dy: f64) -> Self {
        CheckOptions {
            extent: ((width - 1) as f64 * dx, (height - 1) as f64 * dy),
            spacing: (dx, dy),
            allow_holes: false,
            t_junctions: true,
        }
    }
}

/// Statistics of a mesh that passed [`check_mesh`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshReport {
    /// Vertices referenced by triangles.
    pub used_vertices: usize,
    /// Triangles.
    pub triangles: usize,
    /// Sum of triangle areas (world units squared).
    pub area: f64,
    /// Edges with one triangle.
    pub boundary_edges: usize,
}

/// Checks `triangles` over `vertices` (world positions); `Err` names the first problem.
pub fn check_mesh(
    vertices: &[[f32; 3]],
    triangles: &[[u32; 3]],
    o: &CheckOptions,
) -> Result<MeshReport, String> {
    let (dx, dy) = o.spacing;
    let lattice = |v: [f32; 3]| -> Result<(i64, i64), String> {
        let (gx, gy) = (v[0] as f64 / dx, v[1] as f64 / dy);
        let (rx, ry) = (gx.round(), gy.round());
        if (gx - rx).abs() > 1e-3 || (gy - ry).abs() > 1e-3 {
            return Err(format!("vertex {v:?} is not on a grid point"));
        }
        Ok((rx as i64, ry as i64))
    };
    let mut pts = Vec::with_capacity(vertices.len());
    for &v in vertices {
        pts.push(lattice(v)?);
    }
    let mut at: HashMap<(i64, i64), u32> = HashMap::new();
    let mut used = HashSet::new();
    let mut directed: HashSet<(u32, u32)> = HashSet::new();
    let mut area2: i128 = 0;
    for (k, t) in triangles.iter().enumerate() {
        for &i in t {
            if i as usize >= pts.len() {
                return Err(format!("triangle {k} names vertex {i} of {}", pts.len()));
            }
            used.insert(i);
        }
        let [a, b, c] = t.map(|i| pts[i as usize]);
        let o2 =
            (b.0 - a.0) as i128 * (c.1 - a.1) as i128 - (b.1 - a.1) as i128 * (c.0 - a.0) as i128;
        if o2 == 0 {
            return Err(format!("triangle {k} {t:?} is degenerate"));
        }
        if o2 < 0 {
            return Err(format!(
                "triangle {k} {t:?} is clockwise seen from +z (flipped)"
            ));
        }
        area2 += o2;
        for (p, q) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            if !directed.insert((p, q)) {
                return Err(format!(
                    "edge {p}->{q} used twice in one direction (overlap)"
                ));
            }
        }
    }
    for &i in &used {
        if let Some(j) = at.insert(pts[i as usize], i) {
            return Err(format!("vertices {j} and {i} coincide"));
        }
    }
    let (w1, h1) = (
        (o.extent.0 / dx).round() as i64,
        (o.extent.1 / dy).round() as i64,
    );
    let on_border = |p: (i64, i64), q: (i64, i64)| {
        (p.0 == q.0 && (p.0 == 0 || p.0 == w1)) || (p.1 == q.1 && (p.1 == 0 || p.1 == h1))
    };
    let mut boundary = 0;
    for &(p, q) in &directed {
        if directed.contains(&(q, p)) {
            continue;
        }
        boundary += 1;
        let (a, b) = (pts[p as usize], pts[q as usize]);
        if !o.allow_holes && !on_border(a, b) {
            return Err(format!(
                "edge {a:?}-{b:?} has one triangle but is not on the domain border"
            ));
        }
    }
    for &i in &used {
        let p = pts[i as usize];
        if p.0 < 0 || p.1 < 0 || p.0 > w1 || p.1 > h1 {
            return Err(format!("vertex {p:?} lies outside the domain"));
        }
    }
    let domain2 = 2 * w1 as i128 * h1 as i128;
    if o.allow_holes {
        if area2 > domain2 {
            return Err(format!(
                "area {} exceeds the domain's {}",
                area2 as f64 / 2.0,
                domain2 as f64 / 2.0
            ));
        }
    } else if area2 != domain2 {
        return Err(format!(
            "area {} differs from the domain's {}",
            area2 as f64 / 2.0,
            domain2 as f64 / 2.0
        ));
    }
    if o.t_junctions {
        let mut seen = HashSet::new();
        for &(p, q) in &directed {
            let key = (p.min(q), p.max(q));
            if !seen.insert(key) {
                continue;
            }
            let (a, b) = (pts[p as usize], pts[q as usize]);
            let (ex, ey) = (b.0 - a.0, b.1 - a.1);
            let g = gcd(ex.unsigned_abs(), ey.unsigned_abs()) as i64;
            for s in 1..g {
                let m = (a.0 + ex / g * s, a.1 + ey / g * s);
                if at.contains_key(&m) {
                    return Err(format!("T-junction: vertex {m:?} lies on edge {a:?}-{b:?}"));
                }
            }
        }
    }
    Ok(MeshReport {
        used_vertices: used.len(),
        triangles: triangles.len(),
        area: area2 as f64 / 2.0 * dx * dy,
        boundary_edges: boundary,
    })
}

fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn o() -> CheckOptions {
        CheckOptions::grid(3, 3, 1.0, 1.0)
    }

    #[test]
    fn accepts_a_conforming_mesh_and_names_each_defect() {
        let v = [
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.0, 2.0, 0.0],
            [0.0, 2.0, 0.0],
            [1.0, 0.0, 0.0],
        ];
        let good = [[0, 4, 2], [4, 1, 2], [0, 2, 3]];
        let r = check_mesh(&v, &good, &o()).unwrap();
        assert_eq!((r.triangles, r.area, r.boundary_edges), (3, 4.0, 5));
        // Flipped.
        assert!(check_mesh(&v, &[[0, 2, 4], [4, 1, 2], [0, 2, 3]], &o())
            .unwrap_err()
            .contains("clockwise"));
        // Gap: a triangle missing.
        assert!(check_mesh(&v, &good[..2], &o()).is_err());
        // T-junction: vertex 4 on the edge 0-2? No: on the border edge 0-1 of a big triangle.
        let tj = [[0, 1, 2], [0, 2, 3], [0, 4, 2]];
        assert!(check_mesh(&v, &tj, &o()).is_err());
        // Degenerate.
        assert!(check_mesh(&v, &[[0, 4, 1]], &o())
            .unwrap_err()
            .contains("degenerate"));
        // Vertex 4 used as a T-junction on a shared interior edge.
        let v2 = [
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.0, 2.0, 0.0],
            [0.0, 2.0, 0.0],
            [1.0, 1.0, 0.0],
        ];
        let tj2 = [[0, 1, 2], [0, 4, 3], [4, 2, 3]];
        let e = check_mesh(&v2, &tj2, &o()).unwrap_err();
        assert!(
            e.contains("not on the domain border") || e.contains("T-junction"),
            "{e}"
        );
        let mut holes = o();
        holes.allow_holes = true;
        assert!(check_mesh(&v, &good[..2], &holes).is_ok());
    }
}
