//! HTTP/1.1 on one blocking connection, as much of it as `qm serve` needs:
//! request heads read within limits of size, header count and time, and
//! parsed by `httparse`; responses of known length whose bodies are paced
//! and counted as they are written to the socket.

use std::fs::File;
use std::io::{self, Read, Seek, SeekFrom, Write};
use std::net::{Shutdown, TcpStream};
use std::thread;
use std::time::{Duration, Instant, SystemTime};

/// The most bytes a request head (request line and headers) may take.
pub const MAX_HEAD: usize = 16 * 1024;
/// The most header fields a request may have.
pub const MAX_HEADERS: usize = 100;
/// Bytes read and discarded, at most, while closing after a refused request,
/// so that the client sees the answer rather than a reset.
const MAX_DRAIN: usize = 1 << 20;
/// Pieces in which a body is read and written.
const CHUNK: usize = 64 * 1024;

/// A parsed request head.
pub struct Request {
    pub method: String,
    /// The request target as sent.
    pub target: String,
    http10: bool,
    headers: Vec<(String, Vec<u8>)>,
}

impl Request {
    /// The first field named `name` (any case), if its value is text.
    pub fn header(&self, name: &str) -> Option<&str> {
        self.raw_header(name)
            .and_then(|v| std::str::from_utf8(v).ok())
            .map(str::trim)
    }

    /// The first field named `name`, as sent.
    pub fn raw_header(&self, name: &str) -> Option<&[u8]> {
        self.headers
            .iter()
            .find(|(n, _)| n.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_slice())
    }

    /// Whether the connection may serve another request after this one.
    /// A request that announces a body is answered and the connection
    /// closed: no request here has a use for a body, and none is read.
    pub fn keep_alive(&self) -> bool {
        let has_body = self.raw_header("transfer-encoding").is_some()
            || self.header("content-length").is_some_and(|n| n != "0");
        let close = self
            .header("connection")
            .is_some_and(|c| c.split(',').any(|t| t.trim().eq_ignore_ascii_case("close")));
        !self.http10 && !close && !has_body
    }
}

/// Why no request came.
pub enum HeadError {
    /// The connection ended, or stayed idle, before a request began.
    Idle,
    /// Part of a head came, then the time ran out (408).
    TimedOut,
    /// A head too large (431), a request line too long (414), or one that
    /// does not parse (400).
    Refused(u16),
}

/// A response to send: status, headers, body.
pub struct Response {
    pub status: u16,
    headers: Vec<(&'static str, String)>,
    body: Body,
}

enum Body {
    /// No body and no `Content-Length` (204, 304).
    None,
    Bytes(Vec<u8>),
    File {
        file: File,
        start: u64,
        len: u64,
        pace: Option<Pace>,
    },
}

impl Response {
    pub fn empty(status: u16) -> Response {
        Response {
            status,
            headers: Vec::new(),
            body: Body::None,
        }
    }

    pub fn bytes(status: u16, content_type: &str, body: Vec<u8>) -> Response {
        Response::empty(status)
            .with("Content-Type", content_type)
            .with_body(Body::Bytes(body))
    }

    pub fn text(status: u16, text: &str) -> Response {
        Response::bytes(status, "text/plain; charset=utf-8", text.into())
    }

    /// `len` bytes of `file` from `start`, paced if `pace` is given.
    pub fn file(status: u16, file: File, start: u64, len: u64, pace: Option<Pace>) -> Response {
        Response::empty(status).with_body(Body::File {
            file,
            start,
            len,
            pace,
        })
    }

    pub fn with(mut self, name: &'static str, value: impl Into<String>) -> Response {
        self.headers.push((name, value.into()));
        self
    }

    fn with_body(mut self, body: Body) -> Response {
        self.body = body;
        self
    }

    fn body_len(&self) -> Option<u64> {
        match &self.body {
            Body::None => None,
            Body::Bytes(b) => Some(b.len() as u64),
            Body::File { len, .. } => Some(*len),
        }
    }
}

/// Paces a body to at most `kbps` KB (1024 bytes) per second, in pieces of
/// a twentieth of a second.
#[derive(Clone, Copy)]
pub struct Pace {
    bytes_per_second: f64,
    piece: usize,
}

impl Pace {
    pub fn new(kbps: u32) -> Pace {
        let bytes_per_second = f64::from(kbps.max(1)) * 1024.0;
        Pace {
            bytes_per_second,
            piece: ((bytes_per_second / 20.0) as usize).max(1),
        }
    }

