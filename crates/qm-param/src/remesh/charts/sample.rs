//! Sampling a component through its charts ([`resample`]).
//!
//! Each base quad is sampled in the chart of its base vertex (module
//! `chart`): a grid point's bilinear place in the base triangle (module
//! `quads`), mapped linearly into the chart, is looked up among the drawn
//! triangles and takes the surface point there; a point the chart holds on
//! none of its own triangles is looked up in the charts of the triangle's
//! other corners too. A grid point on a base edge along a feature line
//! ([`feature_edges`]) takes its point on the line's input polyline
//! instead, at the same place along the edge. Grid points shared by
//! several quads are one sample (the `Layout`'s numbering), made once.

use std::collections::HashMap;

use qm_lift::glam::DVec3;
use qm_lift::{BaseMesh, Layout};
use rayon::prelude::*;

use super::chart::{Chart, Hit, Orientations, build_chart};
use super::quads::{bilinear, quad_corners, quads};
use super::star::Domain;
use crate::remesh::resample::{Patch, fit_grids};
use crate::remesh::simplify::{Base, Location};
use crate::{Error, RemeshFailure, Result, TriMesh};

/// Per sampled point: its surface position, input triangle, whether a
/// drawn triangle held it (else it was clamped onto the nearest), and
/// whether it lies on a feature line.
type Sampled = (DVec3, u32, bool, bool);

/// A quad's samples and fine nodes (row-major), with the quad's index.
type QuadSamples = (usize, Vec<Option<Sampled>>, Vec<Option<Sampled>>);

/// Charts [`resample`] samples at a time
/// (docs/decisions/015-chart-sampling.md).
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
    // wait to be numbered (five 32-byte entries a sample;
    // docs/decisions/015-chart-sampling.md), and numbered in order, as
    // before: a sample on an edge two charts share is the first's.
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
