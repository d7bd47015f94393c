//! Preprocessed refinement records in a file, memory-mapped for out-of-core refinement (SOAR,
//! Lindstrom & Pascucci 2001: preprocess once, then let the operating system page in only the
//! part of the hierarchy that the view refines).
//!
//! [`write_records`] stores the 8-byte [`VertexRecord`]s of a hierarchy made by
//! [`pack_records`](relief_core::refine::pack_records) with what is needed to use them again;
//! [`MappedRecords`] maps such a file read-only and wraps it as a [`Hierarchy`] in O(1), so a
//! 16385^2 grid (2 GiB of records) is ready to refine at once instead of after minutes of
//! preprocessing.
//!
//! File layout (all little-endian), a 64-byte header then the records:
//!
//! | bytes | field |
//! |---|---|
//! | 0..8 | magic `RELIEFR1` |
//! | 8..12 | `u32` layout: 0 linear, 1 interleaved |
//! | 12..16, 16..20 | `u32` width, height |
//! | 20..24, 24..28, 28..32, 32..36 | `f32` dx, dy, z_scale, z_offset |
//! | 36..40, 40..44 | `f32` smallest and largest local height |
//! | 44..48 | `u32` record count ([`records_len`]) |
//! | 48..64 | zero |
//! | 64.. | records: `f32` height, `u16` error, `u16` radius (bfloat16 codes) |

use crate::write::write_atomic;
use crate::IoError;
use memmap2::Mmap;
use relief_core::refine::{
    check_records, records_hierarchy, records_len, Hierarchy, RecordLayout, VertexRecord,
};
use relief_core::Scale;
use std::fs::File;
use std::path::Path;

const MAGIC: &[u8; 8] = b"RELIEFR1";
const HEADER: usize = 64;

/// Writes the records of `hierarchy` (made by
/// [`pack_records`](relief_core::refine::pack_records)) to `path` in the format of the
/// [module documentation](self), atomically (temporary file, then rename). A hierarchy without
/// records is [`IoError::InvalidOption`].
///
/// ```
/// use relief_core::refine::{pack_records, preprocess, records_len, RecordLayout, VertexRecord};
/// use relief_core::Heightfield;
/// let hf = Heightfield::new(&[0.0f32, 1.0, 0.0, 2.0, 5.0, 1.0, 0.0, 1.0, 0.0], 3, 3).unwrap();
/// let (mut e, mut r) = ([0.0; 9], [0.0; 9]);
/// let h = preprocess(&hf, &mut e, &mut r).unwrap();
/// let dir = tempfile::tempdir().unwrap();
/// assert!(relief_io::write_records(&dir.path().join("no.rec"), &h).is_err());
/// let mut rec = vec![VertexRecord::default(); records_len(3, 3, RecordLayout::Interleaved)];
/// let packed = pack_records(&h, &hf, RecordLayout::Interleaved, &mut rec).unwrap();
/// relief_io::write_records(&dir.path().join("g.rec"), &packed).unwrap();
/// ```
pub fn write_records(path: &Path, hierarchy: &Hierarchy<'_>) -> Result<(), IoError> {
    let Some((recs, layout)) = hierarchy.records() else {
        return Err(IoError::InvalidOption(
            "only a hierarchy of packed records can be written (pack_records)".into(),
        ));
    };
    let g = hierarchy.grid();
    let n = records_len(g.width(), g.height(), layout);
    let recs = recs.get(..n).unwrap_or(recs);
    let count = u32::try_from(n)
        .map_err(|_| IoError::InvalidOption(format!("{n} records do not fit the header")))?;
    let s = hierarchy.scale();
    let (lo, hi) = hierarchy.z_range();
    let mut head = [0u8; HEADER];
    head[..8].copy_from_slice(MAGIC);
    let layout_code: u32 = match layout {
        RecordLayout::Linear => 0,
        RecordLayout::Interleaved => 1,
    };
    let words = [
        layout_code.to_le_bytes(),
        g.width().to_le_bytes(),
        g.height().to_le_bytes(),
        s.dx.to_le_bytes(),
        s.dy.to_le_bytes(),
        s.z_scale.to_le_bytes(),
        s.z_offset.to_le_bytes(),
        lo.to_le_bytes(),
        hi.to_le_bytes(),
        count.to_le_bytes(),
    ];
    for (k, w) in words.iter().enumerate() {
        head[8 + 4 * k..12 + 4 * k].copy_from_slice(w);
    }
    write_atomic(path, |w| {
        w.write_all(&head)?;
        if cfg!(target_endian = "little") {
            w.write_all(bytemuck::cast_slice(recs))
        } else {
            for r in recs {
                w.write_all(&r.z.to_le_bytes())?;
                w.write_all(&r.error.to_le_bytes())?;
                w.write_all(&r.radius.to_le_bytes())?;
            }
            Ok(())
        }
    })
}

