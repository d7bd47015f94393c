//! RBF cascade discretization (compute, `shaders/rbf_discretize.wgsl`): seed 002, Cornel,
//! Horvath and Waser, *Interactive Visualization of Large Heightfields with RBF Approximation*
//! (2022), section 4, last paragraph: the adaptive-grid truncated Gaussian RBF approximation
//! (eq. 1-2) evaluated at the centre of every visible texel of a cascade, on the GPU. The CPU
//! reference is [`relief_core::rbf::discretize`]; this pass writes the same values (the
//! blending weights are computed where they are used, in the cascade ray cast's blend shader,
//! [`crate::cascade`]).

use crate::util::{self, bind_buffers, compute_pipeline, groups, storage_entry, uniform_entry};
use crate::Error;
use relief_core::rbf::{gaussian_weight, Cascade, InfluenceSets, Rbf, MAX_POLYGON};

/// Bytes of a target's parameters (`RbfParams` in the shader).
const PARAM_BYTES: u64 = 64;

/// The adaptive grid, its index map and influence sets on the GPU, and the discretization
/// pipeline.
///
/// ```no_run
/// use relief_core::{Camera, Scale, rbf::*};
/// let gpu = relief_wgpu::headless()?;
/// let cells = [Cell::new(0, 0, 32, 5.0), Cell::new(32, 0, 32, 5.0),
///              Cell::new(0, 32, 32, 5.0), Cell::new(32, 32, 32, 5.0)];
/// let mut index = vec![0; 64 * 64];
/// let grid = AdaptiveGrid::new(64, 64, &cells, &mut index)?;
/// let opts = RbfOptions::default();
/// let mut o = vec![0; InfluenceSets::offsets_len(&grid)];
/// let mut e = vec![0; InfluenceSets::entries_len(&grid, &opts)?];
/// let sets = InfluenceSets::build(&grid, &opts, &mut o, &mut e)?;
/// let rbf = Rbf::new(grid, sets, &opts)?;
/// let cam = Camera::new(glam::Vec3::new(-10.0, 30.0, 20.0), glam::Vec3::new(30.0, 30.0, 0.0), 60.0, 64, 64)?;
/// let c = fit_cascades(&cam, rbf.grid(), &Scale::default(), (5.0, 5.0), &CascadeOptions::default().with_resolution(32), None)?;
/// let mut mask = vec![0u8; 1024];
/// c.cascades[0].mask(&mut mask)?;
/// let pass = relief_wgpu::rbf::RbfPass::new(&gpu.device, &rbf, &sets)?;
/// let values = pass.discretize(&gpu.device, &gpu.queue, &c.cascades[0], &mask)?;
/// assert!(values.iter().zip(&mask).all(|(&v, &m)| if m == 1 { v == 5.0 } else { v == 0.0 }));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug)]
pub struct RbfPass {
    width: u32,
    height: u32,
    sigma: f32,
    cells: wgpu::Buffer,
    index: wgpu::Buffer,
    offsets: wgpu::Buffer,
    entries: wgpu::Buffer,
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
    visible: wgpu::ComputePipeline,
}

