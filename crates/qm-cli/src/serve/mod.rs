//! `qm serve`: a static HTTP/1.1 server on 127.0.0.1 for the browser viewer
//! (`web/dist`) and for streaming model files progressively: single byte
//! ranges, entity tags and conditional requests, CORS for pages on other
//! origins, bounded requests, connections and time, files only from inside
//! the served folders, optional pacing, and one log line per request.
//! docs/serve.md describes the rules.
//!
//! Routes: `/` and the viewer's files; `/models.json`, the served models as
//! `[{"name", "bytes"}]`; `/models/NAME`, one model file (paced with
//! `--throttle`).

mod conditional;
mod files;
mod http;

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Condvar, Mutex};
use std::thread;
use std::time::Duration;

use qm::codec::container;

use crate::output::Failure;
use conditional::{Answer, Conditions, Version};
use files::{Root, content_type};
use http::{Connection, HeadError, Pace, Request, Response, Sent};

/// Where the built viewer is looked for when `--web` is not given.
const BUILT_VIEWER: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../web/dist");

/// How to build the viewer, for the error when it is missing.
const HOW_TO_BUILD: &str = "build it with `web/build.sh` (needs the wasm32-unknown-unknown target, wasm-bindgen-cli and npm; see README.md) or pass --web DIR";

/// Connections served at once; more wait in the listening socket's queue.
const MAX_CONNECTIONS: usize = 128;

/// The stack of a connection's thread (its buffers are on the heap).
const STACK: usize = 256 * 1024;

/// The default of `--timeout`, in seconds.
pub const DEFAULT_TIMEOUT: f64 = 10.0;

/// Response headers that a page on another origin may read.
const EXPOSED: &str = "Content-Range, Content-Length, Accept-Ranges, ETag, Last-Modified";

/// What `qm serve` was asked for.
pub struct ServeOptions {
    pub path: PathBuf,
    pub port: u16,
    pub throttle: Option<u32>,
    pub web: Option<PathBuf>,
    /// How long a connection may wait for a request head, or for the
    /// client to take a piece of a response.
    pub timeout: Duration,
    pub quiet: bool,
}

/// What a model file is.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Kind {
    Qm,
    Gltf,
    /// A `.bin` beside a `.gltf`: served, not listed.
    Buffer,
}

#[derive(Clone)]
struct Model {
    /// The name in `/models/NAME`.
    name: String,
    /// The file's name in the models folder.
    file: String,
    kind: Kind,
}

struct State {
    web: Root,
    models_root: Root,
    models: Vec<Model>,
    pace: Option<Pace>,
    timeout: Duration,
    quiet: bool,
}

pub fn serve(options: ServeOptions) -> Result<(), Failure> {
    let (models_root, models) = find_models(&options.path, options.quiet)?;
    let web = find_viewer(options.web.as_deref())?;
    let address = format!("127.0.0.1:{}", options.port);
    let listener =
        TcpListener::bind(&address).map_err(|e| Failure::file(format!("{address}: {e}")))?;
    let port = listener.local_addr().map_or(options.port, |a| a.port());
    let state = Arc::new(State {
        web,
        models_root,
        models,
        pace: options.throttle.map(Pace::new),
        timeout: options.timeout,
        quiet: options.quiet,
    });
    if !options.quiet {
        for m in &state.models {
            let path = state.models_root.path().join(&m.file);
            log(format_args!(
                "{}: served as /models/{}",
                path.display(),
                m.name
            ));
        }
        let throttle = options.throttle.map_or("unthrottled".to_string(), |k| {
            format!("throttled to {k} KB/s")
        });
        log(format_args!(
            "viewer from {}, model files {throttle}; Ctrl-C stops",
            state.web.path().display()
        ));
    }
    // The address is the result of the command: printed even with --quiet.
    out!("http://127.0.0.1:{port}/");
    let slots = Arc::new(Slots::new(MAX_CONNECTIONS));
    for stream in listener.incoming() {
        let Ok(stream) = stream else {
            // Out of descriptors or the like: let connections end first.
            thread::sleep(Duration::from_millis(50));
            continue;
        };
        let slot = slots.take();
        let state = Arc::clone(&state);
        // A thread that cannot start drops its connection and slot.
        let _ = thread::Builder::new()
            .name("qm-serve".into())
            .stack_size(STACK)
            .spawn(move || {
                serve_connection(stream, &state);
                drop(slot);
            });
    }
    Ok(())
}

/// Counts connections being served, and holds the accepting thread while
/// there are `max` of them.
struct Slots {
    used: Mutex<usize>,
    freed: Condvar,
    max: usize,
}

/// One connection's place; given back when dropped.
struct Slot(Arc<Slots>);

