//! The `qm` command line as a user runs it.

mod common;

use std::path::Path;
use std::process::{Command, Output};

use common::{QUAD_MODELS, asset};

fn qm(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_qm"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("qm runs")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// One line `error: ...` naming the file, and exit status 1 (the input's
/// fault).
fn assert_fails_cleanly(out: &Output, file: &str, problem: &str) {
    assert_fails_with(out, 1, file, problem);
}

/// One line `error: ...` naming the file, and exit status `code`: 1 the
/// input, 2 the arguments, 3 a limit.
fn assert_fails_with(out: &Output, code: i32, file: &str, problem: &str) {
    assert_eq!(out.status.code(), Some(code), "{}", stderr(out));
    let err = stderr(out);
    assert_eq!(err.lines().count(), 1, "one line: {err}");
    assert!(err.starts_with("error: "), "{err}");
    assert!(err.contains(file), "names {file}: {err}");
    assert!(err.contains(problem), "says {problem}: {err}");
}

#[test]
fn compress_decompress_round_trip_every_quad_model() {
    let dir = tempfile::tempdir().unwrap();
    for name in QUAD_MODELS {
        let src = asset(&format!("quad/{name}"));
        std::fs::copy(&src, dir.path().join(name)).unwrap();
        let out = qm(&["compress", name, "--quiet"], dir.path());
        assert!(out.status.success(), "{name}: {}", stderr(&out));
        let packed = Path::new(name).with_extension("qm");
        let out = qm(
            &[
                "decompress",
                packed.to_str().unwrap(),
                "-o",
                "back.ply",
                "--quiet",
            ],
            dir.path(),
        );
        assert!(out.status.success(), "{name}: {}", stderr(&out));
        // The decoded mesh has the input's vertices and quads, and each of its
        // vertices is an input vertex up to quantization.
        let input = qm::read_mesh(dir.path().join(name)).unwrap();
        let back = qm::read_mesh(dir.path().join("back.ply")).unwrap();
        assert_eq!(back.positions.len(), input.positions.len(), "{name}");
        assert_eq!(back.face_count(), input.face_count(), "{name}");
        assert!(back.all_faces_have(4));
        let (lo, hi) = qm::lift::bounding_box(&input.positions);
        let step = (hi - lo).max_element() / 65535.0;
        let mut sorted_in: Vec<[i64; 3]> = input
            .positions
            .iter()
            .map(|p| ((*p - lo) / step).round().as_i64vec3().to_array())
            .collect();
        let mut sorted_out: Vec<[i64; 3]> = back
            .positions
            .iter()
            .map(|p| ((*p - lo) / step).round().as_i64vec3().to_array())
            .collect();
        sorted_in.sort();
        sorted_out.sort();
        assert_eq!(sorted_in, sorted_out, "{name}: same quantized vertices");
    }
}

#[test]
fn info_json_reports_the_layout() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(asset("quad/cc_cube.obj"), dir.path().join("cube.obj")).unwrap();
    assert!(
        qm(
            &[
                "compress", "cube.obj", "-o", "cube.qm", "--quiet", "--bits", "12"
            ],
            dir.path()
        )
        .status
        .success()
    );
    let out = qm(&["info", "cube.qm", "--json"], dir.path());
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let size = std::fs::metadata(dir.path().join("cube.qm")).unwrap().len();
    for key in ["header_bytes", "base_bytes", "stream_bytes"] {
        assert!(v[key].as_u64().unwrap() > 0, "{key}");
    }
    let sum: u64 = ["header_bytes", "base_bytes", "stream_bytes"]
        .iter()
        .map(|k| v[k].as_u64().unwrap())
        .sum();
    assert_eq!(sum, size);
    assert_eq!(v["bits"], 12);
    assert_eq!(v["level"], 5);
    assert_eq!(v["base_vertices"], 8);
    assert_eq!(v["base_faces"], 6);
    assert_eq!(v["vertices"], 6146);
    assert_eq!(v["faces"], 6144);
    assert!(v["passes"].as_u64().unwrap() > 10);
    assert_eq!(
        (&v["version"], &v["frames"], &v["normal_bits"]),
        (
            &qm::codec::container::VERSION.into(),
            &true.into(),
            &2.into()
        )
    );
    // The cube's stream dips inside passes: holds, ordered and apart.
    let holds: Vec<[u64; 2]> = serde_json::from_value(v["holds"].clone()).unwrap();
    assert!(!holds.is_empty());
    assert!(
        holds
            .windows(2)
            .all(|h| h[0][0] < h[0][1] && h[0][1] <= h[1][0])
    );
    // A cut inside the first one decodes as its start, and says so.
    let prefix = v["header_bytes"].as_u64().unwrap() + v["base_bytes"].as_u64().unwrap();
    let [from, to] = holds[0];
    assert!(to - from >= 2, "{holds:?}");
    let cut = (prefix + from + 1).to_string();
    let out = qm(
        &["decompress", "cube.qm", "-o", "held.obj", "--bytes", &cut],
        dir.path(),
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let said = format!("inside a hold: decoded as the first {}", prefix + from);
    assert!(stderr(&out).contains(&said), "{}", stderr(&out));
    // The cube's corners predict each other exactly: no noise bits to
    // move into the stream.
    assert_eq!(v["base_low_bits_in_stream"], 0);

    // World axes on request; both decode to the same lossless mesh.
    let out = qm(
        &[
            "compress",
            "cube.obj",
            "-o",
            "world.qm",
            "--quiet",
            "--bits",
            "12",
            "--no-frames",
            "--no-holds",
        ],
        dir.path(),
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let out = qm(&["info", "world.qm", "--json"], dir.path());
    let w: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        (&w["frames"], &w["normal_bits"], &w["parent_frames_from"]),
        (&false.into(), &0.into(), &serde_json::Value::Null)
    );
    // Without holds: the same format, its list of holds empty.
    assert_eq!(
        (&w["version"], &w["holds"]),
        (
            &qm::codec::container::VERSION.into(),
            &serde_json::json!([])
        )
    );
    // A fixed frame source on request, written into the header.
    let fixed = |level: &str, output: &str| {
        let args = [
            "compress",
            "cube.obj",
            "-o",
            output,
            "--quiet",
            "--bits",
            "12",
            "--frames-from",
            level,
        ];
        qm(&args, dir.path())
    };
    let out = fixed("4", "parents4.qm");
    assert!(out.status.success(), "{}", stderr(&out));
    let out = qm(&["info", "parents4.qm", "--json"], dir.path());
    let p: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        (&p["frames"], &p["parent_frames_from"]),
        (&true.into(), &4.into())
    );
    let out = fixed("2", "parents2.qm");
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(!dir.path().join("parents2.qm").exists());
    for name in ["cube", "world", "parents4"] {
        let out = qm(
            &[
                "decompress",
                &format!("{name}.qm"),
                "-o",
                &format!("{name}-out.obj"),
                "--quiet",
            ],
            dir.path(),
        );
        assert!(out.status.success(), "{}", stderr(&out));
    }
    let read = |n: &str| std::fs::read(dir.path().join(n)).unwrap();
    assert_eq!(read("cube-out.obj"), read("world-out.obj"));
}

