//! Golden-image tests of GPU renders: small frames of several scenes (every method, the
//! effects) compared with `tests/golden/<name>.png`.
//!
//! The sizes must match, and at most 2 % of the pixels may differ by more than 16 (of 255) in
//! some channel: room for `f32` differences between drivers (Mesa lavapipe in CI, a real GPU
//! elsewhere: a ray grazing a ridge may hit on one and miss on the other, shading may round
//! differently; the same frames through wgpu's GL backend instead of Vulkan, on the same
//! llvmpipe, differ in up to 45 pixels by more than 12), none for a changed picture (a moved sun, another colour ramp or a missing
//! effect changes far more pixels; the last test checks that). On a mismatch the actual frame
//! is written to the temporary directory as `relief-wgpu-<name>-actual.png`.
//!
//! Regenerate after an intended change, then look at the pictures before committing:
//! `RELIEF_BLESS=1 cargo test -p relief-wgpu --test golden`
//!
//! Like the other GPU tests they skip loudly without any adapter, and fail instead when
//! `RELIEF_REQUIRE_GPU=1` (CI).

use glam::Vec3;
use relief_core::{Camera, Heightfield};
use relief_wgpu::raycast::Shading;
use relief_wgpu::terrain::Crater;
use relief_wgpu::{Effect, FrameImage, Gpu, Method, Renderer, Scene};
use std::path::PathBuf;
use std::sync::OnceLock;

const W: u32 = 96;
const H: u32 = 72;
const N: u32 = 129;

fn gpu() -> Option<&'static Gpu> {
    static GPU: OnceLock<Option<Gpu>> = OnceLock::new();
    GPU.get_or_init(|| match relief_wgpu::headless() {
        Ok(g) => {
            eprintln!(
                "GPU golden tests on {} ({:?}, {:?})",
                g.info.name, g.info.backend, g.info.device_type
            );
            Some(g)
        }
        Err(e) => {
            if std::env::var("RELIEF_REQUIRE_GPU").is_ok_and(|v| v == "1") {
                panic!("RELIEF_REQUIRE_GPU=1 but {e}");
            }
            assert!(
                std::env::var_os("RELIEF_BLESS").is_none(),
                "RELIEF_BLESS=1 needs a GPU adapter: {e}"
            );
            eprintln!("\n!!!!! SKIPPING GPU GOLDEN TEST: {e} !!!!!\n");
            None
        }
    })
    .as_ref()
}

/// A smooth deterministic terrain (no per-sample noise, so that driver rounding moves few
/// pixels): two hills, a valley below the water level and a ridge.
fn samples() -> Vec<f32> {
    let mut s = Vec::with_capacity((N * N) as usize);
    for y in 0..N {
        for x in 0..N {
            let (fx, fy) = (x as f32, y as f32);
            let hill = |cx: f32, cy: f32, r: f32, a: f32| {
                a * (-((fx - cx).powi(2) + (fy - cy).powi(2)) / (r * r)).exp()
            };
            let ridge = 12.0 * (-(fx - 0.6 * fy - 20.0).powi(2) / 60.0).exp();
            s.push(
                hill(40.0, 44.0, 18.0, 40.0) + hill(90.0, 88.0, 24.0, 28.0) + ridge
                    - hill(80.0, 30.0, 14.0, 15.0)
                    + 0.05 * fx
                    + 20.0,
            );
        }
    }
    s
}

fn camera() -> Camera {
    // South of the map, looking north over it (the whole terrain in front, for silhouettes).
    Camera::new(
        Vec3::new(64.0, -60.0, 90.0),
        Vec3::new(64.0, 70.0, 10.0),
        55.0,
        W,
        H,
    )
    .unwrap()
}

fn render(g: &Gpu, scene: Scene) -> FrameImage {
    let s = samples();
    let hf = Heightfield::new(&s, N, N).unwrap();
    let mut r = Renderer::new(&g.device, &g.queue, &hf, scene).unwrap();
    r.render(&g.device, &g.queue, &camera()).unwrap()
}

fn golden_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join("golden")
        .join(format!("{name}.png"))
}

fn write_png(path: &std::path::Path, w: u32, h: u32, rgba: &[[u8; 4]]) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut enc = png::Encoder::new(file, w, h);
    enc.set_color(png::ColorType::Rgba);
    enc.set_depth(png::BitDepth::Eight);
    let mut wr = enc.write_header().unwrap();
    wr.write_image_data(rgba.as_flattened()).unwrap();
    wr.finish().unwrap();
}

