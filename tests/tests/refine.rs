//! SOAR refinement (relief_core::refine) checked with the crack checker and the full-grid error
//! scan: random grids, the real DEMs in ../shared/data (skipped with a message when absent), and
//! the hard cases of HARD_CASES.md ("## Refinement").

use proptest::prelude::*;
use relief_core::glam::Vec3;
use relief_core::refine::{
    coverage_len, hierarchy_len, pack_records, preprocess, preprocess_compact, preprocess_with,
    records_len, scratch_len, strip_bound, strip_fewest_indices, strip_triangles, vertical_error,
    Criterion, FrameCounts, Hierarchy, PreprocessOptions, RecordLayout, Refiner, UninitBuffers,
    VertexRecord, View,
};
use relief_core::{Camera, Error, Heightfield, Scale, Terrain};
use relief_io::{read_dem, Format, ReadOptions};
use relief_tests::mesh_check::{check_mesh, CheckOptions, MeshReport};
use std::path::{Path, PathBuf};

/// Whether the CPU runs the AVX-512 builds (`triangles_avx512`, `triangles_uninit_avx512`).
#[cfg(target_arch = "x86_64")]
fn has_avx512() -> bool {
    std::is_x86_feature_detected!("popcnt")
        && std::is_x86_feature_detected!("avx512f")
        && std::is_x86_feature_detected!("avx512bw")
}

struct Mesh {
    v: Vec<[f32; 3]>,
    t: Vec<[u32; 3]>,
}

fn refine<T: Terrain>(h: &Hierarchy<'_>, t: &T, c: Criterion) -> Mesh {
    let r = Refiner::new(h, t, c).unwrap();
    let mut s = vec![0; scratch_len(t.width(), t.height())];
    let n = r.count(&mut s).unwrap();
    let mut v = vec![[0.0; 3]; n.vertices];
    let mut tr = vec![[0; 3]; n.triangles];
    assert_eq!(r.triangles(&mut s, &mut v, &mut tr).unwrap(), n);
    same_with_popcnt(&r, &mut s, &v, &tr);
    same_uninit(&r, &mut s, &v, &tr, matches!(c, Criterion::MaxError(_)));
    same_as_grid_triangles(&r, t, &v, &tr, matches!(c, Criterion::View(_)));
    same_as_grid_vertices(&r, t, &mut s, &v, &tr, matches!(c, Criterion::MaxError(_)));
    Mesh { v, t: tr }
}

/// With grid coordinates (`[u16; 2]`) for vertices, every entry point writes the same triangles
/// and each vertex's column and row (its position divided by the spacing), into initialised and
/// uninitialised buffers, with and without popcnt, and refuses a buffer one element short.
fn same_as_grid_vertices<T: Terrain>(
    r: &Refiner<'_, '_, T>,
    t: &T,
    s: &mut [u64],
    v: &[[f32; 3]],
    tr: &[[u32; 3]],
    view_independent: bool,
) {
    use std::mem::MaybeUninit;
    type Call<'r> = Box<
        dyn Fn(&mut [u64], &mut [[u16; 2]], &mut [[u32; 3]]) -> Result<FrameCounts, Error> + 'r,
    >;
    // The uninitialised builds write into `MaybeUninit` copies through `call`, then hand the
    // values back.
    type UninitCall<'r> =
        dyn Fn(&mut [u64], UninitBuffers<'_, '_, [u16; 2]>) -> Result<FrameCounts, Error> + 'r;
    let uninit = |s: &mut [u64], g: &mut [[u16; 2]], o: &mut [[u32; 3]], call: &UninitCall<'_>| {
        let mut g2: Vec<_> = g.iter().map(|&x| MaybeUninit::new(x)).collect();
        let mut o2: Vec<_> = o.iter().map(|&x| MaybeUninit::new(x)).collect();
        let got = call(s, (&mut g2[..], &mut o2[..]));
        // SAFETY: every element was initialised above.
        unsafe {
            for (x, y) in g.iter_mut().zip(&g2) {
                *x = y.assume_init();
            }
            for (x, y) in o.iter_mut().zip(&o2) {
                *x = y.assume_init();
            }
        }
        got
    };
    let mut calls: Vec<Call<'_>> = vec![Box::new(|s, g, o| r.triangles(s, g, o))];
    if view_independent {
        calls.push(Box::new(|s, g, o| {
            uninit(s, g, o, &|s, b| r.triangles_uninit(s, move |_| b))
        }));
    }
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("popcnt") {
        // SAFETY (both): the CPU has popcnt.
        calls.push(Box::new(|s, g, o| unsafe { r.triangles_popcnt(s, g, o) }));
        if view_independent {
            calls.push(Box::new(|s, g, o| {
                uninit(s, g, o, &|s, b| unsafe {
                    r.triangles_uninit_popcnt(s, move |_| b)
                })
            }));
        }
    }
    #[cfg(target_arch = "x86_64")]
    if has_avx512() {
        // SAFETY (both): the CPU has popcnt, AVX-512F and AVX-512BW.
        calls.push(Box::new(|s, g, o| unsafe { r.triangles_avx512(s, g, o) }));
        if view_independent {
            calls.push(Box::new(|s, g, o| {
                uninit(s, g, o, &|s, b| unsafe {
                    r.triangles_uninit_avx512(s, move |_| b)
                })
            }));
        }
    }
    let sc = t.scale();
    for call in &calls {
        let (mut g, mut o) = (vec![[u16::MAX; 2]; v.len()], vec![[u32::MAX; 3]; tr.len()]);
        let c = call(s, &mut g, &mut o).unwrap();
        assert_eq!((c.vertices, c.triangles), (v.len(), tr.len()));
        assert_eq!(o, tr);
        for (gv, p) in g.iter().zip(v) {
            let (x, y) = (gv[0] as f32 * sc.dx, gv[1] as f32 * sc.dy);
            assert_eq!([x.to_bits(), y.to_bits()], [p[0].to_bits(), p[1].to_bits()]);
        }
        if let Some(short) = tr.len().checked_sub(1) {
            assert!(matches!(
                call(s, &mut g, &mut o[..short]),
                Err(Error::BufferTooSmall { .. })
            ));
        }
    }
}