#[test]
fn truncated_files_decode_and_cuts_in_the_header_say_how_much_is_needed() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(asset("quad/torus_4x6_l4.obj"), dir.path().join("t.obj")).unwrap();
    assert!(
        qm(
            &["compress", "t.obj", "--quiet", "--bytes", "3000"],
            dir.path()
        )
        .status
        .success()
    );
    assert_eq!(
        std::fs::metadata(dir.path().join("t.qm")).unwrap().len(),
        3000
    );
    let out = qm(
        &["decompress", "t.qm", "--bytes", "1500", "--quiet"],
        dir.path(),
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let out = qm(
        &["decompress", "t.qm", "--bytes", "20", "-o", "cut.obj"],
        dir.path(),
    );
    assert_fails_cleanly(&out, "t.qm", "needed");
    assert!(!dir.path().join("cut.obj").exists(), "no output on failure");
}

/// The names of the files in `dir`.
fn file_names(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect()
}

/// Vertices of an OBJ written by `qm decompress`.
fn obj_vertices(path: &Path) -> usize {
    qm::read_mesh(path).unwrap().positions.len()
}

#[test]
fn levels_table_level_choice_goals_and_gltf() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(asset("quad/cc_cube.obj"), dir.path().join("cube.obj")).unwrap();
    assert!(
        qm(&["compress", "cube.obj", "--quiet"], dir.path())
            .status
            .success()
    );
    let size = std::fs::metadata(dir.path().join("cube.qm")).unwrap().len();

    // The prefix table: growing bytes, the whole file last and lossless.
    let out = qm(&["info", "cube.qm", "--levels", "--json"], dir.path());
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = v["levels"].as_array().unwrap();
    let bytes: Vec<u64> = rows.iter().map(|r| r["bytes"].as_u64().unwrap()).collect();
    assert!(bytes.windows(2).all(|b| b[0] < b[1]), "{bytes:?}");
    let last = rows.last().unwrap();
    assert_eq!(last["bytes"].as_u64(), Some(size));
    assert_eq!(last["level"], v["level"]);
    assert_eq!(last["error"].as_f64(), Some(0.0));
    let text = qm(&["info", "cube.qm", "--levels"], dir.path());
    assert!(String::from_utf8_lossy(&text.stdout).contains("psnr dB"));

    // A prefix decodes at the level the bytes support unless told.
    let coarse = rows
        .iter()
        .find(|r| r["level"].as_u64() < v["level"].as_u64())
        .unwrap();
    let cut = coarse["bytes"].to_string();
    let decode = |extra: &[&str], output: &str| {
        let mut args = vec!["decompress", "cube.qm", "-o", output];
        args.extend_from_slice(extra);
        let out = qm(&args, dir.path());
        assert!(out.status.success(), "{extra:?}: {}", stderr(&out));
        (stderr(&out), obj_vertices(&dir.path().join(output)))
    };
    let (said, auto) = decode(&["--bytes", &cut], "auto.obj");
    assert!(
        said.contains(&format!("level {} of", coarse["level"])),
        "{said}"
    );
    assert!(said.contains("estimated error"), "{said}");
    assert_eq!(auto as u64, coarse["vertices"].as_u64().unwrap());
    let (_, finest) = decode(&["--bytes", &cut, "--level", "finest"], "finest.obj");
    let (_, zero) = decode(&["--bytes", &cut, "--level", "0"], "zero.obj");
    assert!(zero < auto && auto < finest, "{zero} {auto} {finest}");
    let (_, capped) = decode(&["--max-triangles", "100"], "capped.obj");
    assert!(capped < finest);
    let goal = coarse["error"].to_string();
    let (said, _) = decode(&["--max-error", &goal, "--quiet"], "goal.obj");
    assert!(said.is_empty());
    let bad = qm(&["decompress", "cube.qm", "--level", "fine"], dir.path());
    assert_eq!(bad.status.code(), Some(2));

    // The GLB: the fallback the summary names, the .qm inside or not.
    let out = qm(&["gltf", "cube.qm"], dir.path());
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("fallback: level"), "{}", stderr(&out));
    let glb = std::fs::read(dir.path().join("cube.glb")).unwrap();
    assert_eq!(&glb[..4], b"glTF");
    assert!(glb.len() as u64 > size);
    let out = qm(
        &[
            "gltf", "cube.qm", "-o", "far.glb", "--uri", "cube.qm", "--quiet",
        ],
        dir.path(),
    );
    assert!(out.status.success(), "{}", stderr(&out));
    assert!((std::fs::metadata(dir.path().join("far.glb")).unwrap().len()) < glb.len() as u64);
    let out = qm(
        &["gltf", "cube.qm", "-o", "cube.gltf", "--quiet"],
        dir.path(),
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("cube.gltf")).unwrap()).unwrap();
    let ext = &json["meshes"][0]["primitives"][0]["extensions"]["QM_progressive_mesh"];
    assert_eq!(ext["uri"], "cube.qm");
    let out = qm(&["gltf", "cube.qm", "-o", "cube.usdz"], dir.path());
    assert_fails_with(&out, 2, "cube.usdz", "must be .glb or .gltf");
    std::fs::write(
        dir.path().join("cut.qm"),
        &std::fs::read(dir.path().join("cube.qm")).unwrap()[..30],
    )
    .unwrap();
    let out = qm(&["gltf", "cut.qm"], dir.path());
    assert_fails_cleanly(&out, "cut.qm", "needed");
    assert!(!dir.path().join("cut.glb").exists(), "no output on failure");
}

