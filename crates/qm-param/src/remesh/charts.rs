//! Sampling a component through its base domain (module `simplify`).
//!
//! Each base triangle becomes three quads, through its centroid and its
//! edges' midpoints; the quad at corner `A` is where `A`'s barycentric
//! coordinate is the largest. So every quad lies in the star of one base
//! vertex, and is sampled in that vertex's *chart*: its star laid flat
//! around it (edge lengths kept, angles scaled to a turn), the triangles
//! across its outer edges unfolded, each base triangle mapped linearly,
//! and every input triangle whose three vertices the map puts in the star
//! drawn there through their barycentric coordinates. A grid point of the
//! quad (its bilinear place in the base triangle) is looked up among the
//! drawn triangles and takes the surface point there. Grid points on an
//! edge or corner shared by several quads are one sample (the `Layout`'s
//! numbering), made once, so the remesh has no cracks.
//!
//! Before sampling, the map is mended where the simplification left it
//! folded or squeezed: single vertices move into the kernel of their ring
//! (`untangle_map`), knots come undone by moving their neighbourhoods down
//! a regularized conformal energy (`untangle_knots`), and then every free
//! vertex moves down the map's stretch (`relax_stretch`), never folding a
//! triangle, so that sampling density follows the surface.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};

use qm_lift::glam::{DMat2, DVec2, DVec3};
use qm_lift::{BaseMesh, Layout, coding_order, split_triangles};
use rayon::prelude::*;

use super::resample::{Patch, fit_grids};
use super::simplify::{Base, Location, Ring, ring};
use crate::{Error, RemeshFailure, Result, TriMesh, triangle_area};

/// The quads of base triangle `t`: corner `c`'s quad has corners `t[c]`,
/// the midpoint of `t[c] t[c+1]`, the centroid and the midpoint of
/// `t[c+2] t[c]`, counter-clockwise; in barycentric coordinates of `t`.
fn quad_corners(c: usize) -> [[f64; 3]; 4] {
    let mut e = [[0.0; 3]; 3];
    for (i, row) in e.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    let mid = |a: usize, b: usize| std::array::from_fn(|i| 0.5 * (e[a][i] + e[b][i]));
    [
        e[c],
        mid(c, (c + 1) % 3),
        [1.0 / 3.0; 3],
        mid(c, (c + 2) % 3),
    ]
}

/// Bilinear point `(s, t)` of a quad given by its corners.
fn bilinear(q: &[[f64; 3]; 4], s: f64, t: f64) -> [f64; 3] {
    let w = [(1.0 - s) * (1.0 - t), s * (1.0 - t), s * t, (1.0 - s) * t];
    std::array::from_fn(|i| w[0] * q[0][i] + w[1] * q[1][i] + w[2] * q[2][i] + w[3] * q[3][i])
}

/// The quad base mesh of a base triangle mesh ([`split_triangles`], whose
/// numbering the base coder relies on): the quads, the vertex count, per
/// quad its triangle and corner, and the compact id of each base vertex.
pub(super) struct Quads {
    pub faces: Vec<[u32; 4]>,
    pub vertex_count: u32,
    pub owner: Vec<(u32, u8)>,
    pub compact: HashMap<u32, u32>,
}

pub(super) fn quads(triangles: &[[u32; 3]]) -> Quads {
    let order = coding_order(triangles);
    let turned: Vec<[u32; 3]> = (order.iter())
        .map(|&(t, r)| std::array::from_fn(|i| triangles[t as usize][(r as usize + i) % 3]))
        .collect();
    let split = split_triangles(&turned);
    let compact = (split.corners.iter().enumerate())
        .map(|(i, &v)| (v, i as u32))
        .collect();
    let owner = (0..3 * triangles.len())
        .map(|q| {
            let (t, r) = order[q / 3];
            (t, ((r as usize + q % 3) % 3) as u8)
        })
        .collect();
    Quads {
        faces: split.faces,
        vertex_count: split.vertex_count,
        owner,
        compact,
    }
}

/// One base vertex's chart.
struct Chart {
    /// Per star triangle (index into the base triangles), the 2D places of
    /// its corners.
    star: HashMap<u32, [DVec2; 3]>,
    /// The input triangles drawn in the star's own triangles.
    drawn: Drawn,
    /// Input triangles that reach into the unfolded triangles around the
    /// star, looked up in where none of the star's own holds a point.
    outer: Drawn,
}

/// A lookup in [`Drawn`]: the smallest barycentric coordinate (non-negative
/// inside), the input triangle and the coordinates.
type Near = (f64, u32, [f64; 3]);

/// Drawn input triangles (index and 2D corners) and their buckets.
struct Drawn {
    triangles: Vec<(u32, [DVec2; 3])>,
    grid: Buckets,
}

