//! Memory-mapped raw `f32` grids (out-of-core input, issue 6): the file is mapped read-only
//! with `memmap2` instead of being read, so a grid larger than the machine's memory can be
//! refined; the operating system pages samples in as the refinement touches them and may evict
//! them again (they are clean, file-backed pages).
//!
//! The samples are used in place (little-endian `f32`, row-major), so no copy is made; on a
//! big-endian host [`MappedGrid::open`] returns an error (use [`read_dem`](crate::read_dem)).
//! No huge pages are requested: transparent huge pages for file-backed mappings need kernel
//! support that ordinary file systems lack, so the mapping uses normal pages; the access
//! pattern is declared random (`madvise(MADV_RANDOM)`: no read-ahead beyond the touched page)
//! by [`MappedGrid::advise_random`].

use crate::IoError;
use memmap2::Mmap;
use relief_core::{Heightfield, Scale};
use std::fs::File;
use std::path::Path;

/// A read-only memory map of a raw little-endian `f32` grid (`width * height * 4` bytes).
///
/// ```
/// use relief_io::{write_raw_f32, MappedGrid};
/// let dir = tempfile::tempdir().unwrap();
/// let p = dir.path().join("g.f32");
/// write_raw_f32(&p, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]).unwrap();
/// let g = MappedGrid::open(&p, 3, 2).unwrap();
/// assert_eq!(g.samples(), &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
/// assert_eq!(g.heightfield().unwrap().local_z(2, 1), 6.0);
/// # use relief_core::Terrain;
/// ```
#[derive(Debug)]
pub struct MappedGrid {
    map: Mmap,
    width: u32,
    height: u32,
    /// Spacing and vertical scale applied by [`MappedGrid::heightfield`] (default
    /// [`Scale::default`]).
    pub scale: Scale,
}

impl MappedGrid {
    /// Maps `path` read-only as a `width x height` grid. Errors: the file cannot be opened or
    /// mapped ([`IoError::Io`]), its size is not `width * height * 4` bytes
    /// ([`IoError::SizeMismatch`]), a side is below 2 ([`IoError::InvalidOption`]), or the host
    /// is big-endian ([`IoError::Unsupported`]).
    ///
    /// The file must not be truncated or rewritten while mapped (another process doing so
    /// makes later accesses fault); relief's own writers replace files by renaming, which
    /// leaves an existing mapping intact.
    ///
    /// ```
    /// use relief_io::{write_raw_f32, IoError, MappedGrid};
    /// let dir = tempfile::tempdir().unwrap();
    /// let p = dir.path().join("g.f32");
    /// write_raw_f32(&p, &[0.0; 6]).unwrap();
    /// assert!(matches!(MappedGrid::open(&p, 4, 2), Err(IoError::SizeMismatch { .. })));
    /// assert!(matches!(MappedGrid::open(&dir.path().join("none"), 3, 2), Err(IoError::Io { .. })));
    /// ```
    pub fn open(path: &Path, width: u32, height: u32) -> Result<MappedGrid, IoError> {
        if cfg!(target_endian = "big") {
            return Err(IoError::Unsupported(
                "memory-mapped raw-f32 needs a little-endian host".into(),
            ));
        }
        if width < 2 || height < 2 {
            return Err(IoError::InvalidOption(format!(
                "a grid needs at least 2x2 samples, got {width}x{height}"
            )));
        }
        let io = |source| IoError::Io {
            path: path.to_path_buf(),
            source,
        };
        let file = File::open(path).map_err(io)?;
        let expected = u64::from(width) * u64::from(height) * 4;
        let actual = file.metadata().map_err(io)?.len();
        if actual != expected {
            return Err(IoError::SizeMismatch {
                expected,
                actual,
                what: "bytes",
            });
        }
        // SAFETY: the mapping is read-only and private to this value; the documented contract is
        // that the file is not truncated or modified in place while mapped (the same contract
        // every memory-mapped reader has: the OS cannot prevent another process from doing so).
        let map = unsafe { Mmap::map(&file) }.map_err(io)?;
        if map.len() as u64 != expected {
            return Err(IoError::SizeMismatch {
                expected,
                actual: map.len() as u64,
                what: "bytes",
            });
        }
        Ok(MappedGrid {
            map,
            width,
            height,
            scale: Scale::default(),
        })
    }

    /// Columns.
    ///
    /// ```
    /// # use relief_io::{write_raw_f32, MappedGrid};
    /// # let dir = tempfile::tempdir().unwrap();
    /// # let p = dir.path().join("g.f32");
    /// # write_raw_f32(&p, &[0.0; 6]).unwrap();
    /// assert_eq!(MappedGrid::open(&p, 3, 2).unwrap().width(), 3);
    /// ```
    #[must_use]
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Rows.
    ///
    /// ```
    /// # use relief_io::{write_raw_f32, MappedGrid};
    /// # let dir = tempfile::tempdir().unwrap();
    /// # let p = dir.path().join("g.f32");
    /// # write_raw_f32(&p, &[0.0; 6]).unwrap();
    /// assert_eq!(MappedGrid::open(&p, 3, 2).unwrap().height(), 2);
    /// ```
    #[must_use]
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The mapped samples, row-major, in place (no copy). A mapping is page-aligned, so the
    /// cast to `f32` never fails; an empty slice would mean a mapping that changed size.
    ///
    /// ```
    /// # use relief_io::{write_raw_f32, MappedGrid};
    /// # let dir = tempfile::tempdir().unwrap();
    /// # let p = dir.path().join("g.f32");
    /// # write_raw_f32(&p, &[0.5; 6]).unwrap();
    /// assert_eq!(MappedGrid::open(&p, 3, 2).unwrap().samples().len(), 6);
    /// ```
    #[must_use]
    pub fn samples(&self) -> &[f32] {
        bytemuck::try_cast_slice(&self.map[..]).unwrap_or(&[])
    }

