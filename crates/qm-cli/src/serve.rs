//! `qm serve`: the browser viewer (`web/dist`) and `.qm` files over HTTP on
//! 127.0.0.1, optionally throttled so that the progression can be watched.
//!
//! Routes: `/` and the viewer's files; `/models.json`, the served `.qm`
//! files as `[{"name", "bytes"}]`; `/models/NAME`, one file (throttled).

use std::io::{self, Read};
use std::path::{Component, Path, PathBuf};
use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

use qm::codec::container;
use tiny_http::{Header, Method, Request, Response, Server, StatusCode};

use crate::output::Failure;

/// Where the built viewer is looked for when `--web` is not given.
const BUILT_VIEWER: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../web/dist");

/// How to build the viewer, for the error when it is missing.
const HOW_TO_BUILD: &str = "build it with `web/build.sh` (needs the wasm32-unknown-unknown target, wasm-bindgen-cli and npm; see README.md) or pass --web DIR";

/// What `qm serve` was asked for.
pub struct ServeOptions {
    pub path: PathBuf,
    pub port: u16,
    pub throttle: Option<u32>,
    pub web: Option<PathBuf>,
    pub quiet: bool,
}

struct Model {
    name: String,
    path: PathBuf,
    bytes: u64,
}

struct State {
    web: PathBuf,
    models: Vec<Model>,
    throttle: Option<u32>,
    quiet: bool,
}

pub fn serve(options: ServeOptions) -> Result<(), Failure> {
    let models = find_models(&options.path)?;
    let web = find_viewer(options.web.as_deref())?;
    let address = format!("127.0.0.1:{}", options.port);
    let server = Server::http(&address).map_err(|e| Failure::new(format!("{address}: {e}")))?;
    let port = server
        .server_addr()
        .to_ip()
        .map_or(options.port, |a| a.port());
    let state = Arc::new(State {
        web,
        models,
        throttle: options.throttle,
        quiet: options.quiet,
    });
    if !options.quiet {
        for m in &state.models {
            eprintln!(
                "{}: {} bytes as /models/{}",
                m.path.display(),
                m.bytes,
                m.name
            );
        }
        let throttle = options.throttle.map_or("unthrottled".to_string(), |k| {
            format!("throttled to {k} KB/s")
        });
        eprintln!(
            "viewer from {}, .qm files {throttle}; Ctrl-C stops",
            state.web.display()
        );
    }
    // The address is the result of the command: printed even with --quiet.
    println!("http://127.0.0.1:{port}/");
    // A fixed pool of workers: however many clients connect, the server
    // holds at most this many requests (and threads) at once; the others
    // wait in tiny_http's queue.
    let server = Arc::new(server);
    let workers: Vec<_> = (0..WORKERS)
        .map(|_| {
            let (server, state) = (Arc::clone(&server), Arc::clone(&state));
            thread::spawn(move || {
                while let Ok(request) = server.recv() {
                    handle(request, &state);
                }
            })
        })
        .collect();
    for worker in workers {
        let _ = worker.join();
    }
    Ok(())
}

/// Requests served at once (a throttled download holds its worker).
const WORKERS: usize = 64;

/// The `.qm` files to serve: the one named, or those in the folder, each
/// checked to start with a valid header and base mesh.
fn find_models(path: &Path) -> Result<Vec<Model>, Failure> {
    let meta = std::fs::metadata(path).map_err(|e| Failure::about(path, e))?;
    let paths = if meta.is_dir() {
        let mut paths = Vec::new();
        for entry in std::fs::read_dir(path).map_err(|e| Failure::about(path, e))? {
            let p = entry.map_err(|e| Failure::about(path, e))?.path();
            if p.extension().is_some_and(|e| e.eq_ignore_ascii_case("qm")) && p.is_file() {
                paths.push(p);
            }
        }
        paths.sort();
        if paths.is_empty() {
            return Err(Failure::new(format!(
                "{}: no .qm files in this folder",
                path.display()
            )));
        }
        paths
    } else {
        vec![path.to_path_buf()]
    };
    let mut models = Vec::new();
    for p in paths {
        let data = std::fs::read(&p).map_err(|e| Failure::about(&p, e))?;
        container::read(&data, &qm::Limits::DEFAULT.with_max_memory(u64::MAX))
            .map_err(|e| Failure::about(&p, e))?;
        let name = p
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        models.push(Model {
            name,
            path: p,
            bytes: data.len() as u64,
        });
    }
    Ok(models)
}