impl Drawn {
    fn new(triangles: Vec<(u32, [DVec2; 3])>) -> Drawn {
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
    /// small triangles there. On snowden's glasses, samples taken on such a
    /// triangle lay on the far side of the frame, and the 0.1% of the
    /// remesh's quads with the most error held 96% of it.
    fn nearest(&self, x: DVec2) -> Option<Near> {
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
fn barycentric(q: &[DVec2; 3], x: DVec2) -> [f64; 3] {
    let area = (q[1] - q[0]).perp_dot(q[2] - q[0]);
    [
        (q[1] - x).perp_dot(q[2] - x) / area,
        (q[2] - x).perp_dot(q[0] - x) / area,
        (q[0] - x).perp_dot(q[1] - x) / area,
    ]
}

/// Where a lookup landed: input triangle, barycentric coordinates, and
/// whether it was inside (not the nearest outside).
#[derive(Clone, Copy)]
struct Hit {
    /// The smallest barycentric coordinate before clamping.
    worst: f64,
    /// On one of the star's own triangles, not an outer one.
    own: bool,
    triangle: u32,
    bary: [f64; 3],
    inside: bool,
}

impl Chart {
    fn locate(&self, x: DVec2) -> Option<Hit> {
        let mut best = self.drawn.nearest(x);
        let mut own = true;
        if best.is_none_or(|b| b.0 < -1e-9)
            && let Some(outer) = self.outer.nearest(x)
            && best.is_none_or(|b| outer.0 > b.0)
        {
            best = Some(outer);
            own = false;
        }
        if best.is_none() {
            for (t, q) in &self.drawn.triangles {
                let l = barycentric(q, x);
                let worst = l[0].min(l[1]).min(l[2]);
                if best.is_none_or(|b| worst > b.0) {
                    best = Some((worst, *t, l));
                }
            }
        }
        let (worst, triangle, mut l) = best?;
        if worst < 0.0 {
            for v in &mut l {
                *v = v.max(0.0);
            }
            let s: f64 = l.iter().sum();
            for v in &mut l {
                *v /= s;
            }
        }
        Some(Hit {
            worst,
            own,
            triangle,
            bary: l,
            inside: worst >= -1e-9,
        })
    }
}

/// The 2D places of `a`'s ring vertices: each star triangle keeps its edge
/// lengths at `a`, and the angles at `a` are scaled to a full turn (on a
/// boundary, only as far as needed to stay under one). So a base triangle
/// and its neighbour across an edge sit almost as in 3D in the charts of
/// both ends of that edge, and the two charts agree where their quads meet.
/// Where a scaled angle would open beyond `0.9 pi`, the angles are spread
/// evenly instead.
fn flatten_star(a: DVec3, ring: &[DVec3], closed: bool, triangles: usize) -> Vec<DVec2> {
    let k = ring.len();
    let spokes: Vec<DVec3> = ring.iter().map(|&p| p - a).collect();
    let lengths: Vec<f64> = spokes.iter().map(|s| s.length()).collect();
    let angles: Vec<f64> = (0..triangles)
        .map(|i| spokes[i].angle_between(spokes[(i + 1) % k]))
        .collect();
    let total: f64 = angles.iter().sum();
    let scale = if closed {
        std::f64::consts::TAU / total
    } else {
        (1.8 * std::f64::consts::PI / total).min(1.0)
    };
    let turn = if closed {
        std::f64::consts::TAU
    } else {
        std::f64::consts::PI
    };
    let kept = total > 0.0
        && lengths.iter().all(|&l| l > 0.0)
        && angles
            .iter()
            .all(|&t| t > 0.0 && t * scale < 0.9 * std::f64::consts::PI);
    let step: Vec<f64> = if kept {
        angles.iter().map(|&t| t * scale).collect()
    } else {
        let even = (turn / triangles as f64).min(2.0 * std::f64::consts::FRAC_PI_3);
        vec![even; triangles]
    };
    let mean = lengths.iter().sum::<f64>() / k as f64;
    let mut phi = 0.0f64;
    (0..k)
        .map(|i| {
            let r = if lengths[i] > 0.0 {
                lengths[i]
            } else {
                mean.max(1e-300)
            };
            let p = DVec2::new(r * phi.cos(), r * phi.sin());
            if i < step.len() {
                phi += step[i];
            }
            p
        })
        .collect()
}

/// Per sampled point: its surface position, input triangle, whether a
/// drawn triangle held it (else it was clamped onto the nearest), and
/// whether it lies on a feature line.
type Sampled = (DVec3, u32, bool, bool);

/// Drawn input triangles of a chart: turned over, and turned the right way.
type Orientations = (Vec<u32>, Vec<u32>);

/// A quad's samples and fine nodes (row-major), with the quad's index.
type QuadSamples = (usize, Vec<Option<Sampled>>, Vec<Option<Sampled>>);

/// Charts [`resample`] samples at a time.
const CHART_BATCH: usize = 64;

/// Samples `mesh` through `base` at level `level`: a patch of `3 T` base
/// quads for `T` base triangles, fitted with `fit_rounds` rounds. Also
/// returns how many input triangles fold in the charts that sample them.
pub fn resample(
    mesh: &TriMesh,
    base: &Base,
    domain: &Domain,
    level: u32,
    fit_rounds: usize,
) -> Result<(Patch, usize)> {
    let quads = quads(&base.triangles);
    let base_mesh = BaseMesh::new(quads.vertex_count, quads.faces.clone()).map_err(|e| {
        Error::remesh(RemeshFailure::Step(format!(
            "the base domain is not a valid quad mesh: {e}"
        )))
    })?;
    let layout = Layout::new(base_mesh, level)?;
    let n = layout.n();

    // Input vertices per base triangle, and triangles per input vertex.
    let mut in_face: Vec<Vec<u32>> = vec![Vec::new(); base.triangles.len()];
    for (v, l) in base.location.iter().enumerate() {
        if let Location::Face(f, _) = *l {
            in_face[f as usize].push(v as u32);
        }
    }
    let (star, vertex_triangles) = (&domain.stars, &domain.around);
    let mut vertices: Vec<u32> = star.keys().collect();
    vertices.sort_unstable_by_key(|v| quads.compact[v]);

    // Quads per base vertex.
    let mut quads_at: HashMap<u32, Vec<usize>> = HashMap::new();
    for (q, &(t, c)) in quads.owner.iter().enumerate() {
        quads_at
            .entry(base.triangles[t as usize][c as usize])
            .or_default()
            .push(q);
    }

    let lines = feature_edges(mesh, base, vertex_triangles);
    let side = n + 1;
    let fine_side = 2 * n + 1;
    let fine_wanted = fit_rounds > 0;
    // Per chart: (quad, samples row-major, fine nodes row-major), and folds.
    let sample_chart = |&a: &u32| -> (Vec<QuadSamples>, Orientations) {
        let chart = build_chart(a, &star[&a], mesh, base, &in_face, vertex_triangles);
        let folded = chart.orientations(mesh, &domain.held);
        let chart = chart.chart;
        let mut out = Vec::new();
        // The charts of the triangles' other corners, for the points
        // this chart holds on no own triangle, made when first needed.
        let mut others: HashMap<u32, Chart> = HashMap::new();
        for &q in &quads_at[&a] {
            let (t, c) = quads.owner[q];
            let corners = quad_corners(c as usize);
            let place = chart.star[&t];
            let mut sample = |s: f64, u: f64| -> Option<Sampled> {
                let b = bilinear(&corners, s, u);
                if let Some(on) = on_line(&lines, base.triangles[t as usize], b) {
                    return Some(on);
                }
                let x = place[0] * b[0] + place[1] * b[1] + place[2] * b[2];
                // A point on none of this chart's own triangles (only
                // on an outer one, or nearest to one) is looked up in
                // the charts of the triangle's other corners too, and
                // the best lookup taken: inside first, then on an own
                // triangle, then nearest.
                let good = |h: &Hit| h.inside && h.own;
                let mut hit = chart.locate(x);
                for o in base.triangles[t as usize] {
                    if o == a || hit.as_ref().is_some_and(good) {
                        continue;
                    }
                    let other = others.entry(o).or_insert_with(|| {
                        build_chart(o, &star[&o], mesh, base, &in_face, vertex_triangles).chart
                    });
                    if let Some(p) = other.star.get(&t)
                        && let Some(h) = other.locate(p[0] * b[0] + p[1] * b[1] + p[2] * b[2])
                        && hit
                            .is_none_or(|g| (h.inside, h.own, h.worst) > (g.inside, g.own, g.worst))
                    {
                        hit = Some(h);
                    }
                }
                let hit = hit?;
                let tri = mesh.triangles[hit.triangle as usize];
                let p = mesh.positions[tri[0] as usize] * hit.bary[0]
                    + mesh.positions[tri[1] as usize] * hit.bary[1]
                    + mesh.positions[tri[2] as usize] * hit.bary[2];
                Some((p, hit.triangle, hit.inside, false))
            };
            let fine: Vec<Option<Sampled>> = if fine_wanted {
                (0..fine_side * fine_side)
                    .map(|g| {
                        sample(
                            (g % fine_side) as f64 / (2 * n) as f64,
                            (g / fine_side) as f64 / (2 * n) as f64,
                        )
                    })
                    .collect()
            } else {
                Vec::new()
            };
            // The samples are the fine nodes of even row and column
            // (`2i / 2n` rounds as `i / n` does), else looked up.
            let grid: Vec<Option<Sampled>> = (0..side * side)
                .map(|g| {
                    let (i, j) = (g % side, g / side);
                    if fine_wanted {
                        fine[2 * j * fine_side + 2 * i]
                    } else {
                        sample(i as f64 / n as f64, j as f64 / n as f64)
                    }
                })
                .collect();
            out.push((q, grid, fine));
        }
        (out, folded)
    };

    let samples = layout.sample_count();
    let mut positions = vec![DVec3::ZERO; samples];
    let mut triangles = vec![u32::MAX; samples];
    let mut fine = vec![
        DVec3::ZERO;
        if fine_wanted {
            layout.face_count() * fine_side * fine_side
        } else {
            0
        }
    ];
    let mut uncovered = 0usize;
    let mut clamped = 0usize;
    let mut pinned = vec![false; samples];
    // A triangle is folded in the map if it is turned over in every chart
    // that draws it: one turned over in one chart only is the chart's
    // layout (its angles scaled to a turn), not the map.
    let mut turned = std::collections::HashSet::new();
    let mut right = std::collections::HashSet::new();
    // Charts are sampled a batch at a time, so that only a batch's samples
    // wait to be numbered (five 32-byte entries a sample; all of them held
    // took the bunny's remesh to a 372 MB peak here, 302 MB by batches),
    // and numbered in order, as before: a sample on an edge two charts
    // share is the first's.
    for batch in vertices.chunks(CHART_BATCH) {
        let per_chart: Vec<_> = batch.par_iter().map(sample_chart).collect();
        for (chart, f) in per_chart {
            turned.extend(f.0);
            right.extend(f.1);
            for (q, grid, nodes) in chart {
                for (g, s) in grid.into_iter().enumerate() {
                    let id = layout.face_grid(q)[g] as usize;
                    if triangles[id] != u32::MAX {
                        continue;
                    }
                    match s {
                        Some((p, t, inside, line)) => {
                            positions[id] = p;
                            triangles[id] = t;
                            pinned[id] = line;
                            clamped += usize::from(!inside);
                        }
                        None => uncovered += 1,
                    }
                }
                for (g, s) in nodes.into_iter().enumerate() {
                    if let Some((p, ..)) = s {
                        fine[q * fine_side * fine_side + g] = p;
                    }
                }
            }
        }
    }
    let folded = turned.iter().filter(|t| !right.contains(*t)).count();
    if uncovered > 0 {
        return Err(Error::remesh(RemeshFailure::Step(format!(
            "{uncovered} samples fell outside every chart"
        ))));
    }
    let grids: Vec<u32> = (0..layout.face_count())
        .flat_map(|f| layout.face_grid(f).iter().copied())
        .collect();
    if fine_wanted {
        fit_grids(&mut positions, &grids, &fine, n, fit_rounds);
    }
    Ok((
        Patch {
            faces: quads.faces,
            base_vertices: quads.vertex_count,
            grids,
            positions,
            triangles,
            uncovered: clamped,
            pinned,
        },
        folded,
    ))
}

/// The input's feature lines along base edges: per base edge (its ends in
/// order), the polyline of input vertices the map lays on it, by their
/// place along the edge, each segment with an input triangle at it (the
/// last point's is unused).
type Lines = HashMap<(u32, u32), Vec<(f64, DVec3, u32)>>;

fn feature_edges(mesh: &TriMesh, base: &Base, around: &[Vec<u32>]) -> Lines {
    let mut lines: Lines = HashMap::new();
    for (v, l) in base.location.iter().enumerate() {
        let Location::Face(f, b) = *l else { continue };
        if !base.feature[v] {
            continue;
        }
        let Some(k) = (0..3).min_by(|&i, &j| b[i].total_cmp(&b[j])) else {
            continue;
        };
        if b[k] > 1e-9 {
            continue;
        }
        let (key, t) = along_edge(base.triangles[f as usize], b, k);
        lines
            .entry(key)
            .or_default()
            .push((t, mesh.positions[v], v as u32));
    }
    let shared = |a: u32, b: u32| {
        around[a as usize]
            .iter()
            .copied()
            .find(|&t| mesh.triangles[t as usize].contains(&b))
    };
    for ((u, w), line) in &mut lines {
        line.push((0.0, mesh.positions[*u as usize], *u));
        line.push((1.0, mesh.positions[*w as usize], *w));
        line.sort_by(|a, b| a.0.total_cmp(&b.0));
        // Each point then names the input triangle of the segment from it
        // to the next; a polyline whose consecutive points are not input
        // edges is no feature line (dropped below).
        for i in 0..line.len() - 1 {
            let t = shared(line[i].2, line[i + 1].2).unwrap_or(u32::MAX);
            line[i].2 = t;
        }
    }
    lines.retain(|_, line| line[..line.len() - 1].iter().all(|p| p.2 != u32::MAX));
    // A base edge that is itself an input edge between feature vertices
    // holds no input vertex inside: its line is the one segment.
    for tri in &base.triangles {
        for k in 0..3 {
            let (u, w) = (tri[k].min(tri[(k + 1) % 3]), tri[k].max(tri[(k + 1) % 3]));
            if lines.contains_key(&(u, w))
                || !(base.feature[u as usize] && base.feature[w as usize])
            {
                continue;
            }
            if let Some(t) = shared(u, w) {
                let ends = [
                    (0.0, mesh.positions[u as usize], t),
                    (1.0, mesh.positions[w as usize], t),
                ];
                lines.insert((u, w), ends.to_vec());
            }
        }
    }
    lines
}

/// The base edge of `tri` opposite its corner `k`, as an ordered vertex
/// pair, and where barycentric point `b` (on that edge) lies along it, from
/// the pair's first vertex.
fn along_edge(tri: [u32; 3], b: [f64; 3], k: usize) -> ((u32, u32), f64) {
    let (u, w) = (tri[(k + 1) % 3], tri[(k + 2) % 3]);
    if u < w {
        ((u, w), b[(k + 2) % 3])
    } else {
        ((w, u), b[(k + 1) % 3])
    }
}

/// A sample on a base edge along a feature line: its point on the line's
/// input polyline, at the same place along the edge.
fn on_line(lines: &Lines, tri: [u32; 3], b: [f64; 3]) -> Option<Sampled> {
    let k = (0..3).find(|&k| b[k] <= 1e-12)?;
    let (key, t) = along_edge(tri, b, k);
    let line = lines.get(&key)?;
    let i = line.partition_point(|p| p.0 <= t).clamp(1, line.len() - 1) - 1;
    let (a, z) = (line[i], line[i + 1]);
    let r = if z.0 > a.0 {
        (t - a.0) / (z.0 - a.0)
    } else {
        0.0
    };
    Some((a.1.lerp(z.1, r.clamp(0.0, 1.0)), a.2, true, true))
}

struct Built {
    chart: Chart,
    /// Every drawn triangle, folded or not, and its signed area.
    all: Vec<(u32, [DVec2; 3])>,
    areas: Vec<f64>,
    /// The triangles drawn the right way partly in the unfolded ones.
    outer_right: Vec<u32>,
}

impl Built {
    /// The drawn triangles, split into those turned over in this chart and
    /// those turned the right way.
    ///
    /// A triangle whose three corners lie on feature lines, or are held
    /// between them, is neither: the map lays feature lines straight along
    /// base edges, so an ear of a ragged boundary (two boundary edges) has
    /// no area there, nor has a vertex whose neighbours all lie on one.
    fn orientations(&self, mesh: &TriMesh, held: &[bool]) -> Orientations {
        let (mut folded, mut right) = (Vec::new(), self.outer_right.clone());
        for ((t, _), &area) in self.all.iter().zip(&self.areas) {
            let on_lines = mesh.triangles[*t as usize]
                .iter()
                .all(|&v| held[v as usize]);
            if area > 0.0 {
                right.push(*t);
            } else if !on_lines {
                folded.push(*t);
            }
        }
        (folded, right)
    }
}

/// One base vertex's star: its triangles, each with its corners' 2D places
/// in the vertex's chart (the vertex at the origin), then the triangles
/// across its outer edges, unfolded.
pub(super) struct Star {
    places: Vec<(u32, [DVec2; 3])>,
    /// How many of `places` are the star's own.
    proper: usize,
}

impl Star {
    /// The star's own triangles' places, and (`wide`) the unfolded ones.
    fn drawn(&self, wide: bool) -> &[(u32, [DVec2; 3])] {
        &self.places[..if wide { self.places.len() } else { self.proper }]
    }

    /// The map's location of chart point `x`: the base triangle (among
    /// [`Star::drawn`]) that holds it, and its barycentric coordinates.
    fn locate(&self, x: DVec2, wide: bool) -> Option<Location> {
        self.drawn(wide).iter().find_map(|(t, place)| {
            let l = barycentric(place, x);
            l.iter().all(|&v| v >= 0.0).then_some(Location::Face(*t, l))
        })
    }
}

/// The stars of every base vertex of `base`, keyed by component vertex.
fn stars(mesh: &TriMesh, base: &Base) -> Result<Stars> {
    let mut around: HashMap<u32, Vec<u32>> = HashMap::new();
    for (t, tri) in base.triangles.iter().enumerate() {
        for &v in tri {
            around.entry(v).or_default().push(t as u32);
        }
    }
    let mut across: HashMap<(u32, u32), u32> = HashMap::new();
    for (t, tri) in base.triangles.iter().enumerate() {
        for i in 0..3 {
            across.insert((tri[i], tri[(i + 1) % 3]), t as u32);
        }
    }
    around
        .into_iter()
        .map(|(a, star)| {
            let Ring {
                verts: ring,
                faces: order,
                closed,
            } = ring(a, &star, &base.triangles).ok_or_else(|| {
                Error::remesh(RemeshFailure::Step(format!(
                    "the base domain's triangles around base vertex {a} are not one fan"
                )))
            })?;
            let ring_positions: Vec<DVec3> =
                ring.iter().map(|&w| mesh.positions[w as usize]).collect();
            let flat = flatten_star(
                mesh.positions[a as usize],
                &ring_positions,
                closed,
                order.len(),
            );
            let place_of = |w: u32| -> DVec2 {
                if w == a {
                    DVec2::ZERO
                } else {
                    ring.iter()
                        .position(|&x| x == w)
                        .map_or(DVec2::ZERO, |i| flat[i])
                }
            };
            let mut places: Vec<(u32, [DVec2; 3])> = order
                .iter()
                .map(|&t| (t, base.triangles[t as usize].map(place_of)))
                .collect();
            // The triangles across the star's outer edges, unfolded there
            // with their own shape: input triangles that reach out of the
            // star near its quads are drawn whole.
            for i in 0..order.len() {
                let (w0, w1) = (ring[i], ring[(i + 1) % ring.len()]);
                let Some(&t) = across.get(&(w1, w0)) else {
                    continue;
                };
                if places.iter().any(|(s, _)| *s == t) {
                    continue;
                }
                let tri = base.triangles[t as usize];
                let Some(x) = tri.iter().copied().find(|&v| v != w0 && v != w1) else {
                    continue;
                };
                let (p0, p1, px) = (
                    mesh.positions[w0 as usize],
                    mesh.positions[w1 as usize],
                    mesh.positions[x as usize],
                );
                let e = p1 - p0;
                let len2 = e.length_squared();
                if len2.is_nan() || len2 <= 0.0 {
                    continue;
                }
                let along = (px - p0).dot(e) / len2;
                let perp = ((px - p0) - e * along).length() / len2.sqrt();
                let (q0, q1) = (flat[i], flat[(i + 1) % flat.len()]);
                let d = q1 - q0;
                let right = DVec2::new(d.y, -d.x);
                let qx = q0 + d * along + right * perp;
                let place = tri.map(|v| {
                    if v == w0 {
                        q0
                    } else if v == w1 {
                        q1
                    } else {
                        qx
                    }
                });
                places.push((t, place));
            }
            let proper = order.len();
            Ok((a, Star { places, proper }))
        })
        .try_fold(
            Stars(
                std::iter::repeat_with(|| None)
                    .take(mesh.positions.len())
                    .collect(),
            ),
            |mut stars, star: Result<(u32, Star)>| {
                let (a, star) = star?;
                stars.0[a as usize] = Some(star);
                Ok(stars)
            },
        )
}

/// The stars of a component's base vertices, by component vertex.
pub(super) struct Stars(Vec<Option<Star>>);

impl Stars {
    /// The base vertices, in order.
    fn keys(&self) -> impl Iterator<Item = u32> + '_ {
        (0..self.0.len() as u32).filter(|&v| self.0[v as usize].is_some())
    }
}

impl std::ops::Index<&u32> for Stars {
    type Output = Star;

    /// Base vertex `a`'s star; panics if `a` is not a base vertex.
    fn index(&self, a: &u32) -> &Star {
        self.0[*a as usize].as_ref().expect("a base vertex")
    }
}

/// What sampling and untangling share of a component and its base domain:
/// every base vertex's star (which only the base triangles decide, not the
/// map) and the input triangles at each input vertex.
pub(super) struct Domain {
    stars: Stars,
    around: Vec<Vec<u32>>,
    /// Per input vertex: whether the map holds it on a feature line, or
    /// between such vertices and base vertices only.
    held: Vec<bool>,
}

impl Domain {
    pub(super) fn new(mesh: &TriMesh, base: &Base) -> Result<Domain> {
        let mut around: Vec<Vec<u32>> = vec![Vec::new(); mesh.positions.len()];
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for &v in tri {
                around[v as usize].push(t as u32);
            }
        }
        let fixed =
            |v: u32| base.feature[v as usize] || base.location[v as usize] == Location::Vertex;
        let held = (0..mesh.positions.len() as u32)
            .map(|v| {
                base.feature[v as usize]
                    || around[v as usize].iter().all(|&t| {
                        mesh.triangles[t as usize]
                            .iter()
                            .all(|&w| w == v || fixed(w))
                    })
            })
            .collect();
        Ok(Domain {
            stars: stars(mesh, base)?,
            around,
            held,
        })
    }
}

/// The map of the input onto the base domain, perhaps with one vertex
/// moved to a trial location (a relaxation's probe), so that vertices of
/// one colour can probe their moves side by side.
#[derive(Clone, Copy)]
struct Map<'a> {
    base: &'a Base,
    moved: u32,
    to: Location,
}

