//! Tests of the 8-byte vertex records and their layouts (std only in tests).

use super::layout::record_index;
use super::tests::{list, Mesh};
use super::*;
use crate::{Camera, Error, Heightfield, Scale, Terrain};
use glam::Vec3;
use std::collections::BTreeSet;
use std::vec;
use std::vec::Vec;

fn grid(w: u32, h: u32, seed: u64, amp: f32) -> Vec<f32> {
    let mut s = seed | 1;
    (0..w * h)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            ((s >> 11) % 1000) as f32 / 1000.0 * amp
        })
        .collect()
}

fn area(m: &Mesh) -> f64 {
    m.t.iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| m.v[i as usize].map(|x| x as f64));
            0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
        })
        .sum()
}

fn vertex_set(m: &Mesh) -> BTreeSet<[u32; 2]> {
    m.v.iter()
        .map(|v| [v[0].to_bits(), v[1].to_bits()])
        .collect()
}

fn cameras() -> [Camera; 3] {
    [
        Camera::new(
            Vec3::new(-50.0, -50.0, 200.0),
            Vec3::new(320.0, 240.0, 0.0),
            60.0,
            320,
            240,
        )
        .unwrap(),
        Camera::new(
            Vec3::new(200.0, 150.0, 40.0),
            Vec3::new(600.0, 300.0, 10.0),
            60.0,
            320,
            240,
        )
        .unwrap(),
        Camera::new(
            Vec3::new(150.0, 140.0, 5.0),
            Vec3::new(0.0, 140.0, 5.0),
            60.0,
            320,
            240,
        )
        .unwrap(),
    ]
}

/// A random `w x h` grid (spacing 10, heights up to 30) and its full preprocessing.
fn with_full(w: u32, h: u32, seed: u64, f: impl FnOnce(&Heightfield<'_, f32>, &Hierarchy<'_>)) {
    let s = grid(w, h, seed, 30.0);
    let sc = Scale::default().with_spacing(10.0, 10.0);
    let hf = Heightfield::with_scale(&s, w, h, sc).unwrap();
    let n = hierarchy_len(w, h);
    let (mut er, mut ra) = (vec![0.0; n], vec![0.0; n]);
    let full = preprocess(&hf, &mut er, &mut ra).unwrap();
    f(&hf, &full);
}

/// Both layouts give the same mesh (vertices and triangles, in order), view-independent and
/// view-dependent with and without culling, on square and non-square grids; view-dependent
/// frames of interleaved records on square grids number the same vertices in record order.
#[test]
fn same_mesh_for_both_layouts() {
    for (w, h, seed) in [(65, 65, 3), (37, 29, 5), (2, 2, 7), (3, 3, 9), (64, 17, 11)] {
        with_full(w, h, seed, |hf, full| same_mesh_case(w, h, hf, full));
    }
}

