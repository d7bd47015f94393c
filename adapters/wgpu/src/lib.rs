//! # relief-wgpu
//!
//! GPU passes for relief on [`wgpu`], with their WGSL in the repository's `shaders/` folder.
//! Every pass is checked in this crate's tests against the `relief-core` CPU result on the same
//! input.
//!
//! The crate never owns the window or the device: every pass borrows the application's
//! [`wgpu::Device`] and [`wgpu::Queue`] and only records into the caller's
//! [`wgpu::CommandEncoder`] (nothing inside a frame waits for the GPU). [`headless`] creates a
//! device without a window for tests, the `relief` CLI and offline rendering.
//!
//! | pass | module | seed |
//! |---|---|---|
//! | heightfield upload, deformations, maximum-mipmap build (compute) | [`terrain`] | 002 (sec. 5), 003 (sec. 3.8) |
//! | normal map: central, Sobel, composed base + detail (compute) | [`normals`] | 003 (sec. 3.6), 004 (sec. 2.3, 7.3) |
//! | ray casting: max-mip and march, depth + normal + colour (compute) | [`raycast`] | 002 (sec. 5), 003 (sec. 3.3-3.5) |
//! | mesh drawing with reversed-Z, strips, geomorphing, depth output (render) | [`mesh`] | 003 (sec. 3.7), 004 (sec. 4.5, 4.6.3, 5.1) |
//! | silhouette partitioning: map, packed tree, fixed-cost trace (compute) | [`silhouette`] | 000 |
//! | RBF cascade discretization (compute) | [`rbf`] | 002 (sec. 4) |
//! | cascade ray cast: a max-mip per cascade, overlap hits blended with weights computed on the GPU (compute) | [`cascade`] | 002 (sec. 5) |
//! | effects on demand: a [`Scene`] and the passes its frame needs | [`scene`] | 003 (sec. 4, table 1) |
//!
//! Conventions are those of `relief-core` (CONVENTIONS.md): camera rays from
//! [`relief_core::Camera`], depth images as the distance `t` along the unit ray, `+inf` for a
//! miss. Heights live on the GPU as `f32` *local* heights (`h * z_scale`); the eye is converted to
//! heightfield-local coordinates in `f64` on the CPU before upload, as the CPU tracer does.
//!
//! ## What fits a device
//!
//! Every buffer a pass creates is checked against the device's limits first, and one that does
//! not fit is [`Error::TooLarge`] (naming the buffer, its bytes and the limit) instead of
//! wgpu's validation error, which panics in its default handler; a texture side past
//! `max_texture_dimension_2d` or a dispatch past `max_compute_workgroups_per_dimension`
//! (workgroups of 8 x 8 threads, one thread a pixel or sample) is [`Error::Unsupported`]. A
//! storage buffer must fit `max_storage_buffer_binding_size` (128 MiB on lavapipe and on many
//! GPUs) and any buffer `max_buffer_size`. What a scene allocates, so only what it names:
//!
//! | buffer | bytes | when |
//! |---|---|---|
//! | ray outputs: depth, colour | 4 + 4 a pixel | every ray-cast frame ([`RayOutputs`]) |
//! | per-pixel normals | 16 a pixel | [`Effect::NormalOutput`] only |
//! | heights | 4 a sample (twice with deformations) | every terrain ([`GpuTerrain`]) |
//! | max-mip pyramid | about 5.3 a sample (4 a cell over all levels) | [`Method::MaxMip`] scenes ([`GpuTerrain::new`]; march and silhouette scenes use [`GpuTerrain::without_maxmip`]) |
//! | normal map (gradients) | 8 a sample of the (refined) grid | [`Effect::Lighting`] ([`NormalPass`]) |
//! | colour and depth targets | 4 + 4 a pixel, textures | [`Effect::DepthOutput`], [`MeshPass`] |
//! | mesh vertices, indices | 12 a vertex, 4 an index | [`MeshPass`] (grid vertices: 12 a sample) |
//!
//! With a 128 MiB binding that is about 33 M pixels per frame (8.4 M with normals), terrains up
//! to about 5017 x 5017 samples for max-mip scenes (the pyramid) and 5793 x 5793 for march and
//! silhouette scenes (the heights), lit ones up to 4096 x 4096 (the normal map).
//!
//! ```no_run
//! use relief_core::{Camera, Heightfield, Scale};
//! use relief_wgpu::{headless, Effect, Renderer, Scene};
//! use glam::Vec3;
//! let gpu = headless()?;
//! let samples: Vec<f32> = (0..64 * 64).map(|i| ((i % 64) as f32 * 0.2).sin() * 4.0).collect();
//! let hf = Heightfield::with_scale(&samples, 64, 64, Scale::default())?;
//! let scene = Scene::new().with_effect(Effect::Lighting).with_effect(Effect::Fog);
//! let mut renderer = Renderer::new(&gpu.device, &gpu.queue, &hf, scene)?;
//! let cam = Camera::new(Vec3::new(-10.0, -10.0, 30.0), Vec3::new(32.0, 32.0, 0.0), 60.0, 320, 240)?;
//! let image = renderer.render(&gpu.device, &gpu.queue, &cam)?;
//! assert_eq!(image.depth.len(), 320 * 240);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![deny(missing_docs)]
#![deny(rustdoc::broken_intra_doc_links)]
#![forbid(unsafe_code)]

