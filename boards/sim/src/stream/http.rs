//! HTTP/1.1 byte ranges from any standard web server, over one persistent connection (Streaming
//! QSplat §3.5: "ranges of the original file … so we may stream models from any standard web server").
//!
//! A small client of our own rather than a general one: it sends `GET` with `Range: bytes=a-b` on a
//! kept-alive `TcpStream`, accepts only `206 Partial Content` with the exact `Content-Range` and
//! `Content-Length` asked for, and counts every byte on the wire, which is the figure the streaming
//! report needs. A connection the server closed is reopened once per read.
//!
//! Every request has an overall deadline ([`REQUEST_DEADLINE`], 30 s), and so have the reads of
//! one frame ([`HttpSource::begin_frame`], [`FRAME_DEADLINE`], 60 s) and all the reads of opening
//! the stream together ([`HttpSource::begin_open`], the same 60 s): a server that stalls, drips
//! bytes or never answers is given up on at the first deadline it misses, with an error that says
//! which server did what. Such an error, or a server that ignores byte ranges, is kept as
//! [`HttpSource::fatal`] and every later read fails at once with it, so that the retries of a
//! reader (opening retries each read a few times) happen inside the deadlines, never around them.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

use pocketsplat_core::stream::ChunkSource;

/// Longest response head accepted.
const MAX_HEAD: usize = 16 * 1024;
/// Connect, read and write timeout of one socket operation.
const TIMEOUT: Duration = Duration::from_secs(10);
/// Longest one range request may take, head and body, by default.
pub const REQUEST_DEADLINE: Duration = Duration::from_secs(30);
/// Longest the reads between two [`HttpSource::begin_frame`] calls may take, by default.
pub const FRAME_DEADLINE: Duration = Duration::from_secs(60);

/// Why a range could not be read. Its `Debug` is its message (the stream reports device errors
/// with `{:?}`), written for people.
#[derive(thiserror::Error)]
pub enum HttpError {
    /// The URL is not `http://host[:port]/path` (an IPv6 host in brackets: `http://[::1]:8080/x`).
    #[error("{0:?} is not an http://host[:port]/path URL")]
    BadUrl(String),
    /// Connecting, sending or receiving failed.
    #[error("{0}")]
    Io(#[from] std::io::Error),
    /// The server answered a range request with a whole file: it does not serve byte ranges.
    #[error(
        "server at {server} sent {status} without a byte range for {path} (it ignores `Range:`; \
         streaming needs 206 Partial Content)"
    )]
    NoRange {
        /// `host:port`.
        server: String,
        /// The path asked for.
        path: String,
        /// The status it sent (200).
        status: u16,
    },
    /// The server answered with another status than 206 or 200.
    #[error("server at {server} answered {status} for bytes {first}-{last} of {path} (expected 206 Partial Content)")]
    Status {
        /// `host:port`.
        server: String,
        /// The path asked for.
        path: String,
        /// The status.
        status: u16,
        /// First byte asked for.
        first: u64,
        /// Last byte asked for.
        last: u64,
    },
    /// The server did not complete a response within the deadline.
    #[error(
        "server at {server} sent {got} bytes in {secs} s for a {want}-byte range of {path}: gave up \
         at the {limit} s deadline {per}"
    )]
    Stalled {
        /// `host:port`.
        server: String,
        /// The path asked for.
        path: String,
        /// Bytes of the response (head and body) received by then.
        got: u64,
        /// Body bytes asked for.
        want: u64,
        /// Seconds the request ran.
        secs: f64,
        /// The deadline that ended it, seconds.
        limit: f64,
        /// `"per request"`, `"per frame"` or `"for opening the stream"`: which deadline it was.
        per: &'static str,
    },
    /// An earlier read failed in a way retrying cannot cure ([`HttpSource::fatal`]): this read
    /// was not sent.
    #[error("{0}")]
    GaveUp(String),
    /// The response is not well-formed HTTP/1.1, or not the range asked for.
    #[error("bad response: {0}")]
    BadResponse(String),
}

