//! Local frames: details expressed along the coarser surface's normal.
//!
//! A detail of level `l` moves its sample off the prediction made from the
//! level `l - 1` mesh. Its component along that mesh's normal changes the
//! shape; the two tangential components mostly slide the sample along the
//! surface, which a surface distance hardly sees. With
//! [`crate::Lifting::with_frames`], the forward transform turns every
//! level-`l` detail into `(normal, tangent, tangent)` coordinates so that a
//! coder can spend its bits on the first one, and the inverse undoes it.
//!
//! **The normal** at an odd sample comes from the coarser quads around it,
//! which the decoder has rebuilt before it needs the frame: a face point
//! takes its quad's normal (the cross product of the diagonals), an edge point
//! the sum of the normals of the two quads beside its edge, reaching into the
//! neighbouring base face where there is one. All of it is integer arithmetic
//! on the even samples, so encoder and decoder agree bit for bit.
//!
//! When the stream is cut, the decoder's coarser mesh is approximate and so
//! is its frame, and a detail turned by a wrong frame lands in the wrong
//! place. Where the coarser quads are small and thin (a dense scan, a
//! stretched corner of the parameterization) a small error in their corners
//! turns their normal a lot, and frames from the level `l - 1` quads lose
//! to world axes. So the finer levels use the level `l - 2` quads (the
//! parent of each quad above): twice the size, and resolved a level earlier
//! in the stream. From which level on
//! is the stream's choice ([`crate::Lifting::with_parent_frames_from`]; the
//! default is [`PARENTS_FROM`]; docs/decisions/012-frames-parents-from.md).
//! No one level is best on every model, so the encoder of `qm-codec` tries
//! 3 and 4 and keeps the better stream; if that is 4, it tries later
//! levels too and keeps one only if it is clearly better. Once the
//! coarser levels are exact, so is the frame.
//!
//! **The rotation** maps the normal onto the first axis with two plane
//! rotations (about `z`, then about `y`). Each is done as three integer
//! shears, `x += round(p y)`, `y += round(q x)`, `x += round(p y)` with
//! `p = s / (1 + c)` and `q = -s`, which a decoder undoes exactly in reverse
//! order whatever the rounding did (lifting a rotation, as in reversible
//! integer transforms). Angles beyond 90 degrees first turn by 180 degrees, a
//! sign change, so `|p| <= 1`. The cosines and sines come from the integer
//! normal by `+ - * /` and `sqrt` alone, which IEEE 754 rounds the same way on
//! every platform, so the frames do not depend on the machine or on a maths
//! library.

use crate::layout::Layout;
use crate::mesh::Coord;

/// The default first level whose frames come from the level `l - 2`
/// (parent) quads rather than the level `l - 1` ones. A stream may choose
/// another (see [`crate::Lifting::with_parent_frames_from`]); 2 is the
/// lowest that has parents.
pub const PARENTS_FROM: u32 = 3;

/// Which way [`apply`] turns the details.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Turn {
    /// World to `(normal, tangent, tangent)`.
    ToLocal,
    /// Back to world axes.
    ToWorld,
}

/// Turns the details of `level` (its odd samples) between world axes and
/// their local frames; the even samples (the level `level - 1` mesh) must
/// hold positions and are left as they are.
///
/// From level `parents_from` on, the normals come from the parent quads.
pub(crate) fn apply(
    layout: &Layout,
    level: u32,
    data: &mut [Coord],
    turn: Turn,
    parents_from: u32,
) {
    walk(layout, level, data, &mut Turner(turn), parents_from);
}

