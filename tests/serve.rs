//! `qm serve` as a static server for progressive streaming, checked over
//! raw TCP: byte ranges with exact bytes, HEAD, entity tags and conditional
//! requests, CORS, bounded requests, time-outs, symbolic links, the
//! throttle and the request log. Each test starts its own server; all take
//! a few seconds together.

mod serving;

use std::io::{Read, Write};
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use serving::{Reply, Served, memory_kib};

/// A glTF scene whose buffer is `scene.bin`.
const SCENE: &[u8] = br#"{"buffers":[{"uri":"scene.bin"}]}"#;

/// A real `.qm` file of 14,057 bytes.
const MODEL: &str = "split_octahedron.qm";

fn model_bytes() -> Vec<u8> {
    std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../tests/data")
            .join(MODEL),
    )
    .unwrap()
}

/// A folder with `web/` (a page, a script, a wasm file) and `models/`
/// (the model, a glb, a gltf with its bin).
fn site() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let web = dir.path().join("web");
    std::fs::create_dir(&web).unwrap();
    std::fs::write(web.join("index.html"), b"<!doctype html><p>viewer</p>\n").unwrap();
    std::fs::write(web.join("main.js"), b"console.log(1);\n").unwrap();
    std::fs::write(web.join("qm_wasm_bg.wasm"), b"\0asm\x01\0\0\0").unwrap();
    let models = dir.path().join("models");
    std::fs::create_dir(&models).unwrap();
    std::fs::write(models.join(MODEL), model_bytes()).unwrap();
    std::fs::write(models.join("box.glb"), b"glTF\x02\0\0\0").unwrap();
    std::fs::write(models.join("scene.gltf"), SCENE).unwrap();
    std::fs::write(models.join("scene.bin"), [1u8, 2, 3, 4]).unwrap();
    dir
}

fn start(dir: &Path, extra: &[&str]) -> Served {
    let mut args = vec!["models", "--web", "web", "--quiet"];
    args.extend_from_slice(extra);
    Served::start(dir, &args)
}

const PATH: &str = "/models/split_octahedron.qm";

#[test]
fn ranges_get_exact_bytes() {
    let dir = site();
    let server = start(dir.path(), &[]);
    let data = model_bytes();
    let len = data.len();
    let whole = server.get(PATH, &[]);
    assert_eq!((whole.status, &whole.body), (200, &data));
    assert_eq!(whole.header("accept-ranges"), Some("bytes"));
    assert_eq!(
        whole.header("content-type"),
        Some("application/octet-stream")
    );
    assert!(whole.header("etag").is_some_and(|t| t.starts_with('"')));
    assert!(whole.header("last-modified").is_some());

    let cases = [
        ("bytes=0-3062", 0, 3062),
        ("bytes=3063-", 3063, len - 1),
        ("bytes=-100", len - 100, len - 1),
        ("bytes=10-999999", 10, len - 1),
    ];
    for (range, first, last) in cases {
        let r = server.get(PATH, &[&format!("Range: {range}")]);
        assert_eq!(r.status, 206, "{range}");
        assert_eq!(r.body, &data[first..=last], "{range}");
        assert_eq!(
            r.header("content-range"),
            Some(format!("bytes {first}-{last}/{len}").as_str())
        );
        assert_eq!(
            r.header("content-length"),
            Some((last - first + 1).to_string().as_str())
        );
    }
    for range in [format!("bytes={len}-"), "bytes=-0".to_string()] {
        let r = server.get(PATH, &[&format!("Range: {range}")]);
        assert_eq!(r.status, 416, "{range}");
        assert_eq!(
            r.header("content-range"),
            Some(format!("bytes */{len}").as_str())
        );
        assert!(r.body.is_empty());
    }
    // Several ranges get the whole file.
    let r = server.get(PATH, &["Range: bytes=0-1,5-6"]);
    assert_eq!((r.status, r.body.len()), (200, len));

    // A prefix, then the rest on the same connection, as a streaming
    // client resumes.
    let tag = whole.header("etag").unwrap();
    let two = format!(
        "GET {PATH} HTTP/1.1\r\nHost: x\r\nRange: bytes=0-999\r\n\r\n\
         GET {PATH} HTTP/1.1\r\nHost: x\r\nRange: bytes=1000-\r\nIf-Range: {tag}\r\nConnection: close\r\n\r\n"
    );
    let replies = server.exchange(two.as_bytes()).unwrap();
    assert_eq!(replies.len(), 2);
    let joined: Vec<u8> = replies.iter().flat_map(|r| r.body.clone()).collect();
    assert_eq!(joined, data);
}