/// `grid_triangles` gives the indexed list's triangles, each corner as the grid index of its
/// vertex (corners in the same order), in the list's order where `same_order` (view-dependent
/// frames; a view-independent list may be written row by row, see `Refiner::grid_triangles`),
/// and refuses a buffer one element short.
fn same_as_grid_triangles<T: Terrain>(
    r: &Refiner<'_, '_, T>,
    t: &T,
    v: &[[f32; 3]],
    tr: &[[u32; 3]],
    same_order: bool,
) {
    let mut g = vec![[u32::MAX; 3]; tr.len()];
    assert_eq!(r.grid_triangles(&mut g).unwrap(), tr.len());
    let s = t.scale();
    let w = t.width();
    // The list's triangles with grid-index corners (each vertex checked against its sample).
    let mut listed: Vec<[u32; 3]> = tr
        .iter()
        .map(|lt| {
            lt.map(|li| {
                let p = v[li as usize];
                let (x, y) = ((p[0] / s.dx).round() as u32, (p[1] / s.dy).round() as u32);
                assert_eq!(p[2].to_bits(), t.z(x, y).to_bits());
                y * w + x
            })
        })
        .collect();
    if same_order {
        assert!(
            g == listed,
            "grid_triangles: not the list's triangles in its order"
        );
    } else {
        let mut got = g.clone();
        got.sort_unstable();
        listed.sort_unstable();
        assert!(got == listed, "grid_triangles: not the list's triangles");
    }
    if let Some(short) = tr.len().checked_sub(1) {
        assert!(matches!(
            r.grid_triangles(&mut g[..short]),
            Err(Error::BufferTooSmall { .. })
        ));
    }
}

/// `triangles_uninit` and `triangles_uninit_popcnt` (where the CPU has popcnt) write exactly
/// what `triangles` wrote into the first elements of uninitialised buffers and nothing past
/// them (buffers two elements longer, pre-filled with sentinels so the test can read them all);
/// one element short, they return `triangles`' error and write nothing; the view-dependent
/// criterion is `Unsupported`.
fn same_uninit<T: Terrain>(
    r: &Refiner<'_, '_, T>,
    s: &mut [u64],
    v: &[[f32; 3]],
    t: &[[u32; 3]],
    view_independent: bool,
) {
    use std::mem::MaybeUninit;
    const SV: [f32; 3] = [-7.0; 3];
    const ST: [u32; 3] = [u32::MAX - 1; 3];
    type Out<'a> = (
        &'a mut [MaybeUninit<[f32; 3]>],
        &'a mut [MaybeUninit<[u32; 3]>],
    );
    type Call<'r> = Box<dyn Fn(&mut [u64], Out<'_>) -> Result<FrameCounts, Error> + 'r>;
    let mut calls: Vec<Call<'_>> = vec![Box::new(|s, (v, t)| r.triangles_uninit(s, |_| (v, t)))];
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("popcnt") {
        // SAFETY: the CPU has popcnt.
        calls.push(Box::new(|s, (v, t)| unsafe {
            r.triangles_uninit_popcnt(s, |_| (v, t))
        }));
    }
    #[cfg(target_arch = "x86_64")]
    if has_avx512() {
        // SAFETY: the CPU has popcnt, AVX-512F and AVX-512BW.
        calls.push(Box::new(|s, (v, t)| unsafe {
            r.triangles_uninit_avx512(s, |_| (v, t))
        }));
    }
    // `buffers` is called once, with the counts, and not at all for the view-dependent criterion.
    let seen = std::cell::Cell::new(None);
    let (mut v3, mut t3) = (
        vec![MaybeUninit::new(SV); v.len()],
        vec![MaybeUninit::new(ST); t.len()],
    );
    let (vb, tb, seen_ref) = (&mut v3[..], &mut t3[..], &seen);
    let got = r.triangles_uninit(s, move |c| {
        assert!(seen_ref.replace(Some(c)).is_none());
        (vb, tb)
    });
    assert_eq!(seen.get(), got.ok());
    assert_eq!(seen.get().is_some(), view_independent);
    for call in &calls {
        for short in [false, !t.is_empty()] {
            let (nv, nt) = (v.len() + 2, if short { t.len() - 1 } else { t.len() + 2 });
            let mut v2 = vec![MaybeUninit::new(SV); nv];
            let mut t2 = vec![MaybeUninit::new(ST); nt];
            let got = call(s, (&mut v2, &mut t2));
            // SAFETY: every element was initialised with a sentinel above.
            let (v2, t2): (Vec<[f32; 3]>, Vec<[u32; 3]>) = unsafe {
                (
                    v2.iter().map(|x| x.assume_init()).collect(),
                    t2.iter().map(|x| x.assume_init()).collect(),
                )
            };
            let untouched = v2.iter().all(|x| *x == SV) && t2.iter().all(|x| *x == ST);
            if !view_independent {
                assert!(matches!(got, Err(Error::Unsupported { .. })), "{got:?}");
                assert!(untouched);
            } else if short {
                let mut t3 = vec![ST; nt];
                assert_eq!(got, r.triangles(s, &mut v2.clone(), &mut t3));
                assert!(matches!(got, Err(Error::BufferTooSmall { .. })));
                assert!(untouched);
            } else {
                let c = got.unwrap();
                assert_eq!((c.vertices, c.triangles), (v.len(), t.len()));
                let bits = |x: &[[f32; 3]]| -> Vec<[u32; 3]> {
                    x.iter().map(|p| p.map(f32::to_bits)).collect()
                };
                assert_eq!(bits(&v2[..v.len()]), bits(v));
                assert_eq!(&t2[..t.len()], t);
                assert!(v2[v.len()..].iter().all(|x| *x == SV));
                assert!(t2[t.len()..].iter().all(|x| *x == ST));
            }
        }
    }
}