impl RbfPass {
    /// Uploads `rbf`'s cells, the cell index of every sample and `sets` (the influence sets
    /// `rbf` was built with). [`Error::TooLarge`] when one of them exceeds the device's
    /// storage buffer binding size.
    pub fn new(
        device: &wgpu::Device,
        rbf: &Rbf<'_>,
        sets: &InfluenceSets<'_>,
    ) -> Result<RbfPass, Error> {
        let grid = rbf.grid();
        let cells = grid.cells();
        let (w, h) = (grid.width(), grid.height());
        let cell_data: Vec<[f32; 4]> = cells
            .iter()
            .map(|c| [c.x as f32, c.y as f32, c.size as f32, c.value])
            .collect();
        let mut index = Vec::with_capacity(w as usize * h as usize);
        for y in 0..h {
            for x in 0..w {
                index.push(grid.cell_at(x, y).unwrap_or(0) as u32);
            }
        }
        let mut offsets = Vec::with_capacity(cells.len() + 1);
        let mut entries = Vec::new();
        offsets.push(0u32);
        for j in 0..cells.len() {
            entries.extend_from_slice(sets.of(j));
            offsets.push(entries.len() as u32);
        }
        let module = device
            .create_shader_module(wgpu::include_wgsl!("../../../shaders/rbf_discretize.wgsl"));
        let cs = wgpu::ShaderStages::COMPUTE;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("relief rbf"),
            entries: &[
                uniform_entry(0, cs),
                storage_entry(1, true, cs),
                storage_entry(2, true, cs),
                storage_entry(3, true, cs),
                storage_entry(4, true, cs),
                storage_entry(5, false, cs),
                storage_entry(6, false, cs),
                storage_entry(7, true, cs),
            ],
        });
        let pipeline = compute_pipeline(device, "relief rbf", &layout, &module, "discretize", &[]);
        let visible = compute_pipeline(
            device,
            "relief rbf visible",
            &layout,
            &module,
            "visible",
            &[],
        );
        Ok(RbfPass {
            width: w,
            height: h,
            sigma: rbf.sigma(),
            cells: util::storage_init(
                device,
                "relief rbf cells",
                bytemuck::cast_slice(&cell_data),
            )?,
            index: util::storage_init(device, "relief rbf index", bytemuck::cast_slice(&index))?,
            offsets: util::storage_init(
                device,
                "relief rbf offsets",
                bytemuck::cast_slice(&offsets),
            )?,
            entries: util::storage_init(
                device,
                "relief rbf entries",
                bytemuck::cast_slice(&entries),
            )?,
            layout,
            pipeline,
            visible,
        })
    }

    /// Buffers for discretizing cascades of `resolution^2` texels again and again (one per
    /// cascade of a frame): the mask, the values, the parameters and the polygon's edges, bound
    /// once.
    /// [`Error::Unsupported`] for a resolution of 0 or beyond the device's storage binding size.
    ///
    /// ```no_run
    /// # fn demo(gpu: &relief_wgpu::Gpu, pass: &relief_wgpu::rbf::RbfPass) -> Result<(), relief_wgpu::Error> {
    /// let target = pass.target(&gpu.device, 256)?;
    /// assert_eq!(target.resolution(), 256);
    /// # Ok(()) }
    /// ```
    pub fn target(&self, device: &wgpu::Device, resolution: u32) -> Result<RbfTarget, Error> {
        let n = u64::from(resolution) * u64::from(resolution);
        if n == 0 || n * 4 > device.limits().max_storage_buffer_binding_size {
            return Err(Error::Unsupported(
                "cascade resolution is 0 or beyond the device's storage buffer binding size",
            ));
        }
        util::check_dispatch(device, resolution, resolution)?;
        let mask = util::storage(device, "relief rbf mask", n * 4)?;
        let values = util::storage(device, "relief rbf values", n * 4)?;
        let params = util::uniform(device, "relief rbf params", PARAM_BYTES);
        let edges = util::storage(device, "relief rbf edges", MAX_POLYGON as u64 * 32)?;
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("relief rbf"),
            layout: &self.layout,
            entries: &bind_buffers(&[
                &params,
                &self.cells,
                &self.index,
                &self.offsets,
                &self.entries,
                &mask,
                &values,
                &edges,
            ]),
        });
        Ok(RbfTarget {
            resolution,
            mask,
            values,
            params,
            edges,
            group,
        })
    }

    /// Writes `cascade`'s parameters and visible-texel `mask` (`resolution^2` bytes as
    /// [`Cascade::mask`] writes them) into `target` (queue writes) and records the
    /// discretization: `target.values()` gets the approximation at every visible texel centre
    /// and `invisible` elsewhere (the CPU writes 0). [`Error::Unsupported`] for a short mask, a
    /// cascade of another resolution than the target's or an origin beyond `i32`.
    ///
    /// ```no_run
    /// # fn demo(gpu: &relief_wgpu::Gpu, pass: &relief_wgpu::rbf::RbfPass, c: &relief_core::rbf::Cascade) -> Result<(), Box<dyn std::error::Error>> {
    /// let target = pass.target(&gpu.device, c.resolution)?;
    /// let mut mask = vec![0u8; (c.resolution * c.resolution) as usize];
    /// c.mask(&mut mask)?;
    /// let mut enc = gpu.device.create_command_encoder(&Default::default());
    /// pass.encode_into(&gpu.queue, &mut enc, &target, c, &mask, 0.0)?;
    /// gpu.queue.submit([enc.finish()]);
    /// # Ok(()) }
    /// ```
    pub fn encode_into(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        target: &RbfTarget,
        cascade: &Cascade,
        mask: &[u8],
        invisible: f32,
    ) -> Result<(), Error> {
        let n = cascade.resolution as usize * cascade.resolution as usize;
        let Some(mask) = mask.get(..n) else {
            return Err(Error::Unsupported("mask shorter than resolution^2"));
        };
        self.write_params(queue, target, cascade, invisible, 0)?;
        let mask_u32: Vec<u32> = mask.iter().map(|&m| u32::from(m != 0)).collect();
        queue.write_buffer(&target.mask, 0, bytemuck::cast_slice(&mask_u32));
        dispatch(encoder, target, &[&self.pipeline]);
        Ok(())
    }

    /// [`Self::encode_into`] with the visible-texel mask computed on the GPU, in a dispatch
    /// before the discretization, from the cascade's polygon ([`Cascade::mask_edges`], at most
    /// [`MAX_POLYGON`] edges): the test of [`Cascade::mask`], so a frame uploads a few hundred
    /// bytes instead of computing and uploading `resolution^2` mask entries on the CPU.
    /// `target.mask()` holds the mask afterwards. A texel whose centre lies within rounding
    /// error of the margin may come out differently from the CPU's mask (the GPU's division
    /// and multiply-adds round differently); the tests bound that distance.
    ///
    /// ```no_run
    /// # fn demo(gpu: &relief_wgpu::Gpu, pass: &relief_wgpu::rbf::RbfPass, c: &relief_core::rbf::Cascade) -> Result<(), Box<dyn std::error::Error>> {
    /// let target = pass.target(&gpu.device, c.resolution)?;
    /// let mut enc = gpu.device.create_command_encoder(&Default::default());
    /// pass.encode_into_gpu_mask(&gpu.queue, &mut enc, &target, c, 0.0)?;
    /// gpu.queue.submit([enc.finish()]);
    /// # Ok(()) }
    /// ```
    pub fn encode_into_gpu_mask(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        target: &RbfTarget,
        cascade: &Cascade,
        invisible: f32,
    ) -> Result<(), Error> {
        let mut edges = [[0.0f32; 4]; 2 * MAX_POLYGON];
        let mut n = 0u32;
        for (pair, (a, e, len)) in edges.chunks_exact_mut(2).zip(cascade.mask_edges()) {
            pair[0] = [a.x, a.y, e.x, e.y];
            pair[1] = [len, 0.0, 0.0, 0.0];
            n += 1;
        }
        self.write_params(queue, target, cascade, invisible, n)?;
        let used = &edges[..2 * n as usize];
        if !used.is_empty() {
            queue.write_buffer(&target.edges, 0, bytemuck::cast_slice(used));
        }
        dispatch(encoder, target, &[&self.visible, &self.pipeline]);
        Ok(())
    }

    /// Writes the target's parameters (`edges`: the polygon's edge count for the `visible`
    /// entry point).
    fn write_params(
        &self,
        queue: &wgpu::Queue,
        target: &RbfTarget,
        cascade: &Cascade,
        invisible: f32,
        edges: u32,
    ) -> Result<(), Error> {
        let res = cascade.resolution;
        if res != target.resolution {
            return Err(Error::Unsupported(
                "cascade resolution differs from the target's",
            ));
        }
        let origin = [
            i32::try_from(cascade.origin[0])
                .map_err(|_| Error::Unsupported("cascade origin beyond i32"))?,
            i32::try_from(cascade.origin[1])
                .map_err(|_| Error::Unsupported("cascade origin beyond i32"))?,
        ];
        let remainder = 1.0 - gaussian_weight(0.0, 1.0);
        let world = cascade.world_spacing();
        let mut p = [0u32; PARAM_BYTES as usize / 4];
        p[..4].copy_from_slice(&[self.width, self.height, res, edges]);
        p[4] = origin[0] as u32;
        p[5] = origin[1] as u32;
        p[8] = cascade.spacing.to_bits();
        p[9] = self.sigma.to_bits();
        p[10] = remainder.to_bits();
        p[11] = invisible.to_bits();
        p[12] = world.x.to_bits();
        p[13] = world.y.to_bits();
        p[14] = cascade.mask_margin().to_bits();
        queue.write_buffer(&target.params, 0, bytemuck::cast_slice(&p));
        Ok(())
    }

    /// Records the discretization of `cascade` into fresh buffers ([`RbfPass::target`] then
    /// [`RbfPass::encode_into`]) and returns the values buffer (`resolution^2` `f32`,
    /// row-major, `invisible` where the mask is 0; the CPU writes 0). [`Error::Unsupported`]
    /// for a short mask.
    pub fn encode(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        cascade: &Cascade,
        mask: &[u8],
        invisible: f32,
    ) -> Result<wgpu::Buffer, Error> {
        let target = self.target(device, cascade.resolution)?;
        self.encode_into(queue, encoder, &target, cascade, mask, invisible)?;
        Ok(target.values)
    }

    /// Discretizes `cascade` and reads the values back (one submission; waits for the GPU).
    pub fn discretize(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        cascade: &Cascade,
        mask: &[u8],
    ) -> Result<Vec<f32>, Error> {
        let mut enc = device.create_command_encoder(&Default::default());
        let values = self.encode(device, queue, &mut enc, cascade, mask, 0.0)?;
        queue.submit([enc.finish()]);
        let n = cascade.resolution as u64 * cascade.resolution as u64 * 4;
        Ok(util::f32s(&util::read_buffer(device, queue, &values, n)?))
    }
}

