//! Hostile input: the decoder and the readers survive anything.
//!
//! Three kinds of evidence: a corpus of named malformed files
//! (`tests/corrupt/`, indexed in its README) replayed through the command
//! line; a thousand seeded random corruptions of a valid `.qm` through the
//! library (and a hundred through the command line); and a property-based
//! round trip on small synthetic semi-regular meshes.

mod common;

use std::io::Read;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use proptest::prelude::*;
use qm::io::SplitMix64;
use qm::lift::glam::DVec3;

use common::asset;

/// Folder of the corrupt corpus.
fn corpus_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/corrupt")
}

/// One row of a corpus table: file name and expected error fragment.
struct Case {
    file: String,
    fragment: String,
}

/// The rows of the table under `## {section}` in the corpus README.
fn corpus_table(section: &str) -> Vec<Case> {
    let readme = std::fs::read_to_string(corpus_dir().join("README.md")).expect("corpus index");
    let heading = format!("## {section}");
    let mut rows = Vec::new();
    let mut inside = false;
    for line in readme.lines() {
        if line.starts_with("## ") {
            inside = line.trim() == heading;
            continue;
        }
        if !inside || !line.starts_with("| `") {
            continue;
        }
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        // "", file, defect, fragment, ""
        assert_eq!(cells.len(), 5, "malformed corpus row: {line}");
        let unquote = |s: &str| s.trim_matches('`').to_owned();
        rows.push(Case {
            file: unquote(cells[1]),
            fragment: unquote(cells[3]),
        });
    }
    assert!(!rows.is_empty(), "no rows under {heading}");
    rows
}

/// What a finished (or killed) `qm` run left.
struct Run {
    code: Option<i32>,
    stderr: String,
    elapsed: Duration,
}

/// The address space a corpus file gets: 1.5 GiB. A file that makes `qm`
/// ask for more aborts it (signal 6), which the exit-code check catches.
const CORPUS_ADDRESS_SPACE: u64 = 3 << 29;

/// Runs `qm` in `dir` under an address-space limit of
/// [`CORPUS_ADDRESS_SPACE`] (util-linux `prlimit`), killing it after
/// `limit` (a hang then shows as a missing exit code rather than a stuck
/// test).
fn run_qm(args: &[&str], dir: &Path, limit: Duration) -> Run {
    let start = Instant::now();
    let mut child = Command::new("prlimit")
        .arg(format!("--as={CORPUS_ADDRESS_SPACE}"))
        .arg("--")
        .arg(env!("CARGO_BIN_EXE_qm"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("prlimit (util-linux) starts qm");
    let mut pipe = child.stderr.take().expect("piped stderr");
    let reader = std::thread::spawn(move || {
        let mut text = String::new();
        let _ = pipe.read_to_string(&mut text);
        text
    });
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait for qm") {
            break Some(status);
        }
        if start.elapsed() > limit {
            child.kill().expect("kill qm");
            child.wait().expect("reap qm");
            break None;
        }
        std::thread::sleep(Duration::from_millis(1));
    };
    let elapsed = start.elapsed();
    let stderr = reader.join().expect("stderr reader");
    Run {
        code: status.and_then(|s| s.code()),
        stderr,
        elapsed,
    }
}

/// Names of the files in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Replays one corpus file through `qm compress` or `qm decompress`; returns
/// what went wrong, if anything.
fn replay(case: &Case) -> Result<Duration, String> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(corpus_dir().join(&case.file), dir.path().join(&case.file)).unwrap();
    let verb = if case.file.ends_with(".qm") {
        "decompress"
    } else {
        "compress"
    };
    let run = run_qm(
        &[verb, &case.file, "--quiet"],
        dir.path(),
        Duration::from_secs(10),
    );
    let err = &run.stderr;
    let mut problems = Vec::new();
    // 1: the data's fault; 3: a header asks for more than a limit allows.
    if !matches!(run.code, Some(1 | 3)) {
        problems.push(format!("exit {:?}, not 1 or 3", run.code));
    }
    if err.lines().count() != 1 || !err.starts_with("error: ") {
        problems.push("not exactly one line `error: ...`".to_owned());
    }
    if !err.contains(&case.file) {
        problems.push("does not name the file".to_owned());
    }
    if !err.contains(&case.fragment) {
        problems.push(format!("does not say {:?}", case.fragment));
    }
    let left = listing(dir.path());
    if left != [case.file.clone()] {
        problems.push(format!("left files behind: {left:?}"));
    }
    if problems.is_empty() {
        Ok(run.elapsed)
    } else {
        Err(format!(
            "{}: {}; stderr: {:?}",
            case.file,
            problems.join(", "),
            err
        ))
    }
}