#[test]
fn outputs_and_budgets_are_checked_before_the_work() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(asset("quad/cc_cube.obj"), dir.path().join("cube.obj")).unwrap();
    let out = qm(
        &["compress", "cube.obj", "-o", "missing/cube.qm"],
        dir.path(),
    );
    assert_fails_cleanly(
        &out,
        "missing/cube.qm",
        "the output folder missing does not exist",
    );
    let out = qm(
        &["compress", "cube.obj", "--bytes", "50", "--quiet"],
        dir.path(),
    );
    assert_fails_with(
        &out,
        2,
        "cube.obj",
        "a byte budget of 50 bytes is below the",
    );
    assert!(
        stderr(&out).contains("bytes of the header and base mesh"),
        "{}",
        stderr(&out)
    );
    assert!(!dir.path().join("cube.qm").exists());
}

#[test]
fn bad_input_fails_with_one_line_and_exit_1() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("garbage.qm"), b"this is not a qm file at all").unwrap();
    assert_fails_cleanly(
        &qm(&["decompress", "garbage.qm", "-o", "x.obj"], d),
        "garbage.qm",
        "not a .qm",
    );
    assert!(!d.join("x.obj").exists());
    assert_fails_cleanly(
        &qm(&["info", "missing.qm"], d),
        "missing.qm",
        "No such file",
    );
    // A triangle is remeshed; a triangle with no area leaves nothing to remesh.
    std::fs::write(d.join("tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    assert!(qm(&["compress", "tri.obj", "--quiet"], d).status.success());
    assert!(d.join("tri.qm").exists());
    std::fs::write(d.join("flat.obj"), "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n").unwrap();
    assert_fails_cleanly(&qm(&["compress", "flat.obj"], d), "flat.obj", "area");
    assert!(!d.join("flat.qm").exists());
    std::fs::write(d.join("bad.obj"), "v 0 0 0\nf 1 2 7\n").unwrap();
    assert_fails_cleanly(&qm(&["compress", "bad.obj"], d), "bad.obj", "line 2");
    // Never overwrite the input.
    std::fs::copy(asset("quad/holed_grid_l4.obj"), d.join("g.obj")).unwrap();
    assert_fails_with(
        &qm(&["compress", "g.obj", "-o", "g.obj"], d),
        2,
        "g.obj",
        "overwrite",
    );
}

#[test]
fn bad_usage_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    assert_eq!(qm(&["compress"], dir.path()).status.code(), Some(2));
    assert_eq!(qm(&["frobnicate"], dir.path()).status.code(), Some(2));
    assert_eq!(
        qm(&["compress", "x.obj", "--bits", "99"], dir.path())
            .status
            .code(),
        Some(2)
    );
}