#[test]
fn head_conditional_requests_and_if_range() {
    let dir = site();
    let server = start(dir.path(), &[]);
    let len = model_bytes().len().to_string();
    let head = server.request("HEAD", PATH, &[]);
    assert_eq!((head.status, head.body.len()), (200, 0));
    assert_eq!(head.header("content-length"), Some(len.as_str()));
    let tag = head.header("etag").unwrap().to_string();
    let modified = head.header("last-modified").unwrap().to_string();

    let not_modified = server.get(PATH, &[&format!("If-None-Match: {tag}")]);
    assert_eq!((not_modified.status, not_modified.body.len()), (304, 0));
    assert_eq!(not_modified.header("etag"), Some(tag.as_str()));
    assert_eq!(server.get(PATH, &["If-None-Match: \"other\""]).status, 200);
    assert_eq!(
        server
            .get(PATH, &[&format!("If-Modified-Since: {modified}")])
            .status,
        304
    );
    assert_eq!(
        server
            .get(
                "/",
                &[&format!(
                    "If-None-Match: {}",
                    server.get("/", &[]).header("etag").unwrap()
                )]
            )
            .status,
        304
    );

    let resumed = server.get(PATH, &["Range: bytes=100-", &format!("If-Range: {tag}")]);
    assert_eq!(resumed.status, 206);
    let changed = server.get(PATH, &["Range: bytes=100-", "If-Range: \"changed\""]);
    assert_eq!(
        (changed.status, changed.body.len().to_string()),
        (200, len.clone())
    );
    let dated = server.get(
        PATH,
        &["Range: bytes=100-", &format!("If-Range: {modified}")],
    );
    assert_eq!(dated.status, 206);
}

#[test]
fn cors_types_and_models() {
    let dir = site();
    let server = start(dir.path(), &[]);
    let r = server.get(PATH, &["Origin: http://example.test"]);
    assert_eq!(r.header("access-control-allow-origin"), Some("*"));
    let exposed = r.header("access-control-expose-headers").unwrap();
    for h in [
        "Content-Range",
        "Content-Length",
        "Accept-Ranges",
        "ETag",
        "Last-Modified",
    ] {
        assert!(exposed.contains(h), "{exposed}");
    }
    let preflight = server.request(
        "OPTIONS",
        PATH,
        &[
            "Origin: http://example.test",
            "Access-Control-Request-Method: GET",
            "Access-Control-Request-Headers: range, if-range",
        ],
    );
    assert_eq!(preflight.status, 204);
    assert_eq!(preflight.header("access-control-allow-origin"), Some("*"));
    let methods = preflight.header("access-control-allow-methods").unwrap();
    assert!(
        methods.contains("GET") && methods.contains("HEAD"),
        "{methods}"
    );
    let allowed = preflight.header("access-control-allow-headers").unwrap();
    for h in ["Range", "If-Range", "If-None-Match"] {
        assert!(allowed.contains(h), "{allowed}");
    }
    assert_eq!(
        server.get(PATH, &[]).header("access-control-allow-origin"),
        Some("*")
    );
    assert_eq!(server.request("POST", PATH, &[]).status, 405);

    let types = [
        ("/", "text/html; charset=utf-8"),
        ("/main.js", "text/javascript; charset=utf-8"),
        ("/qm_wasm_bg.wasm", "application/wasm"),
        ("/models/box.glb", "model/gltf-binary"),
        ("/models/scene.gltf", "model/gltf+json"),
        ("/models/scene.bin", "application/octet-stream"),
        ("/models.json", "application/json"),
    ];
    for (path, content_type) in types {
        let r = server.get(path, &[]);
        assert_eq!(
            (r.status, r.header("content-type")),
            (200, Some(content_type)),
            "{path}"
        );
    }
    let list: serde_json::Value =
        serde_json::from_slice(&server.get("/models.json", &[]).body).unwrap();
    assert_eq!(
        list,
        serde_json::json!([
            { "name": MODEL, "bytes": model_bytes().len() },
            { "name": "box.glb", "bytes": 8 },
            { "name": "scene.gltf", "bytes": SCENE.len() },
        ])
    );
    for missing in [
        "/models/nothing.qm",
        "/nothing",
        "/models/../web/index.html",
        "/%2e%2e/models/box.glb",
    ] {
        assert_eq!(server.get(missing, &[]).status, 404, "{missing}");
    }
}

