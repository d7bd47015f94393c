//! Small helpers shared by the passes: buffer creation and readback.

use crate::Error;
use wgpu::util::DeviceExt;

/// [`Error::TooLarge`] when a buffer of `bytes` is more than `limit`.
fn check_limit(what: &'static str, bytes: u64, limit: u64) -> Result<(), Error> {
    if bytes > limit {
        return Err(Error::TooLarge { what, bytes, limit });
    }
    Ok(())
}

/// [`Error::TooLarge`] when a buffer of `bytes` is more than the device allows in one buffer
/// (`max_buffer_size`; wgpu's default handler would panic on the buffer).
pub(crate) fn check_buffer(
    device: &wgpu::Device,
    what: &'static str,
    bytes: u64,
) -> Result<(), Error> {
    check_limit(what, bytes, device.limits().max_buffer_size)
}

/// [`Error::TooLarge`] when a storage buffer of `bytes` is more than the device allows in one
/// buffer or one binding (wgpu's default handler would panic on the buffer or its bind group).
pub(crate) fn check_storage(
    device: &wgpu::Device,
    what: &'static str,
    bytes: u64,
) -> Result<(), Error> {
    let l = device.limits();
    check_limit(
        what,
        bytes,
        l.max_buffer_size.min(l.max_storage_buffer_binding_size),
    )
}

/// A storage buffer initialised with `contents`, usable as a copy source and destination
/// ([`check_storage`] first).
pub(crate) fn storage_init(
    device: &wgpu::Device,
    label: &'static str,
    contents: &[u8],
) -> Result<wgpu::Buffer, Error> {
    check_storage(device, label, contents.len() as u64)?;
    Ok(
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
        }),
    )
}

/// An uninitialised storage buffer of `size` bytes (at least 4; [`check_storage`] first).
pub(crate) fn storage(
    device: &wgpu::Device,
    label: &'static str,
    size: u64,
) -> Result<wgpu::Buffer, Error> {
    let size = size.max(4).next_multiple_of(4);
    check_storage(device, label, size)?;
    Ok(device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    }))
}

/// A uniform buffer of `size` bytes, written with `Queue::write_buffer`.
pub(crate) fn uniform(device: &wgpu::Device, label: &str, size: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// A bind group layout entry for a storage buffer.
pub(crate) fn storage_entry(
    binding: u32,
    read_only: bool,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A bind group layout entry for a uniform buffer.
pub(crate) fn uniform_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// Bind group entries `0..n` for whole buffers, in order.
pub(crate) fn bind_buffers<'a>(buffers: &[&'a wgpu::Buffer]) -> Vec<wgpu::BindGroupEntry<'a>> {
    buffers
        .iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: b.as_entire_binding(),
        })
        .collect()
}

/// A compute pipeline for `entry` of `module` with override `constants`.
pub(crate) fn compute_pipeline(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    module: &wgpu::ShaderModule,
    entry: &str,
    constants: &[(&str, f64)],
) -> wgpu::ComputePipeline {
    let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(&pl),
        module,
        entry_point: Some(entry),
        compilation_options: wgpu::PipelineCompilationOptions {
            constants,
            ..Default::default()
        },
        cache: None,
    })
}

/// Workgroups of `size` needed to cover `n` invocations.
pub(crate) fn groups(n: u32, size: u32) -> u32 {
    n.div_ceil(size)
}

/// [`Error::Unsupported`] unless a dispatch of 8 x 8 workgroups over `w x h` threads fits the
/// device's `max_compute_workgroups_per_dimension` (65,535 on most: 524,280 threads a side;
/// wgpu's default handler would panic on the dispatch).
pub(crate) fn check_dispatch(device: &wgpu::Device, w: u32, h: u32) -> Result<(), Error> {
    let max = device.limits().max_compute_workgroups_per_dimension;
    if groups(w, 8) > max || groups(h, 8) > max {
        return Err(Error::Unsupported(
            "more compute workgroups along a side than the device's \
             max_compute_workgroups_per_dimension",
        ));
    }
    Ok(())
}

/// Copies the first `size` bytes of `buffer` (which needs `COPY_SRC`) to the CPU and waits for
/// them: the one place where this crate blocks on the GPU, meant for the end of a frame (tests,
/// the CLI, screenshots), never inside one.
///
/// ```no_run
/// # let gpu = relief_wgpu::headless()?;
/// use wgpu::util::DeviceExt;
/// let b = gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
///     label: None,
///     contents: &[1, 2, 3, 4],
///     usage: wgpu::BufferUsages::COPY_SRC,
/// });
/// assert_eq!(relief_wgpu::read_buffer(&gpu.device, &gpu.queue, &b, 4)?, vec![1, 2, 3, 4]);
/// # Ok::<(), relief_wgpu::Error>(())
/// ```
pub fn read_buffer(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    buffer: &wgpu::Buffer,
    size: u64,
) -> Result<Vec<u8>, Error> {
    let size = size.next_multiple_of(4);
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("relief readback"),
        size: size.max(4),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("relief readback"),
    });
    enc.copy_buffer_to_buffer(buffer, 0, &staging, 0, size);
    queue.submit([enc.finish()]);
    map_and_read(device, &staging, size)
}

/// Maps `staging` (already filled by submitted work) and copies `size` bytes out.
pub(crate) fn map_and_read(
    device: &wgpu::Device,
    staging: &wgpu::Buffer,
    size: u64,
) -> Result<Vec<u8>, Error> {
    let slice = staging.slice(..size);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| Error::Readback(e.to_string()))?;
    rx.recv()
        .map_err(|e| Error::Readback(e.to_string()))?
        .map_err(|e| Error::Readback(e.to_string()))?;
    let out = slice
        .get_mapped_range()
        .map_err(|e| Error::Readback(e.to_string()))?
        .to_vec();
    staging.unmap();
    Ok(out)
}

/// Reinterprets little-endian bytes as `f32`s.
pub(crate) fn f32s(bytes: &[u8]) -> Vec<f32> {
    bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}