/// Outputs get the mode any new file gets here, not the owner-only mode of
/// the temporary file they are written through.
#[cfg(unix)]
#[test]
fn outputs_get_the_usual_file_mode() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(asset("quad/cc_cube.obj"), dir.path().join("cube.obj")).unwrap();
    let usual = dir.path().join("usual");
    std::fs::File::create(&usual).unwrap();
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    let out = qm(&["compress", "cube.obj", "--quiet"], dir.path());
    assert!(out.status.success(), "{}", stderr(&out));
    let out = qm(
        &["decompress", "cube.qm", "-o", "back.obj", "--quiet"],
        dir.path(),
    );
    assert!(out.status.success(), "{}", stderr(&out));
    for made in ["cube.qm", "back.obj"] {
        assert_eq!(mode(&dir.path().join(made)), mode(&usual), "{made}");
    }
}

/// Work that needs more memory than `--max-memory` is refused before it
/// starts, saying what it needs and what the limit is, and writes nothing:
/// a remesh at a level too fine for the limit, and a decode of a file that
/// asks for more than the limit.
/// A small open patch (from the remesher fuzz target) whose map onto one
/// square folds: `auto` compresses it anyway, as its own four triangles
/// (the charts' base is those triangles too); with one square alone it is
/// refused, and with `--accept-folds` its samples land outside the part,
/// which is refused too.
#[test]
fn a_part_that_folds_on_its_square_is_sent_as_itself() {
    let dir = tempfile::tempdir().unwrap();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/folded-map.obj");
    std::fs::copy(data, dir.path().join("patch.obj")).unwrap();
    let out = qm(&["compress", "patch.obj"], dir.path());
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(
        err.contains("base domain: input, since the remesh through charts took"),
        "{err}"
    );
    assert!(err.contains("remesh measured at"), "{err}");
    assert!(dir.path().join("patch.qm").exists());
    let square = |extra: &[&str]| {
        let mut args = vec![
            "compress",
            "patch.obj",
            "-o",
            "square.qm",
            "--base-domain",
            "square",
        ];
        args.extend_from_slice(extra);
        qm(&args, dir.path())
    };
    let out = square(&["--quiet"]);
    assert_fails_cleanly(&out, "patch.obj", "(--accept-folds writes it anyway)");
    assert!(!dir.path().join("square.qm").exists());
    let out = square(&["--accept-folds", "--quiet"]);
    assert_fails_cleanly(&out, "patch.obj", "does not map onto its square");
}

#[test]
fn memory_limits_refuse_work_before_it_starts() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(asset("spot.obj"), dir.path().join("spot.obj")).unwrap();
    // Level 9 on spot's 81 base quads: 21M samples, 5 GiB by the estimate.
    let out = qm(
        &[
            "compress",
            "spot.obj",
            "--level",
            "9",
            "--max-memory",
            "1G",
            "--quiet",
        ],
        dir.path(),
    );
    assert_fails_with(
        &out,
        3,
        "spot.obj",
        "above the limit of 1 GiB (--max-memory raises it)",
    );
    assert!(!dir.path().join("spot.qm").exists());
    // The input alone: spot's 5,856 triangles need 14 MiB.
    let out = qm(
        &["compress", "spot.obj", "--max-memory", "8M", "--quiet"],
        dir.path(),
    );
    assert_fails_with(&out, 3, "spot.obj", "5856 input triangles");
    std::fs::copy(asset("quad/cc_cube.obj"), dir.path().join("cube.obj")).unwrap();
    let out = qm(&["compress", "cube.obj", "--quiet"], dir.path());
    assert!(out.status.success(), "{}", stderr(&out));
    let out = qm(
        &["decompress", "cube.qm", "--max-memory", "512K", "--quiet"],
        dir.path(),
    );
    assert_fails_with(&out, 3, "cube.qm", "samples, above the limit of 512 KiB");
    let out = qm(
        &["decompress", "cube.qm", "--max-memory", "2M", "--quiet"],
        dir.path(),
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let out = qm(
        &["decompress", "cube.qm", "--max-memory", "lots"],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(2), "bad usage");
}

