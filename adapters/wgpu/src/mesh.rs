//! Mesh drawing with reversed-Z and depth output (render passes, `shaders/mesh.wgsl`,
//! `shaders/depth_resolve.wgsl`).
//!
//! - [`MeshPass`] draws an indexed triangle list or strip: the output of SOAR refinement
//!   (`relief_core::refine`, seed 004 chapter 4.5; the in/out-edge strip of chapter 5.1) or any
//!   ordinary mesh, optionally geomorphed in the vertex shader (SOAR's morphing). Depth is reversed-Z with
//!   an infinite far plane in a [`wgpu::TextureFormat::Depth32Float`] buffer (seed 004, section
//!   4.6.3: floating-point depth is densest near 0, where reversed-Z puts the far mountains, so
//!   they do not z-fight). Vertices and indices are uploaded every frame with
//!   [`wgpu::Queue::write_buffer`] into buffers that only grow: no mapping, no wait.
//! - [`ResolvePass`] is the *depth output* of seed 003, section 3.7: it turns the ray caster's
//!   distances into the same reversed-Z depth buffer (and copies its colour), so ray-cast terrain
//!   and rasterised meshes drawn afterwards occlude each other.
//!
//! Both use the projection of [`reversed_z_view_projection`], which maps pixel centres exactly as
//! [`relief_core::Camera::ray`] does.

use crate::raycast::RayOutputs;
use crate::util::{self, bind_buffers, storage_entry, uniform_entry};
use crate::Error;
use glam::{Mat4, Vec3, Vec4};
use relief_core::Camera;