/// `triangles_popcnt` and `triangles_avx512` (where the CPU has their instructions) write
/// exactly what `triangles` wrote, and refuse buffers one element short the same way.
fn same_with_popcnt<T: Terrain>(
    r: &Refiner<'_, '_, T>,
    s: &mut [u64],
    v: &[[f32; 3]],
    t: &[[u32; 3]],
) {
    type Build<'r> = Box<
        dyn Fn(&mut [u64], &mut [[f32; 3]], &mut [[u32; 3]]) -> Result<FrameCounts, Error> + 'r,
    >;
    let mut builds: Vec<Build<'_>> = Vec::new();
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("popcnt") {
        // SAFETY: the CPU has popcnt.
        builds.push(Box::new(|s, v, t| unsafe { r.triangles_popcnt(s, v, t) }));
    }
    #[cfg(target_arch = "x86_64")]
    if has_avx512() {
        // SAFETY: the CPU has popcnt, AVX-512F and AVX-512BW.
        builds.push(Box::new(|s, v, t| unsafe { r.triangles_avx512(s, v, t) }));
    }
    for build in &builds {
        let (mut v2, mut t2) = (vec![[f32::NAN; 3]; v.len()], vec![[u32::MAX; 3]; t.len()]);
        let c = build(s, &mut v2, &mut t2).unwrap();
        assert_eq!((c.vertices, c.triangles), (v.len(), t.len()));
        assert!(v2
            .iter()
            .zip(v)
            .all(|(a, b)| a.map(f32::to_bits) == b.map(f32::to_bits)));
        assert_eq!(t2, t);
        if let Some(short) = t2.len().checked_sub(1) {
            let e = build(s, &mut v2, &mut t2[..short]);
            assert_eq!(e, r.triangles(s, &mut v2, &mut t2[..short]));
            assert!(e.is_err());
        }
    }
}

fn opts<T: Terrain>(t: &T) -> CheckOptions {
    let s = t.scale();
    CheckOptions::grid(t.width(), t.height(), s.dx as f64, s.dy as f64)
}

fn measured<T: Terrain>(t: &T, m: &Mesh) -> f64 {
    let mut cov = vec![0; coverage_len(t.width(), t.height())];
    vertical_error(t, &m.v, &m.t, &mut cov).unwrap()
}

/// View-independent mesh at `e` from both layouts: crack-free, within `e`.
fn check_vi<T: Terrain>(t: &T, e: f32) -> [MeshReport; 2] {
    let n = hierarchy_len(t.width(), t.height());
    let (mut er, mut ra) = (vec![0.0; n], vec![0.0; n]);
    let full = preprocess(t, &mut er, &mut ra).unwrap();
    let mut ec = vec![0u16; n];
    let compact = preprocess_compact(t, &mut ec).unwrap();
    let m = refine(&full, t, Criterion::MaxError(e));
    let r = check_mesh(&m.v, &m.t, &opts(t)).unwrap_or_else(|s| panic!("E={e}: {s}"));
    let err = measured(t, &m);
    assert!(err <= e as f64, "E={e}: measured {err}");
    // The compact layout: the crack checker is slow on big meshes in debug builds, so it runs on
    // small ones; the (fast) error scan, which also fails on any gap, runs on all.
    let mc = refine(&compact, t, Criterion::MaxError(e));
    let rc = if mc.t.len() < 200_000 {
        check_mesh(&mc.v, &mc.t, &opts(t)).unwrap_or_else(|s| panic!("compact E={e}: {s}"))
    } else {
        MeshReport {
            used_vertices: mc.v.len(),
            triangles: mc.t.len(),
            area: r.area,
            boundary_edges: 0,
        }
    };
    let errc = measured(t, &mc);
    assert!(errc <= e as f64, "compact E={e}: measured {errc}");
    [r, rc]
}

fn noise(w: u32, h: u32, seed: u64, amp: f32) -> Vec<f32> {
    let mut s = seed | 1;
    (0..w * h)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            ((s >> 11) % 10_000) as f32 / 10_000.0 * amp
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn random_grids_are_crack_free_and_within_e(
        w in 2u32..48, h in 2u32..48, seed in 1u64..10_000, amp in 0.0f32..200.0,
        frac in 0.0f32..0.5, smooth in 0u32..4,
    ) {
        let mut s = noise(w, h, seed, amp);
        // Some smoothing passes make meshes coarse (long edges, border forcing visible).
        for _ in 0..smooth {
            let c = s.clone();
            for y in 0..h as usize {
                for x in 0..w as usize {
                    let g = |xx: usize, yy: usize| c[yy.min(h as usize - 1) * w as usize + xx.min(w as usize - 1)];
                    s[y * w as usize + x] = (g(x, y) + g(x + 1, y) + g(x, y + 1) + g(x.saturating_sub(1), y) + g(x, y.saturating_sub(1))) / 5.0;
                }
            }
        }
        let hf = Heightfield::with_scale(&s, w, h, Scale::default().with_spacing(2.5, 1.5)).unwrap();
        check_vi(&hf, frac * amp);
    }
}

