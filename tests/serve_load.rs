//! `qm serve` under load on 127.0.0.1: 200 concurrent clients, 3,000
//! requests for the page, the model list and two `.qm` files in all; every
//! response complete and correct, no crash, the server's memory flat. The
//! test starts the server, bounds every socket and the whole run in time,
//! and stops the server itself.

mod common;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::time::{Duration, Instant};

use common::asset;

const CLIENTS: usize = 200;
const REQUESTS_PER_CLIENT: usize = 15;

/// The server process, killed when dropped.
struct Server(Child);

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// `VmRSS` or `VmHWM` of process `pid`, in KiB.
fn memory_kib(pid: u32, field: &str) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).expect("procfs");
    status
        .lines()
        .find_map(|l| l.strip_prefix(field)?.strip_prefix(':'))
        .and_then(|v| v.trim().trim_end_matches(" kB").parse().ok())
        .expect("a memory field")
}

/// One GET with `Connection: close`: status and body (checked against the
/// Content-Length the server sent).
fn get(port: u16, path: &str) -> Result<(u16, Vec<u8>), String> {
    let mut stream = TcpStream::connect(("127.0.0.1", port)).map_err(|e| e.to_string())?;
    stream
        .set_read_timeout(Some(Duration::from_secs(20)))
        .and_then(|()| stream.set_write_timeout(Some(Duration::from_secs(20))))
        .map_err(|e| e.to_string())?;
    write!(
        stream,
        "GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n"
    )
    .map_err(|e| e.to_string())?;
    let mut reader = BufReader::new(stream);
    let mut line = String::new();
    reader.read_line(&mut line).map_err(|e| e.to_string())?;
    let status: u16 = (line.split_whitespace().nth(1))
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| format!("{path}: status line {line:?}"))?;
    let mut length = None;
    loop {
        line.clear();
        reader.read_line(&mut line).map_err(|e| e.to_string())?;
        let header = line.trim_end();
        if header.is_empty() {
            break;
        }
        if let Some((name, value)) = header.split_once(':')
            && name.eq_ignore_ascii_case("content-length")
        {
            length = value.trim().parse::<usize>().ok();
        }
    }
    let mut body = Vec::new();
    reader.read_to_end(&mut body).map_err(|e| e.to_string())?;
    match length {
        Some(n) if n == body.len() => Ok((status, body)),
        other => Err(format!(
            "{path}: {} body bytes, Content-Length {other:?}",
            body.len()
        )),
    }
}

#[test]
fn serve_stays_correct_and_flat_under_load() {
    let dir = tempfile::tempdir().unwrap();
    let web = dir.path().join("web");
    std::fs::create_dir(&web).unwrap();
    let page = b"<!doctype html><title>qm</title><p>viewer</p>\n".repeat(40);
    std::fs::write(web.join("index.html"), &page).unwrap();
    let models = dir.path().join("models");
    std::fs::create_dir(&models).unwrap();
    let mut files = Vec::new();
    for name in ["holed_grid.qm", "cc_dodecahedron.qm"] {
        let bytes = std::fs::read(asset(&format!("../tests/data/{name}"))).unwrap();
        std::fs::write(models.join(name), &bytes).unwrap();
        files.push((format!("/models/{name}"), bytes));
    }
    let mut child = Command::new(env!("CARGO_BIN_EXE_qm"))
        .args(["serve", "models", "--port", "0", "--web", "web", "--quiet"])
        .current_dir(dir.path())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("qm serve starts");
    let stdout = child.stdout.take().expect("piped stdout");
    let pid = child.id();
    let _server = Server(child);
    let mut address = String::new();
    BufReader::new(stdout).read_line(&mut address).unwrap();
    let port: u16 = (address.trim().trim_end_matches('/').rsplit(':').next())
        .and_then(|p| p.parse().ok())
        .unwrap_or_else(|| panic!("address {address:?}"));

    let expected = Arc::new(
        [
            ("/".to_string(), page),
            (
                "/models.json".to_string(),
                format!(
                    r#"[{{"bytes":{},"name":"cc_dodecahedron.qm"}},{{"bytes":{},"name":"holed_grid.qm"}}]"#,
                    files[1].1.len(),
                    files[0].1.len()
                )
                .into_bytes(),
            ),
        ]
        .into_iter()
        .chain(files)
        .collect::<Vec<_>>(),
    );
    // A warm-up round, then the memory the server settles at.
    for (path, _) in expected.iter() {
        assert_eq!(get(port, path).unwrap().0, 200, "{path}");
    }
    let settled = memory_kib(pid, "VmRSS");
    let start = Instant::now();
    let clients: Vec<_> = (0..CLIENTS)
        .map(|c| {
            let expected = Arc::clone(&expected);
            std::thread::spawn(move || {
                let mut errors = Vec::new();
                for k in 0..REQUESTS_PER_CLIENT {
                    let (path, body) = &expected[(c + k) % expected.len()];
                    match get(port, path) {
                        Ok((200, got)) if got == *body => {}
                        Ok((status, got)) => errors.push(format!(
                            "{path}: status {status}, {} bytes, not the {} expected",
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
    assert_eq!(get(port, "/models.json").unwrap().0, 200);
}