/// Interrupt and terminate at any moment leave either no output or a whole
/// one, and never the hidden temporary file of a write in progress.
#[cfg(unix)]
#[test]
fn a_signal_leaves_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(asset("spot.obj"), dir.path().join("spot.obj")).unwrap();
    let out = qm(&["compress", "spot.obj", "--quiet"], dir.path());
    assert!(out.status.success(), "{}", stderr(&out));
    let whole = qm(
        &[
            "decompress",
            "spot.qm",
            "--level",
            "finest",
            "-o",
            "whole.obj",
            "--quiet",
        ],
        dir.path(),
    );
    assert!(whole.status.success(), "{}", stderr(&whole));
    let whole = std::fs::read(dir.path().join("whole.obj")).unwrap();
    for (k, signal) in ["INT", "TERM", "INT", "TERM", "TERM", "INT"]
        .iter()
        .enumerate()
    {
        let output = format!("out{k}.obj");
        let mut child = Command::new(env!("CARGO_BIN_EXE_qm"))
            .args([
                "decompress",
                "spot.qm",
                "--level",
                "finest",
                "-o",
                &output,
                "--quiet",
            ])
            .current_dir(dir.path())
            .spawn()
            .unwrap();
        std::thread::sleep(std::time::Duration::from_millis(40 * k as u64 + 20));
        let _ = Command::new("kill")
            .args([format!("-{signal}"), child.id().to_string()])
            .status();
        let status = child.wait().unwrap();
        let names = file_names(dir.path());
        assert!(
            !names.iter().any(|n| n.starts_with(".qm-")),
            "{signal} after {k}: {names:?}"
        );
        // A signal may also land after the output's rename, before the
        // exit: then the status says interrupted and the output is whole.
        let written = dir.path().join(&output);
        match std::fs::read(&written) {
            Ok(bytes) => assert!(bytes == whole, "{signal}: {status:?} left part of {output}"),
            Err(_) => assert_ne!(status.code(), Some(0), "{signal}: success without {output}"),
        }
    }
}

/// Past a file-size limit a write fails with one line and no temporary
/// file, instead of SIGXFSZ ending the process with the file left.
#[cfg(unix)]
#[test]
fn a_file_size_limit_fails_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(asset("spot.obj"), dir.path().join("spot.obj")).unwrap();
    assert!(
        qm(&["compress", "spot.obj", "--quiet"], dir.path())
            .status
            .success()
    );
    let script = format!(
        "ulimit -f 100; exec '{}' decompress spot.qm --level finest -o big.obj --quiet",
        env!("CARGO_BIN_EXE_qm")
    );
    let out = Command::new("sh")
        .args(["-c", &script])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_fails_cleanly(&out, "big.obj", "File too large");
    let names = file_names(dir.path());
    assert!(
        !names
            .iter()
            .any(|n| n.starts_with(".qm-") || n == "big.obj"),
        "{names:?}"
    );
}

/// Output piped into a reader that stops early (`qm info x.qm | head -1`)
/// ends `qm` quietly with status 0, not with a panic on the broken pipe;
/// output that cannot be written elsewhere (a full disk) is an error.
#[test]
fn a_closed_stdout_is_no_panic() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(asset("spot.obj"), dir.path().join("spot.obj")).unwrap();
    let out = qm(&["compress", "spot.obj", "--quiet"], dir.path());
    assert!(out.status.success(), "{}", stderr(&out));
    // The read end closed before `qm` writes: its first line meets a
    // broken pipe.
    let mut child = Command::new(env!("CARGO_BIN_EXE_qm"))
        .args(["info", "--levels", "spot.qm"])
        .current_dir(dir.path())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert!(stderr(&out).is_empty(), "{}", stderr(&out));
    if Path::new("/dev/full").exists() {
        let out = Command::new(env!("CARGO_BIN_EXE_qm"))
            .args(["info", "spot.qm"])
            .current_dir(dir.path())
            .stdout(std::fs::File::create("/dev/full").unwrap())
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
        assert!(stderr(&out).starts_with("error: cannot write to stdout"));
    }
}

/// The warning lines of a run's stderr.
fn warnings(out: &Output) -> Vec<String> {
    stderr(out)
        .lines()
        .filter(|l| l.starts_with("warning: "))
        .map(str::to_owned)
        .collect()
}