/// The real DEMs of ../shared/data with their decodings.
fn real_dems() -> Vec<(String, relief_io::Dem)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data");
    let files: [(&str, Option<Format>, f32); 7] = [
        ("martini_fuji.png", Some(Format::TerrainRgb), 1.0),
        ("delatin_14-2625-6369.png", Some(Format::TerrainRgb), 1.0),
        (
            "pymartini_mapbox_st_helens.png",
            Some(Format::TerrainRgb),
            1.0,
        ),
        ("pymartini_terrarium.png", Some(Format::Terrarium), 1.0),
        ("diligent_ps_height_1k.png", Some(Format::Png), 0.1),
        (
            "topotoolbox_srtm_bigtujunga30m_utm11.tif",
            Some(Format::Tiff),
            1.0,
        ),
        ("pysheds_dem.tif", Some(Format::Tiff), 1.0),
    ];
    let mut out = Vec::new();
    for (name, format, zs) in files {
        let p: PathBuf = dir.join(name);
        if !p.exists() {
            eprintln!("skipping {name}: {} not found", p.display());
            continue;
        }
        let mut dem = read_dem(
            &p,
            &ReadOptions {
                format,
                ..Default::default()
            },
        )
        .unwrap();
        dem.scale = dem.scale.with_z_scale(zs);
        out.push((name.to_string(), dem));
    }
    out
}

#[test]
fn real_dems_are_crack_free_and_within_e() {
    let dems = real_dems();
    if dems.is_empty() {
        eprintln!("skipping: no DEMs in ../shared/data");
    }
    for (name, dem) in &dems {
        let hf = dem.heightfield().unwrap();
        for e in [1.0f32, 5.0, 20.0, 50.0] {
            let [full, compact] = check_vi(&hf, e);
            eprintln!(
                "{name} {}x{} E={e}: {} / {} triangles (full / compact)",
                dem.width, dem.height, full.triangles, compact.triangles
            );
            // The compact errors are rounded up by at most 2^-7: only slightly more triangles.
            assert!(compact.triangles >= full.triangles);
            assert!(compact.triangles as f64 <= full.triangles as f64 * 1.1 + 10.0);
        }
    }
}

#[test]
fn hard_flat_ground_is_two_triangles_at_any_e() {
    let s = vec![7.0f32; 33 * 33];
    let hf = Heightfield::new(&s, 33, 33).unwrap();
    for e in [0.0, 1.0] {
        let [a, b] = check_vi(&hf, e);
        assert_eq!((a.triangles, b.triangles), (2, 2));
    }
}

#[test]
fn hard_single_sample_spike() {
    let mut s = vec![0.0f32; 65 * 65];
    s[37 * 65 + 21] = 1000.0;
    let hf = Heightfield::new(&s, 65, 65).unwrap();
    let [a, _] = check_vi(&hf, 10.0);
    assert!(a.triangles < 200, "{}", a.triangles); // only around the spike
    let m = {
        let n = hierarchy_len(65, 65);
        let mut ec = vec![0u16; n];
        let h = preprocess_compact(&hf, &mut ec).unwrap();
        refine(&h, &hf, Criterion::MaxError(10.0))
    };
    assert!(m.v.iter().any(|v| v[2] == 1000.0), "the spike is a vertex");
}

#[test]
fn hard_vertical_cliff() {
    let (w, h) = (50u32, 37u32);
    let s: Vec<f32> = (0..w * h)
        .map(|i| if i % w < 23 { 0.0 } else { 500.0 })
        .collect();
    let hf = Heightfield::new(&s, w, h).unwrap();
    for e in [0.0, 0.5, 100.0] {
        check_vi(&hf, e);
    }
}

/// Grid coordinates as `u16` hold columns and rows up to 65,535: a grid 65,536 samples wide
/// refines into them, one 65,537 wide is refused (`SizeOverflow`) while positions still work.
#[test]
fn grid_vertices_refuse_a_grid_wider_than_u16() {
    for w in [65_536u32, 65_537] {
        let s: Vec<f32> = (0..2 * w).map(|i| (i % 7) as f32).collect();
        let hf = Heightfield::new(&s, w, 2).unwrap();
        let mut e = vec![0u16; hierarchy_len(w, 2)];
        let h = preprocess_compact(&hf, &mut e).unwrap();
        let r = Refiner::new(&h, &hf, Criterion::MaxError(0.5)).unwrap();
        let mut sc = vec![0; scratch_len(w, 2)];
        let n = r.count(&mut sc).unwrap();
        let mut p = vec![[0.0f32; 3]; n.vertices];
        let (mut g, mut t) = (vec![[0u16; 2]; n.vertices], vec![[0u32; 3]; n.triangles]);
        assert_eq!(r.triangles(&mut sc, &mut p, &mut t), Ok(n));
        let got = r.triangles(&mut sc, &mut g, &mut t);
        if w == 65_536 {
            assert_eq!(got, Ok(n));
            assert_eq!(g[n.vertices - 1], [65_535, 1]);
        } else {
            assert_eq!(got, Err(Error::SizeOverflow));
        }
    }
}

#[test]
fn hard_tiny_grids_2x2_and_3x3() {
    let a = Heightfield::new(&[0.0f32, 5.0, 3.0, 1.0], 2, 2).unwrap();
    let [r, _] = check_vi(&a, 0.0);
    assert_eq!(r.triangles, 2);
    let s = [0.0f32, 1.0, 0.0, 2.0, 9.0, 1.0, 0.0, 3.0, 0.0];
    let b = Heightfield::new(&s, 3, 3).unwrap();
    let [r0, _] = check_vi(&b, 0.0);
    assert_eq!(r0.triangles, 8);
    let [r1, _] = check_vi(&b, 100.0);
    assert_eq!(r1.triangles, 2);
    // 2 x 3 and 3 x 2 (not squares).
    check_vi(
        &Heightfield::new(&[1.0f32, 2.0, 3.0, 4.0, 5.0, 7.0], 2, 3).unwrap(),
        0.0,
    );
    check_vi(
        &Heightfield::new(&[1.0f32, 2.0, 3.0, 4.0, 5.0, 7.0], 3, 2).unwrap(),
        0.0,
    );
}

