//! Silhouette partitioning (compute, `shaders/silhouette.wgsl`): seed 000, Jaroszewicz,
//! *Ray tracing height fields on the GPU with silhouette partitioning*.
//!
//! No preprocessing: every frame projects the heightfield's rows (the grid lines most
//! perpendicular to the view, numbered front to back) into a *silhouette map* (section 4.1.2,
//! a binary search per row and screen column), builds the *silhouette partitioning tree* over
//! the rows with two levels packed per `vec4` texel (sections 4.1.3-4.1.5: closer child, the two
//! lower closer children, and the node's own silhouette), and traces every pixel by a
//! fixed-depth binary search down that tree (section 5). Each pixel reads exactly
//! [`SilhouettePass::reads_per_pixel`] texels: one per pair of tree levels plus two of the
//! silhouette map for the final interpolation between rows.
//!
//! The method is an approximation (silhouettes are sampled per screen column and interpolated
//! linearly between rows); it needs the whole terrain in front of the camera
//! ([`Error::Unsupported`] otherwise). The depth written is where the pixel's ray crosses the
//! interpolated row's vertical plane. Tests compare the silhouette map with
//! [`relief_core::silhouette::silhouette_map`] (same texels for views along the grid rows), the
//! depth with a CPU implementation of the same model ([`trace_cpu`]: the nearest row whose
//! silhouette reaches the pixel, found by a linear scan; also the CLI's CPU backend), and
//! report its agreement with the exact CPU trace.

use crate::raycast::RayOutputs;
use crate::util::{self, bind_buffers, compute_pipeline, groups, storage_entry, uniform_entry};
use crate::{Error, GpuTerrain};
use relief_core::Camera;

/// Row layout of one view: grid position of sample `k` of row `v` is
/// `origin + k * ustep + v * vstep`; `rows` rows of `row_len` samples, nearest first.
///
/// ```
/// use relief_core::Camera;
/// use glam::Vec3;
/// let cam = Camera::new(Vec3::new(5.0, -20.0, 30.0), Vec3::new(5.0, 10.0, 0.0), 60.0, 8, 8).unwrap();
/// let m = relief_wgpu::silhouette::RowMap::for_camera(&cam, 11, 21);
/// assert_eq!((m.origin, m.ustep, m.vstep, m.rows, m.row_len), ([0, 0], [1, 0], [0, 1], 21, 11));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RowMap {
    /// Grid position of sample 0 of row 0.
    pub origin: [i32; 2],
    /// Step along a row.
    pub ustep: [i32; 2],
    /// Step from one row to the next (away from the eye).
    pub vstep: [i32; 2],
    /// Number of rows.
    pub rows: u32,
    /// Samples per row.
    pub row_len: u32,
}

impl RowMap {
    /// Rows perpendicular to the dominant horizontal axis of the view, nearest first, for a
    /// `width x height` sample grid.
    #[must_use]
    pub fn for_camera(camera: &Camera, width: u32, height: u32) -> RowMap {
        let f = camera.basis().0;
        let (w, h) = (width as i32, height as i32);
        if f.y.abs() >= f.x.abs() {
            let (oy, sy) = if f.y >= 0.0 { (0, 1) } else { (h - 1, -1) };
            RowMap {
                origin: [0, oy],
                ustep: [1, 0],
                vstep: [0, sy],
                rows: height,
                row_len: width,
            }
        } else {
            let (ox, sx) = if f.x >= 0.0 { (0, 1) } else { (w - 1, -1) };
            RowMap {
                origin: [ox, 0],
                ustep: [0, 1],
                vstep: [sx, 0],
                rows: width,
                row_len: height,
            }
        }
    }
}

/// Rows padded to a power of four (two tree levels per texel) and the number of pair levels.
///
/// ```
/// assert_eq!(relief_wgpu::silhouette::padded_rows(1025), (4096, 6));
/// assert_eq!(relief_wgpu::silhouette::padded_rows(2), (4, 1));
/// ```
#[must_use]
pub fn padded_rows(rows: u32) -> (u32, u32) {
    let mut v = 4u32;
    let mut p = 1u32;
    while v < rows {
        v = v.saturating_mul(4);
        p += 1;
    }
    (v, p)
}

const PARAM_WORDS: usize = 10 * 4 + 16;