impl<'a> Map<'a> {
    fn new(base: &'a Base) -> Map<'a> {
        Map {
            base,
            moved: u32::MAX,
            to: Location::Vertex,
        }
    }

    /// This map with input vertex `p` at `to`.
    fn moving(self, p: u32, to: Location) -> Map<'a> {
        Map {
            moved: p,
            to,
            ..self
        }
    }

    fn location(&self, v: u32) -> Location {
        if v == self.moved {
            self.to
        } else {
            self.base.location[v as usize]
        }
    }
}

/// The place of input vertex `v` in the chart of `star` (centred on `a`),
/// if the map puts it in the star's own triangles (or, `wide`, in those
/// unfolded around it too).
fn place_in(star: &Star, a: u32, v: u32, map: Map, wide: bool) -> Option<DVec2> {
    let star = star.drawn(wide);
    match map.location(v) {
        Location::Vertex => {
            if v == a {
                return Some(DVec2::ZERO);
            }
            star.iter().find_map(|(t, place)| {
                let c = map.base.triangles[*t as usize]
                    .iter()
                    .position(|&w| w == v)?;
                Some(place[c])
            })
        }
        Location::Face(f, b) => {
            let (_, place) = star.iter().find(|(t, _)| *t == f)?;
            Some(place[0] * b[0] + place[1] * b[1] + place[2] * b[2])
        }
    }
}