    /// Sleeps until `sent` bytes are due, `start` being when the first was.
    fn wait(&self, start: Instant, sent: u64) {
        let due = Duration::from_secs_f64(sent as f64 / self.bytes_per_second);
        if let Some(wait) = due.checked_sub(start.elapsed()) {
            thread::sleep(wait);
        }
    }
}

/// What sending a response did.
pub struct Sent {
    pub status: u16,
    /// Body bytes the socket accepted.
    pub bytes: u64,
    /// False if the response could not be sent whole: the connection must
    /// close.
    pub complete: bool,
}

/// One client connection.
pub struct Connection {
    stream: TcpStream,
    timeout: Duration,
    /// Bytes received and not yet used: the start of the next head.
    buf: Vec<u8>,
}

impl Connection {
    /// A connection that waits at most `timeout` for a request head and
    /// for the client to take each piece of a response.
    pub fn new(stream: TcpStream, timeout: Duration) -> io::Result<Connection> {
        stream.set_nodelay(true)?;
        stream.set_write_timeout(Some(timeout))?;
        Ok(Connection {
            stream,
            timeout,
            buf: Vec::with_capacity(MAX_HEAD),
        })
    }

    /// Reads the next request head, which must arrive whole within the
    /// timeout and fit in [`MAX_HEAD`] bytes and [`MAX_HEADERS`] fields.
    pub fn read_head(&mut self) -> Result<Request, HeadError> {
        let deadline = Instant::now() + self.timeout;
        let mut searched = 0;
        let mut piece = [0u8; 4096];
        loop {
            if let Some(end) = head_end(&self.buf, searched) {
                let request = parse(&self.buf[..end]);
                self.buf.drain(..end);
                return request;
            }
            searched = self.buf.len().saturating_sub(3);
            if self.buf.len() >= MAX_HEAD {
                let status = if self.buf.contains(&b'\n') { 431 } else { 414 };
                return Err(HeadError::Refused(status));
            }
            let started = !self.buf.is_empty();
            let Some(left) = deadline
                .checked_duration_since(Instant::now())
                .filter(|d| !d.is_zero())
            else {
                return Err(if started {
                    HeadError::TimedOut
                } else {
                    HeadError::Idle
                });
            };
            if self.stream.set_read_timeout(Some(left)).is_err() {
                return Err(HeadError::Idle);
            }
            let room = (MAX_HEAD - self.buf.len()).min(piece.len());
            match self.stream.read(&mut piece[..room]) {
                Ok(0) if started => return Err(HeadError::Refused(400)),
                Ok(0) => return Err(HeadError::Idle),
                Ok(n) => self.buf.extend_from_slice(&piece[..n]),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) if is_timeout(&e) && started => return Err(HeadError::TimedOut),
                Err(_) => return Err(HeadError::Idle),
            }
        }
    }

    /// Sends `response`, its body only if not `head_only`, announcing that
    /// the connection closes after it if `close`.
    pub fn send(&mut self, response: Response, head_only: bool, close: bool) -> Sent {
        let mut sent = Sent {
            status: response.status,
            bytes: 0,
            complete: false,
        };
        let mut head = format!(
            "HTTP/1.1 {} {}\r\nDate: {}\r\n",
            response.status,
            reason(response.status),
            httpdate::fmt_http_date(SystemTime::now())
        );
        for (name, value) in &response.headers {
            head.push_str(&format!("{name}: {value}\r\n"));
        }
        if let Some(len) = response.body_len() {
            head.push_str(&format!("Content-Length: {len}\r\n"));
        }
        if close {
            head.push_str("Connection: close\r\n");
        }
        head.push_str("\r\n");
        if self.stream.write_all(head.as_bytes()).is_err() {
            return sent;
        }
        let result = match response.body {
            _ if head_only => Ok(()),
            Body::None => Ok(()),
            Body::Bytes(bytes) => write_counted(&mut self.stream, &bytes, &mut sent.bytes),
            Body::File {
                mut file,
                start,
                len,
                pace,
            } => send_file(
                &mut self.stream,
                &mut file,
                start,
                len,
                pace,
                &mut sent.bytes,
            ),
        };
        sent.complete = result.is_ok() && self.stream.flush().is_ok();
        sent
    }