/// Writes `request` whole (ignoring a reset), then reads the status.
fn refusal(server: &Served, request: &[u8]) -> Option<u16> {
    let mut stream = server.connect().ok()?;
    let _ = stream.write_all(request);
    let mut bytes = Vec::new();
    let _ = stream.read_to_end(&mut bytes);
    Reply::parse_all(&bytes, false)
        .ok()?
        .first()
        .map(|r| r.status)
}

#[test]
fn oversized_requests_are_refused_without_growing() {
    let dir = site();
    let server = start(dir.path(), &[]);
    assert_eq!(server.get("/", &[]).status, 200);
    let before = memory_kib(server.pid(), "VmHWM");

    let long_line = format!("GET / HTTP/1.1\r\nX-Long: {}\r\n\r\n", "v".repeat(300_000));
    assert_eq!(refusal(&server, long_line.as_bytes()), Some(431));
    let mut many = "GET / HTTP/1.1\r\n".to_string();
    for i in 0..1000 {
        many.push_str(&format!("X-{i}: v\r\n"));
    }
    many.push_str("\r\n");
    assert_eq!(refusal(&server, many.as_bytes()), Some(431));
    let long_url = format!("GET /{} HTTP/1.1\r\n\r\n", "a".repeat(300_000));
    assert_eq!(refusal(&server, long_url.as_bytes()), Some(414));
    assert_eq!(refusal(&server, b"BAD\r\n\r\n"), Some(400));

    // 16 clients sending 4 MB header lines at once: the server keeps at
    // most a few kilobytes of each.
    let huge =
        Box::leak(format!("GET / HTTP/1.1\r\nX-Huge: {}", "v".repeat(4 << 20)).into_boxed_str());
    let clients: Vec<_> = (0..16)
        .map(|_| {
            let mut stream = server.connect().unwrap();
            let huge: &'static str = huge;
            std::thread::spawn(move || {
                let _ = stream.write_all(huge.as_bytes());
                let _ = stream.read_to_end(&mut Vec::new());
            })
        })
        .collect();
    for c in clients {
        c.join().unwrap();
    }
    let after = memory_kib(server.pid(), "VmHWM");
    assert!(
        after < before + 8 * 1024,
        "peak memory {before} -> {after} KiB"
    );
    assert_eq!(server.get("/", &[]).status, 200);
}

#[test]
fn slow_and_idle_clients_are_timed_out() {
    let dir = site();
    let server = start(dir.path(), &["--timeout", "0.5"]);
    let start = Instant::now();
    let mut slow = server.connect().unwrap();
    slow.write_all(b"GET / HTTP/1.1\r\nHost: x\r\n").unwrap();
    let mut idle = server.connect().unwrap();
    let mut bytes = Vec::new();
    slow.read_to_end(&mut bytes).unwrap();
    assert!(
        bytes.starts_with(b"HTTP/1.1 408 "),
        "{:?}",
        String::from_utf8_lossy(&bytes)
    );
    let mut nothing = Vec::new();
    idle.read_to_end(&mut nothing).unwrap();
    assert!(nothing.is_empty());
    assert!(
        start.elapsed() < Duration::from_secs(3),
        "{:?}",
        start.elapsed()
    );
    // A kept-alive connection is closed after the same time.
    let mut kept = server.connect().unwrap();
    kept.write_all(b"GET / HTTP/1.1\r\nHost: x\r\n\r\n")
        .unwrap();
    let mut bytes = Vec::new();
    kept.read_to_end(&mut bytes).unwrap();
    assert_eq!(Reply::parse_all(&bytes, false).unwrap()[0].status, 200);
}