/// The kinds of `qm compress --json`'s `dropped` list.
fn dropped_kinds(out: &Output) -> (Vec<String>, serde_json::Value) {
    assert!(out.status.success(), "{}", stderr(out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let kinds = v["dropped"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| d["kind"].as_str().unwrap().to_owned())
        .collect();
    (kinds, v)
}

#[test]
fn compress_names_every_attribute_it_cannot_carry() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A textured, vertex-coloured OBJ whose second image is missing.
    std::fs::create_dir(d.join("maps")).unwrap();
    std::fs::write(d.join("maps/wood.png"), b"located, not decoded").unwrap();
    std::fs::write(
        d.join("two.mtl"),
        "newmtl wood\nKd 0.8 0.6 0.4\nmap_Kd -s 1 1 1 maps/wood.png\n\
         newmtl stone\nmap_Kd maps/stone.png\nbump maps/n.png\n",
    )
    .unwrap();
    std::fs::write(
        d.join("two.obj"),
        "mtllib two.mtl\n\
         v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 2 0 0 0 0 1\nv 0 1 0 1 1 1\nv 1 1 0 0 0 0\nv 2 1 0 0 0 0\n\
         vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n\
         usemtl wood\nf 1/1/1 2/2/1 5/3/1 4/4/1\nusemtl stone\nf 2/1/1 3/2/1 6/3/1 5/4/1\n",
    )
    .unwrap();
    let out = qm(&["compress", "two.obj", "--base-domain", "input"], d);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(d.join("two.qm").exists(), "and still compresses");
    let lines = warnings(&out);
    // The vertex colours and the materials' base colours are carried.
    let expected = [
        "texture coordinates not carried (8)",
        "textures not carried (2)",
        "other material maps not carried (1)",
        "normals not carried (1)",
        "other properties not carried (1)",
    ];
    assert_eq!(lines.len(), expected.len(), "one line a kind: {lines:#?}");
    for (line, fragment) in lines.iter().zip(expected) {
        assert!(line.starts_with("warning: two.obj: "), "{line}");
        assert!(line.contains(fragment), "{line:?} lacks {fragment:?}");
    }
    assert!(lines[1].contains("stone.png: No such file"), "{}", lines[1]);

    let began = std::time::Instant::now();
    let out = qm(
        &[
            "compress",
            "two.obj",
            "-o",
            "j.qm",
            "--base-domain",
            "input",
            "--json",
            "--quiet",
        ],
        d,
    );
    let wall = began.elapsed().as_secs_f64();
    assert!(stderr(&out).is_empty(), "--quiet: {}", stderr(&out));
    let (kinds, v) = dropped_kinds(&out);
    // Each step's time, none negative, together within the run's.
    let steps = ["reading", "semi_regular", "coding", "writing"];
    let seconds: Vec<f64> = (steps.iter())
        .map(|k| v["seconds"][k].as_f64().unwrap_or(-1.0))
        .collect();
    assert!(seconds.iter().all(|&t| t >= 0.0), "{v}");
    let total: f64 = seconds.iter().sum();
    assert!(total > 0.0 && total <= wall, "{v}");
    assert_eq!(
        kinds,
        [
            "tex_coords",
            "textures",
            "other_maps",
            "normals",
            "properties"
        ]
    );
    assert_eq!(v["dropped"][0]["count"], 8);
    assert_eq!(v["colour"], true);
    assert_eq!(v["base_domain"], "input");
    assert!(v["base_domain_why"].is_null(), "asked for: {v}");
    assert_eq!(
        v["bytes"].as_u64().unwrap(),
        std::fs::metadata(d.join("j.qm")).unwrap().len()
    );

    // The bundled assets: a textured GLB and a vertex-coloured PLY, with
    // their look and without.
    for (name, geometry_only, expected) in [
        (
            "appearance/pico-neo3-left.glb",
            false,
            &["tex_coords", "textures", "normals"][..],
        ),
        ("appearance/greg-turk-cube.ply", false, &["lines"]),
        (
            "appearance/greg-turk-cube.ply",
            true,
            &["vertex_colors", "lines"],
        ),
        ("quad/cc_cube.obj", false, &[]),
    ] {
        let file = Path::new(name).file_name().unwrap().to_str().unwrap();
        std::fs::copy(asset(name), d.join(file)).unwrap();
        let mut args = vec![
            "compress",
            file,
            "-o",
            "a.qm",
            "--base-domain",
            "input",
            "--json",
        ];
        if geometry_only {
            args.push("--geometry-only");
        }
        let out = qm(&args, d);
        let (kinds, v) = dropped_kinds(&out);
        assert_eq!(kinds, expected, "{name}");
        let coloured = !geometry_only && !name.starts_with("quad");
        assert_eq!(v["colour"], coloured, "{name}");
        // A quad mesh is taken as it is: no base domain.
        assert_eq!(
            v["base_domain"].is_null(),
            name.starts_with("quad"),
            "{name}"
        );
        assert_eq!(
            warnings(&out).len(),
            expected.len(),
            "{name}: {}",
            stderr(&out)
        );
        if name.ends_with(".glb") {
            let detail = v["dropped"][1]["detail"].as_str().unwrap();
            assert!(detail.contains("image/jpeg"), "{detail}");
        }
    }
}

/// A vertex-coloured mesh coded as itself comes back with its colours:
/// every input vertex's colour, exactly, at the vertex where it was, in
/// PLY and in OBJ; the GLB gets them as COLOR_0.
#[test]
fn colours_come_back_at_their_vertices() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(asset("appearance/greg-turk-cube.ply"), d.join("cube.ply")).unwrap();
    let out = qm(
        &["compress", "cube.ply", "--base-domain", "input", "--json"],
        d,
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let floor = summary["colour_floor_db"].as_f64().expect("measured");
    let input = qm::read_asset(d.join("cube.ply"), &qm::AssetOptions::DEFAULT).unwrap();
    let colours = input.colors.as_ref().unwrap();
    for output in ["out.ply", "out.obj"] {
        let out = qm(
            &[
                "decompress",
                "cube.qm",
                "--level",
                "finest",
                "-o",
                output,
                "--quiet",
            ],
            d,
        );
        assert!(out.status.success(), "{}", stderr(&out));
        let decoded = qm::read_asset(d.join(output), &qm::AssetOptions::DEFAULT).unwrap();
        // What the summary said the samples can show is about what the
        // whole file shows, measured as qm distance does.
        let options = qm::param::DistanceOptions::default().with_samples(20_000);
        let colour = qm::param::colour_distance(&input, &decoded, &options)
            .unwrap()
            .expect("both coloured");
        assert!(
            (colour.psnr_db - floor).abs() < 1.5,
            "{output}: {} dB against a floor of {floor} dB",
            colour.psnr_db
        );
        let decoded_colours = decoded.colors.as_ref().expect("colours written");
        assert_eq!(decoded_colours.len(), decoded.mesh.positions.len());
        for (p, c) in input.mesh.positions.iter().zip(colours) {
            let (k, _) = (decoded.mesh.positions.iter().enumerate())
                .map(|(k, q)| (k, q.distance(*p)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap();
            let back = decoded_colours[k].map(|x| (x * 255.0).round() as u8);
            let want = c.map(|x| (x * 255.0).round() as u8);
            assert_eq!(back[..3], want[..3], "{output}: vertex at {p}");
        }
    }
    let out = qm(&["info", "cube.qm", "--json"], d);
    let info: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let stream = info["stream_bytes"].as_u64().unwrap();
    let colour = &info["colour"];
    assert!(colour["runs"].as_u64().unwrap() >= 1, "{info}");
    assert_eq!(
        colour["stream_bytes"].as_u64().unwrap()
            + colour["geometry_stream_bytes"].as_u64().unwrap(),
        stream
    );
    let out = qm(&["gltf", "cube.qm", "-o", "cube.glb", "--quiet"], d);
    assert!(out.status.success(), "{}", stderr(&out));
    let glb = qm::read_asset(d.join("cube.glb"), &qm::AssetOptions::DEFAULT).unwrap();
    assert!(glb.colors.is_some(), "COLOR_0 in the fallback");
}

/// An ASCII PLY of the unit square as two triangles, its corners coloured
/// `colours` (8-bit RGB) unless there are none.
fn square_ply(colours: Option<[[u8; 3]; 4]>) -> String {
    let properties = if colours.is_some() {
        "property uchar red\nproperty uchar green\nproperty uchar blue\n"
    } else {
        ""
    };
    let mut text = format!(
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
         property float z\n{properties}element face 2\nproperty list uchar int vertex_indices\n\
         end_header\n"
    );
    for (k, (x, y)) in [(0, 0), (1, 0), (1, 1), (0, 1)].into_iter().enumerate() {
        text += &format!("{x} {y} 0");
        if let Some(colours) = colours {
            let [r, g, b] = colours[k];
            text += &format!(" {r} {g} {b}");
        }
        text += "\n";
    }
    text + "3 0 1 2\n3 0 2 3\n"
}

#[test]
fn distance_reports_colour_psnr_when_both_meshes_have_colours() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let colours = [[200, 30, 40], [20, 180, 60], [90, 90, 230], [120, 60, 10]];
    let shifted = colours.map(|c| c.map(|x| x + 10));
    std::fs::write(d.join("a.ply"), square_ply(Some(colours))).unwrap();
    std::fs::write(d.join("b.ply"), square_ply(Some(shifted))).unwrap();
    std::fs::write(d.join("plain.ply"), square_ply(None)).unwrap();
    let samples = ["--samples", "20000"];

    let out = qm(&[&["distance", "a.ply", "b.ply"][..], &samples].concat(), d);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8(out.stdout).unwrap();
    // Every channel 10 apart: RMS 10, PSNR 20 log10(25.5), beside the
    // geometric PSNR (infinite: the same surface).
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[3], "      psnr: inf dB", "{text}");
    assert!(
        lines[4].starts_with("    colour: psnr 28.131 dB, rms 10.0000 (8-bit RGB; "),
        "{text}"
    );

    let out = qm(
        &[&["distance", "a.ply", "b.ply", "--json"][..], &samples].concat(),
        d,
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let colour = &v["colour"];
    assert_eq!(colour["rms"], 10.0, "{v}");
    for side in ["a_to_b", "b_to_a"] {
        assert_eq!(colour[side]["rms"], 10.0, "{v}");
        let psnr = colour[side]["psnr_db"].as_f64().unwrap();
        assert!((psnr - 20.0 * 25.5f64.log10()).abs() < 1e-9, "{v}");
    }
    assert!(v["psnr_db"].is_null(), "the geometry's, still there: {v}");

    // One mesh without colour: no colour at all, in text or JSON.
    for args in [
        vec!["distance", "a.ply", "plain.ply"],
        vec!["distance", "plain.ply", "a.ply", "--json"],
    ] {
        let out = qm(&[&args[..], &samples].concat(), d);
        assert!(out.status.success(), "{}", stderr(&out));
        let text = String::from_utf8(out.stdout).unwrap();
        assert!(!text.contains("colour"), "{text}");
    }
}

/// A cube of six quads under a texture with detail far finer than its
/// eight corners: the stream carries the texture's colours at finer levels
/// than the geometry, `decompress` writes them as OBJ + MTL + PNG or into a
/// GLB, and that texture is far closer to the input's colours than the same decode's
/// colours at the vertices (PLY).
#[test]
fn a_texture_finer_than_the_mesh_comes_back_as_a_texture() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let size = 128u32;
    let texels: Vec<[u8; 3]> = (0..size * size)
        .map(|k| {
            let (x, y) = (
                (k % size) as f64 / size as f64,
                (k / size) as f64 / size as f64,
            );
            let wave = |a: f64, b: f64| (127.5 + 120.0 * (a * x + b * y).sin()) as u8;
            [wave(20.0, 3.0), wave(-6.0, 17.0), wave(11.0, 11.0)]
        })
        .collect();
    std::fs::write(d.join("waves.png"), qm::io::png_bytes(size, size, &texels)).unwrap();
    std::fs::write(d.join("cube.mtl"), "newmtl w\nmap_Kd waves.png\n").unwrap();
    let mut obj = String::from("mtllib cube.mtl\nusemtl w\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n");
    let (positions, faces) = qm_shapes::cube();
    for p in positions {
        obj += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    for f in faces.iter().map(|f| f.map(|v| v + 1)) {
        obj += &format!("f {}/1 {}/2 {}/3 {}/4\n", f[0], f[1], f[2], f[3]);
    }
    std::fs::write(d.join("cube.obj"), obj).unwrap();
    let out = qm(&["compress", "cube.obj", "--quiet"], d);
    assert!(out.status.success(), "{}", stderr(&out));
    let out = qm(&["info", "cube.qm", "--json"], d);
    let info: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(info["level"], 0, "{info}");
    assert_eq!(info["colour"]["level"], 6, "{info}");
    let colour_psnr = |output: &str, bytes: Option<&str>| {
        let mut args = vec!["decompress", "cube.qm", "-o", output, "--quiet"];
        args.extend(bytes.map(|b| ["--bytes", b]).into_iter().flatten());
        let out = qm(&args, d);
        assert!(out.status.success(), "{}", stderr(&out));
        let out = qm(&["distance", "cube.obj", output, "--json"], d);
        assert!(out.status.success(), "{}", stderr(&out));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        v["colour"]["psnr_db"].as_f64().unwrap()
    };
    let textured = colour_psnr("t.obj", None);
    for file in ["t.obj", "t.mtl", "t.png"] {
        assert!(d.join(file).exists(), "{file}");
    }
    // The same texture embedded in a GLB (a PNG baseColorTexture).
    let glb = colour_psnr("t.glb", None);
    assert!(
        (glb - textured).abs() < 0.5,
        "GLB {glb:.1} dB, OBJ {textured:.1} dB"
    );
    let at_vertices = colour_psnr("v.ply", None);
    assert!(
        textured > 30.0 && textured > at_vertices + 10.0,
        "texture {textured:.1} dB, vertex colours {at_vertices:.1} dB"
    );
    // A prefix: a coarser texture, still a texture.
    let len = std::fs::metadata(d.join("cube.qm")).unwrap().len();
    let prefix = colour_psnr("p.obj", Some(&(len / 3).to_string()));
    assert!(d.join("p.png").exists());
    assert!(
        prefix < textured,
        "{prefix:.1} dB of a third, {textured:.1} dB whole"
    );
}
