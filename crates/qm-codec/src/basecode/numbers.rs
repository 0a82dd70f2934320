//! Signed numbers of the base section: [`IntModel`], a signed Exp-Golomb
//! code whose bits all have adaptive contexts, through the stream's binary
//! range coder ([`qm_ezw::BitWriter`]).
//!
//! A number `v` is a zero flag; then, if `v != 0`, its sign, the bit length
//! `n` of `|v|` in unary (`n - 1` ones and a zero, one context per
//! position), and the `n - 1` bits of `|v|` below its leading one, one
//! context per position. Faces, triangles and values each keep their own
//! models, so each kind of number learns its own distribution.

use qm_ezw::{BitReader, BitWriter, Context};

/// Contexts of one kind of signed number.
#[derive(Clone)]
pub(super) struct IntModel {
    zero: Context,
    sign: Context,
    /// Unary bit length, one context per position.
    length: [Context; 40],
    /// Bits below the leading one, one context per position.
    bits: [Context; 40],
}

impl IntModel {
    pub(super) fn new() -> Self {
        IntModel {
            zero: Context::default(),
            sign: Context::default(),
            length: [Context::default(); 40],
            bits: [Context::default(); 40],
        }
    }

    pub(super) fn put(&mut self, w: &mut BitWriter, v: i64) {
        w.encode(&mut self.zero, v == 0);
        if v == 0 {
            return;
        }
        w.encode(&mut self.sign, v < 0);
        let a = v.unsigned_abs();
        let n = 64 - a.leading_zeros() as usize;
        for i in 1..n {
            w.encode(&mut self.length[i], true);
        }
        if n < self.length.len() {
            w.encode(&mut self.length[n], false);
        }
        for i in (0..n - 1).rev() {
            w.encode(&mut self.bits[i], (a >> i) & 1 != 0);
        }
    }

    pub(super) fn get(&mut self, r: &mut BitReader) -> Result<i64, String> {
        let bit = |r: &mut BitReader, c: &mut Context| {
            r.decode(c)
                .map_err(|_| "it ends before its last value".to_string())
        };
        if bit(r, &mut self.zero)? {
            return Ok(0);
        }
        let negative = bit(r, &mut self.sign)?;
        let mut n = 1;
        while n < self.length.len() && bit(r, &mut self.length[n])? {
            n += 1;
        }
        if n > 36 {
            return Err(format!("a value of {n} bits"));
        }
        let mut a = 1u64;
        for i in (0..n - 1).rev() {
            a = (a << 1) | bit(r, &mut self.bits[i])? as u64;
        }
        Ok(if negative { -(a as i64) } else { a as i64 })
    }
}