#[cfg(unix)]
#[test]
fn symbolic_links_lead_nowhere() {
    use std::os::unix::fs::symlink;
    let dir = site();
    let outside = tempfile::tempdir().unwrap();
    let secret = outside.path().join("secret.qm");
    std::fs::write(&secret, model_bytes()).unwrap();
    std::fs::create_dir(outside.path().join("folder")).unwrap();
    std::fs::write(outside.path().join("folder/page.html"), b"outside").unwrap();
    let (models, web) = (dir.path().join("models"), dir.path().join("web"));
    symlink(&secret, models.join("link.qm")).unwrap();
    symlink(&secret, web.join("link.html")).unwrap();
    symlink(outside.path().join("folder"), web.join("folder")).unwrap();
    std::fs::write(models.join("swapped.qm"), model_bytes()).unwrap();
    let server = start(dir.path(), &[]);
    assert_eq!(server.get("/models/swapped.qm", &[]).status, 200);
    let listed = String::from_utf8(server.get("/models.json", &[]).body).unwrap();
    assert!(!listed.contains("link.qm"), "{listed}");
    for path in ["/models/link.qm", "/link.html", "/folder/page.html"] {
        assert_eq!(server.get(path, &[]).status, 404, "{path}");
    }
    // A model file replaced by a link after the start is not followed.
    std::fs::remove_file(models.join("swapped.qm")).unwrap();
    symlink(&secret, models.join("swapped.qm")).unwrap();
    assert_eq!(server.get("/models/swapped.qm", &[]).status, 404);
}

#[test]
fn the_throttle_sends_only_the_range() {
    let dir = site();
    let server = start(dir.path(), &["--throttle", "8"]);
    let data = model_bytes();
    let start = Instant::now();
    let r = server.get(PATH, &["Range: bytes=4096-8191"]);
    let took = start.elapsed();
    assert_eq!((r.status, r.body.as_slice()), (206, &data[4096..8192]));
    // 4096 bytes at 8 KB/s in twentieths of a second: the last piece is
    // due after 0.45 s.
    assert!(took >= Duration::from_millis(400), "{took:?}");
}

#[test]
fn the_log_counts_the_bytes_sent() {
    let dir = site();
    let server = Served::start(dir.path(), &["models", "--web", "web", "--throttle", "8"]);
    let prefix = server.get(PATH, &["Range: bytes=0-3062"]);
    assert_eq!(prefix.body.len(), 3063);
    assert_eq!(
        server.wait_for_log("GET /models/"),
        "GET /models/split_octahedron.qm range=0-3062 -> 206 3063"
    );
    server.request("HEAD", "/models.json?x=1", &[]);
    assert!(
        server
            .wait_for_log("HEAD ")
            .starts_with("HEAD /models.json?x=1 range=- -> 200 0")
    );
    assert_eq!(server.get(PATH, &["Range: bytes=999999-"]).status, 416);
    server.wait_for_log("GET /models/split_octahedron.qm range=999999- -> 416 0");

    // A client that stops reading after 2,000 bytes of the body.
    let mut stream = server.connect().unwrap();
    write!(stream, "GET {PATH}?abort HTTP/1.1\r\nHost: x\r\n\r\n").unwrap();
    let mut got = Vec::new();
    let mut piece = [0u8; 1024];
    while got.len() < 2500 {
        let n = stream.read(&mut piece).unwrap();
        assert!(n > 0);
        got.extend_from_slice(&piece[..n]);
    }
    drop(stream);
    let line = server.wait_for_log(&format!("GET {PATH}?abort "));
    let bytes: usize = line.rsplit(' ').next().unwrap().parse().unwrap();
    assert!(line.contains("range=- -> 200 "), "{line}");
    assert!(bytes < model_bytes().len(), "{line}");
    assert!(bytes >= 2000, "{line}");
}

#[test]
fn bad_usage_and_bad_paths() {
    let qm = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_qm"))
            .arg("serve")
            .args(args)
            .output()
            .unwrap()
    };
    let out = qm(&["no-such-folder", "--port", "0"]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(
        err.starts_with("error: no-such-folder: ") && err.lines().count() == 1,
        "{err}"
    );
    for bad in [
        &["x.qm", "--timeout", "0"][..],
        &["x.qm", "--throttle", "0"],
        &["x.qm", "--port", "http"],
    ] {
        assert_eq!(qm(bad).status.code(), Some(2), "{bad:?}");
    }
}