impl Slots {
    fn new(max: usize) -> Slots {
        Slots {
            used: Mutex::new(0),
            freed: Condvar::new(),
            max,
        }
    }

    fn take(self: &Arc<Self>) -> Slot {
        let mut used = self.used.lock().unwrap_or_else(|e| e.into_inner());
        while *used >= self.max {
            used = self.freed.wait(used).unwrap_or_else(|e| e.into_inner());
        }
        *used += 1;
        Slot(Arc::clone(self))
    }
}

impl Drop for Slot {
    fn drop(&mut self) {
        let mut used = self.0.used.lock().unwrap_or_else(|e| e.into_inner());
        *used -= 1;
        self.0.freed.notify_one();
    }
}

/// Requests on one connection until it closes, times out or fails.
fn serve_connection(stream: TcpStream, state: &State) {
    let Ok(mut connection) = Connection::new(stream, state.timeout) else {
        return;
    };
    loop {
        let request = match connection.read_head() {
            Ok(request) => request,
            Err(HeadError::Idle) => break,
            Err(HeadError::TimedOut) => {
                let sent = connection.send(
                    common(Response::text(408, "request timed out")),
                    false,
                    true,
                );
                log_request(state, None, &sent);
                break;
            }
            Err(HeadError::Refused(status)) => {
                let sent = connection.send(
                    common(Response::text(status, "request refused")),
                    false,
                    true,
                );
                log_request(state, None, &sent);
                break;
            }
        };
        let close = !request.keep_alive();
        let response = common(route(&request, state));
        let sent = connection.send(response, request.method == "HEAD", close);
        log_request(state, Some(&request), &sent);
        if close || !sent.complete {
            break;
        }
    }
    connection.close();
}

/// Headers of every response: CORS and no type sniffing.
fn common(response: Response) -> Response {
    response
        .with("Access-Control-Allow-Origin", "*")
        .with("Access-Control-Expose-Headers", EXPOSED)
        .with("X-Content-Type-Options", "nosniff")
}

fn route(request: &Request, state: &State) -> Response {
    match request.method.as_str() {
        "GET" | "HEAD" => {}
        // A CORS preflight, or a plain OPTIONS.
        "OPTIONS" => {
            return Response::empty(204)
                .with("Allow", "GET, HEAD, OPTIONS")
                .with("Access-Control-Allow-Methods", "GET, HEAD, OPTIONS")
                .with(
                    "Access-Control-Allow-Headers",
                    "Range, If-Range, If-None-Match, If-Modified-Since, If-Match, If-Unmodified-Since",
                )
                .with("Access-Control-Max-Age", "86400");
        }
        _ => {
            return Response::text(405, "only GET, HEAD and OPTIONS")
                .with("Allow", "GET, HEAD, OPTIONS");
        }
    }
    let path = percent_decode(request_path(&request.target));
    if path == "/models.json" {
        return models_json(state);
    }
    if let Some(name) = path.strip_prefix("/models/") {
        return match state.models.iter().find(|m| m.name == name) {
            Some(m) => serve_file(request, &state.models_root, &m.file, state.pace),
            None => not_found(),
        };
    }
    let relative = path.trim_start_matches('/');
    if relative.is_empty() || relative.ends_with('/') {
        serve_file(request, &state.web, &format!("{relative}index.html"), None)
    } else {
        serve_file(request, &state.web, relative, None)
    }
}

/// The path of a request target: without query or fragment, and without
/// scheme and host in the absolute form.
fn request_path(target: &str) -> &str {
    let path = target.split(['?', '#']).next().unwrap_or("");
    match path.split_once("://") {
        Some((_, rest)) => rest.find('/').map_or("/", |i| &rest[i..]),
        None => path,
    }
}

fn not_found() -> Response {
    Response::text(404, "not found")
}

/// The models with their current sizes; `.qm` files first, so that the
/// viewer's default (the first) is one it can show.
fn models_json(state: &State) -> Response {
    let list: Vec<serde_json::Value> = (state.models.iter())
        .filter(|m| m.kind != Kind::Buffer)
        .filter_map(|m| {
            let opened = state.models_root.open_file(&m.file).ok()?;
            Some(serde_json::json!({ "name": m.name, "bytes": opened.len }))
        })
        .collect();
    let body = serde_json::to_vec(&list).expect("plain data serializes");
    Response::bytes(200, "application/json", body).with("Cache-Control", "no-store")
}