    /// Closes the connection: stops sending, then reads and drops what the
    /// client still sends (at most [`MAX_DRAIN`] bytes, for at most a
    /// second), so that closing with unread bytes does not reset the
    /// connection before the client has read the answer.
    pub fn close(mut self) {
        if self.stream.shutdown(Shutdown::Write).is_err() {
            return;
        }
        let deadline = Instant::now() + self.timeout.min(Duration::from_secs(1));
        let mut drained = 0;
        let mut piece = [0u8; 4096];
        while drained < MAX_DRAIN {
            let Some(left) = deadline
                .checked_duration_since(Instant::now())
                .filter(|d| !d.is_zero())
            else {
                return;
            };
            if self.stream.set_read_timeout(Some(left)).is_err() {
                return;
            }
            match self.stream.read(&mut piece) {
                Ok(0) => return,
                Ok(n) => drained += n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(_) => return,
            }
        }
    }
}

/// Where the head in `buf` ends (after its blank line), looking from
/// `from` on; a bare `\n` ends lines too.
fn head_end(buf: &[u8], from: usize) -> Option<usize> {
    (from..buf.len()).find_map(|i| {
        if buf[i..].starts_with(b"\r\n\r\n") {
            Some(i + 4)
        } else if buf[i..].starts_with(b"\n\n") {
            Some(i + 2)
        } else if buf[i..].starts_with(b"\n\r\n") {
            Some(i + 3)
        } else {
            None
        }
    })
}

fn parse(head: &[u8]) -> Result<Request, HeadError> {
    let mut fields = [httparse::EMPTY_HEADER; MAX_HEADERS];
    let mut request = httparse::Request::new(&mut fields);
    match request.parse(head) {
        Ok(httparse::Status::Complete(_)) => {}
        Err(httparse::Error::TooManyHeaders) => return Err(HeadError::Refused(431)),
        _ => return Err(HeadError::Refused(400)),
    }
    let (Some(method), Some(target), Some(version)) =
        (request.method, request.path, request.version)
    else {
        return Err(HeadError::Refused(400));
    };
    Ok(Request {
        method: method.to_string(),
        target: target.to_string(),
        http10: version == 0,
        headers: (request.headers.iter())
            .map(|h| (h.name.to_string(), h.value.to_vec()))
            .collect(),
    })
}

fn is_timeout(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
    )
}