/// A read-only memory map of a records file written by [`write_records`].
///
/// ```
/// use relief_core::refine::{pack_records, preprocess, records_len, scratch_len};
/// use relief_core::refine::{Criterion, RecordLayout, Refiner, VertexRecord};
/// use relief_core::Heightfield;
/// let s: Vec<f32> = (0..81).map(|i| ((i * 37) % 11) as f32).collect();
/// let hf = Heightfield::new(&s, 9, 9).unwrap();
/// let (mut e, mut r) = (vec![0.0; 81], vec![0.0; 81]);
/// let h = preprocess(&hf, &mut e, &mut r).unwrap();
/// let mut rec = vec![VertexRecord::default(); records_len(9, 9, RecordLayout::Interleaved)];
/// let packed = pack_records(&h, &hf, RecordLayout::Interleaved, &mut rec).unwrap();
/// let dir = tempfile::tempdir().unwrap();
/// let p = dir.path().join("g.rec");
/// relief_io::write_records(&p, &packed).unwrap();
///
/// let m = relief_io::MappedRecords::open(&p).unwrap();
/// m.check().unwrap(); // once, for a file from elsewhere
/// let mapped = m.hierarchy().unwrap();
/// let rf = Refiner::new(&mapped, &hf, Criterion::MaxError(2.0)).unwrap();
/// let n = rf.count(&mut vec![0; scratch_len(9, 9)]).unwrap().triangles;
/// let rp = Refiner::new(&packed, &hf, Criterion::MaxError(2.0)).unwrap();
/// assert_eq!(n, rp.count(&mut vec![0; scratch_len(9, 9)]).unwrap().triangles);
/// ```
#[derive(Debug)]
pub struct MappedRecords {
    map: Mmap,
    layout: RecordLayout,
    width: u32,
    height: u32,
    scale: Scale,
    z_range: (f32, f32),
}

