//! Adaptive binary arithmetic coding (a carry-less range coder).
//!
//! The encoder keeps a 33-bit `low` and a 32-bit `range`; each binary
//! decision splits the range in proportion to an adaptive probability, and
//! the top byte is shifted out whenever the range falls below 2^24, with
//! pending `0xFF` bytes held back until a carry can no longer reach them.
//!
//! **Prefixes.** The decoder holds a 32-bit window of the stream and decides
//! each symbol by comparing that window with an integer bound; the bytes it
//! has not read yet only add a fraction below one unit, so a decision made
//! from bytes that are all present is the decision the full stream gives.
//! When it needs a byte past the end of a cut stream it flags
//! [`Truncated`] before the next decision: every symbol it returned is right.

/// Probability precision in bits.
const PROB_BITS: u32 = 16;
const ONE: u32 = 1 << PROB_BITS;
const TOP: u32 = 1 << 24;

/// The slowest adaptation rate of a context, 1/2^`SLOWEST`, unless a coder
/// says otherwise ([`BitWriter::with_slowest_rate`]).
pub const SLOWEST: u32 = 6;

/// An adaptive binary model: the probability of a 0, adapting quickly at
/// first and more slowly as it sees more symbols.
#[derive(Clone, Copy, Debug)]
pub struct Context {
    p0: u16,
    seen: u8,
}

impl Default for Context {
    fn default() -> Self {
        Context {
            p0: (ONE / 2) as u16,
            seen: 0,
        }
    }
}

impl Context {
    /// Where `range` splits: the part below codes a 0, the rest a 1.
    #[inline]
    fn split(&self, range: u32) -> u32 {
        (range >> PROB_BITS) * self.p0 as u32
    }

    /// What coding `bit` with this model costs now, in bits (for
    /// measurements; coding does not need it).
    pub fn cost(&self, bit: bool) -> f64 {
        let p0 = self.p0 as f64 / ONE as f64;
        -(if bit { 1.0 - p0 } else { p0 }).log2()
    }

    /// Learns `bit`: adaptation rate 1/2^shift, 1/4 for the first symbols,
    /// down to 1/2^`slowest`.
    #[inline]
    fn update(&mut self, bit: bool, slowest: u32) {
        let shift = (2 + (self.seen as u32 >> 2)).min(slowest);
        self.seen = self.seen.saturating_add(1);
        let p = self.p0 as u32;
        let p = if bit {
            p - (p >> shift)
        } else {
            p + ((ONE - p) >> shift)
        };
        // Keep both symbols codable.
        self.p0 = p.clamp(32, ONE - 32) as u16;
    }
}

/// Arithmetic encoder writing into a byte vector.
#[derive(Debug)]
pub struct BitWriter {
    low: u64,
    range: u32,
    cache: u8,
    pending: u64,
    started: bool,
    out: Vec<u8>,
    slowest: u32,
}

impl Default for BitWriter {
    fn default() -> Self {
        Self::new()
    }
}

impl BitWriter {
    /// An empty encoder.
    pub fn new() -> Self {
        BitWriter {
            low: 0,
            range: u32::MAX,
            cache: 0,
            pending: 0,
            started: false,
            out: Vec::new(),
            slowest: SLOWEST,
        }
    }

    /// This encoder with its contexts' adaptation rate falling to
    /// 1/2^`slowest` at the slowest (the decoder must say the same:
    /// [`BitReader::with_slowest_rate`]); [`SLOWEST`] by default.
    pub fn with_slowest_rate(mut self, slowest: u32) -> Self {
        self.slowest = slowest;
        self
    }

    /// Encodes `bit` with the adaptive model `ctx`.
    #[inline]
    pub fn encode(&mut self, ctx: &mut Context, bit: bool) {
        let bound = ctx.split(self.range);
        if bit {
            self.low += bound as u64;
            self.range -= bound;
        } else {
            self.range = bound;
        }
        ctx.update(bit, self.slowest);
        while self.range < TOP {
            self.range <<= 8;
            self.shift_low();
        }
    }