/// Untangles the map of the input onto `base` where it folds: an input
/// vertex (not a base vertex, not on a feature line) with a triangle turned
/// over in the chart of its nearest base vertex moves into the kernel of
/// its ring there (cyclic projection onto its edges' half-planes, from its
/// place and else from the mean of its neighbours), when that turns fewer
/// of its triangles over. Sweeps repeat, over the vertices still folded and
/// the neighbours of those moved, up to `rounds` times.
///
/// Nothing else moves: smoothing the whole map (mean-value or uniform
/// weights, with or without stretch reweighting) sampled the development
/// models and scans worse than the map the simplification leaves
/// (docs/remesher-next.md).
pub(super) fn untangle_map(mesh: &TriMesh, base: &mut Base, domain: &Domain, rounds: usize) {
    let (stars, around) = (&domain.stars, &domain.around);
    let n = mesh.positions.len();
    let mut todo: Vec<u32> = (0..n as u32).collect();
    for _ in 0..rounds {
        let mut next = Vec::new();
        for &p in &todo {
            if let Some(moved) = untangle_vertex(mesh, base, stars, around, p) {
                if moved {
                    for &t in &around[p as usize] {
                        next.extend(mesh.triangles[t as usize]);
                    }
                } else {
                    next.push(p);
                }
            }
        }
        next.sort_unstable();
        next.dedup();
        if next.is_empty() {
            break;
        }
        todo = next;
    }
}

/// One untangling step of `p`: `None` if none of its triangles is turned
/// over (or it may not move), else whether it moved.
fn untangle_vertex(
    mesh: &TriMesh,
    base: &mut Base,
    stars: &Stars,
    around: &[Vec<u32>],
    p: u32,
) -> Option<bool> {
    let Location::Face(f, b) = base.location[p as usize] else {
        return None;
    };
    if base.feature[p as usize] {
        return None;
    }
    let tri = base.triangles[f as usize];
    // The charts of its base triangle's corners, nearest first: the first
    // that holds its ring decides whether it is folded.
    let mut corners = [0usize, 1, 2];
    corners.sort_by(|&i, &j| b[j].total_cmp(&b[i]));
    let mut tried = None;
    for c in corners {
        let a = tri[c];
        let star = &stars[&a];
        let place = |w: u32| place_in(star, a, w, Map::new(base), false);
        // Turned-over triangles, and their total area turned over: a move
        // that turns none back but less area over is progress too, the way
        // a knot of several vertices comes undone over the sweeps.
        let folds = |x: DVec2| -> Option<(usize, f64)> {
            let mut count = 0;
            let mut over = 0.0;
            for &t in &around[p as usize] {
                let tri = mesh.triangles[t as usize];
                let k = tri.iter().position(|&w| w == p)?;
                let (q, r) = (place(tri[(k + 1) % 3])?, place(tri[(k + 2) % 3])?);
                let area = (q - x).perp_dot(r - x);
                if area <= 0.0 {
                    count += 1;
                    over -= area;
                }
            }
            Some((count, over))
        };
        let Some(now) = place(p) else { continue };
        let Some(before) = folds(now) else { continue };
        if before.0 == 0 {
            return tried;
        }
        tried = Some(false);
        let mut mean = DVec2::ZERO;
        let mut count = 0.0f64;
        for &t in &around[p as usize] {
            for w in mesh.triangles[t as usize] {
                if w != p
                    && let Some(x) = place(w)
                {
                    mean += x;
                    count += 1.0;
                }
            }
        }
        let starts = [now, mean / count.max(1.0)];
        // And steps up the gradient of the turned-over area.
        let mut uphill = DVec2::ZERO;
        let mut reach = 0.0f64;
        for &t in &around[p as usize] {
            let tri = mesh.triangles[t as usize];
            let k = tri.iter().position(|&w| w == p)?;
            let (Some(q), Some(r)) = (place(tri[(k + 1) % 3]), place(tri[(k + 2) % 3])) else {
                continue;
            };
            reach = reach.max((r - q).length());
            if (q - now).perp_dot(r - now) <= 0.0 {
                let e = r - q;
                uphill += DVec2::new(-e.y, e.x);
            }
        }
        let steps = (uphill.length() > 0.0).then(|| uphill.normalize() * reach);
        let best = starts
            .iter()
            .filter_map(|&x0| untangle(mesh, &around[p as usize], p, x0, place))
            .chain(
                steps
                    .into_iter()
                    .flat_map(|d| [0.02, 0.05, 0.1, 0.2, 0.4].map(|f| now + d * f)),
            )
            .filter_map(|y| folds(y).map(|k| (k, y)))
            .min_by(|a, b| a.0.0.cmp(&b.0.0).then(a.0.1.total_cmp(&b.0.1)));
        let Some((after, x)) = best else { continue };
        if after.0 > before.0 || (after.0 == before.0 && after.1 >= 0.5 * before.1) {
            continue;
        }
        if let Some(l) = star.locate(x, false) {
            base.location[p as usize] = l;
            return Some(true);
        }
    }
    tried
}

/// The knots single moves leave (rings whose kernel is empty in every
/// chart) come undone by moving their neighbourhoods together: Gauss-Seidel
/// sweeps over the free vertices within some rings of a folded one, each
/// moved down the energy of its triangles. A triangle's energy is its
/// conformal distortion (MIPS, `|J|^2 / det J`, J the map from the input
/// triangle to its drawing) with Escobar et al.'s regularized determinant
/// `(det + sqrt(det^2 + 4 delta^2)) / 2`, so that a turned-over triangle
/// has a finite energy that falls towards unfolding, taken in the chart
/// that draws it best, plus a large penalty where every chart draws it
/// turned over (a fold, as sampling counts it). Every triangle is thus
/// judged the same way whichever of its corners moves. The neighbourhood
/// widens while folds remain.
///
/// Returns the triangles still folded, early (after a sweep with the fold
/// penalty) where `hopeless` says of them that they are too many to be
/// worth going on for.
pub(super) fn untangle_knots(
    mesh: &TriMesh,
    base: &mut Base,
    domain: &Domain,
    sweeps: usize,
    hopeless: &dyn Fn(&Base, &[u32]) -> bool,
) -> Vec<u32> {
    let mut knots = Knots::new(mesh, domain);
    let n = mesh.positions.len();
    let folded_now = |knots: &Knots, base: &Base| -> Vec<u32> {
        (0..mesh.triangles.len() as u32)
            .filter(|&t| knots.folded(Map::new(base), t))
            .collect()
    };
    let mut folded = folded_now(&knots, base);
    for reach in [2usize, 4, 8, 16] {
        if folded.is_empty() {
            break;
        }
        // The neighbourhood: `reach` rings around the folded triangles.
        let mut inside = vec![false; n];
        let mut front: Vec<u32> = folded
            .iter()
            .flat_map(|&t| mesh.triangles[t as usize])
            .collect();
        for &p in &front {
            inside[p as usize] = true;
        }
        for _ in 0..reach {
            let mut next = Vec::new();
            for &p in &front {
                for &t in &domain.around[p as usize] {
                    for w in mesh.triangles[t as usize] {
                        if !inside[w as usize] {
                            inside[w as usize] = true;
                            next.push(w);
                        }
                    }
                }
            }
            front = next;
        }
        let region: Vec<u32> = (0..n as u32)
            .filter(|&p| inside[p as usize] && knots.movable(base, p))
            .collect();
        // With the fold penalty first; where folds remain, the smooth
        // energy alone and then the penalty again, kept if it leaves fewer.
        knots.penalty = FOLD_PENALTY;
        knots.sweep(base, &region, &inside, sweeps);
        folded = folded_now(&knots, base);
        if hopeless(base, &folded) {
            break;
        }
        if !folded.is_empty() {
            let kept = base.location.clone();
            knots.penalty = 0.0;
            knots.sweep(base, &region, &inside, sweeps);
            knots.penalty = FOLD_PENALTY;
            knots.sweep(base, &region, &inside, sweeps);
            let after = folded_now(&knots, base);
            if after.len() < folded.len() {
                folded = after;
            } else {
                base.location = kept;
            }
        }
    }
    folded
}

/// Evens out the map's stretch, so that sampling density follows the
/// surface (PGC smooths its MAPS map for the same reason): Gauss-Seidel
/// sweeps over every free vertex, each moved down the symmetric Dirichlet
/// energy (`|J|^2 + |J^-1|^2`, times the input triangle's area) of its
/// triangles, J against the part's median ratio of drawn to input area, in
/// the chart that draws each worst. The energy is infinite for a triangle
/// turned over in every chart, so no move folds one, and a triangle turned
/// over in some charts but not all pays [`PLEAT_PENALTY`].
///
/// Any chart that draws a triangle may sample it, so each must draw it
/// well: with the best chart's energy alone the relaxation turned triangles
/// over in the charts that did not count. Unlike harmonic or mean-value
/// smoothing, this weighs compression and expansion alike: a protrusion the
/// simplification squeezed into a sliver of a base triangle, which sampling
/// all but skipped, opens up (docs/decisions/004-chart-map-relaxation.md).
pub(super) fn relax_stretch(mesh: &TriMesh, base: &mut Base, domain: &Domain, sweeps: usize) {
    let mut knots = Knots::new(mesh, domain);
    let mut ratios: Vec<f64> = (0..mesh.triangles.len() as u32)
        .map(|t| knots.area_ratio(Map::new(base), t))
        .filter(|r| *r > 0.0)
        .collect();
    if ratios.is_empty() {
        return;
    }
    let middle = ratios.len() / 2;
    let median = *ratios.select_nth_unstable_by(middle, f64::total_cmp).1;
    let n = mesh.positions.len();
    let inside = vec![true; n];
    let region: Vec<u32> = (0..n as u32).filter(|&p| knots.movable(base, p)).collect();
    let area = mesh
        .triangles
        .iter()
        .map(|t| triangle_area(mesh.corners(t)))
        .collect();
    knots.stretch = Some((median, area));
    knots.sweep(base, &region, &inside, sweeps);
}