/// Format of the colour target.
pub const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// Format of the depth buffer.
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Eye-relative view-projection with reversed-Z and an infinite far plane: a point `p` (world,
/// minus the eye) at view distance `v = dot(p, forward)` gets depth `near / v` (1 at the near
/// plane, towards 0 far away); x and y map pixel centres as [`Camera::ray`].
/// [`Error::Unsupported`] unless `near` is finite and positive.
///
/// ```
/// use relief_core::Camera;
/// use glam::{Vec3, Vec4};
/// let cam = Camera::new(Vec3::ZERO, Vec3::X, 60.0, 4, 4).unwrap();
/// let m = relief_wgpu::mesh::reversed_z_view_projection(&cam, 0.5).unwrap();
/// let c = m * Vec4::new(10.0, 0.0, 0.0, 1.0);
/// assert!((c.z / c.w - 0.05).abs() < 1e-7 && (c.x / c.w).abs() < 1e-7);
/// ```
pub fn reversed_z_view_projection(camera: &Camera, near: f32) -> Result<Mat4, Error> {
    if !(near.is_finite() && near > 0.0) {
        return Err(Error::Unsupported("near plane must be finite and positive"));
    }
    let (f, r, u) = camera.basis();
    let view = Mat4::from_cols(
        Vec4::new(r.x, u.x, -f.x, 0.0),
        Vec4::new(r.y, u.y, -f.y, 0.0),
        Vec4::new(r.z, u.z, -f.z, 0.0),
        Vec4::W,
    );
    let t = camera.tan_half_fov();
    let a = camera.width as f32 / camera.height as f32;
    let proj = Mat4::from_cols(
        Vec4::new(1.0 / (t * a), 0.0, 0.0, 0.0),
        Vec4::new(0.0, 1.0 / t, 0.0, 0.0),
        Vec4::new(0.0, 0.0, 0.0, -1.0),
        Vec4::new(0.0, 0.0, near, 0.0),
    );
    Ok(proj * view)
}

/// The distance along the unit ray of pixel `(i, j)` for a reversed-Z depth value `d` written
/// with near plane `near` (`+inf` for `d = 0`, a miss).
///
/// ```
/// use relief_core::Camera;
/// use glam::Vec3;
/// let cam = Camera::new(Vec3::ZERO, Vec3::X, 60.0, 3, 3).unwrap();
/// assert!((relief_wgpu::mesh::depth_to_distance(&cam, 0.5, 1, 1, 0.05) - 10.0).abs() < 1e-4);
/// assert_eq!(relief_wgpu::mesh::depth_to_distance(&cam, 0.5, 1, 1, 0.0), f32::INFINITY);
/// ```
#[must_use]
pub fn depth_to_distance(camera: &Camera, near: f32, i: u32, j: u32, d: f32) -> f32 {
    if d <= 0.0 {
        return f32::INFINITY;
    }
    let (dir, f) = (camera.ray(i, j).1, camera.basis().0);
    near / d / dir.dot(f)
}

/// A colour target and a reversed-Z depth buffer of one size.
#[derive(Debug)]
pub struct DepthTarget {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Colour ([`COLOR_FORMAT`]).
    pub color: wgpu::Texture,
    /// Depth ([`DEPTH_FORMAT`], reversed-Z, cleared to 0).
    pub depth: wgpu::Texture,
}

impl DepthTarget {
    /// A `width x height` target (both textures copyable to buffers). [`Error::Unsupported`]
    /// for a zero size or a side past the device's `max_texture_dimension_2d` (8192 on many
    /// GPUs; wgpu's default handler would panic on the texture).
    ///
    /// ```no_run
    /// let gpu = relief_wgpu::headless()?;
    /// let target = relief_wgpu::DepthTarget::new(&gpu.device, 640, 360)?;
    /// assert_eq!((target.width, target.height), (640, 360));
    /// assert!(relief_wgpu::DepthTarget::new(&gpu.device, 1 << 20, 1).is_err());
    /// # Ok::<(), relief_wgpu::Error>(())
    /// ```
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> Result<DepthTarget, Error> {
        let max = device.limits().max_texture_dimension_2d;
        if width == 0 || height == 0 {
            return Err(Error::Unsupported("a depth target of zero pixels"));
        }
        if width > max || height > max {
            return Err(Error::Unsupported(
                "image side larger than the device's max_texture_dimension_2d",
            ));
        }
        let tex = |label, format, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
        Ok(DepthTarget {
            width,
            height,
            color: tex("relief colour target", COLOR_FORMAT, usage),
            depth: tex("relief depth target", DEPTH_FORMAT, usage),
        })
    }

    fn read_texture(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        texture: &wgpu::Texture,
        aspect: wgpu::TextureAspect,
    ) -> Result<Vec<[u8; 4]>, Error> {
        let row = (self.width * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
        let size = row as u64 * self.height as u64;
        util::check_buffer(device, "relief texture readback", size)?;
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("relief texture readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        // Some adapters (wgpu's GL backend on Mesa, among others) cannot copy depth textures:
        // capture the validation error instead of letting wgpu's default handler panic.
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut enc = device.create_command_encoder(&Default::default());
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &staging,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row),
                    rows_per_image: Some(self.height),
                },
            },
            wgpu::Extent3d {
                width: self.width,
                height: self.height,
                depth_or_array_layers: 1,
            },
        );
        let commands = enc.finish();
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(if aspect == wgpu::TextureAspect::DepthOnly {
                Error::Unsupported(
                    "this GPU adapter cannot copy a depth texture to a buffer (wgpu downlevel \
                     flag DEPTH_TEXTURE_AND_BUFFER_COPIES): use a Vulkan adapter, e.g. Mesa \
                     lavapipe (mesa-vulkan-drivers)",
                )
            } else {
                Error::Readback(e.to_string().lines().next().unwrap_or("").to_string())
            });
        }
        queue.submit([commands]);
        let bytes = util::map_and_read(device, &staging, size)?;
        let mut out = Vec::with_capacity(self.width as usize * self.height as usize);
        for y in 0..self.height as usize {
            let r = &bytes[y * row as usize..][..self.width as usize * 4];
            out.extend(r.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]));
        }
        Ok(out)
    }

    /// Reads the colour back as RGBA8 (waits for the GPU).
    pub fn read_color(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<Vec<[u8; 4]>, Error> {
        self.read_texture(device, queue, &self.color, wgpu::TextureAspect::All)
    }

    /// Reads the reversed-Z depth buffer back (waits for the GPU). [`Error::Unsupported`] on
    /// adapters that cannot copy depth textures (wgpu's downlevel flag
    /// `DEPTH_TEXTURE_AND_BUFFER_COPIES`, missing on wgpu's GL backend on Mesa, for example).
    pub fn read_depth(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<Vec<f32>, Error> {
        let px = self.read_texture(device, queue, &self.depth, wgpu::TextureAspect::DepthOnly)?;
        Ok(px.into_iter().map(f32::from_le_bytes).collect())
    }
}

/// How a [`MeshPass`] colours its triangles.
///
/// ```
/// let s = relief_wgpu::mesh::MeshStyle::Flat([1.0, 0.0, 0.0]);
/// assert_ne!(s, relief_wgpu::mesh::MeshStyle::Terrain { lighting: false });
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MeshStyle {
    /// The ray caster's height colour ramp over the given world height range, optionally lit
    /// by the sun (face normals).
    Terrain {
        /// Diffuse lighting from [`crate::raycast::Shading`]'s sun.
        lighting: bool,
    },
    /// One colour (linear RGB), unlit.
    Flat([f32; 3]),
}

/// Draws an indexed triangle list with reversed-Z depth into a [`DepthTarget`].
///
/// ```no_run
/// use relief_core::Camera;
/// use relief_wgpu::{mesh::MeshStyle, DepthTarget, MeshPass};
/// use glam::Vec3;
/// let gpu = relief_wgpu::headless()?;
/// let target = DepthTarget::new(&gpu.device, 64, 64)?;
/// let mut mesh = MeshPass::new(&gpu.device);
/// mesh.upload(&gpu.device, &gpu.queue, &[[0.0, -5.0, -5.0], [0.0, 5.0, -5.0], [0.0, 0.0, 5.0]], &[0, 1, 2])?;
/// let cam = Camera::new(Vec3::new(-10.0, 0.0, 0.0), Vec3::ZERO, 60.0, 64, 64)?;
/// let mut enc = gpu.device.create_command_encoder(&Default::default());
/// mesh.encode(&gpu.queue, &mut enc, &target, &cam, MeshStyle::Flat([1.0, 0.0, 0.0]), (0.0, 1.0), true)?;
/// gpu.queue.submit([enc.finish()]);
/// let depth = target.read_depth(&gpu.device, &gpu.queue)?;
/// assert!(depth[32 * 64 + 32] > 0.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug)]
pub struct MeshPass {
    /// Indexed by `[strip as usize][morph as usize]`.
    pipelines: [[wgpu::RenderPipeline; 2]; 2],
    strip: bool,
    morph: bool,
    group: wgpu::BindGroup,
    params: wgpu::Buffer,
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
    near: f32,
    sun: Vec3,
    ambient: f32,
}

/// Grows `buf` to hold `need` bytes: the next power of two (at least 256), capped at the
/// device's `max_buffer_size`. [`Error::TooLarge`] when `need` itself is over that limit (a
/// buffer wgpu would refuse with a validation error, which panics in its default handler); the
/// buffer is then left as it was.
fn grow(
    device: &wgpu::Device,
    buf: &mut wgpu::Buffer,
    need: u64,
    usage: wgpu::BufferUsages,
) -> Result<(), Error> {
    util::check_buffer(device, buf_label(usage), need)?;
    if buf.size() < need {
        let limit = device.limits().max_buffer_size;
        // `limit` is a multiple of 4 on every backend; the size stays one for `write_buffer`.
        let size = need.next_power_of_two().max(256).min(limit & !3);
        *buf = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(buf_label(usage)),
            size,
            usage: usage | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
    }
    Ok(())
}

/// Grows `buf` to hold `bytes` ([`grow`]) and writes them at its start (nothing for none).
fn write_growing(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    buf: &mut wgpu::Buffer,
    bytes: &[u8],
    usage: wgpu::BufferUsages,
) -> Result<(), Error> {
    grow(device, buf, bytes.len() as u64, usage)?;
    if !bytes.is_empty() {
        queue.write_buffer(buf, 0, bytes);
    }
    Ok(())
}

fn buf_label(usage: wgpu::BufferUsages) -> &'static str {
    if usage.contains(wgpu::BufferUsages::INDEX) {
        "relief mesh indices"
    } else {
        "relief mesh vertices"
    }
}