/// The built viewer folder (holding `index.html`).
fn find_viewer(web: Option<&Path>) -> Result<PathBuf, Failure> {
    let dir = web.map_or_else(|| PathBuf::from(BUILT_VIEWER), Path::to_path_buf);
    if dir.join("index.html").is_file() {
        return Ok(dir.canonicalize().unwrap_or(dir));
    }
    Err(Failure::new(format!(
        "{}: the web viewer is not built (no index.html); {HOW_TO_BUILD}",
        dir.display()
    )))
}

fn handle(request: Request, state: &State) {
    let url = request
        .url()
        .split(['?', '#'])
        .next()
        .unwrap_or("/")
        .to_string();
    let method = request.method().clone();
    let result = if method != Method::Get && method != Method::Head {
        respond_text(request, 405, "only GET and HEAD")
    } else if url == "/models.json" {
        let list: Vec<serde_json::Value> = state
            .models
            .iter()
            .map(|m| serde_json::json!({ "name": m.name, "bytes": m.bytes }))
            .collect();
        let body = serde_json::to_vec(&list).expect("plain data serializes");
        let response = Response::from_data(body)
            .with_header(header("Content-Type", "application/json"))
            .with_header(header("Cache-Control", "no-store"));
        request.respond(response)
    } else if let Some(name) = url.strip_prefix("/models/") {
        match state.models.iter().find(|m| m.name == percent_decode(name)) {
            Some(m) => send_model(request, m, state),
            None => respond_text(request, 404, "no such model"),
        }
    } else {
        match static_file(&state.web, &url) {
            Some((path, file)) => {
                let length = file.metadata().ok().map(|m| m.len() as usize);
                let response = Response::new(
                    StatusCode(200),
                    vec![header("Content-Type", content_type(&path))],
                    file,
                    length,
                    None,
                );
                request.respond(response)
            }
            None => respond_text(request, 404, "not found"),
        }
    };
    if let Err(e) = &result
        && !state.quiet
    {
        eprintln!("{method} {url}: {e}");
    }
}

fn send_model(request: Request, model: &Model, state: &State) -> io::Result<()> {
    let file = match std::fs::File::open(&model.path) {
        Ok(f) => f,
        Err(e) => {
            if !state.quiet {
                eprintln!("{}: {e}", model.path.display());
            }
            return respond_text(request, 500, "cannot read the file");
        }
    };
    let length = file.metadata().map(|m| m.len() as usize).ok();
    let start = Instant::now();
    let reader: Box<dyn Read + Send> = match state.throttle {
        Some(kbps) => Box::new(Throttled::new(file, kbps)),
        None => Box::new(file),
    };
    let response = Response::new(
        StatusCode(200),
        vec![
            header("Content-Type", "application/octet-stream"),
            header("Cache-Control", "no-store"),
            // Browsers may hold back the first bytes to sniff the type.
            header("X-Content-Type-Options", "nosniff"),
        ],
        reader,
        length,
        None,
    )
    // With its length known the file goes out as it is read; chunked
    // transfer would hold back 8 KB pieces.
    .with_chunked_threshold(usize::MAX);
    let result = request.respond(response);
    if !state.quiet && result.is_ok() {
        eprintln!(
            "sent /models/{} ({} bytes) in {:.2} s",
            model.name,
            model.bytes,
            start.elapsed().as_secs_f64()
        );
    }
    result
}

fn respond_text(request: Request, status: u16, text: &str) -> io::Result<()> {
    request.respond(
        Response::from_string(text)
            .with_status_code(status)
            .with_header(header("Content-Type", "text/plain; charset=utf-8")),
    )
}

fn header(name: &str, value: &str) -> Header {
    Header::from_bytes(name.as_bytes(), value.as_bytes()).expect("valid header")
}

