//! The 16-bit lane mask shared by every backend.

/// A 16-lane predicate: bit `i` set means lane `i` is active.
///
/// This is the same type on every backend (it is what AVX-512 keeps in a
/// `k` register). Its inherent methods are *uncounted* conveniences for
/// tests and scalar glue; inside a kernel prefer the `Simd::mask_*` methods
/// so that the counting context sees the work.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
#[repr(transparent)]
pub struct Mask16(pub u16);

impl Mask16 {
    /// All 16 lanes active.
    pub const ALL: Mask16 = Mask16(0xFFFF);
    /// No lane active.
    pub const NONE: Mask16 = Mask16(0);

    /// Mask from raw bits.
    #[inline(always)]
    pub const fn from_bits(bits: u16) -> Self {
        Mask16(bits)
    }
    /// Raw bits.
    #[inline(always)]
    pub const fn bits(self) -> u16 {
        self.0
    }
    /// Lanes `0..n` active (all lanes for `n >= 16`): the loop-tail mask.
    #[inline(always)]
    pub const fn first_n(n: usize) -> Self {
        if n >= 16 {
            Mask16(0xFFFF)
        } else {
            Mask16(((1u32 << n) - 1) as u16)
        }
    }
    /// Is lane `i` active?
    #[inline(always)]
    pub const fn test(self, lane: usize) -> bool {
        lane < 16 && (self.0 >> lane) & 1 == 1
    }
    /// Number of active lanes.
    #[inline(always)]
    pub const fn count(self) -> u32 {
        self.0.count_ones()
    }
    /// Any lane active?
    #[inline(always)]
    pub const fn any(self) -> bool {
        self.0 != 0
    }
    /// All 16 lanes active?
    #[inline(always)]
    pub const fn all(self) -> bool {
        self.0 == 0xFFFF
    }
    /// Lowest active lane, if any.
    #[inline(always)]
    pub const fn first(self) -> Option<u32> {
        if self.0 == 0 {
            None
        } else {
            Some(self.0.trailing_zeros())
        }
    }
    /// Highest active lane, if any.
    #[inline(always)]
    pub const fn last(self) -> Option<u32> {
        if self.0 == 0 {
            None
        } else {
            Some(15 - self.0.leading_zeros())
        }
    }
    /// Iterate over the active lanes in ascending order.
    #[inline(always)]
    pub fn iter(self) -> MaskIter {
        MaskIter(self.0)
    }
}

impl core::fmt::Debug for Mask16 {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "Mask16({:#018b})", self.0)
    }
}

/// Iterator over the active lanes of a [`Mask16`], lowest first.
#[derive(Clone, Debug)]
pub struct MaskIter(u16);

impl Iterator for MaskIter {
    type Item = usize;
    #[inline(always)]
    fn next(&mut self) -> Option<usize> {
        if self.0 == 0 {
            None
        } else {
            let i = self.0.trailing_zeros() as usize;
            self.0 &= self.0 - 1;
            Some(i)
        }
    }
}