impl std::fmt::Debug for HttpError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Display::fmt(self, f)
    }
}

/// The socket under a deadline: every read waits at most until the deadline, and counts what came.
#[derive(Debug)]
struct Wire {
    s: TcpStream,
    deadline: Option<Instant>,
    got: u64,
}

impl Read for Wire {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if let Some(d) = self.deadline {
            // A server that sends nothing is waited for until the deadline, as one that drips.
            let left = d.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(std::io::ErrorKind::TimedOut.into());
            }
            self.s.set_read_timeout(Some(left))?;
        }
        let n = self.s.read(buf)?;
        self.got += n as u64;
        Ok(n)
    }
}

/// Counts of an [`HttpSource`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HttpCounters {
    /// Range requests sent.
    pub requests: u64,
    /// TCP connections opened.
    pub connections: u64,
    /// Bytes sent (request lines and headers).
    pub sent: u64,
    /// Bytes received: response heads and bodies.
    pub received: u64,
    /// Body bytes received.
    pub body: u64,
}

/// One file on a web server, read by byte ranges.
#[derive(Debug)]
pub struct HttpSource {
    host: String,
    port: u16,
    path: String,
    conn: Option<BufReader<Wire>>,
    /// The file's length, from the last `Content-Range`.
    total: Option<u64>,
    request_limit: Duration,
    frame_limit: Duration,
    frame_deadline: Option<Instant>,
    /// What the frame deadline is for: `"per frame"` or `"for opening the stream"`.
    frame_what: &'static str,
    fatal: Option<String>,
    /// Response bytes the last request received (for [`HttpError::Stalled`]).
    last_got: u64,
    /// What went over the wire so far.
    pub counters: HttpCounters,
}

impl HttpSource {
    /// A source for `url` (`http://host[:port]/path`); connects on the first read.
    ///
    /// # Errors
    /// [`HttpError::BadUrl`] for anything else (no TLS).
    pub fn new(url: &str) -> Result<Self, HttpError> {
        let bad = || HttpError::BadUrl(url.to_string());
        let rest = url.strip_prefix("http://").ok_or_else(bad)?;
        let (authority, path) = match rest.find('/') {
            Some(i) => (&rest[..i], &rest[i..]),
            None => (rest, "/"),
        };
        // An IPv6 literal is bracketed (RFC 3986 §3.2.2), so that its colons are not the port's.
        let (host, port) = if let Some(rest) = authority.strip_prefix('[') {
            let (h, after) = rest.split_once(']').ok_or_else(bad)?;
            if h.parse::<std::net::Ipv6Addr>().is_err() {
                return Err(bad());
            }
            match after {
                "" => (h, 80),
                p => (
                    h,
                    p.strip_prefix(':')
                        .and_then(|p| p.parse::<u16>().ok())
                        .ok_or_else(bad)?,
                ),
            }
        } else {
            match authority.rsplit_once(':') {
                Some((h, p)) => (h, p.parse::<u16>().map_err(|_| bad())?),
                None => (authority, 80),
            }
        };
        let bracketed = authority.starts_with('[');
        if host.is_empty()
            || (!bracketed && host.contains([':', '[', ']']))
            || path.contains(char::is_whitespace)
        {
            return Err(bad());
        }
        Ok(Self {
            host: host.to_string(),
            port,
            path: path.to_string(),
            conn: None,
            total: None,
            request_limit: REQUEST_DEADLINE,
            frame_limit: FRAME_DEADLINE,
            frame_deadline: None,
            frame_what: "per frame",
            fatal: None,
            last_got: 0,
            counters: HttpCounters::default(),
        })
    }

    /// Sets the deadline of one request and of one frame's reads (defaults [`REQUEST_DEADLINE`],
    /// [`FRAME_DEADLINE`]).
    pub fn with_deadlines(mut self, request: Duration, frame: Duration) -> Self {
        self.request_limit = request;
        self.frame_limit = frame;
        self
    }

