//! Structured values from unstructured bytes: the fuzzer's bytes become numbers, lengths and
//! choices, so that a coverage-guided fuzzer (and a proptest case) can drive APIs that take typed
//! arguments rather than a file. Running out of bytes gives zeros, never an error.

/// A cursor over the input.
pub struct Bytes<'a> {
    data: &'a [u8],
}

/// Floats a malformed input likes to hold: zeros of both signs, the limits of `f64`, NaN and the
/// infinities, tiny and huge values, and ordinary ones.
const SPECIAL: [f64; 16] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    2.0,
    1e-300,
    -1e-300,
    1e300,
    -1e300,
    f64::MAX,
    f64::MIN,
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::EPSILON,
];

impl<'a> Bytes<'a> {
    /// A cursor at the start of `data`.
    pub fn new(data: &'a [u8]) -> Self {
        Self { data }
    }

    /// The next byte (0 past the end).
    pub fn byte(&mut self) -> u8 {
        match self.data.split_first() {
            Some((b, rest)) => {
                self.data = rest;
                *b
            }
            None => 0,
        }
    }

    /// Whether the next byte is odd.
    pub fn bool(&mut self) -> bool {
        self.byte() & 1 == 1
    }

    /// The next 8 bytes, little-endian (zero-padded past the end).
    pub fn u64(&mut self) -> u64 {
        let mut b = [0u8; 8];
        for v in &mut b {
            *v = self.byte();
        }
        u64::from_le_bytes(b)
    }

    /// A count: usually in `0..=small` (one byte), sometimes any `usize` (a header's size field
    /// gone wrong).
    pub fn count(&mut self, small: usize) -> usize {
        match self.byte() {
            0xff => self.u64() as usize,
            b => b as usize % (small + 1),
        }
    }

    /// A float: one of [`SPECIAL`], a small integer or fraction, a value in `[-100, 100)`, or any
    /// bit pattern.
    pub fn f64(&mut self) -> f64 {
        let tag = self.byte();
        match tag % 4 {
            0 => SPECIAL[(tag as usize / 4) % SPECIAL.len()],
            1 => (tag as f64 - 128.0) / 8.0,
            2 => (self.u64() >> 11) as f64 / (1u64 << 53) as f64 * 200.0 - 100.0,
            _ => f64::from_bits(self.u64()),
        }
    }

    /// A float that is `default` unless the next byte says otherwise (so that seeds of mostly
    /// valid settings stay mostly valid under mutation).
    pub fn f64_or(&mut self, default: f64) -> f64 {
        if self.byte() < 200 {
            default
        } else {
            self.f64()
        }
    }

    /// A count that is `default` unless the next byte says otherwise.
    pub fn count_or(&mut self, default: usize, small: usize) -> usize {
        if self.byte() < 200 {
            default
        } else {
            self.count(small)
        }
    }

    /// `N` floats.
    pub fn f64s<const N: usize>(&mut self) -> [f64; N] {
        std::array::from_fn(|_| self.f64())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_input_reads_zeros() {
        let mut b = Bytes::new(&[]);
        assert_eq!(b.byte(), 0);
        assert_eq!(b.u64(), 0);
        assert_eq!(b.f64(), 0.0);
        assert_eq!(b.count(5), 0);
        assert!(!b.bool());
    }

    #[test]
    fn values_come_from_the_bytes() {
        let mut b = Bytes::new(&[0xff, 1, 0, 0, 0, 0, 0, 0, 1, 7, 4 * 12]);
        assert_eq!(b.count(3), (1 << 56) + 1);
        assert_eq!(b.count(3), 3);
        assert!(b.f64().is_nan());
    }
}
