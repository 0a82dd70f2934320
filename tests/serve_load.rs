//! `qm serve` under load on 127.0.0.1: 200 concurrent clients, 3,000
//! requests for the page, the model list, two `.qm` files and ranges of
//! them in all; every response complete and correct, no crash, the
//! server's memory flat. The
//! test starts the server, bounds every socket and the whole run in time,
//! and stops the server itself.

mod common;
mod serving;

use std::sync::Arc;
use std::time::Instant;

use common::asset;
use serving::{Served, memory_kib};

const CLIENTS: usize = 200;
const REQUESTS_PER_CLIENT: usize = 15;

#[test]
fn serve_stays_correct_and_flat_under_load() {
    let dir = tempfile::tempdir().unwrap();
    let web = dir.path().join("web");
    std::fs::create_dir(&web).unwrap();
    let page = b"<!doctype html><title>qm</title><p>viewer</p>\n".repeat(40);
    std::fs::write(web.join("index.html"), &page).unwrap();
    let models = dir.path().join("models");
    std::fs::create_dir(&models).unwrap();
    // (path, Range header, expected status and body)
    let mut expected = vec![("/".to_string(), None, 200, page)];
    let mut list = Vec::new();
    for name in ["cc_dodecahedron.qm", "holed_grid.qm"] {
        let bytes = std::fs::read(asset(&format!("../tests/data/{name}"))).unwrap();
        std::fs::write(models.join(name), &bytes).unwrap();
        list.push(format!(r#"{{"bytes":{},"name":"{name}"}}"#, bytes.len()));
        let path = format!("/models/{name}");
        expected.push((
            path.clone(),
            Some("bytes=100-599"),
            206,
            bytes[100..600].to_vec(),
        ));
        expected.push((path, None, 200, bytes));
    }
    let list = format!("[{}]", list.join(","));
    expected.push(("/models.json".to_string(), None, 200, list.into_bytes()));
    let expected = Arc::new(expected);
    let server = Arc::new(Served::start(
        dir.path(),
        &["models", "--web", "web", "--quiet"],
    ));
    let pid = server.pid();

    // One request with `Connection: close`: its status and body.
    let get = |server: &Served, path: &str, range: Option<&str>| {
        let range = range.map_or(String::new(), |r| format!("Range: {r}\r\n"));
        let head =
            format!("GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n{range}Connection: close\r\n\r\n");
        match server.exchange(head.as_bytes())?.as_slice() {
            [reply] => Ok((reply.status, reply.body.clone())),
            replies => Err(format!("{path}: {} responses", replies.len())),
        }
    };
    // A warm-up round, then the memory the server settles at.
    for (path, range, status, _) in expected.iter() {
        assert_eq!(get(&server, path, *range).unwrap().0, *status, "{path}");
    }
    let settled = memory_kib(pid, "VmRSS");
    let start = Instant::now();
    let clients: Vec<_> = (0..CLIENTS)
        .map(|c| {
            let (expected, server) = (Arc::clone(&expected), Arc::clone(&server));
            std::thread::spawn(move || {
                let mut errors = Vec::new();
                for k in 0..REQUESTS_PER_CLIENT {
                    let (path, range, status, body) = &expected[(c + k) % expected.len()];
                    match get(&server, path, *range) {
                        Ok((s, got)) if s == *status && got == *body => {}
                        Ok((s, got)) => errors.push(format!(
                            "{path} {range:?}: status {s}, {} bytes, not {status} and the {} expected",
                            got.len(),
                            body.len()
                        )),
                        Err(e) => errors.push(e),
                    }
                }
                errors
            })
        })
        .collect();
    let errors: Vec<String> = clients
        .into_iter()
        .flat_map(|c| c.join().expect("client thread"))
        .collect();
    let took = start.elapsed();
    let (rss, peak) = (memory_kib(pid, "VmRSS"), memory_kib(pid, "VmHWM"));
    println!(
        "{} requests from {CLIENTS} clients in {took:?}: {} errors; server RSS {settled} KiB \
         settled, {rss} KiB after, peak {peak} KiB",
        CLIENTS * REQUESTS_PER_CLIENT,
        errors.len()
    );
    assert!(
        errors.is_empty(),
        "{} errors: {:?}",
        errors.len(),
        &errors[..errors.len().min(5)]
    );
    // Flat: the load leaves the server within 32 MiB of where it settled.
    assert!(rss < settled + (32 << 10), "RSS {settled} -> {rss} KiB");
    // Still serving after the load.
    assert_eq!(get(&server, "/models.json", None).unwrap().0, 200);
}
