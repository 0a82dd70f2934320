//! Drawn triangles: input triangles laid in a 2D chart, and the lookup of
//! the one that holds a point.
//!
//! Main items: [`Drawn`] (the drawn triangles and their [`Buckets`], a
//! uniform grid over them) and [`barycentric`]. A point `x` lies in a
//! triangle `q` when its barycentric coordinates
//! `l_i = (q_{i+1} - x) x (q_{i+2} - x) / ((q_1 - q_0) x (q_2 - q_0))`
//! (`x` the 2D cross product) are all non-negative; the smallest of them
//! says how far outside it is. [`drawn_right`] tells a triangle turned the
//! right way from one turned over or laid flat.

use qm_lift::glam::DVec2;

/// A lookup in [`Drawn`]: the smallest barycentric coordinate (non-negative
/// inside), the input triangle and the coordinates.
pub(super) type Near = (f64, u32, [f64; 3]);

/// Drawn input triangles (index and 2D corners) and their buckets.
pub(super) struct Drawn {
    pub(super) triangles: Vec<(u32, [DVec2; 3])>,
    grid: Buckets,
}

impl Drawn {
    pub(super) fn new(triangles: Vec<(u32, [DVec2; 3])>) -> Drawn {
        let grid = Buckets::new(&triangles);
        Drawn { triangles, grid }
    }

    /// The triangle nearest to holding `x`: its smallest barycentric
    /// coordinate (non-negative inside), its index and its coordinates.
    ///
    /// Where several hold `x`, the smallest is taken. Drawn triangles
    /// overlap where an input triangle reaches across base triangles: it is
    /// drawn straight between its corners' places, while the map it stands
    /// for bends at the base edges, and near a base vertex it can cover the
    /// small triangles there, and a sample taken on it lands far from the
    /// surface the base triangle stands for
    /// (docs/decisions/015-chart-sampling.md).
    pub(super) fn nearest(&self, x: DVec2) -> Option<Near> {
        let mut best: Option<Near> = None;
        // With its drawn area.
        let mut smallest: Option<(f64, Near)> = None;
        for reach in [0usize, 1, 3] {
            for &k in self.grid.near(x, reach) {
                let (t, q) = &self.triangles[k as usize];
                let l = barycentric(q, x);
                let worst = l[0].min(l[1]).min(l[2]);
                if best.is_none_or(|b| worst > b.0) {
                    best = Some((worst, *t, l));
                }
                if worst >= -1e-12 {
                    let area = (q[1] - q[0]).perp_dot(q[2] - q[0]).abs();
                    if smallest.is_none_or(|s| area < s.0) {
                        smallest = Some((area, (worst, *t, l)));
                    }
                }
            }
            if let Some((_, hit)) = smallest {
                return Some(hit);
            }
        }
        best
    }
}

/// A uniform grid of buckets over the drawn triangles.
struct Buckets {
    lo: DVec2,
    cell: f64,
    nx: usize,
    ny: usize,
    cells: Vec<Vec<u32>>,
}

impl Buckets {
    fn new(drawn: &[(u32, [DVec2; 3])]) -> Buckets {
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for (_, q) in drawn {
            for p in q {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
        if drawn.is_empty() {
            return Buckets {
                lo: DVec2::ZERO,
                cell: 1.0,
                nx: 0,
                ny: 0,
                cells: Vec::new(),
            };
        }
        let extent = (hi - lo).max(DVec2::splat(1e-300));
        let side = (drawn.len() as f64).sqrt().ceil().max(1.0);
        let cell = (extent.x.max(extent.y) / side).max(1e-300);
        let nx = ((extent.x / cell).ceil() as usize).clamp(1, 4096);
        let ny = ((extent.y / cell).ceil() as usize).clamp(1, 4096);
        let cell = (extent.x / nx as f64).max(extent.y / ny as f64);
        let mut cells = vec![Vec::new(); nx * ny];
        let at =
            |p: f64, lo: f64, n: usize| (((p - lo) / cell).floor().max(0.0) as usize).min(n - 1);
        for (k, (_, q)) in drawn.iter().enumerate() {
            let a = q[0].min(q[1]).min(q[2]);
            let b = q[0].max(q[1]).max(q[2]);
            let turn = (q[1] - q[0]).perp_dot(q[2] - q[0]);
            for j in at(a.y, lo.y, ny)..=at(b.y, lo.y, ny) {
                for i in at(a.x, lo.x, nx)..=at(b.x, lo.x, nx) {
                    let corner = lo + DVec2::new(i as f64, j as f64) * cell;
                    if overlaps(q, turn, corner, cell) {
                        cells[j * nx + i].push(k as u32);
                    }
                }
            }
        }
        Buckets {
            lo,
            cell,
            nx,
            ny,
            cells,
        }
    }

    /// The bucket of `p` and then rings around it out to `reach` cells.
    fn near(&self, p: DVec2, reach: usize) -> impl Iterator<Item = &u32> {
        let (nx, ny) = (self.nx as i64, self.ny as i64);
        let r = reach as i64;
        // A point far outside (the casts saturate) looks at no bucket, and
        // `i + r` must not overflow (found by the remesh_hub fuzz target).
        let i = (((p.x - self.lo.x) / self.cell).floor() as i64).clamp(-r - 1, nx + r);
        let j = (((p.y - self.lo.y) / self.cell).floor() as i64).clamp(-r - 1, ny + r);
        (j - r..=j + r)
            .flat_map(move |b| (i - r..=i + r).map(move |a| (a, b)))
            .filter(move |&(a, b)| a >= 0 && b >= 0 && a < nx && b < ny)
            .flat_map(move |(a, b)| self.cells[(b * nx + a) as usize].iter())
    }
}

/// Whether triangle `q` (of doubled signed area `turn`) reaches into the
/// square cell of side `cell` at `corner` (or nearly: the cell grown by a
/// thousandth of its side), given that their bounding boxes meet: no edge
/// has the whole cell outside it.
/// Only the cells a triangle crosses hold it, not all those of its bounding
/// box: the slivers of a fan around a hub of high valence cross few cells
/// each, but their boxes cover the fan.
fn overlaps(q: &[DVec2; 3], turn: f64, corner: DVec2, cell: f64) -> bool {
    if !turn.is_finite() || turn == 0.0 {
        return true;
    }
    let margin = 1e-3 * cell;
    let (lo, hi) = (corner - margin, corner + cell + margin);
    let box_corners = [lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y)];
    (0..3).all(|e| {
        let (p, r) = (q[e], q[(e + 1) % 3]);
        // Inside an edge is on the side of the opposite corner.
        box_corners
            .iter()
            .any(|&c| (r - p).perp_dot(c - p) * turn >= 0.0)
    })
}

/// Barycentric coordinates of `x` in 2D triangle `q`.
pub(super) fn barycentric(q: &[DVec2; 3], x: DVec2) -> [f64; 3] {
    let area = (q[1] - q[0]).perp_dot(q[2] - q[0]);
    [
        (q[1] - x).perp_dot(q[2] - x) / area,
        (q[2] - x).perp_dot(q[0] - x) / area,
        (q[0] - x).perp_dot(q[1] - x) / area,
    ]
}

/// Whether a triangle drawn at `p, q, r` is turned the right way, and not
/// so nearly collinear (an ear laid along a feature line) that barycentric
/// coordinates in it would be noise.
pub(super) fn drawn_right(p: DVec2, q: DVec2, r: DVec2) -> bool {
    let longest = (q - p)
        .length_squared()
        .max((r - q).length_squared())
        .max((p - r).length_squared());
    (q - p).perp_dot(r - p) > 1e-9 * longest
}