#[test]
fn corpus_fails_cleanly() {
    let cases = corpus_table("Corpus");
    // Every file is indexed exactly once, and every row has its file.
    let remeshed = corpus_table("Remeshed");
    let mut indexed: Vec<String> = cases
        .iter()
        .chain(&remeshed)
        .map(|c| c.file.clone())
        .collect();
    indexed.sort();
    let mut files = listing(&corpus_dir());
    files.retain(|f| f != "README.md");
    assert_eq!(files, indexed, "tests/corrupt/ and its README disagree");
    assert!(cases.len() >= 30);

    let start = Instant::now();
    let mut slowest = (Duration::ZERO, String::new());
    let mut failures = Vec::new();
    for case in &cases {
        match replay(case) {
            Ok(elapsed) if elapsed > slowest.0 => slowest = (elapsed, case.file.clone()),
            Ok(_) => {}
            Err(failure) => failures.push(failure),
        }
    }
    println!(
        "{} corpus files in {:?}; slowest {} in {:?}",
        cases.len(),
        start.elapsed(),
        slowest.1,
        slowest.0
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(slowest.0 < Duration::from_secs(5), "{slowest:?}");
}

/// CRC-32 (IEEE), bit by bit: only for re-sealing corrupted sections.
fn crc32(data: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in data {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = (crc >> 1) ^ (0xEDB8_8320 & (crc & 1).wrapping_neg());
        }
    }
    !crc
}

/// A valid small `.qm`: the holed grid at 10 bits (under a kilobyte), with
/// holds, so that corruptions reach the holds' reader.
fn valid_qm() -> Vec<u8> {
    let mesh = qm::read_mesh(asset("quad/holed_grid_l4.obj")).unwrap();
    let prepared = qm::detect(&mesh).unwrap();
    let options = qm::EncodeOptions::DEFAULT.with_bits(10);
    let bytes = qm::codec::compress(&prepared.mesh, &options).unwrap().bytes;
    let header = qm::codec::container::read(&bytes, &qm::Limits::DEFAULT)
        .unwrap()
        .header;
    assert!(!header.holds.is_empty(), "with holds");
    bytes
}

/// Byte ranges of a valid `.qm`: header (from the version byte) with its
/// checksum, base section with its checksum (see docs/format.md).
struct Sections {
    header_crc: usize,
    base: usize,
    base_crc: usize,
}

fn sections(qm: &[u8]) -> Sections {
    let h = u16::from_le_bytes([qm[5], qm[6]]) as usize;
    let header_crc = 7 + h;
    let b = u32::from_le_bytes(qm[header_crc + 4..header_crc + 8].try_into().unwrap()) as usize;
    let base = header_crc + 8;
    Sections {
        header_crc,
        base,
        base_crc: base + b,
    }
}

/// Corrupts `valid` by the recipe of `seed`: bit flips, a truncation, byte
/// inserts or deletes, a random overwrite, anywhere; a third of the time the
/// damage stays inside the header or base and its checksum is recomputed, so
/// the parser behind the checksum sees it.
fn corrupt(valid: &[u8], seed: u64) -> Vec<u8> {
    let mut rng = SplitMix64::new(seed);
    let mut bytes = valid.to_vec();
    if seed % 3 == 2 {
        let s = sections(valid);
        let (lo, hi, crc_at) = if rng.below(2) == 0 {
            (7, s.header_crc, s.header_crc)
        } else {
            (s.base, s.base_crc, s.base_crc)
        };
        for _ in 0..1 + rng.below(3) {
            let at = lo + rng.below(hi - lo);
            bytes[at] ^= 1 << rng.below(8);
        }
        let sealed = if crc_at == s.header_crc {
            crc32(&bytes[..crc_at])
        } else {
            crc32(&bytes[lo..hi])
        };
        bytes[crc_at..crc_at + 4].copy_from_slice(&sealed.to_le_bytes());
        return bytes;
    }
    for _ in 0..1 + rng.below(3) {
        let len = bytes.len();
        match rng.below(5) {
            0 | 1 if len > 0 => {
                let at = rng.below(len);
                bytes[at] ^= 1 << rng.below(8);
            }
            2 => bytes.truncate(rng.below(len + 1)),
            3 => {
                let at = rng.below(len + 1);
                for _ in 0..1 + rng.below(4) {
                    bytes.insert(at, rng.next_u64() as u8);
                }
            }
            _ if len > 0 => {
                let at = rng.below(len);
                let end = (at + 1 + rng.below(4)).min(len);
                if rng.below(2) == 0 {
                    bytes.drain(at..end);
                } else {
                    for b in &mut bytes[at..end] {
                        *b = rng.next_u64() as u8;
                    }
                }
            }
            _ => {}
        }
    }
    bytes
}