fn same_mesh_case(w: u32, h: u32, hf: &Heightfield<'_, f32>, full: &Hierarchy<'_>) {
    let (hf, full) = (*hf, *full);
    {
        let mut lin = vec![VertexRecord::default(); records_len(w, h, RecordLayout::Linear)];
        let mut il = vec![VertexRecord::default(); records_len(w, h, RecordLayout::Interleaved)];
        let a = pack_records(&full, &hf, RecordLayout::Linear, &mut lin).unwrap();
        let b = pack_records(&full, &hf, RecordLayout::Interleaved, &mut il).unwrap();
        for y in 0..h {
            for x in 0..w {
                assert_eq!(a.error(x, y), b.error(x, y));
                assert_eq!(a.radius(x, y), b.radius(x, y));
            }
        }
        let mut crits = vec![Criterion::MaxError(0.0), Criterion::MaxError(5.0)];
        for cam in cameras() {
            for (lazy, cull) in [(0, true), (4, true), (0, false)] {
                let v = View::new(&cam, 1.5)
                    .unwrap()
                    .with_lazy_levels(lazy)
                    .with_culling(cull);
                crits.push(Criterion::View(v));
            }
        }
        let mut nontrivial = 0;
        for c in crits {
            let (ma, mb) = (list(&a, &hf, c), list(&b, &hf, c));
            let hierarchical = matches!(c, Criterion::View(_)) && full.grid().is_square();
            if hierarchical {
                // Interleaved records number a view-dependent frame's vertices in record order:
                // the same vertices, and the same triangles in the same order, by position.
                let by_pos = |m: &Mesh| -> Vec<[[u32; 3]; 3]> {
                    m.t.iter()
                        .map(|t| t.map(|i| m.v[i as usize].map(f32::to_bits)))
                        .collect()
                };
                assert_eq!(vertex_set(&ma), vertex_set(&mb), "{w}x{h} {c:?}");
                assert_eq!(ma.v.len(), mb.v.len(), "{w}x{h} {c:?}");
                assert_eq!(by_pos(&ma), by_pos(&mb), "{w}x{h} {c:?}");
                if ma.v.len() > 4 {
                    assert_ne!(ma.v, mb.v, "{w}x{h} {c:?}: expected record order");
                }
                // Geomorph data: the same vertices with the same morph, in each list's order.
                let morph = |hier: &Hierarchy<'_>| {
                    let r = Refiner::new(hier, &hf, c).unwrap();
                    let mut out = vec![MorphVertex::default(); (w * h) as usize];
                    let k = r.morph(&mut vec![0; scratch_len(w, h)], &mut out).unwrap();
                    out.truncate(k);
                    out
                };
                let (mo_a, mo_b) = (morph(&a), morph(&b));
                assert_eq!(
                    mo_a.iter().map(|m| m.position).collect::<Vec<_>>(),
                    ma.v,
                    "{w}x{h} {c:?}"
                );
                assert_eq!(
                    mo_b.iter().map(|m| m.position).collect::<Vec<_>>(),
                    mb.v,
                    "{w}x{h} {c:?}"
                );
                let key = |m: &MorphVertex| (m.position.map(f32::to_bits), m.base_z.to_bits());
                let mut ka: Vec<_> = mo_a.iter().map(key).collect();
                let mut kb: Vec<_> = mo_b.iter().map(key).collect();
                ka.sort();
                kb.sort();
                assert_eq!(ka, kb, "{w}x{h} {c:?}");
                // Strips over the interleaved records draw the same triangles, by position,
                // as the strips over the linear records.
                for soar in [false, true] {
                    let strip_tris = |hier: &Hierarchy<'_>| -> Vec<[[u32; 3]; 3]> {
                        let r = Refiner::new(hier, &hf, c).unwrap();
                        let (v, st, k) = super::tests::strip(&r, soar);
                        super::strip_triangles(&st[..k.indices])
                            .map(|t| t.map(|i| v[..k.vertices][i as usize].map(f32::to_bits)))
                            .collect()
                    };
                    let (sa, sb) = (strip_tris(&a), strip_tris(&b));
                    assert!(!sa.is_empty(), "{w}x{h} {c:?}: empty strip");
                    assert_eq!(sa, sb, "{w}x{h} {c:?} soar {soar}");
                }
            } else {
                assert_eq!(ma.v, mb.v, "{w}x{h} {c:?}");
                assert_eq!(ma.t, mb.t, "{w}x{h} {c:?}");
            }
            nontrivial += usize::from(ma.t.len() > 2);
        }
        assert!(w < 4 || nontrivial > 3, "{w}x{h}: too few refined meshes");
    }
}

/// Records round errors and radii up: the record mesh refines the `f32` mesh (its vertex set
/// contains the other's), stays counter-clockwise, covers the domain, and keeps the error bound.
#[test]
fn records_refine_the_f32_mesh_and_keep_the_bound() {
    let (w, h) = (65, 49);
    let s = grid(w, h, 21, 40.0);
    let sc = Scale::default().with_spacing(10.0, 10.0);
    let hf = Heightfield::with_scale(&s, w, h, sc).unwrap();
    let n = hierarchy_len(w, h);
    let (mut er, mut ra) = (vec![0.0; n], vec![0.0; n]);
    let full = preprocess(&hf, &mut er, &mut ra).unwrap();
    let mut il = vec![VertexRecord::default(); records_len(w, h, RecordLayout::Interleaved)];
    let rec = pack_records(&full, &hf, RecordLayout::Interleaved, &mut il).unwrap();
    let domain = (w - 1) as f64 * 10.0 * (h - 1) as f64 * 10.0;
    let mut crits = vec![Criterion::MaxError(1.0), Criterion::MaxError(8.0)];
    for cam in cameras() {
        crits.push(Criterion::View(
            View::new(&cam, 1.0).unwrap().with_culling(false),
        ));
    }
    for c in crits {
        let (mf, mr) = (list(&full, &hf, c), list(&rec, &hf, c));
        assert!(vertex_set(&mr).is_superset(&vertex_set(&mf)), "{c:?}");
        assert!((area(&mr) - domain).abs() < 1e-6 * domain, "{c:?}");
        if let Criterion::MaxError(e) = c {
            let mut cov = vec![0; coverage_len(w, h)];
            let measured = vertical_error(&hf, &mr.v, &mr.t, &mut cov).unwrap();
            assert!(measured <= e as f64, "{measured} > {e}");
        }
    }
}