/// The penalty of a fold in [`untangle_knots`]' energy, against a
/// distortion of at least 2 per triangle.
const FOLD_PENALTY: f64 = 1e4;

/// The penalty, per unit of input area, of a triangle turned over in some
/// of the charts that draw it (a pleat) in [`relax_stretch`]' energy,
/// against at least 4 for an undistorted one. A finite penalty lets the
/// vertices around a pleat move to undo it; an infinite one froze them
/// (docs/decisions/004-chart-map-relaxation.md).
const PLEAT_PENALTY: f64 = 1000.0;

/// How many times its last step a vertex's line search starts from when
/// relaxing the stretch ([`Knots::relax`]): about half the ring energies
/// of starting from half the ring's size, at the same PSNR; a step that can
/// only shrink samples worse (docs/decisions/004-chart-map-relaxation.md).
const STEP_GROWTH: f64 = 2.0;

/// The regularization of the determinant in [`untangle_knots`]' energy,
/// relative to the input triangle's own area.
const UNTANGLE_DELTA: f64 = 1e-2;

/// What [`untangle_knots`] reads: the stars, the input's adjacency, and
/// each input triangle's own 2D shape (inverted).
struct Knots<'a> {
    mesh: &'a TriMesh,
    domain: &'a Domain,
    shapes: Vec<DMat2>,
    /// The penalty of a fold now: none while the smooth energy alone
    /// untangles, [`FOLD_PENALTY`] after.
    penalty: f64,
    /// Where set, the energy is the stretch (symmetric Dirichlet, times
    /// the triangle's area) against this scale of the map's determinant,
    /// not the conformal distortion.
    stretch: Option<(f64, Vec<f64>)>,
    /// Per input vertex: the step its last move took (an `f64`'s bits), 0
    /// before any.
    steps: Vec<AtomicU64>,
    /// Per input vertex: a colour no neighbour has, so that the vertices of
    /// one colour move side by side.
    colours: Vec<u32>,
}

impl<'a> Knots<'a> {
    fn new(mesh: &'a TriMesh, domain: &'a Domain) -> Knots<'a> {
        let shapes = mesh
            .triangles
            .iter()
            .map(|tri| {
                let [o, a, b] = mesh.corners(tri);
                let (u, v) = (a - o, b - o);
                let len = u.length();
                let cross = u.cross(v).length();
                // A degenerate input triangle takes the equilateral shape.
                let shape = if len > 0.0 && cross > 1e-12 * len * len.max(v.length()) {
                    DMat2::from_cols(
                        DVec2::new(len, 0.0),
                        DVec2::new(u.dot(v) / len, cross / len),
                    )
                } else {
                    DMat2::from_cols(DVec2::new(1.0, 0.0), DVec2::new(0.5, 0.75f64.sqrt()))
                };
                shape.inverse()
            })
            .collect();
        Knots {
            mesh,
            domain,
            shapes,
            penalty: FOLD_PENALTY,
            stretch: None,
            steps: (0..mesh.positions.len())
                .map(|_| AtomicU64::new(0))
                .collect(),
            colours: colours(mesh, &domain.around),
        }
    }

    /// Gauss-Seidel sweeps over `region` (the vertices marked `inside`),
    /// each after the first over the neighbours of those that moved. The
    /// vertices of one colour move in parallel (none is another's
    /// neighbour, so none reads what another writes), the colours in turn:
    /// the result does not depend on the threads.
    fn sweep(&self, base: &mut Base, region: &[u32], inside: &[bool], sweeps: usize) {
        let mut active = region.to_vec();
        let mut classes: Vec<Vec<u32>> = Vec::new();
        for _ in 0..sweeps {
            for class in &mut classes {
                class.clear();
            }
            for &p in &active {
                let c = self.colours[p as usize] as usize;
                if classes.len() <= c {
                    classes.resize_with(c + 1, Vec::new);
                }
                classes[c].push(p);
            }
            let mut next = Vec::new();
            for class in &classes {
                let moves: Vec<(u32, Location, bool)> = class
                    .par_iter()
                    .with_min_len(64)
                    .filter_map(|&p| self.relax(base, p).map(|(l, wake)| (p, l, wake)))
                    .collect();
                for (p, l, wake) in moves {
                    base.location[p as usize] = l;
                    if wake {
                        for &t in &self.domain.around[p as usize] {
                            next.extend(
                                self.mesh.triangles[t as usize]
                                    .into_iter()
                                    .filter(|&w| inside[w as usize] && self.movable(base, w)),
                            );
                        }
                    }
                }
            }
            next.sort_unstable();
            next.dedup();
            if next.is_empty() {
                break;
            }
            active = next;
        }
    }

    fn movable(&self, base: &Base, p: u32) -> bool {
        matches!(base.location[p as usize], Location::Face(..)) && !self.domain.held[p as usize]
    }

    /// The base vertices whose charts may draw triangle `t`: the corners
    /// of its corners' base triangles.
    fn charts(&self, map: Map, t: u32) -> impl Iterator<Item = u32> + use<> {
        let mut out = [u32::MAX; 9];
        let mut len = 0;
        for v in self.mesh.triangles[t as usize] {
            let corners = match map.location(v) {
                Location::Vertex => [v, v, v],
                Location::Face(f, _) => map.base.triangles[f as usize],
            };
            for a in corners {
                if !out[..len].contains(&a) {
                    out[len] = a;
                    len += 1;
                }
            }
        }
        out.into_iter().take(len)
    }

    /// Triangle `t`'s drawings, in every chart that draws it whole.
    fn drawings(&self, map: Map, t: u32) -> impl Iterator<Item = [DVec2; 3]> {
        let tri = self.mesh.triangles[t as usize];
        self.charts(map, t).filter_map(move |a| {
            let star = &self.domain.stars[&a];
            Some([
                place_in(star, a, tri[0], map, true)?,
                place_in(star, a, tri[1], map, true)?,
                place_in(star, a, tri[2], map, true)?,
            ])
        })
    }

    /// Triangle `t`'s drawn area over its input area, in the chart that
    /// draws it largest (negative if every chart draws it turned over).
    fn area_ratio(&self, map: Map, t: u32) -> f64 {
        self.drawings(map, t)
            .map(|[p, q, r]| {
                (DMat2::from_cols(q - p, r - p) * self.shapes[t as usize]).determinant()
            })
            .fold(f64::NEG_INFINITY, f64::max)
    }

    /// Whether every chart that draws `t` draws it turned over, as sampling
    /// counts a fold (triangles held between feature lines aside).
    fn folded(&self, map: Map, t: u32) -> bool {
        if self.held(t) {
            return false;
        }
        let mut drawn = false;
        for [p, q, r] in self.drawings(map, t) {
            if drawn_right(p, q, r) {
                return false;
            }
            drawn = true;
        }
        drawn
    }

    /// Triangle `t`'s energy: [`Self::stretch_energy`] when relaxing the
    /// stretch, else [`Self::untangle_energy`].
    fn energy(&self, map: Map, t: u32) -> f64 {
        match &self.stretch {
            Some((scale, area)) => self.stretch_energy(map, t, *scale, area[t as usize]),
            None => self.untangle_energy(map, t),
        }
    }

    /// Whether all of triangle `t`'s corners lie on feature lines, where
    /// its orientation does not count.
    fn held(&self, t: u32) -> bool {
        let tri = self.mesh.triangles[t as usize];
        tri.iter().all(|&v| self.domain.held[v as usize])
    }

    /// Triangle `t`'s least distortion over the charts that draw it, plus
    /// the penalty if it is folded (or drawn in none).
    fn untangle_energy(&self, map: Map, t: u32) -> f64 {
        let mut best = f64::INFINITY;
        let mut right = self.held(t);
        for [p, q, r] in self.drawings(map, t) {
            right |= drawn_right(p, q, r);
            let j = DMat2::from_cols(q - p, r - p) * self.shapes[t as usize];
            let det = j.determinant();
            let norm = j.x_axis.length_squared() + j.y_axis.length_squared();
            let h = 0.5 * (det + (det * det + 4.0 * UNTANGLE_DELTA * UNTANGLE_DELTA).sqrt());
            if h > 0.0 {
                best = best.min(norm / h);
            }
        }
        if !best.is_finite() {
            return 2.0 * FOLD_PENALTY;
        }
        best + if right { 0.0 } else { self.penalty }
    }

    /// Triangle `t`'s symmetric Dirichlet energy (input area `area`,
    /// against the part's typical `scale`) in the chart that draws it
    /// worst, plus [`PLEAT_PENALTY`] if a chart draws it turned over.
    /// Infinite if every chart does, so relaxing never folds a triangle (nor
    /// lays one flat in every chart).
    fn stretch_energy(&self, map: Map, t: u32, scale: f64, area: f64) -> f64 {
        let held = self.held(t);
        let (mut right, mut pleat) = (held, false);
        let mut worst: Option<f64> = None;
        for [p, q, r] in self.drawings(map, t) {
            let this_right = drawn_right(p, q, r);
            right |= this_right;
            pleat |= !this_right;
            let j = DMat2::from_cols(q - p, r - p) * self.shapes[t as usize];
            let det = j.determinant() / scale;
            let norm = (j.x_axis.length_squared() + j.y_axis.length_squared()) / scale;
            if det > 0.0 {
                let e = area * norm * (1.0 + 1.0 / (det * det));
                worst = Some(worst.map_or(e, |w| w.max(e)));
            }
        }
        match worst {
            Some(w) if right => {
                w + if pleat && !held {
                    PLEAT_PENALTY * area
                } else {
                    0.0
                }
            }
            _ => f64::INFINITY,
        }
    }

    fn ring_energy(&self, map: Map, p: u32) -> f64 {
        self.domain.around[p as usize]
            .iter()
            .map(|&t| self.energy(map, t))
            .sum()
    }

    /// One Gauss-Seidel step at `p`: a few line-searched steps down its
    /// triangles' energy, proposed in the chart of the nearest corner of
    /// its base triangle (with the triangles unfolded around it), and, where
    /// one of its triangles is folded, the kernel of its ring there. Returns
    /// its new location and whether the move is worth waking its
    /// neighbours for; reads the map and writes nothing but its step.
    fn relax(&self, base: &Base, p: u32) -> Option<(Location, bool)> {
        let Location::Face(f, b) = base.location[p as usize] else {
            return None;
        };
        let map = Map::new(base);
        let tri = base.triangles[f as usize];
        let c = (0..3).max_by(|&i, &j| b[i].total_cmp(&b[j])).unwrap_or(0);
        let a = tri[c];
        let star = &self.domain.stars[&a];
        let start = place_in(star, a, p, map, true)?;
        // The ring's size, for steps.
        let mut size = 0.0f64;
        for &t in &self.domain.around[p as usize] {
            for w in self.mesh.triangles[t as usize] {
                if let Some(x) = place_in(star, a, w, map, true) {
                    size = size.max((x - start).length());
                }
            }
        }
        if size <= 0.0 {
            return None;
        }
        let at = |x: DVec2| -> Option<(f64, Location)> {
            let l = star.locate(x, true)?;
            Some((self.ring_energy(map.moving(p, l), p), l))
        };
        let first = self.ring_energy(map, p);
        let mut best = (start, first, base.location[p as usize]);
        // Relaxing the stretch starts from an unfolded map and keeps it so.
        let folded = self.stretch.is_none()
            && self.domain.around[p as usize]
                .iter()
                .any(|&t| self.folded(map, t));
        if folded
            && let Some(ring) =
                ring_chart(self.mesh, map, &self.domain.stars, &self.domain.around, p)
        {
            let edges = &ring.edges;
            let mean = edges.iter().map(|&(q, _)| q).sum::<DVec2>() / edges.len().max(1) as f64;
            let chart = &self.domain.stars[&ring.corner];
            for from in [ring.at, mean] {
                let Some(y) = kernel_point(edges, from) else {
                    continue;
                };
                let Some(l) = chart.locate(y, true) else {
                    continue;
                };
                let moved = map.moving(p, l);
                let e = self.ring_energy(moved, p);
                if e < best.1 {
                    // Back in the proposing chart, where the steps go on.
                    if let Some(x) = place_in(star, a, p, moved, true) {
                        best = (x, e, l);
                    }
                }
            }
        }
        for _ in 0..3 {
            let (x, e) = (best.0, best.1);
            let h = 1e-5 * size;
            let mut g = DVec2::ZERO;
            for (k, d) in [DVec2::X, DVec2::Y].into_iter().enumerate() {
                let Some((plus, _)) = at(x + d * h) else {
                    g = DVec2::ZERO;
                    break;
                };
                g[k] = plus - e;
            }
            if !g.is_finite() || g.length() <= 0.0 {
                break;
            }
            let d = -g.normalize();
            // Relaxing the stretch starts from twice the vertex's last
            // step: the map moves little from sweep to sweep.
            let remembered = f64::from_bits(self.steps[p as usize].load(Ordering::Relaxed));
            let mut step = if self.stretch.is_some() && remembered > 0.0 {
                (STEP_GROWTH * remembered).min(0.5 * size)
            } else {
                0.5 * size
            };
            let mut found = None;
            while step > 1e-4 * size {
                let y = x + d * step;
                if let Some((ey, l)) = at(y)
                    && ey < e
                {
                    found = Some((y, ey, l));
                    self.steps[p as usize].store(step.to_bits(), Ordering::Relaxed);
                    break;
                }
                step *= 0.5;
            }
            let Some(next) = found else { break };
            best = next;
        }
        // Only a move that lowers the energy by a share worth sweeping for
        // wakes the neighbours.
        Some((best.2, best.1 < (1.0 - 1e-3) * first))
    }
}

