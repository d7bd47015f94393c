//! Sample types a heightfield can borrow.

mod sealed {
    pub trait Sealed {}
}

/// A height sample type: `u8`, `u16`, `i16`, `i32` or `f32`.
///
/// The trait is sealed; its methods are what the heightfield needs to turn a stored value into
/// a local height (`value * z_scale`).
///
/// ```
/// use relief_core::Sample;
/// assert_eq!(Sample::to_f32(1234u16), 1234.0);
/// assert_eq!(<i16 as Sample>::MAX_ABS, 32768.0);
/// ```
pub trait Sample: Copy + bytemuck::Pod + PartialOrd + sealed::Sealed {
    /// The largest magnitude any value of the type has (`f32::INFINITY` for `f32`, whose values
    /// must then be checked one by one).
    const MAX_ABS: f32;
    /// A short name of the type for messages.
    const NAME: &'static str;
    /// The value as `f32` (exact for `u8`, `u16`, `i16`; rounded for `i32` beyond 2^24).
    fn to_f32(self) -> f32;
}

macro_rules! int_sample {
    ($t:ty, $max:expr) => {
        impl sealed::Sealed for $t {}
        impl Sample for $t {
            const MAX_ABS: f32 = $max;
            const NAME: &'static str = stringify!($t);
            #[inline(always)]
            fn to_f32(self) -> f32 {
                self as f32
            }
        }
    };
}

int_sample!(u8, 255.0);
int_sample!(u16, 65535.0);
int_sample!(i16, 32768.0);
int_sample!(i32, 2_147_483_648.0);

impl sealed::Sealed for f32 {}
impl Sample for f32 {
    const MAX_ABS: f32 = f32::INFINITY;
    const NAME: &'static str = "f32";
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self
    }
}