    fn shift_low(&mut self) {
        if self.low < 0xFF00_0000 || self.low >= 1 << 32 {
            let carry = (self.low >> 32) as u8;
            // The very first byte is always 0 and is left out of the stream.
            if self.started {
                self.out.push(self.cache.wrapping_add(carry));
            }
            self.started = true;
            for _ in 0..self.pending {
                self.out.push(0xFFu8.wrapping_add(carry));
            }
            self.pending = 0;
            self.cache = (self.low >> 24) as u8;
        } else {
            self.pending += 1;
        }
        self.low = (self.low & 0x00FF_FFFF) << 8;
    }

    /// Bytes a decoder needs to decode everything encoded so far.
    pub fn len_needed(&self) -> usize {
        self.out.len() + self.pending as usize + 5
    }

    /// Bytes of the stream that are final: no later symbol or carry
    /// changes them.
    pub fn len_final(&self) -> usize {
        self.out.len()
    }

    /// Flushes and returns the stream.
    pub fn finish(mut self) -> Vec<u8> {
        for _ in 0..5 {
            self.shift_low();
        }
        self.out
    }
}

/// The stream ran out: the symbol asked for cannot be known from the prefix.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Truncated;

/// The state of a [`BitReader`] between two symbols.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReaderSnapshot {
    code: u32,
    range: u32,
    pos: usize,
    slowest: u32,
}

impl ReaderSnapshot {
    /// Bytes the reader had consumed: everything it decided depends on
    /// these and no others.
    pub fn bytes_read(&self) -> usize {
        self.pos
    }
}

/// Arithmetic decoder over a (possibly cut) byte slice.
#[derive(Debug)]
pub struct BitReader<'a> {
    code: u32,
    range: u32,
    data: &'a [u8],
    pos: usize,
    truncated: bool,
    slowest: u32,
}

impl<'a> BitReader<'a> {
    /// Starts decoding `data`.
    pub fn new(data: &'a [u8]) -> Self {
        let mut reader = BitReader {
            code: 0,
            range: u32::MAX,
            data,
            pos: 0,
            truncated: false,
            slowest: SLOWEST,
        };
        for _ in 0..4 {
            reader.code = (reader.code << 8) | reader.next_byte() as u32;
        }
        reader
    }

    /// This decoder with its contexts' adaptation rate falling to
    /// 1/2^`slowest` at the slowest, as its encoder's
    /// ([`BitWriter::with_slowest_rate`]).
    pub fn with_slowest_rate(mut self, slowest: u32) -> Self {
        self.slowest = slowest;
        self
    }

    #[inline]
    fn next_byte(&mut self) -> u8 {
        match self.data.get(self.pos) {
            Some(&b) => {
                self.pos += 1;
                b
            }
            None => self.run_out(),
        }
    }

    #[cold]
    fn run_out(&mut self) -> u8 {
        self.truncated = true;
        0
    }

    /// Decodes one bit with the adaptive model `ctx`.
    #[inline]
    pub fn decode(&mut self, ctx: &mut Context) -> Result<bool, Truncated> {
        if self.truncated {
            return Err(Truncated);
        }
        let bound = ctx.split(self.range);
        let bit = self.code >= bound;
        if bit {
            self.code -= bound;
            self.range -= bound;
        } else {
            self.range = bound;
        }
        ctx.update(bit, self.slowest);
        while self.range < TOP {
            self.range <<= 8;
            self.code = (self.code << 8) | self.next_byte() as u32;
        }
        Ok(bit)
    }

    /// Where the decoder stands, to [`Self::resume`] later on the same data
    /// or a longer cut of it; `None` once it has run past the end of its
    /// data (its window then holds made-up bytes).
    pub fn snapshot(&self) -> Option<ReaderSnapshot> {
        (!self.truncated).then_some(ReaderSnapshot {
            code: self.code,
            range: self.range,
            pos: self.pos,
            slowest: self.slowest,
        })
    }

