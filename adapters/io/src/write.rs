//! Writers. Every one goes through [`write_atomic`].

use crate::IoError;
use std::io::{BufWriter, Write};
use std::path::Path;

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> IoError + '_ {
    move |source| IoError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Writes a file atomically: `body` writes into a temporary file in the same folder, which is
/// flushed, synced and renamed over `path` only if `body` succeeds. On any failure the temporary
/// file is removed and an existing file at `path` is left as it was.
///
/// ```
/// let dir = tempfile::tempdir().unwrap();
/// let p = dir.path().join("a.txt");
/// relief_io::write_atomic(&p, |w| w.write_all(b"ok")).unwrap();
/// let failed = relief_io::write_atomic(&p, |w| {
///     w.write_all(b"half")?;
///     Err(std::io::Error::other("interrupted"))
/// });
/// assert!(failed.is_err());
/// assert_eq!(std::fs::read(&p).unwrap(), b"ok");
/// # use std::io::Write;
/// ```
pub fn write_atomic(
    path: &Path,
    body: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), IoError> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let tmp = tempfile::Builder::new()
        .prefix(".relief-")
        .suffix(".tmp")
        .tempfile_in(dir)
        .map_err(io_err(path))?;
    {
        let mut w = BufWriter::new(tmp.as_file());
        body(&mut w).map_err(io_err(path))?;
        w.flush().map_err(io_err(path))?;
    }
    // Temporary files are created private (0600); give the result the permissions of the file it
    // replaces, or the usual 0644 for a new one.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let perms = std::fs::metadata(path)
            .map(|m| m.permissions())
            .unwrap_or_else(|_| std::fs::Permissions::from_mode(0o644));
        tmp.as_file().set_permissions(perms).map_err(io_err(path))?;
    }
    tmp.as_file().sync_all().map_err(io_err(path))?;
    tmp.persist(path).map_err(|e| IoError::Io {
        path: path.to_path_buf(),
        source: e.error,
    })?;
    Ok(())
}

/// Writes little-endian f32 values, row-major (the depth-image and raw-DEM format).
///
/// ```
/// let dir = tempfile::tempdir().unwrap();
/// let p = dir.path().join("d.f32");
/// relief_io::write_raw_f32(&p, &[1.0, f32::INFINITY]).unwrap();
/// assert_eq!(std::fs::read(&p).unwrap().len(), 8);
/// ```
pub fn write_raw_f32(path: &Path, values: &[f32]) -> Result<(), IoError> {
    write_atomic(path, |w| {
        for v in values {
            w.write_all(&v.to_le_bytes())?;
        }
        Ok(())
    })
}

/// Writes a 16-bit grayscale PNG of `width * height` values.
///
/// ```
/// let dir = tempfile::tempdir().unwrap();
/// let p = dir.path().join("h.png");
/// relief_io::write_png16(&p, 2, 2, &[0, 1, 2, 65535]).unwrap();
/// let dem = relief_io::read_dem(&p, &Default::default()).unwrap();
/// assert_eq!(dem.samples, vec![0.0, 1.0, 2.0, 65535.0]);
/// ```
pub fn write_png16(path: &Path, width: u32, height: u32, values: &[u16]) -> Result<(), IoError> {
    let n = width as usize * height as usize;
    if values.len() != n || n == 0 {
        return Err(IoError::SizeMismatch {
            expected: n as u64,
            actual: values.len() as u64,
            what: "samples",
        });
    }
    write_atomic(path, |w| {
        let mut enc = png::Encoder::new(w, width, height);
        enc.set_color(png::ColorType::Grayscale);
        enc.set_depth(png::BitDepth::Sixteen);
        let mut writer = enc.write_header().map_err(std::io::Error::other)?;
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_be_bytes()).collect();
        writer
            .write_image_data(&bytes)
            .map_err(std::io::Error::other)?;
        writer.finish().map_err(std::io::Error::other)
    })
}

/// Writes a Wavefront OBJ: `v x y z` per vertex (world units) and `f a b c` (1-based) per
/// triangle, counter-clockwise seen from +z as CONVENTIONS.md requires of the caller's data.
/// Fails without writing if a triangle names a vertex that does not exist.
///
/// ```
/// let dir = tempfile::tempdir().unwrap();
/// let p = dir.path().join("m.obj");
/// relief_io::write_obj(&p, &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], &[[0, 1, 2]]).unwrap();
/// assert!(std::fs::read_to_string(&p).unwrap().contains("f 1 2 3"));
/// ```
pub fn write_obj(
    path: &Path,
    vertices: &[[f32; 3]],
    triangles: &[[u32; 3]],
) -> Result<(), IoError> {
    if let Some(t) = triangles
        .iter()
        .find(|t| t.iter().any(|&i| i as usize >= vertices.len()))
    {
        return Err(IoError::InvalidOption(format!(
            "triangle {t:?} names a vertex beyond the {} given",
            vertices.len()
        )));
    }
    write_atomic(path, |w| {
        writeln!(
            w,
            "# relief mesh: {} vertices, {} triangles",
            vertices.len(),
            triangles.len()
        )?;
        for v in vertices {
            writeln!(w, "v {} {} {}", v[0], v[1], v[2])?;
        }
        for t in triangles {
            writeln!(w, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
        }
        Ok(())
    })
}

/// Writes an 8-bit RGB PNG of `width * height` pixels (`3 * width * height` bytes).
///
/// ```
/// let dir = tempfile::tempdir().unwrap();
/// let p = dir.path().join("c.png");
/// relief_io::write_png_rgb8(&p, 1, 2, &[255, 0, 0, 0, 0, 255]).unwrap();
/// assert!(relief_io::write_png_rgb8(&p, 2, 2, &[0; 6]).is_err());
/// ```
pub fn write_png_rgb8(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<(), IoError> {
    let n = width as usize * height as usize * 3;
    if rgb.len() != n || n == 0 {
        return Err(IoError::SizeMismatch {
            expected: n as u64,
            actual: rgb.len() as u64,
            what: "bytes",
        });
    }
    write_atomic(path, |w| {
        let mut enc = png::Encoder::new(w, width, height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc.write_header().map_err(std::io::Error::other)?;
        writer
            .write_image_data(rgb)
            .map_err(std::io::Error::other)?;
        writer.finish().map_err(std::io::Error::other)
    })
}