fn read_png(path: &std::path::Path) -> Result<(u32, u32, Vec<[u8; 4]>), String> {
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let mut dec = png::Decoder::new(std::io::BufReader::new(file));
    dec.set_transformations(png::Transformations::EXPAND);
    let mut reader = dec.read_info().map_err(|e| e.to_string())?;
    let mut buf = vec![0; reader.output_buffer_size().ok_or("png too large")?];
    let info = reader.next_frame(&mut buf).map_err(|e| e.to_string())?;
    if info.color_type != png::ColorType::Rgba || info.bit_depth != png::BitDepth::Eight {
        return Err(format!(
            "{:?} {:?}, expected RGBA8",
            info.color_type, info.bit_depth
        ));
    }
    let px = buf[..info.buffer_size()]
        .chunks_exact(4)
        .map(|c| [c[0], c[1], c[2], c[3]])
        .collect();
    Ok((info.width, info.height, px))
}

/// Pixels differing by more than 16 in some channel.
fn differing(a: &[[u8; 4]], b: &[[u8; 4]]) -> usize {
    a.iter()
        .zip(b)
        .filter(|(x, y)| x.iter().zip(y.iter()).any(|(p, q)| p.abs_diff(*q) > 16))
        .count()
}

/// At most 2 % of the pixels may differ.
const MAX_DIFFERING: usize = (W * H) as usize / 50;

fn check(name: &str, frame: &FrameImage) {
    let path = golden_path(name);
    if std::env::var_os("RELIEF_BLESS").is_some() {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        write_png(&path, frame.width, frame.height, &frame.color);
        return;
    }
    let (w, h, expected) = read_png(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e}; create it with RELIEF_BLESS=1 cargo test -p relief-wgpu --test golden",
            path.display()
        )
    });
    let dump = || {
        let p = std::env::temp_dir().join(format!("relief-wgpu-{name}-actual.png"));
        write_png(&p, frame.width, frame.height, &frame.color);
        p
    };
    assert_eq!(
        (w, h),
        (frame.width, frame.height),
        "{name}: size differs from the golden image (actual written to {})",
        dump().display()
    );
    let n = differing(&expected, &frame.color);
    eprintln!(
        "{name}: {n} of {} pixels differ from the golden image",
        w * h
    );
    assert!(
        n <= MAX_DIFFERING,
        "{name}: {n} pixels differ by more than 16 (at most {MAX_DIFFERING} may); actual written to {}",
        dump().display()
    );
}

fn scenes() -> Vec<(&'static str, Scene)> {
    vec![
        ("bare_maxmip", Scene::new()),
        ("march", Scene::new().with_method(Method::march())),
        (
            "lighting_shadows_fog",
            Scene::new()
                .with_effects(&[Effect::Lighting, Effect::Shadows, Effect::Fog])
                .with_shading(Shading::default().with_fog_density(4e-3)),
        ),
        (
            "detail_water",
            Scene::new()
                .with_effects(&[Effect::Detail, Effect::Water, Effect::Lighting])
                .with_shading(Shading::default().with_water_level(22.0)),
        ),
        (
            "craters_lit",
            Scene::new()
                .with_effects(&[Effect::Deformations, Effect::Lighting])
                .with_craters(&[Crater {
                    center: [40.0, 44.0],
                    radius: 12.0,
                    depth: 25.0,
                }]),
        ),
        ("silhouette", Scene::new().with_method(Method::Silhouette)),
        (
            "cascades",
            Scene::new().with_method(Method::Cascades { resolution: 128 }),
        ),
    ]
}

#[test]
fn gpu_frames_match_their_golden_images() {
    let Some(g) = gpu() else { return };
    for (name, scene) in scenes() {
        let frame = render(g, scene);
        assert!(
            frame.depth.iter().filter(|d| d.is_finite()).count() > (W * H / 3) as usize,
            "{name}: the terrain should fill a good part of the frame"
        );
        check(name, &frame);
    }
}

#[test]
fn the_tolerance_catches_a_changed_picture() {
    let Some(g) = gpu() else { return };
    if std::env::var_os("RELIEF_BLESS").is_some() {
        return;
    }
    // The lit scene with the sun moved from the south-west to the north-east must fail the
    // comparison with its golden image, and so must a scene that dropped an effect.
    let (_, _, lit) = read_png(&golden_path("lighting_shadows_fog")).unwrap();
    let moved = render(
        g,
        Scene::new()
            .with_effects(&[Effect::Lighting, Effect::Shadows, Effect::Fog])
            .with_shading(
                Shading::default()
                    .with_fog_density(4e-3)
                    .with_sun(Vec3::new(0.58, 0.58, 0.57)),
            ),
    );
    let n = differing(&lit, &moved.color);
    eprintln!("moved sun: {n} pixels differ");
    assert!(n > 5 * MAX_DIFFERING, "moved sun: only {n} pixels differ");
    let no_fog = render(
        g,
        Scene::new().with_effects(&[Effect::Lighting, Effect::Shadows]),
    );
    let n = differing(&lit, &no_fog.color);
    eprintln!("no fog: {n} pixels differ");
    assert!(n > 5 * MAX_DIFFERING, "no fog: only {n} pixels differ");
}