#[test]
fn hard_e_zero_is_full_resolution() {
    let (w, h) = (21u32, 14u32);
    let s = noise(w, h, 5, 100.0);
    let hf = Heightfield::new(&s, w, h).unwrap();
    let [r, c] = check_vi(&hf, 0.0);
    assert_eq!(r.triangles, 2 * 20 * 13);
    assert_eq!(c.triangles, 2 * 20 * 13);
}

#[test]
fn hard_4097_square() {
    let n = 4097u32;
    let s: Vec<f32> = (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f32, (i / n) as f32);
            100.0 * (x / 300.0).sin() * (y / 500.0).cos() + 0.002 * x
        })
        .collect();
    let hf = Heightfield::new(&s, n, n).unwrap();
    let mut ec = vec![0u16; hierarchy_len(n, n)];
    let h = preprocess_compact(&hf, &mut ec).unwrap();
    let m = refine(&h, &hf, Criterion::MaxError(1.0));
    check_mesh(&m.v, &m.t, &opts(&hf)).unwrap();
    let err = measured(&hf, &m);
    assert!(err <= 1.0, "{err}");
    assert!(m.t.len() < 2_000_000, "{}", m.t.len());
}

fn cam(eye: Vec3, target: Vec3) -> Camera {
    Camera::new(eye, target, 60.0, 640, 480).unwrap()
}

/// Every in-frustum sample's vertical error projected at its distance is at most `tau` pixels.
fn screen_check<T: Terrain>(t: &T, m: &Mesh, c: &Camera, tau: f32) -> usize {
    let planes = c.frustum_planes(0.1, 1e5).unwrap();
    let s = t.scale();
    let (w, h) = (t.width() as usize, t.height() as usize);
    let mut err = vec![f64::NAN; w * h];
    for tri in &m.t {
        let p: Vec<(f64, f64, f64)> = tri
            .iter()
            .map(|&i| {
                let v = m.v[i as usize];
                (
                    (v[0] / s.dx).round() as f64,
                    (v[1] / s.dy).round() as f64,
                    v[2] as f64,
                )
            })
            .collect();
        let (x0, x1) = (
            p.iter().map(|q| q.0).fold(f64::MAX, f64::min),
            p.iter().map(|q| q.0).fold(f64::MIN, f64::max),
        );
        let (y0, y1) = (
            p.iter().map(|q| q.1).fold(f64::MAX, f64::min),
            p.iter().map(|q| q.1).fold(f64::MIN, f64::max),
        );
        let det = (p[1].0 - p[0].0) * (p[2].1 - p[0].1) - (p[2].0 - p[0].0) * (p[1].1 - p[0].1);
        for y in y0 as usize..=y1 as usize {
            for x in x0 as usize..=x1 as usize {
                let (fx, fy) = (x as f64, y as f64);
                let l1 =
                    ((fx - p[0].0) * (p[2].1 - p[0].1) - (p[2].0 - p[0].0) * (fy - p[0].1)) / det;
                let l2 =
                    ((p[1].0 - p[0].0) * (fy - p[0].1) - (fx - p[0].0) * (p[1].1 - p[0].1)) / det;
                let l0 = 1.0 - l1 - l2;
                if l0 < -1e-9 || l1 < -1e-9 || l2 < -1e-9 {
                    continue;
                }
                let z = l0 * p[0].2 + l1 * p[1].2 + l2 * p[2].2;
                let e = (t.z(x as u32, y as u32) as f64 - z).abs();
                let slot = &mut err[y * w + x];
                if slot.is_nan() || *slot < e {
                    *slot = e;
                }
            }
        }
    }
    let mut checked = 0;
    for y in 0..h {
        for x in 0..w {
            let p = t.position(x as u32, y as u32).unwrap();
            if !planes[..5].iter().all(|q| q.dot(p.extend(1.0)) >= 0.0) {
                continue;
            }
            let e = err[y * w + x];
            assert!(!e.is_nan(), "in-view sample ({x}, {y}) is not covered");
            let d = (p - c.eye).length() as f64;
            if d == 0.0 {
                continue;
            }
            let px = e * c.kappa() as f64 / d;
            assert!(
                px <= tau as f64 + 1e-6 * (1.0 + tau as f64),
                "({x}, {y}): {px} px > {tau}"
            );
            checked += 1;
        }
    }
    checked
}

struct Vd {
    s: Vec<f32>,
    w: u32,
    h: u32,
    scale: Scale,
}

fn vd_terrain() -> Vd {
    let (w, h) = (129u32, 97u32);
    let mut s = noise(w, h, 17, 40.0);
    for (i, v) in s.iter_mut().enumerate() {
        let (x, y) = ((i as u32 % w) as f32, (i as u32 / w) as f32);
        *v += 200.0 * (x / 20.0).sin() * (y / 30.0).cos();
    }
    Vd {
        s,
        w,
        h,
        scale: Scale::default().with_spacing(10.0, 10.0),
    }
}

fn check_vd(eye: Vec3, target: Vec3, tau: f32) -> usize {
    check_vd_on(&vd_terrain(), eye, target, tau)
}