impl MappedRecords {
    /// Maps `path` and reads its header. Errors: the file cannot be opened or mapped
    /// ([`IoError::Io`]), it is not a records file or its header is inconsistent
    /// ([`IoError::Decode`]), its size does not match the header ([`IoError::SizeMismatch`]),
    /// or the host is big-endian ([`IoError::Unsupported`]). The records themselves are not
    /// read: see [`MappedRecords::check`].
    ///
    /// The file must not be truncated or modified in place while mapped ([`write_records`]
    /// replaces files by renaming, which leaves an existing mapping intact).
    ///
    /// ```
    /// let dir = tempfile::tempdir().unwrap();
    /// let p = dir.path().join("x.rec");
    /// std::fs::write(&p, b"not a records file").unwrap();
    /// assert!(relief_io::MappedRecords::open(&p).is_err());
    /// ```
    pub fn open(path: &Path) -> Result<MappedRecords, IoError> {
        if cfg!(target_endian = "big") {
            return Err(IoError::Unsupported(
                "memory-mapped records need a little-endian host".into(),
            ));
        }
        let io = |source| IoError::Io {
            path: path.to_path_buf(),
            source,
        };
        let bad = |m: &str| IoError::Decode {
            format: "relief records",
            message: m.to_string(),
        };
        let file = File::open(path).map_err(io)?;
        // SAFETY: read-only private mapping; the documented contract is that the file is not
        // truncated or modified in place while mapped (as for every memory-mapped reader).
        let map = unsafe { Mmap::map(&file) }.map_err(io)?;
        let head = map
            .get(..HEADER)
            .ok_or_else(|| bad("shorter than the header"))?;
        if &head[..8] != MAGIC {
            return Err(bad("no RELIEFR1 magic"));
        }
        let word = |k: usize| {
            let mut b = [0u8; 4];
            b.copy_from_slice(&head[8 + 4 * k..12 + 4 * k]);
            b
        };
        let u = |k| u32::from_le_bytes(word(k));
        let f = |k| f32::from_le_bytes(word(k));
        let layout = match u(0) {
            0 => RecordLayout::Linear,
            1 => RecordLayout::Interleaved,
            _ => return Err(bad("unknown layout")),
        };
        let (width, height) = (u(1), u(2));
        let scale = Scale {
            dx: f(3),
            dy: f(4),
            z_scale: f(5),
            z_offset: f(6),
        };
        let z_range = (f(7), f(8));
        let n = records_len(width, height, layout);
        if n == 0 || u64::from(u(9)) != n as u64 {
            return Err(bad("record count does not match the grid size"));
        }
        let expected = (HEADER + n * std::mem::size_of::<VertexRecord>()) as u64;
        if map.len() as u64 != expected {
            return Err(IoError::SizeMismatch {
                expected,
                actual: map.len() as u64,
                what: "bytes",
            });
        }
        let m = MappedRecords {
            map,
            layout,
            width,
            height,
            scale,
            z_range,
        };
        m.hierarchy()?; // the header's parameters are valid
        Ok(m)
    }

    /// The mapped records.
    ///
    /// ```no_run
    /// let m = relief_io::MappedRecords::open("g.rec".as_ref()).unwrap();
    /// println!("{} records", m.records().len());
    /// ```
    #[must_use]
    pub fn records(&self) -> &[VertexRecord] {
        bytemuck::try_cast_slice(self.map.get(HEADER..).unwrap_or(&[])).unwrap_or(&[])
    }

    /// The records as a [`Hierarchy`] (O(1): nothing is read; pages load as refinement
    /// touches them). Use it with the grid's terrain (for example a
    /// [`MappedGrid`](crate::MappedGrid) of the same size) in a
    /// [`Refiner`](relief_core::refine::Refiner).
    ///
    /// ```no_run
    /// let m = relief_io::MappedRecords::open("g.rec".as_ref()).unwrap();
    /// assert_eq!(m.hierarchy().unwrap().bytes_per_vertex(), 8);
    /// ```
    pub fn hierarchy(&self) -> Result<Hierarchy<'_>, IoError> {
        Ok(records_hierarchy(
            self.records(),
            self.layout,
            self.width,
            self.height,
            self.scale,
            self.z_range,
        )?)
    }

    /// Checks every record once ([`check_records`]: finite heights in range, errors and radii
    /// valid and nested). Worth it once for a file that did not come from this machine's own
    /// [`write_records`]; it reads the whole file.
    ///
    /// ```no_run
    /// relief_io::MappedRecords::open("g.rec".as_ref()).unwrap().check().unwrap();
    /// ```
    pub fn check(&self) -> Result<(), IoError> {
        Ok(check_records(&self.hierarchy()?)?)
    }

    /// Declares random access (`madvise(MADV_RANDOM)`: no read-ahead), the pattern of
    /// view-dependent refinement; a no-op elsewhere.
    ///
    /// ```no_run
    /// relief_io::MappedRecords::open("g.rec".as_ref()).unwrap().advise_random();
    /// ```
    pub fn advise_random(&self) {
        #[cfg(unix)]
        {
            let _ = self.map.advise(memmap2::Advice::Random);
        }
    }
}