    /// Continues decoding `data` from `at`, a snapshot taken on a prefix of it.
    pub fn resume(data: &'a [u8], at: ReaderSnapshot) -> Self {
        BitReader {
            code: at.code,
            range: at.range,
            data,
            pos: at.pos.min(data.len()),
            truncated: false,
            slowest: at.slowest,
        }
    }

    /// Whether the decoder has run past the end of its data.
    pub fn is_truncated(&self) -> bool {
        self.truncated
    }

    /// Bytes consumed so far.
    pub fn position(&self) -> usize {
        self.pos
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn symbols(n: usize) -> Vec<(usize, bool)> {
        let mut x = 0x2545F4914F6CDD1Du64;
        (0..n)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                let ctx = (x % 4) as usize;
                // Context c emits ones with probability about c / 5.
                (ctx, ((x >> 20) % 5) < ctx as u64)
            })
            .collect()
    }

    fn encode(syms: &[(usize, bool)]) -> Vec<u8> {
        let mut ctx = [Context::default(); 4];
        let mut w = BitWriter::new();
        for &(c, b) in syms {
            w.encode(&mut ctx[c], b);
        }
        w.finish()
    }

    #[test]
    fn round_trip_and_compression() {
        let syms = symbols(100_000);
        let bytes = encode(&syms);
        let mut ctx = [Context::default(); 4];
        let mut r = BitReader::new(&bytes);
        for &(c, b) in &syms {
            assert_eq!(r.decode(&mut ctx[c]), Ok(b));
        }
        assert!(!r.is_truncated());
        // Entropy of the mix is about 0.68 bits per symbol.
        assert!(bytes.len() < 100_000 * 70 / 800, "{} bytes", bytes.len());
    }

    #[test]
    fn every_prefix_decodes_a_correct_prefix_of_symbols() {
        let syms = symbols(3_000);
        let bytes = encode(&syms);
        let mut last = 0;
        for cut in 0..=bytes.len() {
            let mut ctx = [Context::default(); 4];
            let mut r = BitReader::new(&bytes[..cut]);
            let mut good = 0;
            for &(c, b) in &syms {
                match r.decode(&mut ctx[c]) {
                    Ok(bit) => {
                        assert_eq!(bit, b, "cut {cut}, symbol {good}");
                        good += 1;
                    }
                    Err(Truncated) => break,
                }
            }
            assert!(good >= last, "more bytes never give fewer symbols");
            last = good;
        }
        assert_eq!(last, syms.len());
    }

    #[test]
    fn carries_propagate_through_pending_bytes() {
        // Long runs of very probable symbols push low towards 0xFF.. patterns.
        let mut syms = Vec::new();
        for i in 0..50_000 {
            syms.push((0, i % 97 == 0));
            syms.push((3, i % 3 != 0));
        }
        let bytes = encode(&syms);
        let mut ctx = [Context::default(); 4];
        let mut r = BitReader::new(&bytes);
        for &(c, b) in &syms {
            assert_eq!(r.decode(&mut ctx[c]).unwrap(), b);
        }
    }

    /// A reader resumed from a snapshot goes on at its adaptation rate.
    #[test]
    fn a_resumed_reader_keeps_its_rate() {
        let syms = symbols(20_000);
        let mut ctx = [Context::default(); 4];
        let mut w = BitWriter::new().with_slowest_rate(3);
        for &(c, b) in &syms {
            w.encode(&mut ctx[c], b);
        }
        let bytes = w.finish();
        let mut ctx = [Context::default(); 4];
        let mut r = BitReader::new(&bytes).with_slowest_rate(3);
        let (head, tail) = syms.split_at(syms.len() / 2);
        for &(c, b) in head {
            assert_eq!(r.decode(&mut ctx[c]), Ok(b));
        }
        let mut r = BitReader::resume(&bytes, r.snapshot().expect("not truncated"));
        for &(c, b) in tail {
            assert_eq!(r.decode(&mut ctx[c]), Ok(b));
        }
    }
}