/// A file under `root` for a URL path, refusing anything that leaves it.
fn static_file(root: &Path, url: &str) -> Option<(PathBuf, std::fs::File)> {
    let relative = percent_decode(url.trim_start_matches('/'));
    let relative = if relative.is_empty() || relative.ends_with('/') {
        format!("{relative}index.html")
    } else {
        relative
    };
    let relative = Path::new(&relative);
    if !relative
        .components()
        .all(|c| matches!(c, Component::Normal(_)))
    {
        return None;
    }
    let path = root.join(relative);
    let file = std::fs::File::open(&path).ok()?;
    file.metadata().ok()?.is_file().then_some((path, file))
}

fn percent_decode(s: &str) -> String {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        if bytes[i] == b'%'
            && i + 2 < bytes.len()
            && let (Some(h), Some(l)) = (hex(bytes[i + 1]), hex(bytes[i + 2]))
        {
            out.push((h * 16 + l) as u8);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

fn content_type(path: &Path) -> &'static str {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase()
        .as_str()
    {
        "html" => "text/html; charset=utf-8",
        "js" | "mjs" => "text/javascript; charset=utf-8",
        "css" => "text/css; charset=utf-8",
        "json" => "application/json",
        "wasm" => "application/wasm",
        "png" => "image/png",
        "svg" => "image/svg+xml",
        "ico" => "image/x-icon",
        _ => "application/octet-stream",
    }
}

/// A reader that delivers at most `kbps` KB (1024 bytes) per second, in
/// pieces of a twentieth of a second.
struct Throttled<R> {
    inner: R,
    bytes_per_second: f64,
    piece: usize,
    sent: u64,
    start: Option<Instant>,
}

impl<R> Throttled<R> {
    fn new(inner: R, kbps: u32) -> Self {
        let bytes_per_second = f64::from(kbps.max(1)) * 1024.0;
        Throttled {
            inner,
            bytes_per_second,
            piece: ((bytes_per_second / 20.0) as usize).max(1),
            sent: 0,
            start: None,
        }
    }
}

impl<R: Read> Read for Throttled<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let start = *self.start.get_or_insert_with(Instant::now);
        // Wait until the bytes sent so far are due.
        let due = Duration::from_secs_f64(self.sent as f64 / self.bytes_per_second);
        if let Some(wait) = due.checked_sub(start.elapsed()) {
            thread::sleep(wait);
        }
        let n = buf.len().min(self.piece);
        let n = self.inner.read(&mut buf[..n])?;
        self.sent += n as u64;
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_stay_inside_the_root() {
        let root = std::env::temp_dir();
        assert!(static_file(&root, "/../etc/passwd").is_none());
        assert!(static_file(&root, "/%2e%2e/etc/passwd").is_none());
        assert_eq!(percent_decode("a%20b%zz"), "a b%zz");
    }

    #[test]
    fn bad_inputs_are_one_line_errors_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let message = |p: &Path| find_models(p).err().unwrap().to_string();
        let missing = dir.path().join("missing.qm");
        assert!(message(&missing).starts_with(&missing.display().to_string()));
        assert!(message(dir.path()).ends_with("no .qm files in this folder"));
        let bad = dir.path().join("bad.qm");
        std::fs::write(&bad, b"not a qm file").unwrap();
        let m = message(&bad);
        assert!(m.starts_with(&format!("{}: ", bad.display())), "{m}");
        assert!(!m.contains('\n'));
        assert!(message(dir.path()).starts_with(&bad.display().to_string()));
        let m = find_viewer(Some(dir.path())).err().unwrap().to_string();
        assert!(m.contains("not built") && m.contains("web/build.sh"), "{m}");
    }

    #[test]
    fn throttle_paces_reads() {
        let data = vec![7u8; 4096];
        let mut r = Throttled::new(&data[..], 40); // 40 KB/s: 2048-byte pieces
        let start = Instant::now();
        let mut out = Vec::new();
        r.read_to_end(&mut out).unwrap();
        assert_eq!(out, data);
        // The second piece is due after 2048 / 40960 s = 50 ms.
        assert!(start.elapsed() >= Duration::from_millis(45));
    }
}