/// Writes `bytes`, adding to `written` what the socket accepted.
fn write_counted(stream: &mut TcpStream, bytes: &[u8], written: &mut u64) -> io::Result<()> {
    let mut at = 0;
    while at < bytes.len() {
        match stream.write(&bytes[at..]) {
            Ok(0) => return Err(io::ErrorKind::WriteZero.into()),
            Ok(n) => {
                at += n;
                *written += n as u64;
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

fn send_file(
    stream: &mut TcpStream,
    file: &mut File,
    start: u64,
    len: u64,
    pace: Option<Pace>,
    written: &mut u64,
) -> io::Result<()> {
    file.seek(SeekFrom::Start(start))?;
    let piece = pace.map_or(CHUNK, |p| p.piece.min(CHUNK));
    let mut buf = vec![0u8; piece];
    let began = Instant::now();
    let mut sent = 0u64;
    while sent < len {
        let n = piece.min((len - sent).try_into().unwrap_or(usize::MAX));
        if let Some(pace) = pace {
            pace.wait(began, sent);
        }
        // The file may have shrunk since its length was sent: then the
        // response cannot be completed.
        file.read_exact(&mut buf[..n])?;
        write_counted(stream, &buf[..n], written)?;
        sent += n as u64;
    }
    Ok(())
}

fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        204 => "No Content",
        206 => "Partial Content",
        304 => "Not Modified",
        400 => "Bad Request",
        404 => "Not Found",
        405 => "Method Not Allowed",
        408 => "Request Timeout",
        412 => "Precondition Failed",
        414 => "URI Too Long",
        416 => "Range Not Satisfiable",
        431 => "Request Header Fields Too Large",
        _ => "Internal Server Error",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::TcpListener;

    /// A server-side connection and the client's end of it.
    fn pair(timeout: Duration) -> (Connection, TcpStream) {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let client = TcpStream::connect(listener.local_addr().unwrap()).unwrap();
        let (server, _) = listener.accept().unwrap();
        (Connection::new(server, timeout).unwrap(), client)
    }

    fn head_of(bytes: &[u8]) -> Result<Request, HeadError> {
        let (mut connection, mut client) = pair(Duration::from_secs(2));
        client.write_all(bytes).unwrap();
        connection.read_head()
    }

    fn refused(bytes: &[u8]) -> Option<u16> {
        match head_of(bytes) {
            Err(HeadError::Refused(status)) => Some(status),
            _ => None,
        }
    }

    #[test]
    fn heads_parse_within_limits() {
        let r = head_of(b"GET /a?b HTTP/1.1\r\nHost: x\r\nRange:  bytes=0-1 \r\n\r\n")
            .ok()
            .unwrap();
        assert_eq!((r.method.as_str(), r.target.as_str()), ("GET", "/a?b"));
        assert_eq!(r.header("RANGE"), Some("bytes=0-1"));
        assert!(r.keep_alive());
        let r = head_of(b"GET / HTTP/1.0\n\n").ok().unwrap();
        assert!(!r.keep_alive());
        let r = head_of(b"GET / HTTP/1.1\r\nContent-Length: 5\r\n\r\nhello")
            .ok()
            .unwrap();
        assert!(!r.keep_alive());

        let mut many = b"GET / HTTP/1.1\r\n".to_vec();
        for i in 0..=MAX_HEADERS {
            many.extend_from_slice(format!("X-{i}: v\r\n").as_bytes());
        }
        many.extend_from_slice(b"\r\n");
        assert_eq!(refused(&many), Some(431));
        let long_line = format!("GET / HTTP/1.1\r\nX: {}\r\n\r\n", "v".repeat(MAX_HEAD));
        assert_eq!(refused(long_line.as_bytes()), Some(431));
        let long_uri = format!("GET /{} HTTP/1.1\r\n\r\n", "a".repeat(MAX_HEAD));
        assert_eq!(refused(long_uri.as_bytes()), Some(414));
        assert_eq!(refused(b"NOT HTTP AT ALL\r\n\r\n"), Some(400));
    }

    #[test]
    fn pipelined_heads_are_kept_apart() {
        let (mut connection, mut client) = pair(Duration::from_secs(2));
        client
            .write_all(b"GET /1 HTTP/1.1\r\n\r\nGET /2 HTTP/1.1\r\n\r\n")
            .unwrap();
        let first = connection.read_head().ok().unwrap();
        let second = connection.read_head().ok().unwrap();
        assert_eq!(
            (first.target.as_str(), second.target.as_str()),
            ("/1", "/2")
        );
    }

    #[test]
    fn slow_and_idle_clients_time_out() {
        let (mut connection, _client) = pair(Duration::from_millis(200));
        assert!(matches!(connection.read_head(), Err(HeadError::Idle)));
        let (mut connection, mut client) = pair(Duration::from_millis(200));
        client.write_all(b"GET / HTTP/1.1\r\n").unwrap();
        let start = Instant::now();
        assert!(matches!(connection.read_head(), Err(HeadError::TimedOut)));
        assert!(start.elapsed() < Duration::from_secs(1));
    }

    #[test]
    fn pace_spreads_a_body() {
        let (mut connection, mut client) = pair(Duration::from_secs(5));
        let mut file = tempfile::tempfile().unwrap();
        file.write_all(&[7u8; 8192]).unwrap();
        // 40 KB/s: pieces of 2048 bytes, 50 ms apart.
        let response = Response::file(206, file, 1024, 4096, Some(Pace::new(40)));
        let start = Instant::now();
        let sent = connection.send(response, false, true);
        assert!(sent.complete && sent.bytes == 4096);
        assert!(start.elapsed() >= Duration::from_millis(45));
        drop(connection);
        let mut got = Vec::new();
        client.read_to_end(&mut got).unwrap();
        assert!(got.ends_with(&[7u8; 4096]));
        assert!(String::from_utf8_lossy(&got).contains("Content-Length: 4096\r\n"));
    }
}
