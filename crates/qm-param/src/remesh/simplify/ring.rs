//! A vertex's 1-ring in a triangle mesh, in order around it, and the key
//! of an undirected edge.

pub(super) fn edge_key(a: u32, b: u32) -> u64 {
    (u64::from(a.min(b)) << 32) | u64::from(a.max(b))
}

/// A vertex's 1-ring: `faces[i]` is `(v, verts[i], verts[i + 1])` (indices
/// taken cyclically when `closed`).
pub(in crate::remesh) struct Ring {
    pub verts: Vec<u32>,
    pub faces: Vec<u32>,
    pub closed: bool,
}

/// Faces around a vertex up to which [`ring`] scans its spokes instead of
/// sorting them, with no lists but the ring's own.
const SMALL: usize = 16;

/// The 1-ring of `v` in a manifold triangle mesh, from `faces`, the indices
/// into `triangles` of its triangles (counter-clockwise): in order around
/// it, a boundary fan from its first boundary neighbour. `None` if they do
/// not make one fan.
pub(in crate::remesh) fn ring(v: u32, faces: &[u32], triangles: &[[u32; 3]]) -> Option<Ring> {
    if faces.is_empty() {
        return None;
    }
    if faces.len() <= SMALL {
        small_ring(v, faces, triangles)
    } else {
        sorted_ring(v, faces, triangles)
    }
}

/// Face `f`'s spoke around `v`: `(x, y, f)` with `v, x, y`
/// counter-clockwise.
fn spoke(v: u32, f: u32, triangles: &[[u32; 3]]) -> (u32, u32, u32) {
    let t = triangles[f as usize];
    let c = t.iter().position(|&w| w == v).expect("face of its vertex");
    (t[(c + 1) % 3], t[(c + 2) % 3], f)
}

/// [`ring`] of any valence: spokes looked up in sorted lists, so that a
/// vertex of high valence costs `k log k`, not `k^2`.
fn sorted_ring(v: u32, faces: &[u32], triangles: &[[u32; 3]]) -> Option<Ring> {
    let spokes: Vec<(u32, u32, u32)> = faces.iter().map(|&f| spoke(v, f, triangles)).collect();
    // (x, spoke) and the ys.
    let mut by_x: Vec<(u32, usize)> = spokes.iter().enumerate().map(|(i, s)| (s.0, i)).collect();
    by_x.sort_unstable();
    let mut ys: Vec<u32> = spokes.iter().map(|s| s.1).collect();
    ys.sort_unstable();
    walk(
        &spokes,
        |x| ys.binary_search(&x).is_ok(),
        |y| {
            let i = by_x.partition_point(|e| e.0 < y);
            by_x.get(i).filter(|e| e.0 == y).map(|e| e.1)
        },
    )
}

/// [`ring`] for at most [`SMALL`] faces: the same ring, each spoke looked up
/// by a scan (the first spoke whose `x` is asked for, as the sorted lookup
/// finds it), with no list but the ring's own.
fn small_ring(v: u32, faces: &[u32], triangles: &[[u32; 3]]) -> Option<Ring> {
    let mut spokes = [(0u32, 0u32, 0u32); SMALL];
    for (slot, &f) in spokes.iter_mut().zip(faces) {
        *slot = spoke(v, f, triangles);
    }
    let spokes = &spokes[..faces.len()];
    walk(
        spokes,
        |x| spokes.iter().any(|s| s.1 == x),
        |y| spokes.iter().position(|s| s.0 == y),
    )
}

/// The ring the `spokes` make, walked from spoke to spoke: `is_y(x)` tells
/// whether `x` is some spoke's `y`, `from(y)` the first spoke whose `x` is
/// `y`. A boundary fan starts at the `x` that is no spoke's `y`.
fn walk(
    spokes: &[(u32, u32, u32)],
    is_y: impl Fn(u32) -> bool,
    from: impl Fn(u32) -> Option<usize>,
) -> Option<Ring> {
    let n = spokes.len();
    let start = spokes.iter().position(|s| !is_y(s.0)).unwrap_or(0);
    let closed = spokes.iter().all(|s| is_y(s.0));
    let mut verts = Vec::with_capacity(n + 1);
    verts.push(spokes[start].0);
    let mut order = Vec::with_capacity(n);
    let mut at = start;
    for _ in 0..n {
        let (_, y, f) = spokes[at];
        order.push(f);
        match from(y) {
            Some(next) if order.len() < n => {
                verts.push(y);
                at = next;
            }
            _ => {
                if !closed {
                    verts.push(y);
                }
                break;
            }
        }
    }
    if order.len() != n {
        return None;
    }
    let repeated = if verts.len() <= SMALL + 1 {
        (1..verts.len()).any(|i| verts[..i].contains(&verts[i]))
    } else {
        let mut unique = verts.clone();
        unique.sort_unstable();
        unique.dedup();
        unique.len() != verts.len()
    };
    (!repeated).then_some(Ring {
        verts,
        faces: order,
        closed,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scan and the sorted lookups make the same ring, or both none, on
    /// closed and open fans, fans with faces missing or turned over, and
    /// faces given in any order.
    #[test]
    fn small_rings_are_the_sorted_ones() {
        let mut rng = qm_io::SplitMix64::new(7);
        let mut shapes = 0;
        for _ in 0..20_000 {
            let k = 3 + (rng.next_u64() % (SMALL as u64 - 2)) as u32;
            let mut triangles: Vec<[u32; 3]> =
                (0..k).map(|i| [0, 1 + i, 1 + (i + 1) % k]).collect();
            match rng.next_u64() % 5 {
                0 => {
                    triangles.pop();
                }
                1 => {
                    let i = (rng.next_u64() % u64::from(k)) as usize;
                    triangles[i].swap(1, 2);
                }
                2 => {
                    let i = (rng.next_u64() % u64::from(k)) as usize;
                    triangles[i][2] = triangles[(i + 2) % k as usize][1];
                }
                3 => {
                    triangles.truncate(triangles.len() / 2);
                }
                _ => {}
            }
            let mut faces: Vec<u32> = (0..triangles.len() as u32).collect();
            for i in (1..faces.len()).rev() {
                faces.swap(i, (rng.next_u64() % (i as u64 + 1)) as usize);
            }
            let small = small_ring(0, &faces, &triangles);
            let sorted = sorted_ring(0, &faces, &triangles);
            let as_tuple = |r: &Option<Ring>| {
                r.as_ref()
                    .map(|r| (r.verts.clone(), r.faces.clone(), r.closed))
            };
            assert_eq!(
                as_tuple(&small),
                as_tuple(&sorted),
                "{triangles:?} {faces:?}"
            );
            shapes += usize::from(small.is_some());
        }
        assert!(shapes > 5_000, "{shapes} rings made");
    }
}