/// The three silhouette passes for one terrain and image size, writing depth and colour into
/// [`RayOutputs`] (normals are not written).
///
/// ```no_run
/// use relief_core::{Camera, Heightfield};
/// use relief_wgpu::{silhouette::SilhouettePass, GpuTerrain};
/// use glam::Vec3;
/// let gpu = relief_wgpu::headless()?;
/// let s: Vec<f32> = (0..64 * 64).map(|i| (i % 7) as f32).collect();
/// let hf = Heightfield::new(&s, 64, 64)?;
/// let t = GpuTerrain::new(&gpu.device, &gpu.queue, &hf, false)?;
/// let pass = SilhouettePass::new(&gpu.device, &t, 160, 120)?;
/// let cam = Camera::new(Vec3::new(32.0, -40.0, 40.0), Vec3::new(32.0, 32.0, 0.0), 60.0, 160, 120)?;
/// let mut enc = gpu.device.create_command_encoder(&Default::default());
/// pass.encode(&gpu.queue, &mut enc, &t, &cam)?;
/// gpu.queue.submit([enc.finish()]);
/// let depth = pass.outputs().read_depth(&gpu.device, &gpu.queue)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug)]
pub struct SilhouettePass {
    v2: u32,
    pairs: u32,
    offsets: Vec<u32>,
    map_pipeline: wgpu::ComputePipeline,
    tree_pipeline: wgpu::ComputePipeline,
    trace_pipeline: wgpu::ComputePipeline,
    params: Vec<wgpu::Buffer>,
    groups: Vec<wgpu::BindGroup>,
    sil: wgpu::Buffer,
    out: RayOutputs,
}

