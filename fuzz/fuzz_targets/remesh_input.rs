//! The remesher fuzz target's input, shared with `tests/fuzz_replay.rs`: a
//! small mesh built from bytes, made semi-regular by clean-up, detection and
//! the remesher.
//!
//! Input layout (short inputs are padded with zeros):
//! byte 0: vertex count `3 + b % 62`; byte 1: jitter `10^-(b % 13)`, and
//! in its top bits the remesher's settings (normal placement or not,
//! extra cuts 0 to 2, stretch iterations 1 to 7, 8 or 30 samples a
//! vertex), so that each path is taken and most runs are quick;
//! then 3 bytes a vertex, each coordinate `(b >> 4) + (b & 15) * jitter` (so
//! that small jitters make nearly coincident vertices), times a unit
//! `10^(5 (h - 64))` clamped to `10^-320 ..= 10^305` (from light years to
//! subnormals), `h` the top seven bits of the first face's header byte; the
//! rest: faces, each a header byte (bit 0: triangle or quad) and then its
//! corners as bytes modulo the vertex count (so repeated corners, duplicate
//! and opposite faces, non-manifold fans and many tiny parts all occur), at
//! most 160 faces.

use qm::lift::glam::DVec3;

/// Makes the input's mesh semi-regular: `Ok` or `Err`, never a panic.
pub fn run(data: &[u8]) {
    let (mesh, options) = input(data);
    if let Ok(prepared) = qm::prepare(&mesh, &options) {
        assert!(prepared.mesh.positions().iter().all(|p| p.is_finite()));
    }
}

/// The mesh and the remesher settings that `data` describes.
pub fn input(data: &[u8]) -> (qm::PolyMesh, qm::RemeshOptions) {
    let byte = |i: usize| data.get(i).copied().unwrap_or(0);
    let n = 3 + usize::from(byte(0)) % 62;
    let jitter = 10f64.powi(-i32::from(byte(1) % 13));
    let unit_exponent = (5 * (i32::from(byte(2 + 3 * n) >> 1) - 64)).clamp(-320, 305);
    let unit = 10f64.powi(unit_exponent);
    let coordinate = |b: u8| (f64::from(b >> 4) + f64::from(b & 15) * jitter) * unit;
    let positions: Vec<DVec3> = (0..n)
        .map(|v| {
            let at = 2 + 3 * v;
            DVec3::new(
                coordinate(byte(at)),
                coordinate(byte(at + 1)),
                coordinate(byte(at + 2)),
            )
        })
        .collect();
    let mut mesh = qm::PolyMesh::from_faces::<3>(positions, &[]);
    let mut at = 2 + 3 * n;
    while at < data.len() && mesh.face_count() < 160 {
        let corners = if byte(at) & 1 == 0 { 3 } else { 4 };
        let face: Vec<u32> = (1..=corners)
            .map(|k| (usize::from(byte(at + k)) % n) as u32)
            .collect();
        mesh.push_face(&face);
        at += 1 + corners;
    }
    let settings = byte(1) / 13;
    let options = qm::RemeshOptions::DEFAULT
        .with_max_memory(256 << 20)
        .with_normal(settings & 1 == 1)
        .with_extra_cuts(usize::from(settings / 2 % 3))
        .with_stretch_iterations(if settings >= 12 { 7 } else { 1 })
        .with_samples_per_vertex(if settings >= 16 { 30.0 } else { 8.0 });
    (mesh, options)
}