/// Records `pipelines` over the target's texels, in order, in one compute pass (each
/// dispatch sees the previous one's writes: wgpu orders storage writes between dispatches).
fn dispatch(
    encoder: &mut wgpu::CommandEncoder,
    target: &RbfTarget,
    pipelines: &[&wgpu::ComputePipeline],
) {
    let res = target.resolution;
    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some("relief rbf discretize"),
        timestamp_writes: None,
    });
    pass.set_bind_group(0, &target.group, &[]);
    for p in pipelines {
        pass.set_pipeline(p);
        pass.dispatch_workgroups(groups(res, 8), groups(res, 8), 1);
    }
}

/// Buffers one cascade is discretized into, reused frame after frame ([`RbfPass::target`]).
#[derive(Debug)]
pub struct RbfTarget {
    resolution: u32,
    mask: wgpu::Buffer,
    values: wgpu::Buffer,
    params: wgpu::Buffer,
    edges: wgpu::Buffer,
    group: wgpu::BindGroup,
}

impl RbfTarget {
    /// Texels per side.
    ///
    /// ```no_run
    /// # fn demo(t: &relief_wgpu::rbf::RbfTarget) { let _ = t.resolution(); }
    /// ```
    #[must_use]
    pub fn resolution(&self) -> u32 {
        self.resolution
    }

    /// The discretized values (`resolution^2` `f32`, row-major).
    ///
    /// ```no_run
    /// # fn demo(t: &relief_wgpu::rbf::RbfTarget) { let _ = t.values().size(); }
    /// ```
    #[must_use]
    pub fn values(&self) -> &wgpu::Buffer {
        &self.values
    }

    /// The visible-texel mask as the GPU sees it (`resolution^2` `u32`, 1 visible, 0 not).
    ///
    /// ```no_run
    /// # fn demo(t: &relief_wgpu::rbf::RbfTarget) { let _ = t.mask().size(); }
    /// ```
    #[must_use]
    pub fn mask(&self) -> &wgpu::Buffer {
        &self.mask
    }
}