/// Limits low enough that a corrupted-but-sealed header cannot make a test
/// allocate gigabytes (the valid file has 4,000 samples).
fn test_limits() -> qm::Limits {
    qm::Limits::DEFAULT.with_max_samples(1 << 20)
}

/// The holed grid with a colour per sample (a smooth field): a colour
/// header, runs and two interleaved streams to corrupt.
fn valid_coloured_qm() -> Vec<u8> {
    let mesh = qm::read_mesh(asset("quad/holed_grid_l4.obj")).unwrap();
    let prepared = qm::detect(&mesh).unwrap();
    let colours: Vec<[u8; 3]> = (prepared.mesh.positions().iter())
        .map(|p| [p.x, p.y, p.z].map(|x| (128.0 + 120.0 * (9.0 * x).sin()) as u8))
        .collect();
    let options = qm::EncodeOptions::DEFAULT.with_bits(10);
    let bytes = qm::codec::compress_coloured(
        &prepared.mesh,
        qm::codec::Colours::new(&colours),
        &options,
        None,
    )
    .unwrap()
    .bytes;
    let header = qm::codec::container::read(&bytes, &qm::Limits::DEFAULT)
        .unwrap()
        .header;
    assert!(
        header.colour.is_some_and(|c| c.runs.len() > 1),
        "interleaved"
    );
    bytes
}

#[test]
fn random_corruptions_never_panic_the_library() {
    never_panics(&valid_qm());
}

/// As [`random_corruptions_never_panic_the_library`], with colours: what
/// decodes has one colour per vertex.
#[test]
fn random_corruptions_of_a_coloured_file_never_panic() {
    never_panics(&valid_coloured_qm());
}

/// As [`random_corruptions_never_panic_the_library`], with colours finer
/// than the geometry (the textured cube of `tests/data`): what decodes
/// with a texture has a whole atlas and coordinates inside it.
#[test]
fn random_corruptions_of_a_textured_file_never_panic() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/textured_cube.qm");
    never_panics(&std::fs::read(path).unwrap());
}

/// 1,000 corruptions of `valid` decode or fail with a one-line error, never
/// a panic, each within 5 s.
fn never_panics(valid: &[u8]) {
    let options = qm::DecodeOptions::default().with_limits(test_limits());
    assert!(qm::codec::decompress(valid, &options).is_ok());
    let (mut ok, mut err, mut truncated) = (0, 0, 0);
    let mut panics = Vec::new();
    let mut slowest = Duration::ZERO;
    for seed in 0..1000u64 {
        let bytes = corrupt(valid, seed);
        let start = Instant::now();
        match catch_unwind(AssertUnwindSafe(|| qm::codec::decompress(&bytes, &options))) {
            Ok(Ok(d)) => {
                ok += 1;
                if let Some(colours) = &d.colours {
                    assert_eq!(colours.len(), d.level_mesh().0.len(), "seed {seed}");
                }
                if let Some(atlas) = &d.texture {
                    let texels = atlas.width as usize * atlas.height as usize;
                    assert_eq!(atlas.texels.len(), texels, "seed {seed}");
                    let corners = atlas.corner_texcoords(d.layout.face_count(), d.level);
                    assert_eq!(corners.len(), 4 * d.level_mesh().1.len(), "seed {seed}");
                    assert!(corners.iter().flatten().all(|&x| (0.0..1.0).contains(&x)));
                }
            }
            Ok(Err(e)) => {
                err += 1;
                truncated += usize::from(e.is_truncated());
                // Every error renders as one line.
                assert!(!e.to_string().contains('\n'), "seed {seed}: {e}");
            }
            Err(_) => panics.push(seed),
        }
        slowest = slowest.max(start.elapsed());
    }
    println!(
        "1000 corruptions: {ok} ok, {err} errors ({truncated} truncated); slowest {slowest:?}"
    );
    assert!(
        panics.is_empty(),
        "decompress panicked for seeds {panics:?}"
    );
    assert!(slowest < Duration::from_secs(5), "{slowest:?}");
}