/// A greedy colouring of the input's vertices (each the least colour none
/// of its neighbours before it has), from the triangles `around` each.
fn colours(mesh: &TriMesh, around: &[Vec<u32>]) -> Vec<u32> {
    let mut colours = vec![u32::MAX; around.len()];
    let mut taken: Vec<bool> = Vec::new();
    for v in 0..around.len() {
        taken.clear();
        for &t in &around[v] {
            for w in mesh.triangles[t as usize] {
                let c = colours[w as usize];
                if c != u32::MAX {
                    if taken.len() <= c as usize {
                        taken.resize(c as usize + 1, false);
                    }
                    taken[c as usize] = true;
                }
            }
        }
        colours[v] = taken.iter().position(|&t| !t).unwrap_or(taken.len()) as u32;
    }
    colours
}

/// Vertex `p`'s ring drawn in the chart of the nearest corner of its base
/// triangle that holds it whole.
struct RingChart {
    corner: u32,
    at: DVec2,
    /// Per triangle: its other two corners' places, counter-clockwise.
    edges: Vec<(DVec2, DVec2)>,
}

fn ring_chart(
    mesh: &TriMesh,
    map: Map,
    stars: &Stars,
    around: &[Vec<u32>],
    p: u32,
) -> Option<RingChart> {
    let Location::Face(f, b) = map.location(p) else {
        return None;
    };
    let tri = map.base.triangles[f as usize];
    let mut corners = [0usize, 1, 2];
    corners.sort_by(|&i, &j| b[j].total_cmp(&b[i]));
    'corner: for (c, wide) in corners
        .iter()
        .map(|&c| (c, false))
        .chain(corners.iter().map(|&c| (c, true)))
    {
        let a = tri[c];
        let star = &stars[&a];
        let Some(at) = place_in(star, a, p, map, wide) else {
            continue;
        };
        let mut edges = Vec::with_capacity(around[p as usize].len());
        for &t in &around[p as usize] {
            let tri = mesh.triangles[t as usize];
            let Some(k) = tri.iter().position(|&w| w == p) else {
                continue 'corner;
            };
            let (Some(q), Some(r)) = (
                place_in(star, a, tri[(k + 1) % 3], map, wide),
                place_in(star, a, tri[(k + 2) % 3], map, wide),
            ) else {
                continue 'corner;
            };
            edges.push((q, r));
        }
        return Some(RingChart {
            corner: a,
            at,
            edges,
        });
    }
    None
}

/// A place for `p` inside the kernel of its ring in a chart (every one of
/// its triangles turned the right way), from `x` by cyclic projection onto
/// the half-planes of the ring's edges; `None` if it finds none.
fn untangle(
    mesh: &TriMesh,
    around: &[u32],
    p: u32,
    x: DVec2,
    place: impl Fn(u32) -> Option<DVec2>,
) -> Option<DVec2> {
    let mut edges = Vec::with_capacity(around.len());
    for &t in around {
        let tri = mesh.triangles[t as usize];
        let k = tri.iter().position(|&w| w == p)?;
        edges.push((place(tri[(k + 1) % 3])?, place(tri[(k + 2) % 3])?));
    }
    kernel_point(&edges, x)
}

/// A point in the kernel of a ring given by its edges, from `x` by cyclic
/// projection onto the edges' half-planes; `None` if it finds none.
fn kernel_point(edges: &[(DVec2, DVec2)], mut x: DVec2) -> Option<DVec2> {
    let scale = edges
        .iter()
        .map(|&(q, r)| (r - q).length())
        .fold(0.0f64, f64::max);
    // From a wide margin to a thin one: a ring pinched against a feature
    // line has a thin kernel.
    let start = x;
    for margin in [1e-3 * scale, 1e-5 * scale, 1e-8 * scale] {
        x = start;
        for _ in 0..64 {
            let mut inside = true;
            for &(q, r) in edges {
                let e = r - q;
                let len = e.length();
                if len <= 0.0 {
                    return None;
                }
                let normal = DVec2::new(-e.y, e.x) / len;
                let d = (x - q).dot(normal);
                if d < margin {
                    inside = false;
                    x += normal * (2.0 * margin - d);
                }
            }
            if inside {
                return Some(x);
            }
        }
    }
    None
}

/// Whether a triangle drawn at `p, q, r` is turned the right way, and not
/// so nearly collinear (an ear laid along a feature line) that barycentric
/// coordinates in it would be noise.
fn drawn_right(p: DVec2, q: DVec2, r: DVec2) -> bool {
    let longest = (q - p)
        .length_squared()
        .max((r - q).length_squared())
        .max((p - r).length_squared());
    (q - p).perp_dot(r - p) > 1e-9 * longest
}