/// A file under `root`, answering range and conditional requests.
fn serve_file(request: &Request, root: &Root, relative: &str, pace: Option<Pace>) -> Response {
    let Ok(opened) = root.open_file(relative) else {
        return not_found();
    };
    let asked = Conditions {
        if_match: request.header("if-match"),
        if_none_match: request.header("if-none-match"),
        if_modified_since: request.header("if-modified-since"),
        if_unmodified_since: request.header("if-unmodified-since"),
        if_range: request.header("if-range"),
        range: request.header("range"),
    };
    let version = Version {
        etag: &opened.etag,
        modified: opened.modified,
        len: opened.len,
    };
    let answer = conditional::answer(&asked, request.method == "GET", &version);
    let validators = |response: Response| {
        response
            .with("ETag", opened.etag.clone())
            .with("Last-Modified", httpdate::fmt_http_date(opened.modified))
            .with("Cache-Control", "no-cache")
    };
    let len = opened.len;
    let with_type = |response: Response| {
        validators(response)
            .with("Content-Type", content_type(relative))
            .with("Accept-Ranges", "bytes")
    };
    match answer {
        Answer::NotModified => validators(Response::empty(304)),
        Answer::PreconditionFailed => Response::text(412, "precondition failed"),
        Answer::Unsatisfiable => Response::bytes(416, "text/plain; charset=utf-8", Vec::new())
            .with("Content-Range", format!("bytes */{len}"))
            .with("Accept-Ranges", "bytes"),
        Answer::Whole => with_type(Response::file(200, opened.file, 0, len, pace)),
        Answer::Part { start, end } => with_type(
            Response::file(206, opened.file, start, end - start + 1, pace)
                .with("Content-Range", format!("bytes {start}-{end}/{len}")),
        ),
    }
}

/// One line on stderr, ignoring a closed stderr.
fn log(line: std::fmt::Arguments) {
    let _ = writeln!(std::io::stderr().lock(), "{line}");
}

/// The request log: `METHOD TARGET range=RANGE -> STATUS BYTES`, with `-`
/// for what is unknown or absent; RANGE is the Range header's value without
/// a leading `bytes=`, BYTES the body bytes the socket took.
fn log_request(state: &State, request: Option<&Request>, sent: &Sent) {
    if state.quiet {
        return;
    }
    let method = request.map_or("-", |r| r.method.as_str());
    let target = request.map_or("-".to_string(), |r| escape(r.target.as_bytes()));
    let range = match request.and_then(|r| r.raw_header("range")) {
        Some(value) => escape(value.strip_prefix(b"bytes=").unwrap_or(value)),
        None => "-".to_string(),
    };
    log(format_args!(
        "{method} {target} range={range} -> {} {}",
        sent.status, sent.bytes
    ));
}

/// `bytes` as one word of printable ASCII: other bytes, spaces and `%` as
/// `%XX`.
fn escape(bytes: &[u8]) -> String {
    if bytes.is_empty() {
        return "-".to_string();
    }
    bytes
        .iter()
        .map(|&b| match b {
            b'!'..=b'~' if b != b'%' => (b as char).to_string(),
            _ => format!("%{b:02X}"),
        })
        .collect()
}

/// The model files to serve: the one named, or the `.qm`, `.glb` and
/// `.gltf` files in the folder (with the `.bin` files beside a `.gltf`);
/// each `.qm` checked to start with a valid header and base mesh. Symbolic
/// links in the folder are not served.
fn find_models(path: &Path, quiet: bool) -> Result<(Root, Vec<Model>), Failure> {
    let meta = std::fs::metadata(path).map_err(|e| Failure::about(path, e))?;
    // A file named: the folder it is in, wherever a link named leads.
    let named = if meta.is_dir() {
        None
    } else {
        Some(path.canonicalize().map_err(|e| Failure::about(path, e))?)
    };
    let folder = named
        .as_ref()
        .map_or(path, |f| f.parent().unwrap_or(Path::new("/")));
    let root = Root::open(folder).map_err(|e| Failure::about(folder, e))?;
    let found = files_in(folder, quiet || named.is_some())?;
    let mut models: Vec<Model> = match &named {
        Some(file) => {
            let name = |p: &Path| p.file_name().and_then(|n| n.to_str()).map(str::to_string);
            let (Some(given), Some(file)) = (name(path), name(file)) else {
                return Err(Failure::parameter(format!(
                    "{}: not a file name",
                    path.display()
                )));
            };
            let kind = kind_of(&file)
                .filter(|&k| k != Kind::Buffer)
                .unwrap_or(Kind::Qm);
            vec![Model {
                name: given,
                file,
                kind,
            }]
        }
        None => (found.iter())
            .filter(|m| m.kind != Kind::Buffer)
            .cloned()
            .collect(),
    };
    if models.is_empty() {
        return Err(Failure::file(format!(
            "{}: no .qm, .glb or .gltf files in this folder",
            path.display()
        )));
    }
    if models
        .iter()
        .any(|m| m.file.to_ascii_lowercase().ends_with(".gltf"))
    {
        models.extend(found.iter().filter(|m| m.kind == Kind::Buffer).cloned());
    }
    models.sort_by(|a, b| (a.kind, &a.name).cmp(&(b.kind, &b.name)));
    for m in models.iter().filter(|m| m.kind == Kind::Qm) {
        let shown = match named {
            Some(_) => path.to_path_buf(),
            None => folder.join(&m.file),
        };
        let mut data = Vec::new();
        (root.open_file(&m.file))
            .and_then(|mut opened| opened.file.read_to_end(&mut data))
            .map_err(|e| Failure::about(&shown, e))?;
        container::read(&data, &qm::Limits::DEFAULT.with_max_memory(u64::MAX))
            .map_err(|e| Failure::about(&shown, e))?;
    }
    Ok((root, models))
}