    /// Starts a frame: the reads until the next call share one deadline (the frame's).
    pub fn begin_frame(&mut self) {
        self.frame_deadline = Some(Instant::now() + self.frame_limit);
        self.frame_what = "per frame";
    }

    /// Starts opening the stream: every read of it (header, CRC table, head, brick table, with
    /// their retries) shares one deadline, as long as a frame's.
    pub fn begin_open(&mut self) {
        self.frame_deadline = Some(Instant::now() + self.frame_limit);
        self.frame_what = "for opening the stream";
    }

    /// The first error that retrying will not cure (a server that ignores ranges, or one that
    /// missed a deadline), as its message. Every read after it fails at once with it.
    pub fn fatal(&self) -> Option<&str> {
        self.fatal.as_deref()
    }

    /// `host:port`.
    fn server(&self) -> String {
        format!("{}:{}", self.host, self.port)
    }

    /// Whether `s` looks like a URL this source takes.
    pub fn is_url(s: &str) -> bool {
        s.starts_with("http://")
    }

    /// `host:port` as the `Host` header writes it (an IPv6 literal in brackets).
    fn authority(&self) -> String {
        if self.host.contains(':') {
            format!("[{}]:{}", self.host, self.port)
        } else {
            format!("{}:{}", self.host, self.port)
        }
    }

    fn connect(&mut self, deadline: Instant) -> Result<&mut BufReader<Wire>, HttpError> {
        // Connecting and sending wait no longer than the deadline either.
        let timeout = deadline
            .saturating_duration_since(Instant::now())
            .clamp(Duration::from_millis(1), TIMEOUT);
        if self.conn.is_none() {
            // Every address the name has, in order (`localhost` may give ::1 before 127.0.0.1).
            let mut last = None;
            let mut stream = None;
            for addr in (self.host.as_str(), self.port).to_socket_addrs()? {
                match TcpStream::connect_timeout(&addr, timeout) {
                    Ok(s) => {
                        stream = Some(s);
                        break;
                    }
                    Err(e) => last = Some(e),
                }
            }
            let s = match (stream, last) {
                (Some(s), _) => s,
                (None, Some(e)) => return Err(e.into()),
                (None, None) => return Err(HttpError::BadUrl(self.authority())),
            };
            s.set_read_timeout(Some(TIMEOUT))?;
            s.set_nodelay(true)?;
            self.counters.connections += 1;
            self.conn = Some(BufReader::with_capacity(
                64 * 1024,
                Wire {
                    s,
                    deadline: None,
                    got: 0,
                },
            ));
        }
        let conn = self.conn.as_mut().expect("connected above");
        conn.get_ref().s.set_write_timeout(Some(timeout))?;
        Ok(conn)
    }

    /// The file's length, from the `Content-Range` of a one-byte range.
    ///
    /// # Errors
    /// As for reads.
    pub fn content_length(&mut self) -> Result<u64, HttpError> {
        let mut b = [0u8; 1];
        self.range(0, &mut b)
    }

    /// Reads `buf.len()` bytes at `offset`; returns the file's total length.
    fn range(&mut self, offset: u64, buf: &mut [u8]) -> Result<u64, HttpError> {
        // A kept-alive connection may have been closed by the server since the last request: on an
        // I/O error before any of the response arrived, reconnect once.
        if let Some(why) = &self.fatal {
            return Err(HttpError::GaveUp(why.clone()));
        }
        let reused = self.conn.is_some();
        let start = Instant::now();
        let by_request = start + self.request_limit;
        let (deadline, per, limit) = match self.frame_deadline {
            Some(f) if f < by_request => (f, self.frame_what, self.frame_limit),
            _ => (by_request, "per request", self.request_limit),
        };
        let r = match self.try_range(offset, buf, deadline) {
            Err(HttpError::Io(e)) if reused && !timed_out(&e) && Instant::now() < deadline => {
                self.conn = None;
                self.try_range(offset, buf, deadline)
            }
            r => r,
        };
        let r = match r {
            Err(HttpError::Io(e)) if timed_out(&e) => Err(HttpError::Stalled {
                server: self.server(),
                path: self.path.clone(),
                got: self.last_got,
                want: buf.len() as u64,
                secs: (Instant::now() - start).as_secs_f64().round_to_tenths(),
                limit: limit.as_secs_f64().round_to_tenths(),
                per,
            }),
            r => r,
        };
        if let Err(e @ (HttpError::Stalled { .. } | HttpError::NoRange { .. })) = &r {
            self.fatal.get_or_insert_with(|| e.to_string());
        }
        if let Ok(total) = r {
            self.total = Some(total);
        }
        r
    }