fn build_chart(
    a: u32,
    places: &Star,
    mesh: &TriMesh,
    base: &Base,
    in_face: &[Vec<u32>],
    vertex_triangles: &[Vec<u32>],
) -> Built {
    // 2D places of the input vertices: in the star's own triangles first,
    // then (where not already placed) in the unfolded ones.
    let mut coords: HashMap<u32, (DVec2, bool)> = HashMap::new();
    coords.insert(a, (DVec2::ZERO, true));
    for (k, (t, place)) in places.places.iter().enumerate() {
        let own = k < places.proper;
        for (c, &w) in base.triangles[*t as usize].iter().enumerate() {
            coords.entry(w).or_insert((place[c], own));
        }
        for &v in &in_face[*t as usize] {
            if let Location::Face(_, b) = base.location[v as usize] {
                coords.insert(
                    v,
                    (place[0] * b[0] + place[1] * b[1] + place[2] * b[2], own),
                );
            }
        }
    }
    let mut seen = std::collections::HashSet::new();
    let mut all = Vec::new();
    let mut areas = Vec::new();
    let mut own = Vec::new();
    let mut outer = Vec::new();
    let mut outer_right = Vec::new();
    let mut keys: Vec<u32> = coords.keys().copied().collect();
    keys.sort_unstable();
    for v in keys {
        for &t in &vertex_triangles[v as usize] {
            if !seen.insert(t) {
                continue;
            }
            let tri = mesh.triangles[t as usize];
            let (Some(&(p, op)), Some(&(q, oq)), Some(&(r, or))) = (
                coords.get(&tri[0]),
                coords.get(&tri[1]),
                coords.get(&tri[2]),
            ) else {
                continue;
            };
            // Nearly collinear (an ear laid along a feature line) counts as
            // no area: its barycentric coordinates would be noise.
            let area = if drawn_right(p, q, r) || (q - p).perp_dot(r - p) < 0.0 {
                (q - p).perp_dot(r - p)
            } else {
                0.0
            };
            if op && oq && or {
                areas.push(area);
                all.push((t, [p, q, r]));
                if area > 0.0 {
                    own.push((t, [p, q, r]));
                }
            } else if area > 0.0 {
                outer.push((t, [p, q, r]));
                outer_right.push(t);
            }
        }
    }
    Built {
        chart: Chart {
            star: places.places.iter().copied().collect(),
            drawn: Drawn::new(own),
            outer: Drawn::new(outer),
        },
        all,
        areas,
        outer_right,
    }
}

#[cfg(test)]
mod tests {
    use super::super::{BaseDomain, RemeshOptions, remesh};
    use super::Drawn;
    use crate::clean::topology;
    use crate::{Error, PolyMesh, RemeshFailure, TriMesh};
    use qm_lift::glam::{DVec2, DVec3};

    /// Where drawn triangles overlap, a point is looked up on the smallest
    /// that holds it, wherever it comes in the list; outside all, on the
    /// nearest.
    #[test]
    fn overlapping_drawn_triangles_give_the_smallest() {
        let v = DVec2::new;
        let big = [v(-10.0, -10.0), v(10.0, -10.0), v(0.0, 10.0)];
        let small = [v(-0.5, -0.5), v(0.5, -0.5), v(0.0, 0.5)];
        let middle = [v(-2.0, -2.0), v(2.0, -2.0), v(0.0, 2.0)];
        let drawn = Drawn::new(vec![(7, big), (8, middle), (9, small)]);
        assert_eq!(drawn.nearest(v(0.0, 0.0)).map(|h| h.1), Some(9));
        assert_eq!(drawn.nearest(v(0.0, 1.0)).map(|h| h.1), Some(8));
        assert_eq!(drawn.nearest(v(0.0, 5.0)).map(|h| h.1), Some(7));
        let (worst, t, _) = drawn.nearest(v(0.0, 11.0)).unwrap();
        assert!(worst < 0.0 && t == 7);
    }

    /// A torus of `m x n` vertices, radii 1 and 0.35, a little bumpy.
    fn torus(m: usize, n: usize) -> PolyMesh {
        let mut positions = Vec::new();
        for i in 0..m {
            let u = std::f64::consts::TAU * i as f64 / m as f64;
            for j in 0..n {
                let v = std::f64::consts::TAU * j as f64 / n as f64;
                let r = 0.35 + 0.03 * (3.0 * u).sin() * (2.0 * v).cos();
                positions.push(DVec3::new(
                    (1.0 + r * v.cos()) * u.cos(),
                    (1.0 + r * v.cos()) * u.sin(),
                    r * v.sin(),
                ));
            }
        }
        let at = |i: usize, j: usize| ((i % m) * n + j % n) as u32;
        let mut faces = Vec::new();
        for i in 0..m {
            for j in 0..n {
                faces.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                faces.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
        PolyMesh::from_faces(positions, &faces)
    }

    fn options() -> RemeshOptions {
        RemeshOptions::DEFAULT.with_domain(BaseDomain::Charts)
    }

    /// The remesh as triangles (each quad split), for its topology.
    fn triangles(r: &super::super::Remeshed) -> TriMesh {
        let layout = r.mesh.layout();
        let triangles = layout
            .quads(layout.level())
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        TriMesh {
            positions: r.mesh.positions().to_vec(),
            triangles,
        }
    }

    #[test]
    fn a_torus_remeshes_closed_with_its_genus_and_near_the_input() {
        let input = torus(48, 24);
        let r = remesh(&input, &options()).expect("remesh");
        assert_eq!(r.report.domain, "charts");
        let psnr = r.report.psnr.expect("measured");
        assert!(psnr > 70.0, "remesh at {psnr:.1} dB");
        let topo = topology(&triangles(&r));
        assert!(topo.manifold && topo.is_closed(), "{topo:?}");
        assert_eq!(topo.genus, 1);
        let samples = r.mesh.positions().len() as f64;
        assert!(samples <= super::super::MAX_SAMPLES_PER_VERTEX * 48.0 * 24.0);
        assert!(r.report.components.iter().all(|c| c.flipped == 0));
    }

    /// A simplified sphere, its domain, and its map's fold count.
    fn sphere_map() -> (TriMesh, super::Base) {
        let sphere = super::super::tests::sphere(48);
        let mesh = crate::clean::clean(&sphere).unwrap().components.remove(0);
        let base = super::super::simplify::simplify(&mesh, 40);
        (mesh, base)
    }

    fn folds(mesh: &TriMesh, domain: &super::Domain, base: &super::Base) -> usize {
        let knots = super::Knots::new(mesh, domain);
        (0..mesh.triangles.len() as u32)
            .filter(|&t| knots.folded(super::Map::new(base), t))
            .count()
    }

    fn free(base: &super::Base, v: u32) -> bool {
        matches!(base.location[v as usize], super::Location::Face(..)) && !base.feature[v as usize]
    }

    /// Swapped locations along input edges: the knots' energy alone
    /// undoes them.
    #[test]
    fn swapped_vertices_come_undone() {
        let (mesh, mut base) = sphere_map();
        let domain = super::Domain::new(&mesh, &base).expect("stars");
        assert_eq!(folds(&mesh, &domain, &base), 0, "the simplification's map");
        let mut swapped = 0;
        for tri in mesh.triangles.iter().step_by(97) {
            let [a, b, _] = *tri;
            if free(&base, a) && free(&base, b) {
                base.location.swap(a as usize, b as usize);
                swapped += 1;
            }
        }
        assert!(swapped >= 5, "{swapped} swaps");
        let tangled = folds(&mesh, &domain, &base);
        assert!(tangled > 0, "the swaps fold the map");
        let left = super::untangle_knots(&mesh, &mut base, &domain, 50, &|_, _| false).len();
        assert_eq!(left, 0, "{tangled} folds, {left} left");
        assert_eq!(folds(&mesh, &domain, &base), 0);
    }

    /// A patch mirrored in its base triangle (two barycentric coordinates
    /// swapped about its centre vertex) is folded all over; together the
    /// single moves and the knots' energy unfold it.
    #[test]
    fn a_mirrored_patch_comes_undone() {
        let (mesh, mut base) = sphere_map();
        let domain = super::Domain::new(&mesh, &base).expect("stars");
        // The free vertex deepest in its base triangle, and the free
        // vertices of its face within three rings.
        let (centre, f, at) = (0..mesh.positions.len() as u32)
            .filter_map(|v| match base.location[v as usize] {
                super::Location::Face(f, b) if free(&base, v) => Some((v, f, b)),
                _ => None,
            })
            .max_by(|x, y| {
                let m = |b: [f64; 3]| b[0].min(b[1]).min(b[2]);
                m(x.2).total_cmp(&m(y.2))
            })
            .expect("a free vertex");
        let mut patch = vec![centre];
        for _ in 0..4 {
            let mut next = patch.clone();
            for &p in &patch {
                for &t in &domain.around[p as usize] {
                    next.extend(mesh.triangles[t as usize]);
                }
            }
            next.sort_unstable();
            next.dedup();
            patch = next;
        }
        let mut mirrored = 0;
        for &v in &patch {
            if let super::Location::Face(g, b) = base.location[v as usize]
                && g == f
                && free(&base, v)
            {
                let d = [b[0] - at[0], b[1] - at[1], b[2] - at[2]];
                let m = [at[0] + d[0], at[1] + d[2], at[2] + d[1]];
                if m.iter().all(|&x| x >= 0.0) {
                    base.location[v as usize] = super::Location::Face(f, m);
                    mirrored += 1;
                }
            }
        }
        assert!(mirrored >= 20, "{mirrored} mirrored");
        let tangled = folds(&mesh, &domain, &base);
        assert!(tangled >= 20, "{tangled} folds");
        super::untangle_map(&mesh, &mut base, &domain, 50);
        let single = folds(&mesh, &domain, &base);
        // Told after its first neighbourhood that the folds left are
        // hopeless, the untangling returns them at once.
        let mut early = base.clone();
        let asked = std::cell::Cell::new(0);
        let hopeless = |_: &super::Base, _: &[u32]| {
            asked.set(asked.get() + 1);
            true
        };
        let stopped = super::untangle_knots(&mesh, &mut early, &domain, 50, &hopeless);
        assert_eq!(asked.get(), 1);
        assert_eq!(stopped.len(), folds(&mesh, &domain, &early));
        let left = super::untangle_knots(&mesh, &mut base, &domain, 50, &|_, _| false).len();
        assert_eq!(
            left, 0,
            "{tangled} folds, {single} after single moves, {left} after knots"
        );
        assert_eq!(folds(&mesh, &domain, &base), 0);
    }

    /// The smallest share of the median drawn-to-input area ratio over
    /// the triangles (each in its best chart).
    fn least_ratio(mesh: &TriMesh, domain: &super::Domain, base: &super::Base) -> f64 {
        let knots = super::Knots::new(mesh, domain);
        let mut ratios: Vec<f64> = (0..mesh.triangles.len() as u32)
            .map(|t| knots.area_ratio(super::Map::new(base), t))
            .collect();
        ratios.sort_by(f64::total_cmp);
        ratios[0] / ratios[ratios.len() / 2]
    }

    /// `measure` of the map of `sphere` onto a base of 40 triangles before
    /// and after relaxing its stretch, and the folds after.
    fn relaxed<T>(
        sphere: &PolyMesh,
        measure: fn(&TriMesh, &super::Domain, &super::Base) -> T,
    ) -> (T, T, usize) {
        let mesh = crate::clean::clean(sphere).unwrap().components.remove(0);
        let mut base = super::super::simplify::simplify(&mesh, 40);
        let domain = super::Domain::new(&mesh, &base).expect("stars");
        let before = measure(&mesh, &domain, &base);
        super::relax_stretch(&mesh, &mut base, &domain, 50);
        (
            before,
            measure(&mesh, &domain, &base),
            folds(&mesh, &domain, &base),
        )
    }

    /// No two vertices of a triangle share a colour, so the vertices of
    /// one colour read none of each other's places when they move.
    #[test]
    fn neighbours_never_share_a_colour() {
        let mesh = crate::clean::clean(&torus(24, 12))
            .unwrap()
            .components
            .remove(0);
        let domain =
            super::Domain::new(&mesh, &super::super::simplify::simplify(&mesh, 60)).expect("stars");
        let colours = super::colours(&mesh, &domain.around);
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|v| colours[v as usize]);
            assert!(a != b && b != c && c != a, "triangle {t:?}: {a} {b} {c}");
        }
        // A torus of valence 6 needs few colours.
        assert!(colours.iter().all(|&c| c < 8), "{:?}", colours.iter().max());
    }