pub mod cascade;
pub mod mesh;
pub mod normals;
pub mod raycast;
pub mod rbf;
pub mod scene;
pub mod silhouette;
pub mod terrain;
mod util;

pub use mesh::{DepthTarget, MeshPass, ResolvePass};
pub use normals::NormalPass;
pub use raycast::{Method, RayCastPass, RayOutputs};
pub use scene::{Clock, Effect, FrameImage, PassName, PassTiming, Renderer, Scene};
pub use terrain::GpuTerrain;
pub use util::read_buffer;

/// Everything that can go wrong in this crate.
///
/// ```
/// let e = relief_wgpu::Error::NoAdapter("No suitable graphics adapter found".into());
/// assert!(e.to_string().starts_with("no GPU adapter"));
/// ```
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Error {
    /// No graphics adapter exists (no GPU and no software driver such as Mesa lavapipe): the
    /// wgpu message.
    NoAdapter(String),
    /// The adapter refused to create a device: the wgpu message.
    Device(String),
    /// Reading results back from the GPU failed (mapping or polling): the wgpu message.
    Readback(String),
    /// The input is not valid for this pass (a relief-core error).
    Core(relief_core::Error),
    /// A size or option does not fit the device or the pass: what and why.
    Unsupported(&'static str),
    /// A buffer larger than the device allows (`max_buffer_size`, and for storage buffers
    /// `max_storage_buffer_binding_size`): a smaller image, terrain or mesh fits.
    TooLarge {
        /// The buffer (its label).
        what: &'static str,
        /// Bytes it needs.
        bytes: u64,
        /// Bytes the device allows.
        limit: u64,
    },
}

impl core::fmt::Display for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Error::NoAdapter(m) => write!(f, "no GPU adapter: {m} (install a Vulkan driver, e.g. Mesa lavapipe: mesa-vulkan-drivers)"),
            Error::Device(m) => write!(f, "GPU device request failed: {m}"),
            Error::Readback(m) => write!(f, "GPU readback failed: {m}"),
            Error::Core(e) => write!(f, "{e}"),
            Error::Unsupported(m) => write!(f, "unsupported: {m}"),
            Error::TooLarge { what, bytes, limit } => write!(
                f,
                "{what}: {bytes} bytes, more than this device allows in one buffer ({limit}): use a smaller image, terrain or mesh"
            ),
        }
    }
}

impl std::error::Error for Error {}

impl From<relief_core::Error> for Error {
    fn from(e: relief_core::Error) -> Self {
        Error::Core(e)
    }
}