impl SilhouettePass {
    /// Passes for `terrain` and a `width x height` image. [`Error::Unsupported`] for an empty
    /// image or buffers beyond the device's storage binding size.
    pub fn new(
        device: &wgpu::Device,
        terrain: &GpuTerrain,
        width: u32,
        height: u32,
    ) -> Result<SilhouettePass, Error> {
        if width == 0 || height == 0 {
            return Err(Error::Unsupported("empty image"));
        }
        let (gw, gh) = terrain.size();
        let (v2, pairs) = padded_rows(gw.max(gh));
        let mut offsets = Vec::new();
        let mut total = 0u64;
        for k in 0..pairs {
            offsets.push(total as u32);
            total += u64::from(v2 >> (2 * (k + 1))) * u64::from(width);
        }
        let limit = device.limits().max_storage_buffer_binding_size;
        let sil_bytes = u64::from(v2) * u64::from(width) * 8;
        if total * 16 > limit || sil_bytes > limit || total > u64::from(u32::MAX) {
            return Err(Error::Unsupported(
                "silhouette tree larger than the device's storage buffer binding size",
            ));
        }
        // Its passes dispatch over (width, v2) and (width, nodes of a level, at most v2 / 4).
        util::check_dispatch(device, width, v2)?;
        let sil = util::storage(device, "relief silhouette map", sil_bytes)?;
        let tree = util::storage(device, "relief silhouette tree", total * 16)?;
        let out = RayOutputs::new(device, width, height, false)?;
        let module =
            device.create_shader_module(wgpu::include_wgsl!("../../../shaders/silhouette.wgsl"));
        let cs = wgpu::ShaderStages::COMPUTE;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("relief silhouette"),
            entries: &[
                uniform_entry(0, cs),
                storage_entry(1, true, cs),
                storage_entry(2, false, cs),
                storage_entry(3, false, cs),
                storage_entry(4, false, cs),
                storage_entry(5, false, cs),
            ],
        });
        let pl =
            |entry| compute_pipeline(device, "relief silhouette", &layout, &module, entry, &[]);
        let (map_pipeline, tree_pipeline, trace_pipeline) = (
            pl("silhouette_map"),
            pl("silhouette_tree"),
            pl("silhouette_trace"),
        );
        let mut params = Vec::new();
        let mut bgs = Vec::new();
        for _ in 0..pairs {
            let pb = util::uniform(device, "relief silhouette params", PARAM_WORDS as u64 * 4);
            bgs.push(device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("relief silhouette"),
                layout: &layout,
                entries: &bind_buffers(&[
                    &pb,
                    terrain.heights(),
                    &sil,
                    &tree,
                    &out.depth,
                    &out.color,
                ]),
            }));
            params.push(pb);
        }
        Ok(SilhouettePass {
            v2,
            pairs,
            offsets,
            map_pipeline,
            tree_pipeline,
            trace_pipeline,
            params,
            groups: bgs,
            sil,
            out,
        })
    }

    /// Texels each pixel reads, whatever the terrain looks like: one tree texel per pair of
    /// levels and two silhouette-map texels.
    ///
    /// ```no_run
    /// # let gpu = relief_wgpu::headless()?;
    /// # let hf = relief_core::Heightfield::new(&[0.0f32; 1025 * 1025], 1025, 1025)?;
    /// # let t = relief_wgpu::GpuTerrain::new(&gpu.device, &gpu.queue, &hf, false)?;
    /// let pass = relief_wgpu::silhouette::SilhouettePass::new(&gpu.device, &t, 64, 64)?;
    /// assert_eq!(pass.reads_per_pixel(), 6 + 2); // 1025 rows: 4096 padded, 6 pairs of levels
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn reads_per_pixel(&self) -> u32 {
        self.pairs + 2
    }

    /// The output buffers (depth and colour).
    #[must_use]
    pub fn outputs(&self) -> &RayOutputs {
        &self.out
    }

    /// The silhouette map buffer (`(y, u)` per padded row and column; for tests and tools).
    #[must_use]
    pub fn silhouette_map(&self) -> &wgpu::Buffer {
        &self.sil
    }

    /// Writes the view's parameters and records the three passes (map, tree, trace).
    /// [`Error::Unsupported`] when part of the terrain is behind the camera or the image size
    /// differs from the pass's.
    pub fn encode(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        terrain: &GpuTerrain,
        camera: &Camera,
    ) -> Result<(), Error> {
        self.write_params(queue, terrain, camera)?;
        self.encode_map(encoder);
        self.encode_tree(encoder);
        self.encode_trace(encoder);
        Ok(())
    }

    /// Writes the view's parameters (queue writes) for the next
    /// [`SilhouettePass::encode_map`], [`SilhouettePass::encode_tree`] and
    /// [`SilhouettePass::encode_trace`]. [`Error::Unsupported`] when part of the terrain is
    /// behind the camera or the image size differs from the pass's.
    pub fn write_params(
        &self,
        queue: &wgpu::Queue,
        terrain: &GpuTerrain,
        camera: &Camera,
    ) -> Result<(), Error> {
        if camera.width != self.out.width || camera.height != self.out.height {
            return Err(Error::Unsupported(
                "camera image size differs from the pass's",
            ));
        }
        let (gw, gh) = terrain.size();
        let s = terrain.scale();
        let (f, r, u) = camera.basis();
        let (zmin, zmax) = terrain.height_range();
        let eye = camera.eye.as_dvec3() - glam::DVec3::new(0.0, 0.0, f64::from(s.z_offset));
        for cx in [0.0, f64::from(gw - 1) * f64::from(s.dx)] {
            for cy in [0.0, f64::from(gh - 1) * f64::from(s.dy)] {
                for cz in [f64::from(zmin), f64::from(zmax)] {
                    let q = glam::DVec3::new(cx, cy, cz) - eye;
                    if q.dot(f.as_dvec3()) <= 0.0 {
                        return Err(Error::Unsupported(
                            "silhouette partitioning needs the whole terrain in front of the camera",
                        ));
                    }
                }
            }
        }
        let m = RowMap::for_camera(camera, gw, gh);
        let eye = eye.as_vec3();
        let fl: [[f32; 4]; 6] = [
            [eye.x, eye.y, eye.z, 0.0],
            [f.x, f.y, f.z, 0.0],
            [r.x, r.y, r.z, 0.0],
            [u.x, u.y, u.z, 0.0],
            [
                s.dx,
                s.dy,
                camera.tan_half_fov(),
                camera.width as f32 / camera.height as f32,
            ],
            [zmin, zmax, s.z_offset, 0.0],
        ];
        let mut p = [0u32; PARAM_WORDS];
        for (i, v) in fl.iter().flatten().enumerate() {
            p[i] = v.to_bits();
        }
        p[24..28].copy_from_slice(&[camera.width, camera.height, gw, gh]);
        let ints = [
            m.origin[0],
            m.origin[1],
            m.ustep[0],
            m.ustep[1],
            m.vstep[0],
            m.vstep[1],
        ];
        for (k, v) in ints.iter().enumerate() {
            p[28 + k] = *v as u32;
        }
        p[34] = m.rows;
        p[35] = m.row_len;
        p[36] = self.v2;
        p[37] = self.pairs;
        for (k, &o) in self.offsets.iter().enumerate() {
            p[40 + k] = o;
        }
        for (level, buf) in self.params.iter().enumerate() {
            p[38] = level as u32;
            queue.write_buffer(buf, 0, bytemuck::cast_slice(&p));
        }
        Ok(())
    }

    /// Records the silhouette map (section 4.1.2): one binary search per padded row and screen
    /// column. Parameters from the last [`SilhouettePass::write_params`].
    pub fn encode_map(&self, encoder: &mut wgpu::CommandEncoder) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("relief silhouette map"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.map_pipeline);
        pass.set_bind_group(0, &self.groups[0], &[]);
        pass.dispatch_workgroups(groups(self.out.width, 8), groups(self.v2, 8), 1);
    }

    /// Records the packed partitioning tree (sections 4.1.3-4.1.5): one dispatch per pair of
    /// levels, bottom up.
    pub fn encode_tree(&self, encoder: &mut wgpu::CommandEncoder) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("relief silhouette tree"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.tree_pipeline);
        for (level, g) in self.groups.iter().enumerate() {
            pass.set_bind_group(0, g, &[]);
            let nodes = self.v2 >> (2 * (level as u32 + 1));
            pass.dispatch_workgroups(groups(self.out.width, 8), groups(nodes, 8), 1);
        }
    }

    /// Records the fixed-cost trace (section 5): [`SilhouettePass::reads_per_pixel`] texel
    /// reads per pixel, writing depth and colour.
    pub fn encode_trace(&self, encoder: &mut wgpu::CommandEncoder) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("relief silhouette trace"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.trace_pipeline);
        pass.set_bind_group(0, &self.groups[0], &[]);
        pass.dispatch_workgroups(groups(self.out.width, 8), groups(self.out.height, 8), 1);
    }
}