#[test]
fn random_corruptions_through_the_binary() {
    let valid = valid_qm();
    let dir = tempfile::tempdir().unwrap();
    let mut slowest = (Duration::ZERO, 0);
    let mut failures = Vec::new();
    let (mut ok, mut err) = (0, 0);
    // Sealed-header recipes (seed % 3 == 2) are left to the library test,
    // where the sample limit is low; here the default limits apply.
    for seed in (0..1500u64).filter(|s| s % 3 != 2).take(1000) {
        let bytes = corrupt(&valid, seed);
        std::fs::write(dir.path().join("in.qm"), &bytes).unwrap();
        let run = run_qm(
            &["decompress", "in.qm", "-o", "out.obj", "--quiet"],
            dir.path(),
            Duration::from_secs(10),
        );
        if run.elapsed > slowest.0 {
            slowest = (run.elapsed, seed);
        }
        let left = listing(dir.path());
        match run.code {
            Some(0) if left == ["in.qm", "out.obj"] => ok += 1,
            Some(1 | 3)
                if left == ["in.qm"]
                    && run.stderr.lines().count() == 1
                    && run.stderr.starts_with("error: in.qm: ") =>
            {
                err += 1
            }
            code => failures.push(format!(
                "seed {seed}: exit {code:?}, files {left:?}, stderr {:?}",
                run.stderr
            )),
        }
        let _ = std::fs::remove_file(dir.path().join("out.obj"));
    }
    println!(
        "1000 corruptions through qm: {ok} ok, {err} errors; slowest seed {} in {:?}",
        slowest.1, slowest.0
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(slowest.0 < Duration::from_secs(5), "{slowest:?}");
}

/// Random positions for every sample of the cube layout at `level`.
fn random_cube(level: u32, seed: u64) -> qm::SemiRegularMesh {
    let layout = qm::lift::Layout::new(qm::lift::synthetic::cube(), level).unwrap();
    let mut rng = SplitMix64::new(seed);
    let mut coord = || rng.next_f64() * 2.0 - 1.0;
    let positions = (0..layout.sample_count())
        .map(|_| DVec3::new(coord(), coord(), coord()))
        .collect();
    qm::SemiRegularMesh::new(layout, positions).unwrap()
}

proptest! {
    // No failure persistence: the test file is not under a crate's src/.
    #![proptest_config(ProptestConfig {
        failure_persistence: None,
        ..ProptestConfig::with_cases(32)
    })]

    /// Lossless at the end, and every one of 20 cuts after the base decodes.
    #[test]
    fn random_cubes_round_trip(level in 1u32..=3, bits in 8u32..=16, seed in any::<u64>()) {
        let mesh = random_cube(level, seed);
        let options = qm::EncodeOptions::DEFAULT.with_bits(bits);
        let compressed = qm::codec::compress(&mesh, &options).unwrap();
        let full = qm::codec::decompress(&compressed.bytes, &qm::DecodeOptions::default()).unwrap();
        prop_assert_eq!(&full.values, &compressed.quantized);
        prop_assert!(!full.truncated);
        let start = compressed.header_bytes + compressed.base_bytes;
        let len = compressed.bytes.len();
        for k in 0..20 {
            let cut = start + (len - start) * k / 20;
            let decoded = qm::codec::decompress(&compressed.bytes[..cut], &qm::DecodeOptions::default());
            prop_assert!(decoded.is_ok(), "cut {} of {}: {:?}", cut, len, decoded.err());
            // One value per sample of the levels the decoder built, which
            // hold the level it chose.
            let decoded = decoded.unwrap();
            prop_assert_eq!(decoded.values.len(), decoded.layout.sample_count());
            prop_assert!(decoded.level <= decoded.layout.level() && decoded.layout.level() <= level);
        }
    }
}

/// Messy but usable meshes compress (clean-up and remeshing) and decode.
#[test]
fn messy_meshes_are_remeshed() {
    let cases = corpus_table("Remeshed");
    assert!(!cases.is_empty());
    for case in cases {
        let dir = tempfile::tempdir().unwrap();
        std::fs::copy(corpus_dir().join(&case.file), dir.path().join(&case.file)).unwrap();
        let run = run_qm(
            &["compress", &case.file, "-o", "out.qm", "--quiet"],
            dir.path(),
            Duration::from_secs(10),
        );
        assert_eq!(run.code, Some(0), "{}: {}", case.file, run.stderr);
        let run = run_qm(
            &["decompress", "out.qm", "-o", "out.obj", "--quiet"],
            dir.path(),
            Duration::from_secs(10),
        );
        assert_eq!(run.code, Some(0), "{}: {}", case.file, run.stderr);
        let back = qm::read_mesh(dir.path().join("out.obj")).unwrap();
        assert!(
            back.all_faces_have(4) && back.face_count() > 0,
            "{}",
            case.file
        );
    }
}