/// The frame normal of every odd sample of `level`, as `(sample id,
/// normal)`, computed from the even samples of `data` (the level
/// `level - 1` mesh, positions) exactly as the transform computes it; the
/// normal is not normalized (see the module docs for its length) and is
/// zero where there is no quad to take it from. Each odd sample appears
/// once. For tools that shape a mesh to suit the frames, such as a
/// remesher that makes the details normal. `parents_from` is the stream's
/// first level with frames from the parent quads
/// ([`crate::Lifting::with_parent_frames_from`]).
pub fn normals(
    layout: &Layout,
    level: u32,
    data: &[Coord],
    parents_from: u32,
) -> Vec<(u32, [i64; 3])> {
    struct Collect(Vec<(u32, [i64; 3])>);
    impl Visit for Collect {
        fn visit(
            &mut self,
            data: &mut [Coord],
            id: usize,
            normal: impl FnOnce(&[Coord]) -> [i64; 3],
        ) {
            self.0.push((id as u32, normal(data)));
        }
    }
    // The walk is shared with the in-place turning, which writes the odd
    // samples, so it takes the samples mutably: collect from a copy.
    let mut copy = data.to_vec();
    let mut collect = Collect(Vec::new());
    walk(layout, level, &mut copy, &mut collect, parents_from);
    collect.0
}

/// What [`walk`] does at each odd sample.
trait Visit {
    /// `id` is the odd sample; `normal` computes its frame normal from the
    /// even samples of `data`.
    fn visit(&mut self, data: &mut [Coord], id: usize, normal: impl FnOnce(&[Coord]) -> [i64; 3]);
}

/// Turns each nonzero detail by the frame of its normal (zero in any frame,
/// and most fine details of a short prefix are, so their normal is never
/// computed).
struct Turner(Turn);

impl Visit for Turner {
    fn visit(&mut self, data: &mut [Coord], id: usize, normal: impl FnOnce(&[Coord]) -> [i64; 3]) {
        if data[id] == [0; 3] {
            return;
        }
        let frame = Frame::new(normal(data));
        let v = &mut data[id];
        *v = match self.0 {
            Turn::ToLocal => frame.to_local(*v),
            Turn::ToWorld => frame.to_world(*v),
        };
    }
}

/// Visits every odd sample of `level` once (base edges by the face that
/// owns them) with the way to compute its frame normal; from level
/// `parents_from` on, the normals come from the parent quads.
fn walk(
    layout: &Layout,
    level: u32,
    data: &mut [Coord],
    visitor: &mut impl Visit,
    parents_from: u32,
) {
    let base = layout.base();
    let s = 1usize << (layout.level() - level + 1);
    let h = s / 2;
    let m = layout.n() / s;
    let side = layout.n() + 1;
    // Normals of the face's level `level - 1` quads, each used by up to
    // five odd samples.
    // From level `parents_from` on, the normals come from the level
    // `level - 2` quads
    // (the frame then depends on a mesh a cut stream has resolved better,
    // and the quads are twice the size): see the module docs.
    let coarse = if level >= parents_from.max(2) { 2 } else { 1 };
    let (bs, bm) = (s * coarse, m / coarse);
    let mut quads = vec![[0i64; 3]; bm * bm];
    for f in 0..layout.face_count() {
        let owns = |k: u8| base.owns(f as u32, k);
        let grid = layout.face_grid(f);
        let at = |a: usize, b: usize| data[grid[b * bs * side + a * bs] as usize].map(i64::from);
        for b in 0..bm {
            for a in 0..bm {
                quads[b * bm + a] =
                    diagonal_cross(at(a, b), at(a + 1, b), at(a + 1, b + 1), at(a, b + 1));
            }
        }
        // A quad of the face, or across its side (looked up in the
        // neighbouring face; `None` where there is none).
        let quad = |data: &[Coord], a: isize, b: isize| -> Option<[i64; 3]> {
            let (a, b) = (a.div_euclid(coarse as isize), b.div_euclid(coarse as isize));
            if (0..bm as isize).contains(&a) && (0..bm as isize).contains(&b) {
                Some(quads[b as usize * bm + a as usize])
            } else {
                quad_normal(
                    layout,
                    f,
                    a * bs as isize,
                    b * bs as isize,
                    bs as isize,
                    data,
                )
            }
        };
        let sum = |x: Option<[i64; 3]>, y: Option<[i64; 3]>| -> [i64; 3] {
            let (x, y) = (x.unwrap_or([0; 3]), y.unwrap_or([0; 3]));
            [x[0] + y[0], x[1] + y[1], x[2] + y[2]]
        };
        let id = |i: usize, j: usize| grid[j * side + i] as usize;
        for b in 0..=m {
            for a in 0..=m {
                let (i, j) = (a * s, b * s);
                let (ai, bi) = (a as isize, b as isize);
                let row_owned = (b != 0 || owns(0)) && (b != m || owns(2));
                let column_owned = (a != 0 || owns(3)) && (a != m || owns(1));
                // Horizontal edge point: quads above and below its edge.
                if a < m && row_owned {
                    visitor.visit(data, id(i + h, j), |data| {
                        sum(quad(data, ai, bi), quad(data, ai, bi - 1))
                    });
                }
                // Vertical edge point: quads right and left of its edge.
                if b < m && column_owned {
                    visitor.visit(data, id(i, j + h), |data| {
                        sum(quad(data, ai, bi), quad(data, ai - 1, bi))
                    });
                }
                // Face point: its own quad.
                if a < m && b < m {
                    visitor.visit(data, id(i + h, j + h), |data| {
                        quad(data, ai, bi).unwrap_or([0; 3])
                    });
                }
            }
        }
    }
}