/// View-dependent meshes of `t` from every layout (full, compact, linear and interleaved
/// records), with and without culling and lazy culling: crack-free where culling keeps them
/// whole, within the pixel threshold; returns the samples checked.
fn check_vd_on(t: &Vd, eye: Vec3, target: Vec3, tau: f32) -> usize {
    let hf = Heightfield::with_scale(&t.s, t.w, t.h, t.scale).unwrap();
    let n = hierarchy_len(t.w, t.h);
    let (mut er, mut ra) = (vec![0.0; n], vec![0.0; n]);
    let full = preprocess(&hf, &mut er, &mut ra).unwrap();
    let mut ec = vec![0u16; n];
    let compact = preprocess_compact(&hf, &mut ec).unwrap();
    let mut rl = vec![VertexRecord::default(); records_len(t.w, t.h, RecordLayout::Linear)];
    let lin = pack_records(&full, &hf, RecordLayout::Linear, &mut rl).unwrap();
    let mut ri = vec![VertexRecord::default(); records_len(t.w, t.h, RecordLayout::Interleaved)];
    let il = pack_records(&full, &hf, RecordLayout::Interleaved, &mut ri).unwrap();
    let c = cam(eye, target);
    let mut checked = 0;
    for h in [&full, &compact, &lin, &il] {
        for (culling, lazy) in [(false, 0), (true, 0), (true, 4)] {
            let v = View::new(&c, tau)
                .unwrap()
                .with_culling(culling)
                .with_lazy_levels(lazy);
            let m = refine(h, &hf, Criterion::View(v));
            let mut o = opts(&hf);
            o.allow_holes = culling;
            o.t_junctions = lazy == 0; // lazy culling may leave T-junctions outside the view
            check_mesh(&m.v, &m.t, &o)
                .unwrap_or_else(|s| panic!("culling {culling} lazy {lazy}: {s}"));
            checked += screen_check(&hf, &m, &c, tau);
            // Both strips draw culled triangles coarse and test culling at every level: no
            // holes, no T-junctions.
            let r = Refiner::new(h, &hf, Criterion::View(v)).unwrap();
            for soar in [false, true] {
                let m = strip_mesh(&r, &hf, soar);
                o.allow_holes = false;
                o.t_junctions = true;
                check_mesh(&m.v, &m.t, &o).unwrap_or_else(|s| {
                    panic!("strip (soar {soar}) culling {culling} lazy {lazy}: {s}")
                });
                checked += screen_check(&hf, &m, &c, tau);
            }
        }
    }
    checked
}

/// The in/out-edge strip (or SOAR's with `soar`) of `r` as triangles (degenerates dropped,
/// odd positions turned round), within [`strip_bound`].
fn strip_mesh<T: Terrain>(r: &Refiner<'_, '_, T>, t: &T, soar: bool) -> Mesh {
    let (w, h) = (t.width(), t.height());
    let mut s = vec![0; scratch_len(w, h)];
    let mut v = vec![[0.0; 3]; hierarchy_len(w, h)];
    let mut st = vec![0; strip_bound(w, h)];
    let c = if soar {
        r.soar_strip(&mut s, &mut v, &mut st).unwrap()
    } else {
        r.inout_strip(&mut s, &mut v, &mut st).unwrap()
    };
    let t: Vec<[u32; 3]> = strip_triangles(&st[..c.indices]).collect();
    assert_eq!(t.len(), c.triangles);
    // On a square grid (one piece), the fewest indices for its triangle order up to its
    // start (the entry vertex twice).
    if w == h && (w - 1).is_power_of_two() && c.triangles > 0 {
        let fewest = strip_fewest_indices(&st[..c.indices], true).unwrap();
        assert!(
            c.indices <= fewest + 3,
            "soar {soar}: {c:?}, fewest {fewest}"
        );
    }
    v.truncate(c.vertices);
    Mesh { v, t }
}

/// View-dependent frames of a square grid on every layout: `refine` checks that
/// `grid_triangles` (which writes grid indices, not vertex numbers) gives the indexed list's
/// triangles corner for corner; each mesh is crack-free where culling keeps it whole and meets
/// the pixel threshold.
#[test]
fn square_view_dependent_grid_triangles_match_the_list_on_every_layout() {
    let (w, h) = (129u32, 129u32);
    let mut s = noise(w, h, 23, 40.0);
    for (i, v) in s.iter_mut().enumerate() {
        let (x, y) = ((i as u32 % w) as f32, (i as u32 / w) as f32);
        *v += 150.0 * (x / 17.0).sin() * (y / 23.0).cos();
    }
    let t = Vd {
        s,
        w,
        h,
        scale: Scale::default().with_spacing(10.0, 10.0),
    };
    let views = [
        (
            Vec3::new(-200.0, -200.0, 600.0),
            Vec3::new(600.0, 500.0, 0.0),
            1.0,
        ),
        (
            Vec3::new(640.0, 640.0, -300.0),
            Vec3::new(1000.0, 700.0, -300.0),
            2.0,
        ),
        (
            Vec3::new(0.0, 640.0, 250.0),
            Vec3::new(1280.0, 640.0, 250.0),
            0.5,
        ),
        (
            Vec3::new(640.0, 640.0, 1e5),
            Vec3::new(10_640.0, 640.0, 0.0),
            1.0,
        ),
    ];
    let checked: usize = views
        .into_iter()
        .map(|(eye, target, tau)| check_vd_on(&t, eye, target, tau))
        .sum();
    assert!(checked > 1000, "{checked}");
}

#[test]
fn view_dependent_oblique_view_meets_the_pixel_threshold() {
    assert!(
        check_vd(
            Vec3::new(-200.0, -200.0, 600.0),
            Vec3::new(600.0, 500.0, 0.0),
            1.0
        ) > 1000
    );
}

#[test]
fn hard_view_eye_inside_the_terrain() {
    // Eye 50 m below the surface in the middle of the grid.
    check_vd(
        Vec3::new(640.0, 480.0, -300.0),
        Vec3::new(1000.0, 700.0, -300.0),
        2.0,
    );
}

