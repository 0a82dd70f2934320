//! The quadric error of Garland and Heckbert: the sum of squared distances
//! to a set of planes, weighted, as `x^T A x + 2 b . x + c` with `A`
//! symmetric (its six entries kept), plus the area the planes stand for.

use qm_lift::glam::DVec3;

/// A quadric: `a` the upper triangle of `A` row by row (xx, xy, xz, yy,
/// yz, zz), `b`, `c`, and the area it stands for.
#[derive(Clone, Copy, Default)]
pub(super) struct Quadric {
    a: [f64; 6],
    b: [f64; 3],
    c: f64,
    pub(super) area: f64,
}

impl Quadric {
    pub(super) fn plane(n: DVec3, p: DVec3, w: f64) -> Quadric {
        let d = -n.dot(p);
        Quadric {
            a: [
                w * n.x * n.x,
                w * n.x * n.y,
                w * n.x * n.z,
                w * n.y * n.y,
                w * n.y * n.z,
                w * n.z * n.z,
            ],
            b: [w * n.x * d, w * n.y * d, w * n.z * d],
            c: w * d * d,
            area: 0.0,
        }
    }

    pub(super) fn add(&mut self, o: &Quadric) {
        for i in 0..6 {
            self.a[i] += o.a[i];
        }
        for i in 0..3 {
            self.b[i] += o.b[i];
        }
        self.c += o.c;
        self.area += o.area;
    }

    pub(super) fn eval(&self, p: DVec3) -> f64 {
        let [xx, xy, xz, yy, yz, zz] = self.a;
        let quad = xx * p.x * p.x
            + 2.0 * xy * p.x * p.y
            + 2.0 * xz * p.x * p.z
            + yy * p.y * p.y
            + 2.0 * yz * p.y * p.z
            + zz * p.z * p.z;
        let lin = 2.0 * (self.b[0] * p.x + self.b[1] * p.y + self.b[2] * p.z);
        (quad + lin + self.c).max(0.0)
    }
}
