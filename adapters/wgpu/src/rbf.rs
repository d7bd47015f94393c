//! RBF cascade discretization (compute, `shaders/rbf_discretize.wgsl`): seed 002, Cornel,
//! Horvath and Waser, *Interactive Visualization of Large Heightfields with RBF Approximation*
//! (2022), section 4, last paragraph: the adaptive-grid truncated Gaussian RBF approximation
//! (eq. 1-2) evaluated at the centre of every visible texel of a cascade, on the GPU. The CPU
//! reference is [`relief_core::rbf::discretize`]; this pass writes the same values (the
//! blending weights are left to the CPU's [`relief_core::rbf::Cascade::blend_weight`]).

use crate::util::{self, bind_buffers, compute_pipeline, groups, storage_entry, uniform_entry};
use crate::Error;
use relief_core::rbf::{gaussian_weight, Cascade, InfluenceSets, Rbf};

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
}

impl RbfPass {
    /// Uploads `rbf`'s cells, the cell index of every sample and `sets` (the influence sets
    /// `rbf` was built with). [`Error::Unsupported`] when they exceed the device's storage
    /// buffer binding size.
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
        let limit = device.limits().max_storage_buffer_binding_size;
        if entries.len() as u64 * 4 > limit || index.len() as u64 * 4 > limit {
            return Err(Error::Unsupported(
                "influence sets larger than the device's storage buffer binding size",
            ));
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
                storage_entry(5, true, cs),
                storage_entry(6, false, cs),
            ],
        });
        let pipeline = compute_pipeline(device, "relief rbf", &layout, &module, "discretize", &[]);
        Ok(RbfPass {
            width: w,
            height: h,
            sigma: rbf.sigma(),
            cells: util::storage_init(device, "relief rbf cells", bytemuck::cast_slice(&cell_data)),
            index: util::storage_init(device, "relief rbf index", bytemuck::cast_slice(&index)),
            offsets: util::storage_init(
                device,
                "relief rbf offsets",
                bytemuck::cast_slice(&offsets),
            ),
            entries: util::storage_init(
                device,
                "relief rbf entries",
                bytemuck::cast_slice(&entries),
            ),
            layout,
            pipeline,
        })
    }

    /// Records the discretization of `cascade` (visible texels from `mask`, `resolution^2`
    /// bytes as [`Cascade::mask`] writes them) and returns the values buffer
    /// (`resolution^2` `f32`, row-major, `invisible` where the mask is 0; the CPU writes 0).
    /// [`Error::Unsupported`] for a short mask.
    pub fn encode(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        cascade: &Cascade,
        mask: &[u8],
        invisible: f32,
    ) -> Result<wgpu::Buffer, Error> {
        let res = cascade.resolution;
        let n = res as usize * res as usize;
        let Some(mask) = mask.get(..n) else {
            return Err(Error::Unsupported("mask shorter than resolution^2"));
        };
        let origin = [
            i32::try_from(cascade.origin[0])
                .map_err(|_| Error::Unsupported("cascade origin beyond i32"))?,
            i32::try_from(cascade.origin[1])
                .map_err(|_| Error::Unsupported("cascade origin beyond i32"))?,
        ];
        let mask_u32: Vec<u32> = mask.iter().map(|&m| u32::from(m != 0)).collect();
        let mask_buf =
            util::storage_init(device, "relief rbf mask", bytemuck::cast_slice(&mask_u32));
        let values = util::storage(device, "relief rbf values", n as u64 * 4);
        let params = util::uniform(device, "relief rbf params", 48);
        let remainder = 1.0 - gaussian_weight(0.0, 1.0);
        let mut p = [0u32; 12];
        p[..4].copy_from_slice(&[self.width, self.height, res, 0]);
        p[4] = origin[0] as u32;
        p[5] = origin[1] as u32;
        p[8] = cascade.spacing.to_bits();
        p[9] = self.sigma.to_bits();
        p[10] = remainder.to_bits();
        p[11] = invisible.to_bits();
        queue.write_buffer(&params, 0, bytemuck::cast_slice(&p));
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("relief rbf"),
            layout: &self.layout,
            entries: &bind_buffers(&[
                &params,
                &self.cells,
                &self.index,
                &self.offsets,
                &self.entries,
                &mask_buf,
                &values,
            ]),
        });
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("relief rbf discretize"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(groups(res, 8), groups(res, 8), 1);
        drop(pass);
        Ok(values)
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