/// The regular files of the kinds served in `folder`, under their own
/// names; symbolic links are left out (and said so unless `quiet`).
fn files_in(folder: &Path, quiet: bool) -> Result<Vec<Model>, Failure> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir(folder).map_err(|e| Failure::about(folder, e))? {
        let entry = entry.map_err(|e| Failure::about(folder, e))?;
        let Some(name) = entry.file_name().to_str().map(str::to_string) else {
            continue;
        };
        let (Some(kind), Ok(file_type)) = (kind_of(&name), entry.file_type()) else {
            continue;
        };
        if file_type.is_symlink() && !quiet {
            log(format_args!(
                "{}: a symbolic link, not served",
                entry.path().display()
            ));
        }
        if file_type.is_file() {
            found.push(Model {
                file: name.clone(),
                name,
                kind,
            });
        }
    }
    Ok(found)
}

/// What a file in the models folder is, by its extension.
fn kind_of(name: &str) -> Option<Kind> {
    let extension = name.rsplit_once('.')?.1.to_ascii_lowercase();
    match extension.as_str() {
        "qm" => Some(Kind::Qm),
        "glb" | "gltf" => Some(Kind::Gltf),
        "bin" => Some(Kind::Buffer),
        _ => None,
    }
}

/// The built viewer folder (holding `index.html`).
fn find_viewer(web: Option<&Path>) -> Result<Root, Failure> {
    let dir = web.map_or_else(|| PathBuf::from(BUILT_VIEWER), Path::to_path_buf);
    let dir = dir.canonicalize().unwrap_or(dir);
    match Root::open(&dir) {
        Ok(root) if root.open_file("index.html").is_ok() => Ok(root),
        _ => Err(Failure::file(format!(
            "{}: the web viewer is not built (no index.html); {HOW_TO_BUILD}",
            dir.display()
        ))),
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn targets_to_paths() {
        assert_eq!(request_path("/a/b?x=1#f"), "/a/b");
        assert_eq!(request_path("http://127.0.0.1:8000/m.json?x"), "/m.json");
        assert_eq!(request_path("http://host"), "/");
        assert_eq!(percent_decode("a%20b%zz%2"), "a b%zz%2");
        assert_eq!(escape(b"0-5, 9-%\x01"), "0-5,%209-%25%01");
        assert_eq!(escape(b""), "-");
    }

    #[test]
    fn bad_inputs_are_one_line_errors_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let message = |p: &Path| find_models(p, true).err().unwrap().to_string();
        let missing = dir.path().join("missing.qm");
        assert!(message(&missing).starts_with(&missing.display().to_string()));
        assert!(message(dir.path()).ends_with("no .qm, .glb or .gltf files in this folder"));
        let bad = dir.path().join("bad.qm");
        std::fs::write(&bad, b"not a qm file").unwrap();
        let m = message(&bad);
        assert!(m.starts_with(&format!("{}: ", bad.display())), "{m}");
        assert!(!m.contains('\n'));
        assert!(message(dir.path()).contains("bad.qm: "));
        let m = find_viewer(Some(dir.path())).err().unwrap().to_string();
        assert!(m.contains("not built") && m.contains("web/build.sh"), "{m}");
    }

    #[test]
    fn folders_list_models_qm_first_with_their_buffers() {
        let dir = tempfile::tempdir().unwrap();
        let qm = std::fs::read(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/data/cc_dodecahedron.qm"
        ))
        .unwrap();
        std::fs::write(dir.path().join("b.qm"), &qm).unwrap();
        for name in ["a.glb", "scene.gltf", "scene.bin", "notes.txt"] {
            std::fs::write(dir.path().join(name), b"x").unwrap();
        }
        let (_, models) = find_models(dir.path(), true).unwrap();
        let names: Vec<&str> = models.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(names, ["b.qm", "a.glb", "scene.gltf", "scene.bin"]);
        std::fs::remove_file(dir.path().join("scene.gltf")).unwrap();
        let (_, models) = find_models(dir.path(), true).unwrap();
        assert_eq!(models.len(), 2, "no .bin without a .gltf");
    }
}