    fn try_range(
        &mut self,
        offset: u64,
        buf: &mut [u8],
        deadline: Instant,
    ) -> Result<u64, HttpError> {
        if buf.is_empty() {
            return Err(HttpError::BadResponse("empty range".into()));
        }
        let last = offset + buf.len() as u64 - 1;
        let request = format!(
            "GET {} HTTP/1.1\r\nHost: {}\r\nRange: bytes={offset}-{last}\r\nUser-Agent: pocketsplat\r\n\r\n",
            self.path,
            self.authority()
        );
        let result = self.exchange(request.as_bytes(), offset, last, buf, deadline);
        self.last_got = self
            .conn
            .as_ref()
            .map_or(self.last_got, |c| c.get_ref().got);
        if result.is_err() {
            // Unknown state of the stream: never reuse it.
            self.conn = None;
        }
        result
    }

    fn exchange(
        &mut self,
        request: &[u8],
        offset: u64,
        last: u64,
        buf: &mut [u8],
        deadline: Instant,
    ) -> Result<u64, HttpError> {
        let (server, path) = (self.server(), self.path.clone());
        let conn = self.connect(deadline)?;
        let wire = conn.get_mut();
        wire.deadline = Some(deadline);
        wire.got = 0;
        wire.s.write_all(request)?;
        let mut head = 0usize;
        let mut line = String::new();
        let mut read_line = |conn: &mut BufReader<Wire>, line: &mut String| {
            line.clear();
            let n = conn.by_ref().take(8192).read_line(line)?;
            head += n;
            if n == 0 {
                return Err(HttpError::Io(std::io::ErrorKind::UnexpectedEof.into()));
            }
            if head > MAX_HEAD || !line.ends_with('\n') {
                return Err(HttpError::BadResponse("response head too long".into()));
            }
            Ok::<(), HttpError>(())
        };
        read_line(conn, &mut line)?;
        let status = parse_status(&line)?;
        let (mut length, mut range, mut close) = (None, None, false);
        loop {
            read_line(conn, &mut line)?;
            let l = line.trim_end();
            if l.is_empty() {
                break;
            }
            let Some((name, value)) = l.split_once(':') else {
                return Err(HttpError::BadResponse(format!("header line {l:?}")));
            };
            let value = value.trim();
            match name.trim().to_ascii_lowercase().as_str() {
                "content-length" => {
                    length =
                        Some(value.parse::<u64>().map_err(|_| {
                            HttpError::BadResponse(format!("Content-Length {value:?}"))
                        })?)
                }
                "content-range" => range = Some(value.to_string()),
                "connection" => close = value.eq_ignore_ascii_case("close"),
                "transfer-encoding" => {
                    return Err(HttpError::BadResponse(format!(
                        "Transfer-Encoding {value:?} on a range"
                    )))
                }
                _ => {}
            }
        }
        if status == 200 {
            return Err(HttpError::NoRange {
                server,
                path,
                status,
            });
        }
        if status != 206 {
            return Err(HttpError::Status {
                server,
                path,
                status,
                first: offset,
                last,
            });
        }
        if length != Some(buf.len() as u64) {
            return Err(HttpError::BadResponse(format!(
                "Content-Length {length:?} for a range of {} bytes",
                buf.len()
            )));
        }
        let total = parse_content_range(range.as_deref(), offset, last)?;
        conn.read_exact(buf)?;
        let head = head as u64;
        self.counters.requests += 1;
        self.counters.sent += request.len() as u64;
        self.counters.received += head + buf.len() as u64;
        self.counters.body += buf.len() as u64;
        if close {
            self.conn = None;
        }
        Ok(total)
    }
}