impl MeshPass {
    /// A pass with empty buffers, near plane 1 world unit, the default sun.
    pub fn new(device: &wgpu::Device) -> MeshPass {
        let module = device.create_shader_module(wgpu::include_wgsl!("../../../shaders/mesh.wgsl"));
        let vf = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("relief mesh"),
            entries: &[uniform_entry(0, vf)],
        });
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("relief mesh"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let plain = wgpu::vertex_attr_array![0 => Float32x3];
        let morph = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32, 2 => Float32];
        let make = |strip: bool, morphed: bool| {
            let (attrs, stride, entry): (&[wgpu::VertexAttribute], u64, &str) = if morphed {
                (&morph, 20, "vs_morph")
            } else {
                (&plain, 12, "vs_mesh")
            };
            let primitive = if strip {
                wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleStrip,
                    strip_index_format: Some(wgpu::IndexFormat::Uint32),
                    ..Default::default()
                }
            } else {
                wgpu::PrimitiveState::default()
            };
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("relief mesh"),
                layout: Some(&pl),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    buffers: &[Some(wgpu::VertexBufferLayout {
                        array_stride: stride,
                        step_mode: wgpu::VertexStepMode::Vertex,
                        attributes: attrs,
                    })],
                },
                primitive,
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::Greater),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs_mesh"),
                    compilation_options: Default::default(),
                    targets: &[Some(COLOR_FORMAT.into())],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let pipelines = [
            [make(false, false), make(false, true)],
            [make(true, false), make(true, true)],
        ];
        let params = util::uniform(device, "relief mesh params", 128);
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("relief mesh"),
            layout: &layout,
            entries: &bind_buffers(&[&params]),
        });
        let mk = |usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(buf_label(usage)),
                size: 256,
                usage: usage | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let s = crate::raycast::Shading::default();
        MeshPass {
            pipelines,
            strip: false,
            morph: false,
            group,
            params,
            vertices: mk(wgpu::BufferUsages::VERTEX),
            indices: mk(wgpu::BufferUsages::INDEX),
            index_count: 0,
            near: 1.0,
            sun: s.sun.normalize(),
            ambient: s.ambient,
        }
    }

    /// Sets the near plane distance (default 1 world unit; depth output must use the same).
    #[must_use]
    pub fn with_near(mut self, near: f32) -> Self {
        self.near = near;
        self
    }

    /// Sets the sun and ambient term for [`MeshStyle::Terrain`] lighting.
    #[must_use]
    pub fn with_sun(mut self, sun: Vec3, ambient: f32) -> Self {
        self.sun = sun.normalize_or(Vec3::Z);
        self.ambient = ambient;
        self
    }

    /// Uploads this frame's mesh: world positions and a triangle list (three indices per
    /// triangle, e.g. [`relief_core::refine::Refiner::triangles`]). Queue writes only (no
    /// stall); the buffers grow to the next power of two when the mesh does not fit (capped at
    /// the device's `max_buffer_size`). [`Error::TooLarge`] when the vertices or indices are
    /// larger than that limit: nothing is uploaded and the previous mesh stays.
    pub fn upload(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        vertices: &[[f32; 3]],
        indices: &[u32],
    ) -> Result<(), Error> {
        self.upload_bytes(
            device,
            queue,
            Some(bytemuck::cast_slice(vertices)),
            indices,
            false,
            false,
        )
    }

    /// Uploads every sample of `terrain` as a vertex, index `y * width + x`, at its
    /// [`relief_core::Terrain::position`] (the position [`relief_core::refine::Refiner::triangles`]
    /// gives a vertex, bit for bit): the vertex buffer that
    /// [`MeshPass::upload_grid_triangles`] indexes. Upload it once per terrain (and again after
    /// an edit); each frame then writes only its indices. [`Error::TooLarge`] when the
    /// grid's vertices (12 bytes a sample) are larger than the device's `max_buffer_size`:
    /// draw such a terrain with [`MeshPass::upload`] (only the frame's vertices) instead.
    ///
    /// ```no_run
    /// # fn f(device: &wgpu::Device, queue: &wgpu::Queue, rf: &relief_core::refine::Refiner<'_, '_, relief_core::Heightfield<'_, f32>>, hf: &relief_core::Heightfield<'_, f32>) {
    /// use relief_core::Terrain;
    /// let mut mesh = relief_wgpu::MeshPass::new(device);
    /// mesh.upload_grid_vertices(device, queue, hf).unwrap();
    /// let mut tris = vec![[0u32; 3]; relief_core::refine::triangle_bound(hf.width(), hf.height())];
    /// let n = rf.grid_triangles(&mut tris).unwrap();
    /// mesh.upload_grid_triangles(device, queue, bytemuck::cast_slice(&tris[..n])).unwrap();
    /// # }
    /// ```
    pub fn upload_grid_vertices<T: relief_core::Terrain>(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        terrain: &T,
    ) -> Result<(), Error> {
        let (w, h) = (terrain.width(), terrain.height());
        // Checked before the vertices are built (a grid past the limit may not fit in memory
        // either).
        let bytes = u64::from(w) * u64::from(h) * 12;
        util::check_buffer(device, "relief grid vertices", bytes)?;
        let vb: Vec<[f32; 3]> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter_map(|(x, y)| terrain.position(x, y))
            .map(|p| p.to_array())
            .collect();
        write_growing(
            device,
            queue,
            &mut self.vertices,
            bytemuck::cast_slice(&vb),
            wgpu::BufferUsages::VERTEX,
        )?;
        self.morph = false;
        Ok(())
    }

    /// Uploads this frame's triangle list as indices into the grid vertices of
    /// [`MeshPass::upload_grid_vertices`] (e.g. [`relief_core::refine::Refiner::grid_triangles`]):
    /// only the index buffer is written. Errors as [`MeshPass::upload`].
    pub fn upload_grid_triangles(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        indices: &[u32],
    ) -> Result<(), Error> {
        self.upload_bytes(device, queue, None, indices, false, false)
    }

    /// Uploads a generalized triangle strip (e.g. [`relief_core::refine::Refiner::inout_strip`]:
    /// every three consecutive indices form a triangle, degenerate ones included). Errors as
    /// [`MeshPass::upload`].
    pub fn upload_strip(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        vertices: &[[f32; 3]],
        strip: &[u32],
    ) -> Result<(), Error> {
        self.upload_bytes(
            device,
            queue,
            Some(bytemuck::cast_slice(vertices)),
            strip,
            true,
            false,
        )
    }

    /// Uploads geomorphing vertices with a triangle list (`strip = false`:
    /// [`relief_core::refine::Refiner::morph`], in the vertex order of
    /// [`relief_core::refine::Refiner::triangles`]) or a strip
    /// ([`relief_core::refine::Refiner::inout_strip_morph`] or `soar_strip_morph`, in the
    /// strip's vertex order): the vertex shader draws each at `base_z + morph (z - base_z)`.
    /// Errors as [`MeshPass::upload`].
    pub fn upload_morph(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        vertices: &[relief_core::refine::MorphVertex],
        indices: &[u32],
        strip: bool,
    ) -> Result<(), Error> {
        self.upload_bytes(
            device,
            queue,
            Some(bytemuck::cast_slice(vertices)),
            indices,
            strip,
            true,
        )
    }

    fn upload_bytes(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        vb: Option<&[u8]>,
        indices: &[u32],
        strip: bool,
        morph: bool,
    ) -> Result<(), Error> {
        let ib: &[u8] = bytemuck::cast_slice(indices);
        // Both checked before either buffer changes, so a refused mesh leaves the last one.
        util::check_buffer(
            device,
            buf_label(wgpu::BufferUsages::INDEX),
            ib.len() as u64,
        )?;
        if u32::try_from(indices.len()).is_err() {
            return Err(Error::Unsupported(
                "more mesh indices than a u32 draw count",
            ));
        }
        if let Some(v) = vb {
            util::check_buffer(
                device,
                buf_label(wgpu::BufferUsages::VERTEX),
                v.len() as u64,
            )?;
        }
        if let Some(vb) = vb {
            let usage = wgpu::BufferUsages::VERTEX;
            write_growing(device, queue, &mut self.vertices, vb, usage)?;
        }
        write_growing(
            device,
            queue,
            &mut self.indices,
            ib,
            wgpu::BufferUsages::INDEX,
        )?;
        self.strip = strip;
        self.morph = morph;
        self.index_count = if strip {
            if indices.len() >= 3 {
                indices.len() as u32
            } else {
                0
            }
        } else {
            indices.len() as u32 / 3 * 3
        };
        Ok(())
    }

    /// Records the draw into `target`. `clear` clears colour (sky) and depth (0) first; without
    /// it the pass loads them (drawing over a [`ResolvePass`] output or another mesh).
    /// `z_range` is the world height range of the colour ramp.
    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        target: &DepthTarget,
        camera: &Camera,
        style: MeshStyle,
        z_range: (f32, f32),
        clear: bool,
    ) -> Result<(), Error> {
        let vp = reversed_z_view_projection(camera, self.near)?;
        let (color, flat, lit) = match style {
            MeshStyle::Flat(c) => (c, 1.0, 0.0),
            MeshStyle::Terrain { lighting } => ([0.0; 3], 0.0, f32::from(u8::from(lighting))),
        };
        let mut p = [0f32; 32];
        p[..16].copy_from_slice(&vp.to_cols_array());
        p[16..19].copy_from_slice(&camera.eye.to_array());
        p[20..23].copy_from_slice(&color);
        p[23] = flat;
        p[24..28].copy_from_slice(&[z_range.0, z_range.1, lit, self.ambient]);
        p[28..31].copy_from_slice(&self.sun.to_array());
        queue.write_buffer(&self.params, 0, bytemuck::cast_slice(&p));
        let views = (
            target.color.create_view(&Default::default()),
            target.depth.create_view(&Default::default()),
        );
        let (cop, dop) = if clear {
            (
                wgpu::LoadOp::Clear(wgpu::Color {
                    r: 0.55,
                    g: 0.7,
                    b: 0.9,
                    a: 1.0,
                }),
                wgpu::LoadOp::Clear(0.0),
            )
        } else {
            (wgpu::LoadOp::Load, wgpu::LoadOp::Load)
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("relief mesh"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &views.0,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: cop,
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &views.1,
                depth_ops: Some(wgpu::Operations {
                    load: dop,
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        if self.index_count > 0 {
            pass.set_pipeline(&self.pipelines[usize::from(self.strip)][usize::from(self.morph)]);
            pass.set_bind_group(0, &self.group, &[]);
            pass.set_vertex_buffer(0, self.vertices.slice(..));
            pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..self.index_count, 0, 0..1);
        }
        Ok(())
    }
}

/// Depth output: writes a ray caster's colour and distances into a [`DepthTarget`] as
/// reversed-Z depth (seed 003, section 3.7), so meshes drawn afterwards with [`MeshPass`]
/// (`clear = false`) are hidden behind the terrain and hide it.
///
/// ```no_run
/// # use relief_core::{Camera, Heightfield};
/// # use relief_wgpu::{raycast::{RayEffects, Shading}, DepthTarget, GpuTerrain, Method, RayCastPass, ResolvePass};
/// # use glam::Vec3;
/// let gpu = relief_wgpu::headless()?;
/// let hf = Heightfield::new(&[0.0f32; 16], 4, 4)?;
/// let t = GpuTerrain::new(&gpu.device, &gpu.queue, &hf, false)?;
/// let rays = RayCastPass::new(&gpu.device, &t, None, None, Method::MaxMip, RayEffects::default(), 8, 8)?;
/// let target = DepthTarget::new(&gpu.device, 8, 8)?;
/// let resolve = ResolvePass::new(&gpu.device, rays.outputs(), 1.0);
/// let cam = Camera::new(Vec3::new(-1.0, -1.0, 3.0), Vec3::new(2.0, 2.0, 0.0), 60.0, 8, 8)?;
/// let mut enc = gpu.device.create_command_encoder(&Default::default());
/// t.encode_maxmip(&mut enc);
/// rays.encode(&gpu.queue, &mut enc, &t, &cam, &Shading::default())?;
/// resolve.encode(&gpu.queue, &mut enc, &target, &cam)?;
/// gpu.queue.submit([enc.finish()]);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug)]
pub struct ResolvePass {
    pipeline: wgpu::RenderPipeline,
    group: wgpu::BindGroup,
    params: wgpu::Buffer,
    near: f32,
}

impl ResolvePass {
    /// A resolve pass reading `rays` with near plane `near` (the [`MeshPass`]'s).
    pub fn new(device: &wgpu::Device, rays: &RayOutputs, near: f32) -> ResolvePass {
        let module =
            device.create_shader_module(wgpu::include_wgsl!("../../../shaders/depth_resolve.wgsl"));
        let fs = wgpu::ShaderStages::FRAGMENT;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("relief depth resolve"),
            entries: &[
                uniform_entry(0, fs),
                storage_entry(1, true, fs),
                storage_entry(2, true, fs),
            ],
        });
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("relief depth resolve"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("relief depth resolve"),
            layout: Some(&pl),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_fullscreen"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Always),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_resolve"),
                compilation_options: Default::default(),
                targets: &[Some(COLOR_FORMAT.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
        let params = util::uniform(device, "relief resolve params", 80);
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("relief depth resolve"),
            layout: &layout,
            entries: &bind_buffers(&[&params, &rays.depth, &rays.color]),
        });
        ResolvePass {
            pipeline,
            group,
            params,
            near,
        }
    }

    /// Records the full-screen pass into `target` (same size as the ray outputs).
    pub fn encode(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        target: &DepthTarget,
        camera: &Camera,
    ) -> Result<(), Error> {
        if camera.width != target.width || camera.height != target.height {
            return Err(Error::Unsupported(
                "camera image size differs from the target's",
            ));
        }
        let (f, r, u) = camera.basis();
        let mut p = [0u32; 20];
        let fl = [
            f.x,
            f.y,
            f.z,
            0.0,
            r.x,
            r.y,
            r.z,
            0.0,
            u.x,
            u.y,
            u.z,
            0.0,
            camera.tan_half_fov(),
            camera.width as f32 / camera.height as f32,
            self.near,
            0.0,
        ];
        for (i, v) in fl.iter().enumerate() {
            p[i] = v.to_bits();
        }
        p[16] = target.width;
        p[17] = target.height;
        queue.write_buffer(&self.params, 0, bytemuck::cast_slice(&p));
        let views = (
            target.color.create_view(&Default::default()),
            target.depth.create_view(&Default::default()),
        );
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("relief depth resolve"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &views.0,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &views.1,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(0.0),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.group, &[]);
        pass.draw(0..3, 0..1);
        Ok(())
    }
}