    /// The grid as a [`Heightfield`] with [`MappedGrid::scale`]. Validation reads every sample
    /// once (sequentially): a NaN, infinite or out-of-range height is an error naming it
    /// (raw-f32 voids cannot be filled without copying; use [`read_dem`](crate::read_dem) with
    /// a [`Fill`](crate::Fill) policy for those).
    ///
    /// ```
    /// use relief_io::{write_raw_f32, MappedGrid};
    /// let dir = tempfile::tempdir().unwrap();
    /// let p = dir.path().join("g.f32");
    /// write_raw_f32(&p, &[0.0, f32::NAN, 0.0, 0.0]).unwrap();
    /// assert!(MappedGrid::open(&p, 2, 2).unwrap().heightfield().is_err());
    /// ```
    pub fn heightfield(&self) -> Result<Heightfield<'_, f32>, IoError> {
        Ok(Heightfield::with_scale(
            self.samples(),
            self.width,
            self.height,
            self.scale,
        )?)
    }

    /// Declares random access (`madvise(MADV_RANDOM)` on Unix: no read-ahead), the pattern of
    /// view-dependent refinement; a no-op elsewhere. Failure to advise is not an error.
    ///
    /// ```
    /// # use relief_io::{write_raw_f32, MappedGrid};
    /// # let dir = tempfile::tempdir().unwrap();
    /// # let p = dir.path().join("g.f32");
    /// # write_raw_f32(&p, &[0.5; 6]).unwrap();
    /// MappedGrid::open(&p, 3, 2).unwrap().advise_random();
    /// ```
    pub fn advise_random(&self) {
        #[cfg(unix)]
        {
            let _ = self.map.advise(memmap2::Advice::Random);
        }
    }
}

/// A zeroed, page-aligned anonymous memory buffer of `len` values of a `Pod` type, with
/// transparent huge pages requested (`madvise(MADV_HUGEPAGE)` on Linux; elsewhere, or when the
/// kernel refuses, normal pages). For large per-vertex arrays (refinement hierarchies and
/// records of 4097^2 and larger grids): 2 MiB pages cut TLB misses of the scattered accesses
/// of view-dependent refinement. Linux grants them only where
/// `/sys/kernel/mm/transparent_hugepage/enabled` is `always` or `madvise`.
///
/// ```
/// let mut b = relief_io::HugeBuffer::<u32>::zeroed(1000).unwrap();
/// assert_eq!(b.as_slice().len(), 1000);
/// b.as_mut_slice()[999] = 7;
/// assert_eq!(b.as_slice()[999], 7);
/// ```
#[derive(Debug)]
pub struct HugeBuffer<T: bytemuck::Pod> {
    map: memmap2::MmapMut,
    len: usize,
    _t: std::marker::PhantomData<T>,
}

impl<T: bytemuck::Pod> HugeBuffer<T> {
    /// Maps `len` zeroed values (at least one byte is mapped). Errors: the size overflows or
    /// the mapping fails ([`IoError::Io`] with an empty path).
    ///
    /// ```
    /// assert!(relief_io::HugeBuffer::<u64>::zeroed(usize::MAX).is_err());
    /// ```
    pub fn zeroed(len: usize) -> Result<HugeBuffer<T>, IoError> {
        let io = |source| IoError::Io {
            path: std::path::PathBuf::new(),
            source,
        };
        let bytes = len
            .checked_mul(std::mem::size_of::<T>())
            .filter(|&b| b <= isize::MAX as usize)
            .ok_or_else(|| io(std::io::Error::other("buffer size overflows")))?;
        let map = memmap2::MmapMut::map_anon(bytes.max(1)).map_err(io)?;
        #[cfg(target_os = "linux")]
        {
            let _ = map.advise(memmap2::Advice::HugePage);
        }
        Ok(HugeBuffer {
            map,
            len,
            _t: std::marker::PhantomData,
        })
    }

    /// The values.
    ///
    /// ```
    /// assert_eq!(relief_io::HugeBuffer::<f32>::zeroed(3).unwrap().as_slice(), &[0.0; 3]);
    /// ```
    #[must_use]
    pub fn as_slice(&self) -> &[T] {
        let b = self
            .map
            .get(..self.len * std::mem::size_of::<T>())
            .unwrap_or(&[]);
        bytemuck::try_cast_slice(b).unwrap_or(&[])
    }

    /// The values, mutable.
    ///
    /// ```
    /// let mut b = relief_io::HugeBuffer::<u16>::zeroed(2).unwrap();
    /// b.as_mut_slice().copy_from_slice(&[1, 2]);
    /// assert_eq!(b.as_slice(), &[1, 2]);
    /// ```
    pub fn as_mut_slice(&mut self) -> &mut [T] {
        let n = self.len * std::mem::size_of::<T>();
        let b = self.map.get_mut(..n).unwrap_or(&mut []);
        bytemuck::try_cast_slice_mut(b).unwrap_or(&mut [])
    }
}