fn parse_status(line: &str) -> Result<u16, HttpError> {
    let mut parts = line.split_whitespace();
    match (parts.next(), parts.next().map(str::parse::<u16>)) {
        (Some(v), Some(Ok(code))) if v.starts_with("HTTP/1.") => Ok(code),
        _ => Err(HttpError::BadResponse(format!(
            "status line {:?}",
            line.trim_end()
        ))),
    }
}

/// Checks `bytes a-b/total` against the range asked for; returns `total`.
fn parse_content_range(value: Option<&str>, offset: u64, last: u64) -> Result<u64, HttpError> {
    let bad =
        || HttpError::BadResponse(format!("Content-Range {value:?} for bytes {offset}-{last}"));
    let v = value.ok_or_else(bad)?;
    let rest = v.strip_prefix("bytes ").ok_or_else(bad)?;
    let (span, total) = rest.split_once('/').ok_or_else(bad)?;
    let (a, b) = span.split_once('-').ok_or_else(bad)?;
    let (a, b) = (a.parse::<u64>(), b.parse::<u64>());
    if a != Ok(offset) || b != Ok(last) {
        return Err(bad());
    }
    total.parse::<u64>().map_err(|_| bad())
}

impl ChunkSource for HttpSource {
    type Error = HttpError;
    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> Result<(), HttpError> {
        self.range(offset, buf).map(|_| ())
    }
    fn byte_len(&self) -> Option<u64> {
        self.total
    }
}

/// Whether an I/O error is a socket timeout or [`Wire`]'s deadline.
fn timed_out(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock
    )
}

/// Seconds to one decimal, for messages.
trait RoundToTenths {
    fn round_to_tenths(self) -> f64;
}