/// Normal of the quad with corner `(a, b)` and side `s` (grid units of face
/// `f`, possibly reaching across one side of the face): the cross product of
/// its diagonals, or `None` where a corner does not exist.
fn quad_normal(
    layout: &Layout,
    f: usize,
    a: isize,
    b: isize,
    s: isize,
    data: &[Coord],
) -> Option<[i64; 3]> {
    let at = |i: isize, j: isize| -> Option<[i64; 3]> {
        let id = layout.sample_beyond(f, i as i32, j as i32)?;
        Some(data[id as usize].map(i64::from))
    };
    Some(diagonal_cross(
        at(a, b)?,
        at(a + s, b)?,
        at(a + s, b + s)?,
        at(a, b + s)?,
    ))
}

/// `(p2 - p0) x (p3 - p1)`: twice the area vector of the quad `p0 p1 p2 p3`.
#[inline]
fn diagonal_cross(p0: [i64; 3], p1: [i64; 3], p2: [i64; 3], p3: [i64; 3]) -> [i64; 3] {
    let d = [p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]];
    let e = [p3[0] - p1[0], p3[1] - p1[1], p3[2] - p1[2]];
    [
        d[1] * e[2] - d[2] * e[1],
        d[2] * e[0] - d[0] * e[2],
        d[0] * e[1] - d[1] * e[0],
    ]
}

/// A rotation taking a normal onto the first axis, as two plane rotations.
#[derive(Clone, Copy, Debug)]
struct Frame {
    /// Rotation in the `(x, y)` plane, or `None` when the normal has no
    /// `(x, y)` part.
    xy: Option<Givens>,
    /// Rotation in the `(x, z)` plane.
    xz: Option<Givens>,
}

impl Frame {
    fn new(n: [i64; 3]) -> Frame {
        let [x, y, z] = n.map(|v| v as f64);
        let r2 = x * x + y * y;
        let len2 = r2 + z * z;
        if len2 == 0.0 {
            return Frame { xy: None, xz: None };
        }
        let r = r2.sqrt();
        let len = len2.sqrt();
        let xy = (r > 0.0).then(|| {
            let inv = 1.0 / r;
            Givens::new(x * inv, y * inv)
        });
        let inv = 1.0 / len;
        Frame {
            xy,
            xz: Some(Givens::new(r * inv, z * inv)),
        }
    }

