//! Remeshing triangle meshes end to end: topology kept, seams closed.

mod common;

use std::collections::{HashMap, HashSet};

use common::asset;
use qm::lift::glam::DVec3;
use qm::param::distance::{DistanceOptions, distance};
use qm::{PolyMesh, RemeshOptions};

/// Euler characteristic and boundary edge count of a quad mesh.
fn topology(mesh: &PolyMesh) -> (i64, usize) {
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    for f in mesh.faces() {
        for k in 0..f.len() {
            let (a, b) = (f[k], f[(k + 1) % f.len()]);
            *edges.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let euler = mesh.positions.len() as i64 - edges.len() as i64 + mesh.face_count() as i64;
    (euler, edges.values().filter(|&&c| c == 1).count())
}

fn remeshed(input: &PolyMesh) -> PolyMesh {
    let r = qm::remesh(input, &RemeshOptions::DEFAULT).unwrap();
    let layout = r.mesh.layout();
    assert!(r.report.components.iter().all(|c| c.uncovered == 0));
    PolyMesh::from_faces(r.mesh.positions().to_vec(), &layout.quads(layout.level()))
}

/// A triangulated torus (genus 1), `n x m` vertices, radii 2 and 1.
fn torus(n: u32, m: u32) -> PolyMesh {
    qm_shapes::poly(qm_shapes::torus(n, m, 2.0, |_, _| 1.0))
}

#[test]
fn closed_genus_0_stays_closed_without_duplicate_vertices() {
    let input = qm::read_mesh(asset("spot.obj")).unwrap();
    let out = remeshed(&input);
    assert_eq!(
        topology(&out),
        (2, 0),
        "a sphere: Euler characteristic 2, no boundary"
    );
    let distinct: HashSet<[u64; 3]> = out
        .positions
        .iter()
        .map(|p| p.to_array().map(f64::to_bits))
        .collect();
    assert_eq!(
        distinct.len(),
        out.positions.len(),
        "seam mates are one vertex"
    );
    assert!(out.positions.len() <= 32 * input.positions.len());
    let d = distance(
        &input,
        &out,
        &DistanceOptions::DEFAULT.with_samples(200_000),
    )
    .unwrap();
    // Measured 86.3 dB at 28x the input's vertices (1M samples); the issue
    // asks for 85 dB.
    assert!(d.psnr_db > 85.0, "remesh PSNR {:.2} dB", d.psnr_db);
}

#[test]
fn genus_1_stays_genus_1() {
    let out = remeshed(&torus(40, 20));
    assert_eq!(
        topology(&out),
        (0, 0),
        "a torus: Euler characteristic 0, no boundary"
    );
}

#[test]
fn holes_stay_holes() {
    // A torus with one square of two triangles removed: one hole.
    let mut input = torus(30, 15);
    let faces: Vec<[u32; 3]> = input.faces().skip(2).map(|f| [f[0], f[1], f[2]]).collect();
    input = PolyMesh::from_faces(std::mem::take(&mut input.positions), &faces);
    let out = remeshed(&input);
    let (euler, boundary) = topology(&out);
    assert_eq!(euler, -1, "genus 1 with one hole");
    assert!(boundary > 0);
}

/// Messy input: two components, a non-manifold fan of three triangles on one
/// edge, a zero-area triangle and an unused vertex. Clean-up splits and drops
/// what it must, and every component comes out as its own closed or open
/// patch.
#[test]
fn messy_input_remeshes() {
    let a = torus(24, 12);
    let mut positions = a.positions.clone();
    let mut faces: Vec<Vec<u32>> = a.faces().map(<[u32]>::to_vec).collect();
    // A second torus, moved away.
    let offset = positions.len() as u32;
    positions.extend(a.positions.iter().map(|p| *p + DVec3::new(10.0, 0.0, 0.0)));
    faces.extend(a.faces().map(|f| f.iter().map(|v| v + offset).collect()));
    // Three triangles sharing the edge (e0, e1), away from both tori.
    let e = positions.len() as u32;
    positions.extend([
        DVec3::new(0.0, 10.0, 0.0),
        DVec3::new(1.0, 10.0, 0.0),
        DVec3::new(0.5, 11.0, 0.0),
        DVec3::new(0.5, 10.0, 1.0),
        DVec3::new(0.5, 9.0, 0.0),
    ]);
    faces.extend([
        vec![e, e + 1, e + 2],
        vec![e, e + 1, e + 3],
        vec![e, e + 1, e + 4],
    ]);
    // A zero-area triangle and an unused vertex.
    faces.push(vec![e, e + 1, e]);
    positions.push(DVec3::new(5.0, 5.0, 5.0));
    let mut input = PolyMesh::new();
    input.positions = positions;
    for f in &faces {
        input.push_face(f);
    }
    let r = qm::remesh(&input, &RemeshOptions::DEFAULT).unwrap();
    assert_eq!(
        r.report.clean.to_string().lines().count(),
        1,
        "one summary line"
    );
    // Two tori and the three triangles of the split fan.
    assert_eq!(r.report.components.len(), 5, "{}", r.report.clean);
    let layout = r.mesh.layout();
    let out = PolyMesh::from_faces(r.mesh.positions().to_vec(), &layout.quads(layout.level()));
    // Two closed tori (Euler 0 each) and three open disks (Euler 1 each).
    assert_eq!(topology(&out).0, 3);
}

/// A faceted input (two coarse tori, every edge a crease) is sent as its
/// own triangles: level 0, exactly the input after the last byte, and the
/// file smaller than its remesh's.
#[test]
fn a_faceted_input_is_sent_as_itself() {
    let mut input = torus(12, 6);
    input.append(&torus(12, 6), DVec3::new(10.0, 0.0, 0.0));
    let options = qm::Options::default();
    let encoded = qm::encode(&input, &options).unwrap();
    let report = encoded.remeshed.as_ref().unwrap();
    assert_eq!((report.domain, encoded.level), ("input", 0));
    assert!(report.fallback.is_some());
    let decoded = qm::decode(&encoded.bytes, &qm::DecodeOptions::default()).unwrap();
    let d = distance(&input, &decoded.mesh, &DistanceOptions::default()).unwrap();
    assert!(d.psnr_db > 95.0, "{} dB", d.psnr_db);
    // Bit-exact: the midpoints and centres snapped to their predictions are
    // what comes back.
    let prepared = qm::prepare(&input, &RemeshOptions::DEFAULT).unwrap();
    let compressed = qm::codec::compress(&prepared.mesh, &qm::EncodeOptions::DEFAULT).unwrap();
    let back = qm::codec::decompress(&compressed.bytes, &qm::DecodeOptions::default()).unwrap();
    assert_eq!(back.values, compressed.quantized);
    // The corners' low bits follow the base section in the stream, plane
    // by plane: every cut past it decodes, the shortest far coarser than
    // the whole file.
    let start = encoded.header_bytes + encoded.base_bytes;
    assert!(
        4 * start < 3 * encoded.bytes.len(),
        "{start} of {}",
        encoded.bytes.len()
    );
    let few = DistanceOptions::default().with_samples(20_000);
    let cut_psnr = |cut: usize| {
        let decoded = qm::decode(&encoded.bytes[..cut], &qm::DecodeOptions::default()).unwrap();
        distance(&input, &decoded.mesh, &few).unwrap().psnr_db
    };
    let (first, whole) = (cut_psnr(start), cut_psnr(encoded.bytes.len()));
    assert!(first < whole - 12.0, "{first} dB, then {whole} dB");
    let step = ((encoded.bytes.len() - start) / 12).max(1);
    for cut in (start..encoded.bytes.len()).step_by(step) {
        assert!(cut_psnr(cut) <= whole + 0.1, "cut {cut}");
    }
    // Its remesh, forced: further from the input, and larger.
    let remesh =
        options.with_remesh(RemeshOptions::DEFAULT.with_domain(qm::param::BaseDomain::Square));
    let remeshed = qm::encode(&input, &remesh).unwrap();
    let decoded = qm::decode(&remeshed.bytes, &qm::DecodeOptions::default()).unwrap();
    let r = distance(&input, &decoded.mesh, &DistanceOptions::default()).unwrap();
    assert!(
        r.psnr_db < d.psnr_db - 10.0,
        "{} against {} dB",
        r.psnr_db,
        d.psnr_db
    );
    assert!(remeshed.bytes.len() > encoded.bytes.len());
}

/// A faceted CAD part whose remesh measures well (87 dB through charts,
/// above the remesher's 80 dB) but costs more bytes than its own triangles
/// at 65 and 78 dB: `auto` weighs both streams by rate and takes the
/// triangles. Measured on the full yardstick, the choice holds: the
/// stream taken reaches 78 dB in fewer bytes than the remesh's reaches it.
#[test]
fn auto_weighs_a_cad_part_by_rate() {
    let input = qm::read_mesh(asset("cad/CSG.obj")).unwrap();
    let options = qm::Options::default();
    let encoded = qm::encode(&input, &options).unwrap();
    let report = encoded.remeshed.as_ref().unwrap();
    assert_eq!(report.domain, "input");
    let why = report.fallback.as_deref().unwrap_or_default();
    assert!(why.contains("reach 65 / 78 dB"), "{why}");
    let charts =
        options.with_remesh(RemeshOptions::DEFAULT.with_domain(qm::param::BaseDomain::Charts));
    let remeshed = qm::encode(&input, &charts).unwrap();
    let few = DistanceOptions::default().with_samples(50_000);
    // The first pass end of each stream at 78 dB or better.
    let bytes_to_78 = |e: &qm::Encoded| {
        e.pass_ends.iter().copied().find(|&cut| {
            let decoded = qm::decode(&e.bytes[..cut], &qm::DecodeOptions::default()).unwrap();
            distance(&input, &decoded.mesh, &few).unwrap().psnr_db >= 78.0
        })
    };
    let (taken, remesh) = (bytes_to_78(&encoded).unwrap(), bytes_to_78(&remeshed));
    assert!(
        remesh.is_none_or(|r| taken < r),
        "{taken} against {remesh:?}"
    );
}

/// Meshes in any unit (light years, nanometres) code alike: the remesh,
/// the stream and the measured distance are those of the same shape near
/// unit size, scaled. From about 1e155 up a tetrahedron used to panic in
/// the remesher, and from 1e77 up or 1e-78 down it was refused.
#[test]
fn every_unit_codes_alike() {
    let tetrahedron = |s: f64| {
        let (p, faces) = qm_shapes::tetrahedron_inward();
        PolyMesh::from_faces(p.into_iter().map(|p| p * s).collect(), &faces)
    };
    let options = DistanceOptions::DEFAULT.with_samples(20_000);
    let code = |s: f64| {
        let input = tetrahedron(s);
        let encoded = qm::encode(&input, &qm::Options::default()).unwrap();
        let decoded = qm::decode(&encoded.bytes, &qm::DecodeOptions::default()).unwrap();
        let d = distance(&input, &decoded.mesh, &options).unwrap();
        assert!(d.rms.is_finite() && d.rms > 0.0, "{s}: rms {}", d.rms);
        (encoded.bytes, d.psnr_db)
    };
    let (unit, psnr) = code(1.0);
    // Powers of two: the same work exactly, so the same stream but for
    // the header's origin and step.
    for k in [-1000, -300, -100, 100, 300, 1000] {
        let (bytes, p) = code(2f64.powi(k));
        assert_eq!(bytes.len(), unit.len(), "2^{k}");
        assert_eq!(bytes[bytes.len() - 40..], unit[unit.len() - 40..], "2^{k}");
        assert!((p - psnr).abs() < 0.01, "2^{k}: {p} dB against {psnr}");
    }
    for s in [1e-300, 1e-80, 1e80, 1e160, 1e300] {
        let (_, p) = code(s);
        assert!((p - psnr).abs() < 0.5, "{s}: {p} dB against {psnr}");
    }
}

/// A hub of high valence (the fan caps of a CAD cylinder, a capped hole,
/// an n-gon) remeshes as any other vertex: faithfully, and in time that
/// `cargo xtask valence` shows near-linear (a hub of 500 took 170 s).
#[test]
fn high_valence_hubs_remesh() {
    let cylinder = qm_shapes::poly(qm_shapes::cylinder_ring_by_ring(300));
    let polygon = qm_shapes::ngon(1000);
    for (name, input) in [("cylinder", cylinder), ("1000-gon", polygon)] {
        let out = remeshed(&input);
        let d = distance(&input, &out, &DistanceOptions::DEFAULT.with_samples(20_000)).unwrap();
        assert!(d.psnr_db > 60.0, "{name}: {} dB", d.psnr_db);
    }
}

/// `prepare_reporting` announces the steps of `auto` as they start: the
/// clean-up first, both base domains' steps (made side by side), and the
/// measure that chooses between them; the remesh is the one `prepare` makes.
#[test]
fn the_steps_of_a_remesh_are_announced() {
    use qm::param::Step;
    use std::sync::Mutex;
    let input = torus(24, 12);
    let steps = Mutex::new(Vec::new());
    let report = |step: Step| steps.lock().unwrap().push(step);
    let options = RemeshOptions::DEFAULT;
    let reported = qm::prepare_reporting(&input, &options, &report).unwrap();
    let steps = steps.into_inner().unwrap();
    assert_eq!(steps.first(), Some(&Step::Cleaning), "{steps:?}");
    for step in [
        Step::MappingSquares,
        Step::SamplingSquares,
        Step::Simplifying,
        Step::MappingCharts,
        Step::Measuring,
    ] {
        assert!(steps.contains(&step), "{step:?} missing from {steps:?}");
    }
    let position = |s: Step| steps.iter().position(|&t| t == s).unwrap();
    assert!(position(Step::MappingSquares) < position(Step::SamplingSquares));
    assert!(position(Step::Simplifying) < position(Step::MappingCharts));
    let plain = qm::prepare(&input, &options).unwrap();
    assert_eq!(plain.mesh.positions(), reported.mesh.positions());
}
