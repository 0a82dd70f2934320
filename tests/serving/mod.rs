//! `qm serve` started for a test, and a raw HTTP/1.1 client for it: the
//! tests see exactly the bytes the server sends.

#![allow(dead_code)]
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// A running `qm serve`, killed when dropped.
pub struct Served {
    child: Child,
    pub port: u16,
    /// Its stderr lines so far (empty with `--quiet`).
    log: Arc<Mutex<Vec<String>>>,
}

impl Served {
    /// Runs `qm serve ARGS --port 0` in `dir` and waits for its address.
    pub fn start(dir: &Path, args: &[&str]) -> Served {
        let mut child = Command::new(env!("CARGO_BIN_EXE_qm"))
            .arg("serve")
            .args(args)
            .args(["--port", "0"])
            .current_dir(dir)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("qm serve starts");
        let stdout = child.stdout.take().expect("piped stdout");
        let stderr = child.stderr.take().expect("piped stderr");
        let log = Arc::new(Mutex::new(Vec::new()));
        let lines = Arc::clone(&log);
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                lines.lock().unwrap().push(line);
            }
        });
        let mut address = String::new();
        BufReader::new(stdout).read_line(&mut address).unwrap();
        let mut served = Served {
            child,
            port: 0,
            log,
        };
        served.port = (address.trim().trim_end_matches('/').rsplit(':').next())
            .and_then(|p| p.parse().ok())
            .unwrap_or_else(|| panic!("address {address:?}, log {:?}", served.log()));
        served
    }

    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    pub fn log(&self) -> Vec<String> {
        self.log.lock().unwrap().clone()
    }

    /// The first log line that starts with `prefix`, waiting up to 5 s.
    pub fn wait_for_log(&self, prefix: &str) -> String {
        let start = Instant::now();
        loop {
            if let Some(line) = self.log().into_iter().find(|l| l.starts_with(prefix)) {
                return line;
            }
            assert!(
                start.elapsed() < Duration::from_secs(5),
                "no log line {prefix:?} in {:?}",
                self.log()
            );
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// Sends `request` whole and reads the answers to it until the server
    /// closes the connection.
    pub fn exchange(&self, request: &[u8]) -> Result<Vec<Reply>, String> {
        let mut stream = self.connect()?;
        stream.write_all(request).map_err(|e| e.to_string())?;
        let mut bytes = Vec::new();
        stream.read_to_end(&mut bytes).map_err(|e| e.to_string())?;
        Reply::parse_all(&bytes, request.starts_with(b"HEAD "))
    }

    /// One request with `Connection: close` and the given extra header
    /// lines; its one answer.
    pub fn request(&self, method: &str, path: &str, headers: &[&str]) -> Reply {
        let mut head =
            format!("{method} {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n");
        for h in headers {
            head.push_str(h);
            head.push_str("\r\n");
        }
        head.push_str("\r\n");
        let mut replies = self
            .exchange(head.as_bytes())
            .unwrap_or_else(|e| panic!("{method} {path}: {e}"));
        assert_eq!(replies.len(), 1, "{method} {path}");
        replies.remove(0)
    }

    pub fn get(&self, path: &str, headers: &[&str]) -> Reply {
        self.request("GET", path, headers)
    }

    /// A connection with 20 s time-outs, so that no test hangs.
    pub fn connect(&self) -> Result<TcpStream, String> {
        let stream = TcpStream::connect(("127.0.0.1", self.port)).map_err(|e| e.to_string())?;
        stream
            .set_read_timeout(Some(Duration::from_secs(20)))
            .and_then(|()| stream.set_write_timeout(Some(Duration::from_secs(20))))
            .map_err(|e| e.to_string())?;
        Ok(stream)
    }
}

impl Drop for Served {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// One response: status, headers, body.
#[derive(Debug)]
pub struct Reply {
    pub status: u16,
    pub headers: Vec<(String, String)>,
    pub body: Vec<u8>,
}

impl Reply {
    pub fn header(&self, name: &str) -> Option<&str> {
        (self.headers.iter())
            .find(|(n, _)| n.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_str())
    }

    /// The responses in `bytes`, each body as long as its Content-Length
    /// says (none for HEAD, 204 and 304); the last may run to the end.
    pub fn parse_all(mut bytes: &[u8], head_only: bool) -> Result<Vec<Reply>, String> {
        let mut replies = Vec::new();
        while !bytes.is_empty() {
            let end = (bytes.windows(4).position(|w| w == b"\r\n\r\n"))
                .ok_or_else(|| format!("no end of head in {:?}", String::from_utf8_lossy(bytes)))?;
            let head = std::str::from_utf8(&bytes[..end]).map_err(|e| e.to_string())?;
            let mut lines = head.split("\r\n");
            let status_line = lines.next().unwrap_or("");
            let status = (status_line.split(' ').nth(1))
                .and_then(|s| s.parse().ok())
                .ok_or_else(|| format!("status line {status_line:?}"))?;
            let headers: Vec<(String, String)> = lines
                .filter_map(|l| l.split_once(':'))
                .map(|(n, v)| (n.to_string(), v.trim().to_string()))
                .collect();
            let mut reply = Reply {
                status,
                headers,
                body: Vec::new(),
            };
            bytes = &bytes[end + 4..];
            let length = match reply.header("content-length") {
                _ if head_only || status == 204 || status == 304 => 0,
                Some(n) => n.parse::<usize>().map_err(|e| e.to_string())?,
                None => bytes.len(),
            };
            if length > bytes.len() {
                return Err(format!(
                    "{} body bytes, Content-Length {length}",
                    bytes.len()
                ));
            }
            reply.body = bytes[..length].to_vec();
            bytes = &bytes[length..];
            replies.push(reply);
        }
        Ok(replies)
    }
}

/// `VmRSS` or `VmHWM` of process `pid`, in KiB.
pub fn memory_kib(pid: u32, field: &str) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).expect("procfs");
    status
        .lines()
        .find_map(|l| l.strip_prefix(field)?.strip_prefix(':'))
        .and_then(|v| v.trim().trim_end_matches(" kB").parse().ok())
        .expect("a memory field")
}