#[test]
fn hard_view_eye_far_above() {
    let n = check_vd(
        Vec3::new(640.0, 480.0, 1e5),
        Vec3::new(10_640.0, 480.0, 0.0),
        1.0,
    );
    assert!(n > 0);
}

#[test]
fn hard_view_looking_along_the_ground() {
    check_vd(
        Vec3::new(0.0, 480.0, 250.0),
        Vec3::new(1280.0, 480.0, 250.0),
        1.0,
    );
}

#[test]
fn hard_view_nan_camera_is_an_error() {
    assert!(matches!(
        Camera::new(Vec3::new(f32::NAN, 0.0, 1.0), Vec3::ONE, 60.0, 64, 64),
        Err(Error::InvalidCamera { .. })
    ));
    let c = cam(Vec3::new(0.0, 0.0, 10.0), Vec3::new(5.0, 5.0, 0.0));
    assert!(View::new(&c, f32::NAN).is_err());
    let hf = Heightfield::new(&[0.0f32; 9], 3, 3).unwrap();
    let mut ec = [0u16; 9];
    let h = preprocess_compact(&hf, &mut ec).unwrap();
    let v = View::new(&c, 1.0).unwrap().with_near_far(f32::NAN, None);
    assert!(Refiner::new(&h, &hf, Criterion::View(v)).is_err());
}

#[test]
fn hard_buffer_one_element_too_small() {
    let t = vd_terrain();
    let hf = Heightfield::with_scale(&t.s, t.w, t.h, t.scale).unwrap();
    let mut ec = vec![0u16; hierarchy_len(t.w, t.h)];
    let h = preprocess_compact(&hf, &mut ec).unwrap();
    let c = cam(
        Vec3::new(-200.0, -200.0, 600.0),
        Vec3::new(600.0, 500.0, 0.0),
    );
    let r = Refiner::new(&h, &hf, Criterion::View(View::new(&c, 1.0).unwrap())).unwrap();
    let mut s = vec![0; scratch_len(t.w, t.h)];
    let n = r.count(&mut s).unwrap();
    let mut v = vec![[0.0; 3]; n.vertices];
    let mut tr = vec![[0; 3]; n.triangles - 1];
    assert_eq!(
        r.triangles(&mut s, &mut v, &mut tr),
        Err(Error::BufferTooSmall {
            needed: n.triangles,
            actual: n.triangles - 1
        })
    );
    let mut short = vec![0; scratch_len(t.w, t.h) - 1];
    assert!(matches!(
        r.count(&mut short),
        Err(Error::BufferTooSmall { .. })
    ));
    let mut e2 = vec![0u16; hierarchy_len(t.w, t.h) - 1];
    assert!(matches!(
        preprocess_compact(&hf, &mut e2),
        Err(Error::BufferTooSmall { .. })
    ));
}

/// Seed 004, chapter 5.2: with spheres that only contain their descendants (SOAR 2002), culling
/// a finest-level vertex can coarsen a triangle that is still partly in view ("pop"); lazy
/// culling of the finest levels removes it.
#[test]
fn lazy_culling_removes_the_culling_pop() {
    let t = vd_terrain();
    let hf = Heightfield::with_scale(&t.s, t.w, t.h, t.scale).unwrap();
    let n = hierarchy_len(t.w, t.h);
    let (mut er, mut ra) = (vec![0.0; n], vec![0.0; n]);
    let o = PreprocessOptions::default().with_contain_diamond(false);
    let soar = preprocess_with(&hf, &mut er, &mut ra, o).unwrap();
    let mut pops = 0;
    for k in 0..24 {
        // Cameras sweeping across the terrain, low and close: frustum borders cut fine triangles.
        let a = k as f32 * 0.26;
        let eye = Vec3::new(640.0 + 300.0 * a.cos(), 480.0 + 300.0 * a.sin(), 260.0);
        let target = eye + Vec3::new(-(a + 0.7).sin(), (a + 0.7).cos(), -0.25) * 100.0;
        let c = cam(eye, target);
        let strict = View::new(&c, 0.5).unwrap().with_lazy_levels(0);
        let m = refine(&soar, &hf, Criterion::View(strict));
        let res = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            screen_check(&hf, &m, &c, 0.5)
        }));
        if res.is_err() {
            pops += 1;
        }
        // Lazy culling of the finest 2 levels: never a pop.
        let lazy = View::new(&c, 0.5).unwrap().with_lazy_levels(2);
        let m = refine(&soar, &hf, Criterion::View(lazy));
        screen_check(&hf, &m, &c, 0.5);
    }
    assert!(pops > 0, "no culling pop found: the test shows nothing");
}

#[test]
fn inout_strip_on_a_real_dem_is_the_fewest_for_its_order() {
    let dems = real_dems();
    let Some((_, dem)) = dems.iter().find(|(n, _)| n.starts_with("diligent")) else {
        eprintln!("skipping: diligent_ps_height_1k.png not found");
        return;
    };
    let mut dem = dem.clone();
    dem.scale = dem.scale.with_spacing(160.0, 160.0);
    let hf = dem.heightfield().unwrap();
    let (w, h) = (dem.width, dem.height);
    let mut ec = vec![0u16; hierarchy_len(w, h)];
    let hi = preprocess_compact(&hf, &mut ec).unwrap();
    let r = Refiner::new(&hi, &hf, Criterion::MaxError(5.0)).unwrap();
    let mut s = vec![0; scratch_len(w, h)];
    let mut v = vec![[0.0; 3]; hierarchy_len(w, h)];
    let mut st = vec![0; strip_bound(w, h)];
    let c = r.inout_strip(&mut s, &mut v, &mut st).unwrap();
    let fewest = strip_fewest_indices(&st[..c.indices], true).unwrap();
    eprintln!(
        "in/out strip: {} indices, {} triangles, {:.3} per triangle; fewest for its order {fewest}",
        c.indices,
        c.triangles,
        c.indices_per_triangle()
    );
    assert!(c.indices_per_triangle() < 2.0);
    // Seed 004's 1.32 indices per triangle is below what any strip of this triangle order
    // can reach; this one is the fewest up to its start.
    assert!(c.indices <= fewest + 3);
    assert!(fewest as f64 > 1.5 * c.triangles as f64);
}