    /// On a sphere with a long bump, the map the simplification leaves
    /// squeezes the bump's triangles (the flattenings compound); relaxing
    /// its stretch opens them up, and nothing folds.
    #[test]
    fn relaxing_the_stretch_opens_up_squeezed_triangles() {
        let mut sphere = super::super::tests::sphere(48);
        for p in &mut sphere.positions {
            let d = p.distance_squared(DVec3::Z);
            *p *= 1.0 + 1.5 * (-d / 0.05).exp();
        }
        let (before, after, folded) = relaxed(&sphere, least_ratio);
        assert_eq!(folded, 0);
        assert!(
            after > 1.5 * before,
            "least area ratio {before:.4} -> {after:.4}"
        );
    }

    /// Input triangles turned over in some of the charts that draw them,
    /// but not all (pleats: the charts overlap themselves there).
    fn pleats(mesh: &TriMesh, domain: &super::Domain, base: &super::Base) -> usize {
        let knots = super::Knots::new(mesh, domain);
        (0..mesh.triangles.len() as u32)
            .filter(|&t| {
                let right: Vec<bool> = knots
                    .drawings(super::Map::new(base), t)
                    .map(|[p, q, r]| super::drawn_right(p, q, r))
                    .collect();
                right.contains(&true) && right.contains(&false)
            })
            .count()
    }

    /// Relaxing the stretch weighs every chart that draws a triangle: on
    /// rippled spheres with three bumps it leaves no more pleats than it
    /// found. Weighing only the chart that draws each best, they went from
    /// 4 to 7 and from 48 to 55.
    #[test]
    fn relaxing_the_stretch_adds_no_pleats() {
        for (tall, wide, n, ripple) in [(0.8, 0.1, 40, 0.02), (2.0, 0.03, 48, 0.05)] {
            let mut sphere = super::super::tests::sphere(n);
            let bumps = [DVec3::Z, DVec3::X, DVec3::new(0.0, -0.6, -0.8)];
            for p in &mut sphere.positions {
                let height: f64 = bumps
                    .iter()
                    .map(|b| (-p.distance_squared(*b) / wide).exp())
                    .sum();
                *p *= 1.0 + tall * height + ripple * (13.0 * p.x).sin() * (11.0 * p.y).cos();
            }
            let (before, after, _) = relaxed(&sphere, pleats);
            assert!(after <= before, "pleats {before} -> {after}");
        }
    }

    /// A patch whose border is ragged (a notch every few edges): the
    /// remesh's boundary samples lie on the input's border, through the
    /// notches, not on the chords the straight base edges lay across them.
    #[test]
    fn a_ragged_border_is_sampled_along_itself() {
        let input = ragged_patch();
        // Sampling itself: no fit or normal placement after it.
        let sampling = options().with_normal(false).with_fit_rounds(0);
        let (on, total) = on_border(&input, &sampling);
        // Through the charts alone, 86% of them were (2,922 of 3,392).
        assert!(
            on as f64 >= 0.99 * total as f64,
            "{on} of {total} remesh boundary points on the input's border"
        );
    }

    /// Normal placement leaves the samples on feature lines (here the
    /// border) where the sampling put them: the frame normal there is one
    /// side's, and a ray along it slides the sample off the line (on the
    /// fandisk's creases that cost 2.7 dB, depending on which base face
    /// came first). Moved, 49% of these points stayed on the border (1,662
    /// of 3,392).
    #[test]
    fn normal_placement_keeps_feature_lines() {
        let input = ragged_patch();
        let (on, total) = on_border(&input, &options().with_fit_rounds(0));
        assert!(
            on as f64 >= 0.99 * total as f64,
            "{on} of {total} remesh boundary points on the input's border"
        );
    }

    /// A 40 x 40 patch with a triangle of its border cells dropped here and
    /// there.
    fn ragged_patch() -> PolyMesh {
        let m = 40;
        let border = |i: usize, j: usize| i == 0 || j == 0 || i == m - 2 || j == m - 2;
        patch(m, 0.1, |i, j| !(border(i, j) && (i + j) % 3 == 0))
    }

    /// How many of the remesh's boundary points lie on the input's border,
    /// of how many.
    fn on_border(input: &PolyMesh, options: &RemeshOptions) -> (usize, usize) {
        let cleaned = crate::clean::clean(input).unwrap();
        assert_eq!(cleaned.components.len(), 1);
        let mesh = &cleaned.components[0];
        let border = boundary_edges(mesh);
        let r = remesh(input, options).expect("remesh");
        let remeshed = triangles(&r);
        let (mut on, mut total) = (0, 0);
        for [a, b] in boundary_edges(&remeshed) {
            for p in [
                remeshed.positions[a as usize],
                remeshed.positions[b as usize],
            ] {
                let d = border
                    .iter()
                    .map(|&[u, w]| {
                        let (u, w) = (mesh.positions[u as usize], mesh.positions[w as usize]);
                        let t = ((p - u).dot(w - u) / (w - u).length_squared()).clamp(0.0, 1.0);
                        p.distance(u.lerp(w, t))
                    })
                    .fold(f64::INFINITY, f64::min);
                total += 1;
                on += usize::from(d < 1e-9);
            }
        }
        (on, total)
    }

    /// The edges of one triangle only.
    fn boundary_edges(mesh: &TriMesh) -> Vec<[u32; 2]> {
        let topo = super::super::cut::Topology::new(mesh);
        topo.edges
            .iter()
            .zip(&topo.edge_faces)
            .filter(|(_, faces)| faces[1] == u32::MAX)
            .map(|(&e, _)| e)
            .collect()
    }

    /// An `m x m` grid patch over the unit square, a height field of
    /// amplitude `z`; each cell's first triangle only where `keep(i, j)`.
    fn patch(m: usize, z: f64, keep: impl Fn(usize, usize) -> bool) -> PolyMesh {
        let at = |i: usize, j: usize| (j * m + i) as u32;
        let positions: Vec<DVec3> = (0..m * m)
            .map(|k| {
                let (x, y) = (
                    (k % m) as f64 / (m - 1) as f64,
                    (k / m) as f64 / (m - 1) as f64,
                );
                DVec3::new(x, y, z * (3.0 * x).sin() * (2.0 * y).cos())
            })
            .collect();
        let mut faces = Vec::new();
        for j in 0..m - 1 {
            for i in 0..m - 1 {
                if keep(i, j) {
                    faces.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                }
                faces.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
        PolyMesh::from_faces(positions, &faces)
    }

    #[test]
    fn an_open_patch_keeps_its_boundary() {
        let input = patch(30, 0.2, |_, _| true);
        let r = remesh(&input, &options()).expect("remesh");
        let topo = topology(&triangles(&r));
        assert!(topo.manifold, "{topo:?}");
        assert_eq!((topo.boundary_loops, topo.genus), (1, 0));
        assert!(r.report.psnr.expect("measured") > 70.0);
    }

    #[test]
    fn a_remesh_below_the_floor_is_refused() {
        let input = torus(32, 16);
        let err = remesh(&input, &options().with_min_psnr(400.0)).expect_err("above any remesh");
        assert!(
            matches!(
                err,
                Error::Remesh {
                    failure: RemeshFailure::TooFar { floor, .. },
                    ..
                } if floor == 400.0
            ),
            "{err}"
        );
    }
}
