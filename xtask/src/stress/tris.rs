//! A triangle mesh under construction ([`Tris`]), and the randomness of
//! the stress set: SplitMix64 of a seed, as a function, so each draw is
//! named ([`unit`], [`between`]).

use qm::io::SplitMix64;
use qm::lift::glam::DVec3;

/// A triangle mesh under construction.
#[derive(Clone, Debug, Default)]
pub struct Tris {
    pub positions: Vec<DVec3>,
    pub faces: Vec<[u32; 3]>,
}

impl Tris {
    pub(super) fn push(&mut self, p: DVec3) -> u32 {
        self.positions.push(p);
        (self.positions.len() - 1) as u32
    }

    /// Appends another mesh, renumbering its vertices.
    pub(super) fn append(&mut self, other: &Tris) {
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        (self.faces).extend(other.faces.iter().map(|f| f.map(|v| v + base)));
    }

    /// Drops the vertices no face uses, keeping the others' order.
    pub(super) fn compact(&mut self) {
        let mut map = vec![u32::MAX; self.positions.len()];
        let mut positions = Vec::new();
        for f in &mut self.faces {
            for v in f.iter_mut() {
                if map[*v as usize] == u32::MAX {
                    map[*v as usize] = positions.len() as u32;
                    positions.push(self.positions[*v as usize]);
                }
                *v = map[*v as usize];
            }
        }
        self.positions = positions;
    }

    /// Turns every face so its normal points along `outward(centroid)`.
    pub(super) fn orient(&mut self, outward: impl Fn(DVec3) -> DVec3) {
        for f in &mut self.faces {
            let [a, b, c] = f.map(|v| self.positions[v as usize]);
            if (b - a).cross(c - a).dot(outward((a + b + c) / 3.0)) < 0.0 {
                f.swap(1, 2);
            }
        }
    }
}

/// A uniform number in `[0, 1)` from a stream and an index in it.
pub(crate) fn unit(stream: u64, i: u64) -> f64 {
    let h = SplitMix64::mix(SplitMix64::mix(stream) ^ i.wrapping_mul(0xd6e8_feb8_6659_fd93));
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// A uniform number in `[lo, hi)`.
pub(super) fn between(stream: u64, i: u64, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * unit(stream, i)
}