impl RoundToTenths for f64 {
    fn round_to_tenths(self) -> f64 {
        (self * 10.0).round() / 10.0
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    #[test]
    fn urls() {
        let s = HttpSource::new("http://127.0.0.1:8080/models/dragon.tg").unwrap();
        assert_eq!(
            (s.host.as_str(), s.port, s.path.as_str()),
            ("127.0.0.1", 8080, "/models/dragon.tg")
        );
        let s = HttpSource::new("http://example.invalid").unwrap();
        assert_eq!((s.port, s.path.as_str()), (80, "/"));
        let s = HttpSource::new("http://[::1]:8080/x.tg").unwrap();
        assert_eq!(
            (s.host.as_str(), s.port, s.path.as_str(), s.authority()),
            ("::1", 8080, "/x.tg", "[::1]:8080".to_string())
        );
        let s = HttpSource::new("http://[fe80::1]/").unwrap();
        assert_eq!((s.host.as_str(), s.port), ("fe80::1", 80));
        for bad in [
            "http://[::1/x",
            "http://[::1]x/y",
            "http://[::1]:/y",
            "http://[nope]:80/y",
            "http://::1:80/y",
            "http://[]:80/y",
            "https://x/y",
            "http://:80/a",
            "http://x:port/a",
            "ftp://x",
            "http://x/a b",
        ] {
            assert!(HttpSource::new(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn content_ranges() {
        assert_eq!(
            parse_content_range(Some("bytes 0-511/4096"), 0, 511).unwrap(),
            4096
        );
        for bad in [
            None,
            Some("bytes 0-510/4096"),
            Some("bytes 1-511/4096"),
            Some("bytes */4096"),
            Some("items 0-511/4096"),
            Some("bytes 0-511/x"),
        ] {
            assert!(parse_content_range(bad, 0, 511).is_err(), "{bad:?}");
        }
        assert_eq!(
            parse_status("HTTP/1.1 206 Partial Content\r\n").unwrap(),
            206
        );
        assert!(parse_status("SPDY 206\r\n").is_err());
    }

    /// `http://[::1]:PORT/...` reaches a server on the IPv6 loopback, with the bracketed `Host`.
    #[test]
    fn ipv6_literal_urls_connect() {
        use std::net::TcpListener;
        let Ok(listener) = TcpListener::bind("[::1]:0") else {
            eprintln!("note: no IPv6 loopback here; skipping");
            return;
        };
        let port = listener.local_addr().unwrap().port();
        let server = std::thread::spawn(move || {
            let (s, _) = listener.accept().unwrap();
            let mut r = BufReader::new(s.try_clone().unwrap());
            let mut host = String::new();
            loop {
                let mut l = String::new();
                r.read_line(&mut l).unwrap();
                if l.trim().is_empty() {
                    break;
                }
                if let Some(h) = l.strip_prefix("Host: ") {
                    host = h.trim().to_string();
                }
            }
            let mut w = s;
            write!(
                w,
                "HTTP/1.1 206 Partial Content\r\nContent-Length: 4\r\nContent-Range: bytes 0-3/10\r\n\r\nPSTG"
            )
            .unwrap();
            host
        });
        let mut src = HttpSource::new(&format!("http://[::1]:{port}/x.tg")).unwrap();
        let mut buf = [0u8; 4];
        src.read_at(0, &mut buf).unwrap();
        assert_eq!(&buf, b"PSTG");
        assert_eq!(server.join().unwrap(), format!("[::1]:{port}"));
    }

    /// A one-connection server on loopback that answers two ranges on the same connection, then
    /// one with `Connection: close`, then closes; the client must reconnect for the fourth.
    #[test]
    fn keeps_the_connection_alive_and_reconnects_when_closed() {
        use std::net::TcpListener;
        let file: Vec<u8> = (0..10_000u32).map(|i| (i % 251) as u8).collect();
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let port = listener.local_addr().unwrap().port();
        let served = file.clone();
        let server = std::thread::spawn(move || {
            for (conn_no, per_conn) in [(0, 3), (1, 1)] {
                let (s, _) = listener.accept().unwrap();
                let mut r = BufReader::new(s.try_clone().unwrap());
                let mut w = s;
                for k in 0..per_conn {
                    let mut range = None;
                    loop {
                        let mut l = String::new();
                        r.read_line(&mut l).unwrap();
                        if l.trim().is_empty() {
                            break;
                        }
                        if let Some(v) = l.strip_prefix("Range: bytes=") {
                            let (a, b) = v.trim().split_once('-').unwrap();
                            range =
                                Some((a.parse::<usize>().unwrap(), b.parse::<usize>().unwrap()));
                        }
                    }
                    let (a, b) = range.unwrap();
                    let close = conn_no == 0 && k == per_conn - 1;
                    write!(
                        w,
                        "HTTP/1.1 206 Partial Content\r\nContent-Length: {}\r\nContent-Range: bytes {a}-{b}/{}\r\n{}\r\n",
                        b + 1 - a,
                        served.len(),
                        if close { "Connection: close\r\n" } else { "" }
                    )
                    .unwrap();
                    w.write_all(&served[a..=b]).unwrap();
                }
            }
        });
        let mut src = HttpSource::new(&format!("http://127.0.0.1:{port}/f")).unwrap();
        for (off, len) in [(0u64, 512usize), (4096, 1000), (9000, 1000), (17, 3)] {
            let mut buf = vec![0u8; len];
            src.read_at(off, &mut buf).unwrap();
            assert_eq!(buf, file[off as usize..off as usize + len]);
        }
        server.join().unwrap();
        assert_eq!(src.counters.requests, 4);
        assert_eq!(src.counters.connections, 2);
        assert_eq!(src.counters.body, 512 + 1000 + 1000 + 3);
    }

    /// A server on loopback that answers every request on one connection with `respond`.
    pub(crate) fn serve_with(
        respond: impl Fn(&mut TcpStream, u64, u64) + Send + 'static,
    ) -> (u16, std::thread::JoinHandle<()>) {
        use std::net::TcpListener;
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let port = listener.local_addr().unwrap().port();
        let server = std::thread::spawn(move || {
            let Ok((s, _)) = listener.accept() else {
                return;
            };
            let mut r = BufReader::new(s.try_clone().unwrap());
            let mut w = s;
            loop {
                let mut range = None;
                loop {
                    let mut l = String::new();
                    if r.read_line(&mut l).unwrap_or(0) == 0 {
                        return;
                    }
                    if l.trim().is_empty() {
                        break;
                    }
                    if let Some(v) = l.strip_prefix("Range: bytes=") {
                        let (a, b) = v.trim().split_once('-').unwrap();
                        range = Some((a.parse().unwrap(), b.parse().unwrap()));
                    }
                }
                let (a, b) = range.unwrap();
                respond(&mut w, a, b);
            }
        });
        (port, server)
    }

    #[test]
    fn a_server_that_ignores_ranges_is_named() {
        let (port, server) = serve_with(|w, _, _| {
            let _ = w.write_all(b"HTTP/1.1 200 OK\r\nContent-Length: 4\r\n\r\nPSTG");
        });
        let mut src = HttpSource::new(&format!("http://127.0.0.1:{port}/m.tg")).unwrap();
        let mut buf = [0u8; 512];
        let err = src.read_at(0, &mut buf).unwrap_err();
        let msg = err.to_string();
        assert_eq!(
            msg,
            format!(
                "server at 127.0.0.1:{port} sent 200 without a byte range for /m.tg (it ignores \
                 `Range:`; streaming needs 206 Partial Content)"
            )
        );
        assert_eq!(format!("{err:?}"), msg, "Debug is the message too");
        assert_eq!(src.fatal(), Some(msg.as_str()));
        drop(src);
        server.join().unwrap();
    }

    #[test]
    fn a_server_that_drips_is_given_up_on_at_the_request_and_the_frame_deadline() {
        // 8 bytes of the head every 100 ms: each read succeeds, the request never ends.
        let drip = |w: &mut TcpStream, a: u64, b: u64| {
            let head = format!(
                "HTTP/1.1 206 Partial Content\r\nContent-Length: {}\r\nContent-Range: bytes {a}-{b}/1000000\r\n\r\n",
                b + 1 - a
            );
            for chunk in head.as_bytes().chunks(8) {
                if w.write_all(chunk).is_err() {
                    return;
                }
                std::thread::sleep(Duration::from_millis(100));
            }
        };
        for (request, frame, per) in [
            (600u64, 60_000u64, "0.6 s deadline per request"),
            (60_000, 400, "0.4 s deadline per frame"),
        ] {
            let (port, server) = serve_with(drip);
            let mut src = HttpSource::new(&format!("http://127.0.0.1:{port}/m.tg"))
                .unwrap()
                .with_deadlines(Duration::from_millis(request), Duration::from_millis(frame));
            src.begin_frame();
            let t = Instant::now();
            let mut buf = [0u8; 4096];
            let err = src.read_at(0, &mut buf).unwrap_err().to_string();
            let took = t.elapsed();
            assert!(
                took < Duration::from_millis(request.min(frame) + 500),
                "{per}: took {took:?}"
            );
            let prefix = format!("server at 127.0.0.1:{port} sent ");
            assert!(err.starts_with(&prefix), "{err}");
            assert!(
                err.ends_with(&format!(
                    " s for a 4096-byte range of /m.tg: gave up at the {per}"
                )) && err.contains(" bytes in "),
                "{err}"
            );
            let got: u64 = err[prefix.len()..]
                .split(' ')
                .next()
                .unwrap()
                .parse()
                .unwrap();
            assert!((8..100).contains(&got), "{err}");
            assert!(src.fatal().is_some());
            // Later reads fail at once with the same error: retries cost no time.
            let t = Instant::now();
            assert_eq!(src.read_at(0, &mut buf).unwrap_err().to_string(), err);
            assert!(t.elapsed() < Duration::from_millis(50));
            drop(src);
            server.join().unwrap();
        }
    }
}