/// Texels each pixel of a silhouette-partitioning trace reads for a `width x height` grid,
/// whatever the terrain and view: one packed tree texel per pair of levels of the tree over the
/// `max(width, height)` rows padded to a power of four, plus two silhouette-map texels for the
/// interpolation between rows (the same as [`SilhouettePass::reads_per_pixel`]).
///
/// ```
/// assert_eq!(relief_wgpu::silhouette::reads_per_pixel(1025, 1025), 8);
/// assert_eq!(relief_wgpu::silhouette::reads_per_pixel(64, 16), 3 + 2);
/// ```
#[must_use]
pub fn reads_per_pixel(width: u32, height: u32) -> u32 {
    padded_rows(width.max(height)).1 + 2
}

/// A frame traced by [`trace_cpu`].
#[derive(Debug, Clone, PartialEq)]
pub struct CpuTrace {
    /// Distance along each pixel's unit ray (`+inf` where the pixel sees no row).
    pub depth: Vec<f32>,
    /// Local height (`z - z_offset`) of the point each pixel sees (NaN for a miss), for
    /// colouring as the GPU does.
    pub height: Vec<f32>,
}

/// The silhouette-partitioning trace of `shaders/silhouette.wgsl` on the CPU in `f64`, the
/// reference its tests compare the GPU with and the `relief render --backend cpu --method
/// silhouette` renderer: per screen column, each row's silhouette (a binary search along the
/// row for the crossing of the column, interpolated linearly), then per pixel the nearest row
/// whose silhouette reaches it, found by a linear scan instead of the tree, interpolated with
/// the row before; the depth is where the ray crosses that fractional row's vertical plane.
/// [`Error::Unsupported`] when part of the terrain is behind the camera (as
/// [`SilhouettePass::write_params`]).
///
/// ```
/// use relief_core::{Camera, Heightfield};
/// use glam::Vec3;
/// let s: Vec<f32> = (0..32 * 32).map(|i| ((i % 32) as f32 * 0.3).sin() * 2.0).collect();
/// let hf = Heightfield::new(&s, 32, 32).unwrap();
/// let cam = Camera::new(Vec3::new(16.0, -20.0, 15.0), Vec3::new(16.0, 16.0, 0.0), 50.0, 40, 30).unwrap();
/// let t = relief_wgpu::silhouette::trace_cpu(&hf, &cam).unwrap();
/// assert!(t.depth.iter().any(|d| d.is_finite()));
/// let behind = Camera::new(Vec3::new(16.0, 16.0, 15.0), Vec3::new(16.0, 40.0, 0.0), 50.0, 40, 30).unwrap();
/// assert!(relief_wgpu::silhouette::trace_cpu(&hf, &behind).is_err());
/// ```
pub fn trace_cpu<T: relief_core::Terrain + ?Sized>(
    terrain: &T,
    cam: &Camera,
) -> Result<CpuTrace, Error> {
    let s = terrain.scale();
    let (gw, gh) = (terrain.width(), terrain.height());
    let (mut zmin, mut zmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for y in 0..gh {
        for x in 0..gw {
            let z = f64::from(terrain.local_z(x, y));
            zmin = zmin.min(z);
            zmax = zmax.max(z);
        }
    }
    let m = RowMap::for_camera(cam, gw, gh);
    let (f, r, u) = cam.basis();
    let (f, r, u) = (f.as_dvec3(), r.as_dvec3(), u.as_dvec3());
    let eye = cam.eye.as_dvec3() - glam::DVec3::new(0.0, 0.0, f64::from(s.z_offset));
    for cx in [0.0, f64::from(gw - 1) * f64::from(s.dx)] {
        for cy in [0.0, f64::from(gh - 1) * f64::from(s.dy)] {
            for cz in [zmin, zmax] {
                if (glam::DVec3::new(cx, cy, cz) - eye).dot(f) <= 0.0 {
                    return Err(Error::Unsupported(
                        "silhouette partitioning needs the whole terrain in front of the camera",
                    ));
                }
            }
        }
    }
    let grid = |k: i32, v: i32| {
        [
            m.origin[0] + k * m.ustep[0] + v * m.vstep[0],
            m.origin[1] + k * m.ustep[1] + v * m.vstep[1],
        ]
    };
    let screen = |k: i32, v: i32| {
        let g = grid(k, v);
        let p = glam::DVec3::new(
            f64::from(g[0]) * f64::from(s.dx),
            f64::from(g[1]) * f64::from(s.dy),
            f64::from(terrain.local_z(g[0] as u32, g[1] as u32)),
        );
        let q = p - eye;
        let vz = q.dot(f);
        (q.dot(r) / vz, q.dot(u) / vz)
    };
    let (w, h) = (cam.width, cam.height);
    let tan = f64::from(cam.tan_half_fov());
    let aspect = f64::from(w) / f64::from(h);
    let nu = m.row_len as i32;
    let n = w as usize * h as usize;
    let mut depth = vec![f32::INFINITY; n];
    let mut height = vec![f32::NAN; n];
    for i in 0..w {
        let x = (2.0 * (f64::from(i) + 0.5) / f64::from(w) - 1.0) * aspect * tan;
        // Silhouette map column: (y, u) per row, None where the row does not cover x.
        let col: Vec<Option<(f64, f64)>> = (0..m.rows as i32)
            .map(|v| {
                let (a, b) = (screen(0, v), screen(nu - 1, v));
                if x < a.0.min(b.0) || x > a.0.max(b.0) {
                    return None;
                }
                let inc = b.0 > a.0;
                let (mut lo, mut hi) = (0, nu - 1);
                while hi - lo > 1 {
                    let mid = (lo + hi) / 2;
                    if (screen(mid, v).0 <= x) == inc {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                let (s0, s1) = (screen(lo, v), screen(hi, v));
                let t = if s1.0 != s0.0 {
                    ((x - s0.0) / (s1.0 - s0.0)).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                Some((
                    s0.1 + t * (s1.1 - s0.1),
                    f64::from(lo) + t * f64::from(hi - lo),
                ))
            })
            .collect();
        for j in 0..h {
            let y = (1.0 - 2.0 * (f64::from(j) + 0.5) / f64::from(h)) * tan;
            let Some((v, s1)) = col
                .iter()
                .enumerate()
                .find_map(|(v, c)| c.filter(|c| c.0 >= y).map(|c| (v, c)))
            else {
                continue;
            };
            let (mut vh, mut uh) = (v as f64, s1.1);
            if let Some(Some(s0)) = v.checked_sub(1).and_then(|p| col.get(p)) {
                if s1.0 != s0.0 {
                    let t = ((y - s0.0) / (s1.0 - s0.0)).clamp(0.0, 1.0);
                    vh = (v - 1) as f64 + t;
                    uh = s0.1 + t * (s1.1 - s0.1);
                }
            }
            let dir = (f + x * r + y * u).normalize();
            let gx =
                f64::from(m.origin[0]) + vh * f64::from(m.vstep[0]) + uh * f64::from(m.ustep[0]);
            let gy =
                f64::from(m.origin[1]) + vh * f64::from(m.vstep[1]) + uh * f64::from(m.ustep[1]);
            let t = if m.vstep[0] != 0 {
                (gx * f64::from(s.dx) - eye.x) / dir.x
            } else {
                (gy * f64::from(s.dy) - eye.y) / dir.y
            };
            let k = (j * w + i) as usize;
            depth[k] = t.max(0.0) as f32;
            height[k] = (eye.z + t * dir.z) as f32;
        }
    }
    Ok(CpuTrace { depth, height })
}
