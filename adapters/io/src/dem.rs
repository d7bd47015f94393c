//! An owned elevation grid as read from a file.

use crate::IoError;
use relief_core::{Heightfield, Scale};

/// An owned, void-free elevation grid: `width * height` finite `f32` heights, row-major, and the
/// scale the file implies (overridable by the caller).
///
/// ```
/// use relief_io::Dem;
/// let dem = Dem::new(2, 2, vec![1.0, 2.0, 3.0, 4.0]).unwrap();
/// assert_eq!(dem.stats().mean, 2.5);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Dem {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Heights, row-major, before `z_scale` and `z_offset`.
    pub samples: Vec<f32>,
    /// Spacing and vertical scale (from the file where it has them, else the defaults).
    pub scale: Scale,
    /// How many samples were voids (NaN, infinite or the no-data value) and were filled.
    pub nodata_count: usize,
}

/// Summary statistics of a [`Dem`] in world units (after `z_scale` and `z_offset`).
///
/// ```
/// let s = relief_io::Dem::new(2, 2, vec![0.0, 0.0, 0.0, 4.0]).unwrap().stats();
/// assert_eq!((s.min, s.max, s.mean), (0.0, 4.0, 1.0));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stats {
    /// Lowest world height.
    pub min: f64,
    /// Highest world height.
    pub max: f64,
    /// Mean world height.
    pub mean: f64,
}

impl Dem {
    /// A DEM from heights, checked like a core [`Heightfield`] (at least 2 x 2, size matches,
    /// every value finite), with the default scale.
    ///
    /// ```
    /// assert!(relief_io::Dem::new(2, 2, vec![0.0; 3]).is_err());
    /// ```
    pub fn new(width: u32, height: u32, samples: Vec<f32>) -> Result<Dem, IoError> {
        let dem = Dem {
            width,
            height,
            samples,
            scale: Scale::default(),
            nodata_count: 0,
        };
        dem.heightfield()?;
        Ok(dem)
    }

    /// A core view over the samples with this DEM's scale.
    ///
    /// ```
    /// use relief_core::Terrain;
    /// let dem = relief_io::Dem::new(3, 2, vec![0.0; 6]).unwrap();
    /// assert_eq!(dem.heightfield().unwrap().width(), 3);
    /// ```
    pub fn heightfield(&self) -> Result<Heightfield<'_, f32>, IoError> {
        Ok(Heightfield::with_scale(
            &self.samples,
            self.width,
            self.height,
            self.scale,
        )?)
    }

    /// Minimum, maximum and mean world height (computed in `f64`).
    ///
    /// ```
    /// let mut dem = relief_io::Dem::new(2, 2, vec![10.0, 20.0, 30.0, 40.0]).unwrap();
    /// dem.scale.z_scale = 0.1;
    /// assert!((dem.stats().max - 4.0).abs() < 1e-6);
    /// ```
    #[must_use]
    pub fn stats(&self) -> Stats {
        let (zs, zo) = (
            f64::from(self.scale.z_scale),
            f64::from(self.scale.z_offset),
        );
        let mut min = f64::INFINITY;
        let mut max = f64::NEG_INFINITY;
        let mut sum = 0.0;
        for &v in &self.samples {
            let z = f64::from(v) * zs + zo;
            min = min.min(z);
            max = max.max(z);
            sum += z;
        }
        let n = self.samples.len().max(1) as f64;
        Stats {
            min,
            max,
            mean: sum / n,
        }
    }
}