/// The smallest conforming bisection mesh whose every triangle is within E of the samples it
/// covers (a least fixed point: split every triangle over E, close under parents, repeat), for a
/// square (2^k+1)^2 grid. Returns its triangle count.
fn smallest_conforming<T: Terrain>(t: &T, e: f64) -> usize {
    let n = (t.width() - 1) as i64;
    let w = t.width() as i64;
    let mut active = vec![false; (w * w) as usize];
    let z = |x: i64, y: i64| t.local_z(x as u32, y as u32) as f64;
    // Parents of a hierarchy vertex (the apexes of its diamond), corners excluded.
    let parents = |x: i64, y: i64| -> Vec<(i64, i64)> {
        let s = 1i64 << (x | y).trailing_zeros();
        let ok = |p: (i64, i64)| {
            p.0 >= 0
                && p.1 >= 0
                && p.0 <= n
                && p.1 <= n
                && !((p.0 == 0 || p.0 == n) && (p.1 == 0 || p.1 == n))
        };
        let c: Vec<(i64, i64)> = if (x / s) % 2 == 1 && (y / s) % 2 == 1 {
            let (x0, y0) = (x - s, y - s);
            if ((x0 / (2 * s)) + (y0 / (2 * s))) % 2 == 0 {
                vec![(x + s, y - s), (x - s, y + s)]
            } else {
                vec![(x - s, y - s), (x + s, y + s)]
            }
        } else if (x / s) % 2 == 1 {
            vec![(x, y - s), (x, y + s)]
        } else {
            vec![(x - s, y), (x + s, y)]
        };
        c.into_iter().filter(|&p| ok(p)).collect()
    };
    let own_error = |l: (i64, i64), r: (i64, i64), a: (i64, i64)| -> f64 {
        let det = ((r.0 - l.0) * (a.1 - l.1) - (a.0 - l.0) * (r.1 - l.1)) as f64;
        let (x0, x1) = (l.0.min(r.0).min(a.0), l.0.max(r.0).max(a.0));
        let (y0, y1) = (l.1.min(r.1).min(a.1), l.1.max(r.1).max(a.1));
        let mut m = 0.0f64;
        for y in y0..=y1 {
            for x in x0..=x1 {
                let b1 = ((x - l.0) * (a.1 - l.1) - (a.0 - l.0) * (y - l.1)) as f64 / det;
                let b2 = ((r.0 - l.0) * (y - l.1) - (x - l.0) * (r.1 - l.1)) as f64 / det;
                let b0 = 1.0 - b1 - b2;
                if b0 < -1e-12 || b1 < -1e-12 || b2 < -1e-12 {
                    continue;
                }
                let p = b0 * z(l.0, l.1) + b1 * z(r.0, r.1) + b2 * z(a.0, a.1);
                m = m.max((z(x, y) - p).abs());
            }
        }
        m
    };
    loop {
        // Emitted triangles of the current active set; collect the split vertices of those over E.
        let mut stack = vec![((n, n), (0, 0), (n, 0)), ((0, 0), (n, n), (0, n))];
        let mut tris = 0usize;
        let mut add = Vec::new();
        while let Some((l, r, a)) = stack.pop() {
            if (l.0 - r.0).abs() == 1 && (l.1 - r.1).abs() == 1 {
                tris += 1;
                continue;
            }
            let m = ((l.0 + r.0) / 2, (l.1 + r.1) / 2);
            if active[(m.1 * w + m.0) as usize] {
                stack.push((a, l, m));
                stack.push((r, a, m));
            } else {
                tris += 1;
                if own_error(l, r, a) > e {
                    add.push(m);
                }
            }
        }
        if add.is_empty() {
            return tris;
        }
        while let Some(m) = add.pop() {
            let i = (m.1 * w + m.0) as usize;
            if !active[i] {
                active[i] = true;
                add.extend(parents(m.0, m.1));
            }
        }
    }
}

/// How far relief's nested-error mesh is from the smallest conforming mesh meeting E (printed;
/// run with `--nocapture`). Nesting can only add vertices, so relief's mesh is never smaller.
#[test]
fn distance_from_the_smallest_conforming_mesh() {
    let dems = real_dems();
    let Some((_, dem)) = dems.iter().find(|(n, _)| n.starts_with("diligent")) else {
        eprintln!("skipping: diligent_ps_height_1k.png not found");
        return;
    };
    let hf = dem.heightfield().unwrap();
    let n = hierarchy_len(dem.width, dem.height);
    let (mut ef, mut rf) = (vec![0.0; n], vec![0.0; n]);
    let full = preprocess(&hf, &mut ef, &mut rf).unwrap();
    for e in [5.0f32, 20.0, 50.0] {
        let m = refine(&full, &hf, Criterion::MaxError(e));
        let best = smallest_conforming(&hf, e as f64);
        eprintln!(
            "Puget E={e} m: relief {} triangles, smallest conforming {best}, ratio {:.4}",
            m.t.len(),
            m.t.len() as f64 / best as f64
        );
        assert!(m.t.len() >= best);
        assert!((m.t.len() as f64) < best as f64 * 1.1);
    }
}