/// A device and queue created by [`headless`], and the adapter's description.
///
/// ```no_run
/// let gpu = relief_wgpu::headless()?;
/// println!("{} ({:?})", gpu.info.name, gpu.info.backend);
/// # Ok::<(), relief_wgpu::Error>(())
/// ```
#[derive(Debug)]
pub struct Gpu {
    /// The device (borrowed by every pass).
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// Name, backend and device type of the adapter.
    pub info: wgpu::AdapterInfo,
}

/// Creates a device without a window, for tests, the CLI and offline rendering.
///
/// The adapter follows wgpu's environment variables (`WGPU_BACKEND`, `WGPU_ADAPTER_NAME`,
/// `WGPU_POWER_PREF`, read by [`wgpu::util::initialize_adapter_from_env_or_default`] and
/// [`wgpu::InstanceDescriptor::new_without_display_handle_from_env`]); on machines without a GPU,
/// Mesa's lavapipe Vulkan driver works. [`Error::NoAdapter`] when no adapter exists at all.
/// The device gets the adapter's own limits, and [`wgpu::Features::TIMESTAMP_QUERY`] with
/// [`wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS`] when the adapter has both and is not a
/// CPU adapter (for GPU pass times, [`scene::Clock`]; lavapipe's timestamps do not wait for
/// compute work, see [`scene`]).
///
/// ```no_run
/// match relief_wgpu::headless() {
///     Ok(gpu) => println!("using {}", gpu.info.name),
///     Err(e) => eprintln!("{e}"),
/// }
/// ```
pub fn headless() -> Result<Gpu, Error> {
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = pollster::block_on(wgpu::util::initialize_adapter_from_env_or_default(
        &instance, None,
    ))
    .map_err(|e| Error::NoAdapter(e.to_string()))?;
    let info = adapter.get_info();
    let timing = wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS;
    let features =
        if adapter.features().contains(timing) && info.device_type != wgpu::DeviceType::Cpu {
            timing
        } else {
            wgpu::Features::empty()
        };
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("relief-wgpu headless"),
        required_features: features,
        required_limits: adapter.limits(),
        ..Default::default()
    }))
    .map_err(|e| Error::Device(e.to_string()))?;
    Ok(Gpu {
        device,
        queue,
        info,
    })
}

#[cfg(test)]
mod shader_validation {
    //! Every WGSL file in `shaders/` parses and validates with naga (no GPU needed), as wgpu's
    //! `naga/tests/example_wgsl.rs` does.

    fn validate(name: &str, src: &str) {
        let module = naga::front::wgsl::parse_str(src)
            .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(src)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(src)));
    }

    #[test]
    fn every_shader_validates() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shaders");
        let mut n = 0;
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "wgsl") {
                validate(
                    &path.display().to_string(),
                    &std::fs::read_to_string(&path).unwrap(),
                );
                n += 1;
            }
        }
        assert!(
            n >= 5,
            "expected the pass shaders in {}, found {n}",
            dir.display()
        );
    }

    /// The CPU water march ([`crate::raycast::water_surface_hit`]) takes the shader's sample
    /// counts.
    #[test]
    fn the_cpu_water_march_has_the_shaders_counts() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shaders/raycast.wgsl");
        let src = std::fs::read_to_string(path).unwrap();
        for (name, n) in [
            ("WATER_STEPS", crate::raycast::WATER_STEPS),
            ("WATER_REFINE", crate::raycast::WATER_REFINE),
        ] {
            let line = format!("const {name}: u32 = {n}u;");
            assert!(src.contains(&line), "shaders/raycast.wgsl lacks `{line}`");
        }
    }

    #[test]
    fn a_broken_shader_is_rejected() {
        let bad = "@compute @workgroup_size(8, 8) fn f() { let x: f32 = 1u; }";
        let parsed = naga::front::wgsl::parse_str(bad);
        assert!(parsed.is_err());
    }
}