    fn to_local(self, v: Coord) -> Coord {
        let [mut x, mut y, mut z] = v.map(i64::from);
        if let Some(g) = self.xy {
            g.forward(&mut x, &mut y);
        }
        if let Some(g) = self.xz {
            g.forward(&mut x, &mut z);
        }
        [x, y, z].map(|c| c as i32)
    }

    fn to_world(self, v: Coord) -> Coord {
        let [mut x, mut y, mut z] = v.map(i64::from);
        if let Some(g) = self.xz {
            g.inverse(&mut x, &mut z);
        }
        if let Some(g) = self.xy {
            g.inverse(&mut x, &mut y);
        }
        [x, y, z].map(|c| c as i32)
    }
}

/// The plane rotation `(x, y) -> (c x + s y, -s x + c y)` as integer shears.
#[derive(Clone, Copy, Debug)]
struct Givens {
    /// Turn by 180 degrees first (when `c < 0`).
    flip: bool,
    p: f64,
    q: f64,
}

impl Givens {
    fn new(c: f64, s: f64) -> Givens {
        let flip = c < 0.0;
        let (c, s) = if flip { (-c, -s) } else { (c, s) };
        Givens {
            flip,
            p: s / (1.0 + c),
            q: -s,
        }
    }

    /// `R(k v)`: the product in doubles, plus a half away from zero, then
    /// truncated (a plain add and an exact conversion, where `f64::round`
    /// would be a library call on most targets).
    #[inline]
    fn shear(k: f64, v: i64) -> i64 {
        let x = k * v as f64;
        (x + 0.5f64.copysign(x)) as i64
    }

    fn forward(self, x: &mut i64, y: &mut i64) {
        if self.flip {
            *x = -*x;
            *y = -*y;
        }
        *x += Self::shear(self.p, *y);
        *y += Self::shear(self.q, *x);
        *x += Self::shear(self.p, *y);
    }

    fn inverse(self, x: &mut i64, y: &mut i64) {
        *x -= Self::shear(self.p, *y);
        *y -= Self::shear(self.q, *x);
        *x -= Self::shear(self.p, *y);
        if self.flip {
            *x = -*x;
            *y = -*y;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(seed: &mut u64) -> i64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*seed >> 33) as i64
    }

    #[test]
    fn frames_invert_exactly_and_put_the_normal_first() {
        let mut seed = 7;
        for _ in 0..20_000 {
            let n = [0; 3].map(|_| lcg(&mut seed) % 2001 - 1000);
            let frame = Frame::new(n);
            let v: Coord = [0; 3].map(|_| (lcg(&mut seed) % (1 << 24) - (1 << 23)) as i32);
            let local = frame.to_local(v);
            assert_eq!(frame.to_world(local), v, "normal {n:?}");
            // The normal itself, scaled up, lands on the first axis.
            let big = n.map(|c| (c * 1000) as i32);
            let l = frame.to_local(big);
            let len = n
                .iter()
                .map(|&c| (c * 1000) as f64)
                .map(|c| c * c)
                .sum::<f64>();
            if len > 0.0 {
                assert!((l[0] as f64 - len.sqrt()).abs() <= 3.0, "{n:?} -> {l:?}");
                assert!(l[1].abs() <= 3 && l[2].abs() <= 3, "{n:?} -> {l:?}");
            }
        }
    }

    #[test]
    fn rotation_keeps_lengths_up_to_rounding() {
        let mut seed = 3;
        for _ in 0..5_000 {
            let n = [0; 3].map(|_| lcg(&mut seed) % 201 - 100);
            let frame = Frame::new(n);
            let v: Coord = [0; 3].map(|_| (lcg(&mut seed) % 20_001 - 10_000) as i32);
            let l = frame.to_local(v);
            let norm = |c: Coord| c.iter().map(|&x| (x as f64).powi(2)).sum::<f64>().sqrt();
            assert!((norm(l) - norm(v)).abs() <= 4.0, "{v:?} -> {l:?}");
        }
    }
}