/// Re-nested rounded radii: every sphere contains its in-domain children's spheres.
#[test]
fn rounded_radii_stay_nested() {
    let (w, h) = (33, 33);
    let s = grid(w, h, 5, 50.0);
    let sc = Scale::default().with_spacing(3.0, 3.0);
    let hf = Heightfield::with_scale(&s, w, h, sc).unwrap();
    let n = hierarchy_len(w, h);
    let (mut er, mut ra) = (vec![0.0; n], vec![0.0; n]);
    let full = preprocess(&hf, &mut er, &mut ra).unwrap();
    let mut lin = vec![VertexRecord::default(); n];
    let rec = pack_records(&full, &hf, RecordLayout::Linear, &mut lin).unwrap();
    let g = rec.grid();
    let mut checked = 0;
    for y in 0..h {
        for x in 0..w {
            let Some(rp) = rec.radius(x, y) else { continue };
            if g.level(x, y).is_none() {
                continue;
            }
            assert!(rp >= full.radius(x, y).unwrap());
            let p = hf.position(x, y).unwrap().as_dvec3();
            for (cx, cy) in g.children(x, y).into_iter().flatten() {
                if !g.in_domain(cx, cy) {
                    continue;
                }
                let (cx, cy) = (cx as u32, cy as u32);
                let c = hf.position(cx, cy).unwrap().as_dvec3();
                let rc = rec.radius(cx, cy).unwrap() as f64;
                assert!(
                    rp as f64 >= (p - c).length() + rc,
                    "({x},{y}) -> ({cx},{cy})"
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 1000);
}

#[test]
fn bad_inputs_are_errors() {
    let s = grid(9, 9, 1, 1.0);
    let hf = Heightfield::new(&s, 9, 9).unwrap();
    let (mut er, mut ra) = (vec![0.0; 81], vec![0.0; 81]);
    let full = preprocess(&hf, &mut er, &mut ra).unwrap();
    let mut short = vec![VertexRecord::default(); 80];
    assert_eq!(
        pack_records(&full, &hf, RecordLayout::Interleaved, &mut short).unwrap_err(),
        crate::Error::BufferTooSmall {
            needed: 81,
            actual: 80
        }
    );
    let other = Heightfield::new(&s[..72], 9, 8).unwrap();
    let mut buf = vec![VertexRecord::default(); 81];
    assert!(pack_records(&full, &other, RecordLayout::Linear, &mut buf).is_err());
    assert_eq!(records_len(1, 5, RecordLayout::Linear), 0);
}

/// One scratch reused across view-dependent frames, view-independent calls, strips, a failed
/// call (buffer too small) and a garbage start gives the same meshes as fresh zeroed scratch:
/// sparse clearing leaves nothing behind.
#[test]
fn reused_scratch_gives_the_same_meshes() {
    let (w, h) = (65, 65);
    let s = grid(w, h, 9, 30.0);
    let sc = Scale::default().with_spacing(10.0, 10.0);
    let hf = Heightfield::with_scale(&s, w, h, sc).unwrap();
    let n = hierarchy_len(w, h);
    let (mut er, mut ra) = (vec![0.0; n], vec![0.0; n]);
    let full = preprocess(&hf, &mut er, &mut ra).unwrap();
    let mut crits = vec![];
    for cam in cameras() {
        crits.push(Criterion::View(View::new(&cam, 1.0).unwrap()));
        crits.push(Criterion::MaxError(3.0));
    }
    let mut scratch = vec![u64::MAX; scratch_len(w, h)]; // garbage start
    let (mut v, mut t) = (vec![[0.0f32; 3]; n], vec![[0u32; 3]; triangle_bound(w, h)]);
    let mut strip = vec![0u32; strip_bound(w, h)];
    for (k, c) in crits.iter().cycle().take(3 * crits.len()).enumerate() {
        let expected = list(&full, &hf, *c);
        let r = Refiner::new(&full, &hf, *c).unwrap();
        let got = r.triangles(&mut scratch, &mut v, &mut t).unwrap();
        assert_eq!(got.triangles, expected.t.len());
        assert_eq!(&t[..got.triangles], &expected.t[..], "call {k}");
        assert_eq!(&v[..got.vertices], &expected.v[..], "call {k}");
        assert_eq!(r.count(&mut scratch).unwrap(), got);
        match k % 3 {
            0 => {
                let mut short = vec![[0u32; 3]; got.triangles - 1];
                assert!(r.triangles(&mut scratch, &mut v, &mut short).is_err());
            }
            1 => {
                r.inout_strip(&mut scratch, &mut v, &mut strip).unwrap();
            }
            _ => {
                r.soar_strip(&mut scratch, &mut v, &mut strip).unwrap();
            }
        }
    }
}

/// The triangle list skips the second decision of a vertex already in the mesh; the selection
/// behind `count` and `morph` decides every visit. Both give the same vertices.
#[test]
fn skipping_repeated_decisions_keeps_the_mesh() {
    let (w, h) = (65, 49);
    let s = grid(w, h, 13, 40.0);
    let sc = Scale::default().with_spacing(10.0, 10.0);
    let hf = Heightfield::with_scale(&s, w, h, sc).unwrap();
    let n = hierarchy_len(w, h);
    let (mut er, mut ra) = (vec![0.0; n], vec![0.0; n]);
    let full = preprocess(&hf, &mut er, &mut ra).unwrap();
    let mut rec = vec![VertexRecord::default(); records_len(w, h, RecordLayout::Interleaved)];
    let il = pack_records(&full, &hf, RecordLayout::Interleaved, &mut rec).unwrap();
    let mut scratch = vec![0u64; scratch_len(w, h)];
    let mut checked = 0;
    for hier in [&full, &il] {
        for cam in cameras() {
            for (lazy, cull) in [(0, true), (4, true), (2, false)] {
                let v = View::new(&cam, 0.7)
                    .unwrap()
                    .with_lazy_levels(lazy)
                    .with_culling(cull);
                let r = Refiner::new(hier, &hf, Criterion::View(v)).unwrap();
                let m = list(hier, &hf, Criterion::View(v));
                let mut mv = vec![MorphVertex::default(); n];
                let k = r.morph(&mut scratch, &mut mv).unwrap();
                let pos: Vec<[f32; 3]> = mv[..k].iter().map(|v| v.position).collect();
                assert_eq!(pos, m.v);
                checked += usize::from(m.t.len() > 8);
            }
        }
    }
    assert!(checked > 6);
}

/// Records stored and wrapped again (`records_hierarchy`, as after mapping a file) give the
/// packed hierarchy's meshes exactly; `check_records` accepts every packed layout and names the
/// first record that breaks an invariant: a NaN or negative error, a height outside the range,
/// an error above its parent's, a sphere its parent does not contain.
#[test]
fn stored_records_refine_alike_and_the_checker_finds_broken_ones() {
    for (w, h, seed) in [(65, 65, 3), (37, 29, 5), (2, 2, 7), (64, 17, 11)] {
        with_full(w, h, seed, |hf, full| stored_records_case(w, h, hf, full));
    }
}

fn stored_records_case(w: u32, h: u32, hf: &Heightfield<'_, f32>, full: &Hierarchy<'_>) {
    let (hf, full) = (*hf, *full);
    let sc = hf.scale();
    {
        assert!(check_records(&full).is_err(), "not records");
        for layout in [RecordLayout::Linear, RecordLayout::Interleaved] {
            let mut rec = vec![VertexRecord::default(); records_len(w, h, layout)];
            let packed = pack_records(&full, &hf, layout, &mut rec).unwrap();
            let z = packed.z_range();
            let mut crits = vec![Criterion::MaxError(2.0)];
            crits.extend(cameras().map(|c| Criterion::View(View::new(&c, 1.5).unwrap())));
            let meshes: Vec<_> = crits.iter().map(|&c| list(&packed, &hf, c)).collect();
            let stored = rec.clone();
            let again = records_hierarchy(&stored, layout, w, h, sc, z).unwrap();
            assert_eq!(check_records(&again), Ok(()), "{w}x{h} {layout:?}");
            for (c, m) in crits.iter().zip(&meshes) {
                let m2 = list(&again, &hf, *c);
                assert_eq!((&m.v, &m.t), (&m2.v, &m2.t), "{w}x{h} {layout:?} {c:?}");
            }
            // Sizes and parameters.
            let short = &stored[..stored.len() - 1];
            assert!(records_hierarchy(short, layout, w, h, sc, z).is_err());
            assert!(records_hierarchy(&stored, layout, w, h, sc, (z.1 + 1.0, z.1)).is_err());
            assert!(records_hierarchy(&stored, layout, w, h, sc, (f32::NAN, z.1)).is_err());
            assert!(records_hierarchy(&stored, layout, w, h, sc.with_z_scale(0.0), z).is_err());
            assert!(records_hierarchy(&stored, layout, 1, h, sc, z).is_err());
            if w < 4 {
                continue;
            }
            // One corruption at a time, each named at the vertex it is made at.
            let (x, y) = (w / 2, h / 2);
            let g = full.grid();
            let at = |x: u32, y: u32| record_index(layout, &g, x as u64, y as u64);
            let (cx, cy) = g.children(x, y).into_iter().flatten().next().unwrap();
            let (cx, cy) = (cx as u32, cy as u32);
            let parent_err = rec[at(x, y)].error;
            type Corrupt = fn(&mut VertexRecord, u16);
            let cases: [(u32, u32, Corrupt); 6] = [
                (x, y, |r, _| r.error = 0xffc0),                  // NaN error
                (x, y, |r, _| r.error = 0xbf80),                  // -1
                (x, y, |r, _| r.z = f32::INFINITY),               // height
                (x, y, |r, _| r.radius = 0),                      // no longer holds its children
                (cx, cy, |r, pe| r.error = pe.saturating_add(1)), // above the parent's
                (x, y, |r, _| r.error = 0x8000),                  // -0 (code above all)
            ];
            for (k, (bx, by, f)) in cases.into_iter().enumerate() {
                let mut bad = rec.clone();
                f(&mut bad[at(bx, by)], parent_err);
                let hb = records_hierarchy(&bad, layout, w, h, sc, z).unwrap();
                // A raised child error breaks nesting at its first parent in row-major order
                // (a vertex has two parents in the diamond hierarchy).
                let first_parent = (0..h)
                    .flat_map(|py| (0..w).map(move |px| (px, py)))
                    .find(|&(px, py)| g.children(px, py).contains(&Some((cx as i64, cy as i64))))
                    .unwrap();
                let want = if k == 4 { first_parent } else { (bx, by) };
                assert_eq!(
                    check_records(&hb),
                    Err(Error::BadSample {
                        x: want.0,
                        y: want.1
                    }),
                    "{w}x{h} {layout:?} case {k}"
                );
            }
            // A grid smaller than its square: a vertex whose diamond crosses the border must
            // keep its +inf error (always split), or the mesh cracks there.
            if !g.is_square() {
                let (fx, fy) = (0..h)
                    .flat_map(|y| (0..w).map(move |x| (x, y)))
                    .find(|&(x, y)| {
                        g.level(x, y).is_some() && rec[at(x, y)].error_value() == f32::INFINITY
                    })
                    .expect("a forced vertex");
                let mut bad = rec.clone();
                bad[at(fx, fy)].error = 0x3f80; // 1.0
                let hb = records_hierarchy(&bad, layout, w, h, sc, z).unwrap();
                assert_eq!(
                    check_records(&hb),
                    Err(Error::BadSample { x: fx, y: fy }),
                    "{w}x{h} {layout:?} forced vertex"
                );
            }
        }
    }
}
