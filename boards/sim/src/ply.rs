//! PLY mesh import: ASCII, `binary_little_endian` and `binary_big_endian`, each optionally
//! gzip-compressed (recognised by its magic bytes, whatever the file is called).
//!
//! The header grammar and the typed record decoding come from `ply-rs-bw`; this module drives it one
//! record at a time, streaming vertices and faces straight into a [`TriMesh`], so that every error
//! names the file, the element and the record. The finished mesh is checked once with
//! [`TriMesh::validate`], whose errors are passed on as [`PlyError::Mesh`].
//!
//! Where `ply-rs-bw` 4.0 falls short, and what is done here instead:
//! - It keeps elements and properties in maps keyed by name, so a repeated name silently drops a
//!   column and misreads a binary body: the header is scanned here and repeated names are rejected.
//! - Its header reader reads lines without a length limit: the header is read here first, at most
//!   [`MAX_HEADER_BYTES`], and only then handed to the crate.
//! - Its whole-payload readers report binary errors without the record index, and collect every
//!   record before returning: records are read here one by one with its per-record functions.
//! - Its ASCII number grammar takes only `[+-]digits[.digits][e[+-]digits]`: `nan` and `inf` are
//!   syntax errors there (a vertex line that fails is re-checked, so a non-finite coordinate is still
//!   reported as one), and `.5` or `5.` are rejected.
//! - Its binary readers grow a list element by element for whatever count the file declares (a
//!   face list of 2³² − 1 entries fills gigabytes before the file runs out): binary records are
//!   decoded here (`Body::binary_record`), a face list of other than 3 entries is refused at its
//!   count, and every other list is skipped by its byte size.
//! - Records of elements the mesh does not use are skipped without decoding them: by their byte
//!   size in binary, by line in ASCII, so that a file of billions of tiny records takes as long as
//!   its bytes take to read.
//!
//! **Limits** ([`crate::limits`]): the counts a header declares are checked before the body is
//! read, against the `vertices` and `triangles` limits and against the bytes that can follow the
//! header (what is left of a file, or the `ply` limit on decompressed bytes for a gzip stream or a
//! reader of unknown length); the decompressed stream is cut at the `ply` limit; and a gzip
//! stream is read to its end, so that its trailer (CRC-32 and length, RFC 1952 §2.3.1) is checked.
//!
//! # Example
//!
//! ```
//! let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
//!            property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
//!            0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
//! let mesh = pocketsplat_sim::ply::load_mesh_from_reader("triangle.ply", ply.as_bytes())?;
//! assert_eq!(mesh.triangles, vec![[0, 1, 2]]);
//! # Ok::<(), pocketsplat_sim::ply::PlyError>(())
//! ```

use std::fs::File;
use std::io::{self, BufRead, BufReader, Read};
use std::path::Path;

use flate2::read::MultiGzDecoder;
use ply_rs_bw::parser::{ParseError, Parser, Reader};
use ply_rs_bw::ply::{
    BeginList, ElementDef, Encoding, Header, PropertyAccess, PropertyAccessResult, PropertyType,
    ScalarType,
};
use pocketsplat_core::bake::{MeshError, TriMesh};

use crate::limits::{self, Exceeded, Limits};

/// Longest header accepted, in bytes (comments included).
pub const MAX_HEADER_BYTES: u64 = 1 << 20;
/// Longest line accepted in an ASCII body, in bytes.
pub const MAX_LINE_BYTES: u64 = 1 << 20;
/// Most records reserved up front from a header count (the count is not trusted until read).
const MAX_RESERVE: usize = 1 << 20;
/// First two bytes of every gzip member (RFC 1952 §2.3.1).
const GZIP_MAGIC: [u8; 2] = [0x1f, 0x8b];
/// Read buffer size.
const BUFFER_BYTES: usize = 1 << 16;

/// Why a PLY file could not be imported. The message always starts with the file name and names the
/// element (`vertex 12`, `face 7`, `element 'face'`) when there is one.
#[derive(Debug, thiserror::Error)]
pub enum PlyError {
    /// The file cannot be opened or read, or its gzip stream is corrupt.
    #[error("{file}: cannot read: {error}")]
    Io {
        /// The file.
        file: String,
        /// What the system or the decompressor said.
        error: io::Error,
    },
    /// The file is not a PLY file, or its header is malformed.
    #[error("{file}: not a PLY file or malformed header: {what}")]
    Header {
        /// The file.
        file: String,
        /// What is wrong (with the header line number when the PLY grammar rejected a line).
        what: String,
    },
    /// An element lacks a property the mesh needs (`x`, `y`, `z`, a colour channel, the face list).
    #[error("{file}: element '{element}' has no property '{property}'")]
    MissingProperty {
        /// The file.
        file: String,
        /// The element (`vertex` or `face`).
        element: String,
        /// The missing property.
        property: String,
    },
    /// A property has a type this importer cannot use (a list for a coordinate, float face indices).
    #[error("{file}: element '{element}' property '{property}' is '{found}', expected {expected}")]
    PropertyType {
        /// The file.
        file: String,
        /// The element.
        element: String,
        /// The property.
        property: String,
        /// Its declared type, as written in the header (`list uchar float`).
        found: String,
        /// What would be accepted.
        expected: &'static str,
    },
    /// A record of the body cannot be parsed.
    #[error("{file}: {element} {index}: {what}")]
    Body {
        /// The file.
        file: String,
        /// The element.
        element: String,
        /// Index of the record within its element, from 0.
        index: usize,
        /// What is wrong (with the line number in an ASCII body).
        what: String,
    },
    /// The body ends before every record the header declares has been read.
    #[error("{file}: truncated body: {element} {index} of {count} is missing or incomplete")]
    Truncated {
        /// The file.
        file: String,
        /// The element.
        element: String,
        /// Index of the first missing or incomplete record, from 0.
        index: usize,
        /// Number of records the header declares.
        count: usize,
    },
    /// A face with other than three vertices (polygons are not triangulated).
    #[error("{file}: face {face} has {count} vertices; only triangles are supported")]
    NotTriangle {
        /// The file.
        file: String,
        /// Index of the face, from 0.
        face: usize,
        /// Its number of vertices.
        count: usize,
    },
    /// A face refers to a negative vertex index. (Indices past the last vertex are reported as
    /// [`MeshError::IndexOutOfRange`] by [`TriMesh::validate`].)
    #[error("{file}: face {face} refers to vertex {index}, which is negative")]
    NegativeIndex {
        /// The file.
        file: String,
        /// Index of the face, from 0.
        face: usize,
        /// The offending vertex index.
        index: i64,
    },
    /// A limit was exceeded: a declared count, or the bytes of the decompressed stream.
    #[error("{file}: {error}")]
    Limit {
        /// The file.
        file: String,
        /// Which limit, the value found, and how to raise it.
        error: Exceeded,
    },
    /// The header declares more records than the bytes after it can hold.
    #[error("{file}: the header declares {declared}: at least {needed} bytes, but {available}")]
    TooShort {
        /// The file.
        file: String,
        /// The counts declared (`3 'vertex' records of at least 6 bytes`, ...).
        declared: String,
        /// Bytes those records take at the least.
        needed: u64,
        /// What is available, in words (`only 12 bytes follow it`).
        available: String,
    },
    /// The mesh was read but fails [`TriMesh::validate`]: empty, a non-finite vertex, a face index
    /// out of range, or no triangle with any area.
    #[error("{file}: {error}")]
    Mesh {
        /// The file.
        file: String,
        /// What `validate` found; it names the vertex or face.
        error: MeshError,
    },
}

/// Reads a PLY mesh from a file; gzip-compressed files are recognised by their magic bytes.
///
/// Vertices need `x`, `y`, `z` (any numeric type); `red`, `green`, `blue` (`uchar`, or `float` /
/// `double` in 0..1) become per-vertex colours. Faces need a `vertex_indices` (or `vertex_index`)
/// list of integers with exactly three entries. Other elements and properties are skipped. Zero-area
/// faces and duplicate or unreferenced vertices are kept as they are.
///
/// # Errors
/// A [`PlyError`] naming the file and the element: unreadable file, not PLY or malformed header,
/// missing or mistyped property, malformed or truncated body, a face that is not a triangle or has a
/// negative index, and whatever [`TriMesh::validate`] rejects.
pub fn load_mesh(path: &Path) -> Result<TriMesh, PlyError> {
    load_mesh_with(path, &limits::current())
}

/// [`load_mesh`] within `limits` rather than those in force.
///
/// # Errors
/// As [`load_mesh`], and [`PlyError::Limit`] or [`PlyError::TooShort`] when the file declares more
/// than the limits or its bytes allow. A folder, device or FIFO is refused ([`PlyError::Io`]).
pub fn load_mesh_with(path: &Path, limits: &Limits) -> Result<TriMesh, PlyError> {
    let file = path.display().to_string();
    let io = |error| PlyError::Io {
        file: file.clone(),
        error,
    };
    // Looked at before it is opened: opening a FIFO blocks until something writes to it.
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        return Err(io(io::Error::new(
            io::ErrorKind::InvalidInput,
            if meta.is_dir() {
                "it is a folder"
            } else {
                "not a regular file (a device, FIFO or socket); copy it to a file first"
            },
        )));
    }
    let reader = File::open(path).map_err(io)?;
    let len = reader.metadata().map_err(io)?.len();
    load(&file, reader, limits, Some(len))
}

/// Reads a PLY mesh from any reader, compressed or not, within the limits in force; `name` stands
/// for the file in errors.
///
/// # Errors
/// As [`load_mesh_with`].
pub fn load_mesh_from_reader(name: &str, reader: impl Read + Send) -> Result<TriMesh, PlyError> {
    load(name, reader, &limits::current(), None)
}

/// [`load_mesh_from_reader`] within `limits`.
///
/// # Errors
/// As [`load_mesh_with`].
pub fn load_mesh_from_reader_with(
    name: &str,
    reader: impl Read + Send,
    limits: &Limits,
) -> Result<TriMesh, PlyError> {
    load(name, reader, limits, None)
}

/// `len`: the reader's length in bytes when known (a regular file).
fn load(
    name: &str,
    mut reader: impl Read + Send,
    limits: &Limits,
    len: Option<u64>,
) -> Result<TriMesh, PlyError> {
    let mut magic = [0u8; 2];
    let n = read_prefix(&mut reader, &mut magic).map_err(|error| PlyError::Io {
        file: name.to_owned(),
        error,
    })?;
    let prefix = magic.get(..n).unwrap_or_default();
    let stream = prefix.chain(reader);
    if prefix == GZIP_MAGIC {
        // Multi-member, as `gzip` itself reads concatenated files.
        let inflated = Capped::new(MultiGzDecoder::new(stream), limits.ply);
        read_ahead(inflated, |inflated| {
            let mut reader = BufReader::with_capacity(BUFFER_BYTES, inflated);
            let mesh = read_ply(name, &mut reader, limits, None)?;
            // To the end of the stream: the decoder checks each member's CRC-32 and length there.
            io::copy(&mut reader, &mut io::sink()).map_err(|error| {
                capped(name, &error).unwrap_or_else(|| PlyError::Io {
                    file: name.to_owned(),
                    error: io::Error::new(
                        error.kind(),
                        format!("the gzip stream after the last record is damaged: {error}"),
                    ),
                })
            })?;
            Ok(mesh)
        })
    } else {
        if let Some(len) = len {
            limits
                .check("ply", "size in bytes", len)
                .map_err(|error| PlyError::Limit {
                    file: name.to_owned(),
                    error,
                })?;
        }
        let mut reader = BufReader::with_capacity(BUFFER_BYTES, Capped::new(stream, limits.ply));
        read_ply(name, &mut reader, limits, len)
    }
}

/// Bytes a [`read_ahead`] thread reads at a time, and chunks it may hold unread.
const AHEAD_CHUNK: usize = 1 << 18;
const AHEAD_CHUNKS: usize = 4;

/// Runs `body` on a reader of `inner` that a second thread reads ahead of it, at most
/// `AHEAD_CHUNKS × AHEAD_CHUNK` bytes ahead: inflating a `.ply.gz` is about a third of reading it,
/// and the parsing need not wait for it. Errors arrive in order, as `inner` raised them.
fn read_ahead<T>(mut inner: impl Read + Send, body: impl FnOnce(Ahead) -> T) -> T {
    std::thread::scope(|scope| {
        let (tx, rx) = std::sync::mpsc::sync_channel(AHEAD_CHUNKS);
        scope.spawn(move || loop {
            let mut chunk = std::vec![0u8; AHEAD_CHUNK];
            let mut n = 0;
            let end = loop {
                match inner.read(&mut chunk[n..]) {
                    Ok(0) => break None,
                    Ok(k) => {
                        n += k;
                        if n == chunk.len() {
                            break Some(Ok(()));
                        }
                    }
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                    Err(e) => break Some(Err(e)),
                }
            };
            chunk.truncate(n);
            // A send fails once `body` has returned and dropped the reader: then stop.
            if n > 0 && tx.send(Ok(chunk)).is_err() {
                return;
            }
            match end {
                Some(Ok(())) => {}
                Some(Err(e)) => {
                    let _ = tx.send(Err(e));
                    return;
                }
                None => return,
            }
        });
        // `body` owns the receiving end, so it is dropped (and the thread released) before the
        // scope waits for the thread, however `body` returns.
        body(Ahead {
            rx,
            chunk: Vec::new(),
            at: 0,
        })
    })
}

/// The reading end of [`read_ahead`].
struct Ahead {
    rx: std::sync::mpsc::Receiver<io::Result<Vec<u8>>>,
    chunk: Vec<u8>,
    at: usize,
}

impl Read for Ahead {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        while self.at == self.chunk.len() {
            match self.rx.recv() {
                Ok(Ok(chunk)) => {
                    self.chunk = chunk;
                    self.at = 0;
                }
                Ok(Err(e)) => return Err(e),
                // The thread has finished: the end of `inner`.
                Err(_) => return Ok(0),
            }
        }
        let n = buf.len().min(self.chunk.len() - self.at);
        buf[..n].copy_from_slice(&self.chunk[self.at..self.at + n]);
        self.at += n;
        Ok(n)
    }
}

/// A reader that fails once more than `max` bytes come through it (the `ply` limit on the
/// decompressed stream).
struct Capped<R> {
    inner: R,
    left: u64,
    max: u64,
}

impl<R> Capped<R> {
    fn new(inner: R, max: u64) -> Self {
        Self {
            inner,
            left: max,
            max,
        }
    }
}

/// The error a [`Capped`] reader fails with.
#[derive(Debug)]
struct CapReached(u64);

impl std::fmt::Display for CapReached {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "more than {} bytes", self.0)
    }
}

impl std::error::Error for CapReached {}

impl<R: Read> Read for Capped<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.left == 0 {
            let mut probe = [0u8; 1];
            return match self.inner.read(&mut probe)? {
                0 => Ok(0),
                _ => Err(io::Error::other(CapReached(self.max))),
            };
        }
        let n = buf
            .len()
            .min(usize::try_from(self.left).unwrap_or(usize::MAX));
        let k = self.inner.read(buf.get_mut(..n).unwrap_or_default())?;
        self.left = self.left.saturating_sub(k as u64);
        Ok(k)
    }
}

/// The [`PlyError::Limit`] for an I/O error a [`Capped`] reader raised.
fn capped(file: &str, e: &io::Error) -> Option<PlyError> {
    let cap = e.get_ref()?.downcast_ref::<CapReached>()?;
    Some(PlyError::Limit {
        file: file.to_owned(),
        error: Exceeded {
            name: "ply",
            what: "decompressed size in bytes".into(),
            value: cap.0.saturating_add(1),
            max: cap.0,
        },
    })
}

/// Fills `buf` as far as the reader allows; returns how many bytes were read.
fn read_prefix(reader: &mut impl Read, buf: &mut [u8]) -> io::Result<usize> {
    let mut n = 0;
    while let Some(rest) = buf.get_mut(n..).filter(|rest| !rest.is_empty()) {
        match reader.read(rest) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

fn read_ply(
    file: &str,
    reader: &mut impl BufRead,
    limits: &Limits,
    len: Option<u64>,
) -> Result<TriMesh, PlyError> {
    let (header, header_lines, header_bytes) = read_header(file, reader)?;
    let vertex = header
        .elements
        .get("vertex")
        .map(|def| VertexLayout::new(file, def))
        .transpose()?;
    let face_list = match header.elements.get("face") {
        Some(def) => Some(check_face(file, def)?),
        None => None,
    };
    check_counts(file, &header, limits, len, header_bytes)?;

    let mut mesh = TriMesh::default();
    let mut colors = Vec::new();
    let mut body = Body {
        file,
        reader,
        encoding: header.encoding,
        line: Vec::new(),
        line_no: header_lines,
    };
    for def in header.elements.values() {
        match (def.name.as_str(), &vertex) {
            ("vertex", Some(layout)) => {
                mesh.positions.reserve(def.count.min(MAX_RESERVE));
                if layout.has_color {
                    colors.reserve(def.count.min(MAX_RESERVE));
                }
                body.read_records(def, layout.coord_columns, None, |_, v: VertexRecord| {
                    mesh.positions.push(v.position);
                    if layout.has_color {
                        colors.push(v.color);
                    }
                    Ok(())
                })?;
            }
            ("face", _) => {
                mesh.triangles.reserve(def.count.min(MAX_RESERVE));
                body.read_records(def, None, face_list.as_deref(), |face, f: FaceRecord| {
                    mesh.triangles.push(f.triangle(file, face)?);
                    Ok(())
                })?;
            }
            _ => body.skip_records(def)?,
        }
    }
    if vertex.as_ref().is_some_and(|layout| layout.has_color) {
        mesh.colors = Some(colors);
    }
    mesh.validate().map_err(|error| PlyError::Mesh {
        file: file.to_owned(),
        error,
    })?;
    Ok(mesh)
}

/// Checks the header's counts before the body is read: `vertices` and `triangles` against their
/// limits, and every element's records at their smallest against the bytes that can follow the
/// header: what is left of a file of `len` bytes, else the `ply` limit.
fn check_counts(
    file: &str,
    header: &Header,
    limits: &Limits,
    len: Option<u64>,
    header_bytes: u64,
) -> Result<(), PlyError> {
    let limit = |name, what, count: usize| {
        limits
            .check(name, what, count as u64)
            .map_err(|error| PlyError::Limit {
                file: file.to_owned(),
                error,
            })
    };
    if let Some(def) = header.elements.get("vertex") {
        limit("vertices", "declared vertices", def.count)?;
    }
    if let Some(def) = header.elements.get("face") {
        limit("triangles", "declared faces", def.count)?;
    }
    let ascii = header.encoding == Encoding::Ascii;
    let mut needed: u128 = 0;
    let mut declared = Vec::new();
    for def in header.elements.values() {
        let min = min_record_bytes(def, ascii);
        if def.count > 0 && min > 0 {
            needed += def.count as u128 * u128::from(min);
            declared.push(format!(
                "{} '{}' records of at least {min} bytes",
                def.count, def.name
            ));
        }
    }
    // The last ASCII line may end without its line break.
    if ascii {
        needed = needed.saturating_sub(1);
    }
    let needed = u64::try_from(needed).unwrap_or(u64::MAX);
    let (available, words) = match len {
        Some(len) => {
            let left = len.saturating_sub(header_bytes);
            (left, format!("only {left} bytes follow it"))
        }
        None => {
            let left = limits.ply.saturating_sub(header_bytes);
            (
                left,
                format!(
                    "the limit ply={} leaves {left} bytes after it once decompressed (raise it with \
                     --limits ply=SIZE)",
                    crate::args::format_size(limits.ply)
                ),
            )
        }
    };
    if needed > available {
        return Err(PlyError::TooShort {
            file: file.to_owned(),
            declared: declared.join(", "),
            needed,
            available: words,
        });
    }
    Ok(())
}

/// The fewest bytes a record of `def` takes: in binary its scalars and its lists' counts (a list
/// may be empty); in ASCII 2 per value (a digit and a separator), 1 for a record with none (its
/// line break). 0 for a binary record of no properties (never read).
fn min_record_bytes(def: &ElementDef, ascii: bool) -> u64 {
    if ascii && def.properties.is_empty() {
        return 1;
    }
    def.properties
        .values()
        .map(|p| match (&p.data_type, ascii) {
            (_, true) => 2,
            (PropertyType::Scalar(t), false) | (PropertyType::List(t, _), false) => scalar_bytes(t),
        })
        .sum()
}

/// Bytes of a binary scalar.
fn scalar_bytes(t: &ScalarType) -> u64 {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

// ---------------------------------------------------------------------------------------------
// Header

/// Reads the header (through `end_header`) with a length limit, checks for repeated names, and parses
/// it with `ply-rs-bw`. Returns the header, its number of lines and its bytes.
fn read_header(file: &str, reader: &mut impl BufRead) -> Result<(Header, usize, u64), PlyError> {
    let header_error = |what: String| PlyError::Header {
        file: file.to_owned(),
        what,
    };
    let mut text = Vec::new();
    let mut limited = reader.take(MAX_HEADER_BYTES);
    let mut lines = 0usize;
    // (element name, its property names) in order, to catch names the crate's maps would merge.
    let mut names: Vec<(String, Vec<String>)> = Vec::new();
    loop {
        let start = text.len();
        let n = limited
            .read_until(b'\n', &mut text)
            .map_err(|error| PlyError::Io {
                file: file.to_owned(),
                error,
            })?;
        let line = text.get(start..).unwrap_or_default();
        let trimmed = line.trim_ascii_end();
        if n == 0 || (lines == 0 && trimmed != b"ply") {
            return Err(header_error(if lines == 0 && n == 0 {
                "the file is empty".to_owned()
            } else if lines == 0 {
                format!(
                    "it does not start with a 'ply' line (starts with {:?})",
                    preview(line)
                )
            } else if limited.limit() == 0 {
                format!("no 'end_header' line in the first {MAX_HEADER_BYTES} bytes")
            } else {
                "the file ends before the 'end_header' line".to_owned()
            }));
        }
        lines += 1;
        if trimmed == b"end_header" {
            break;
        }
        let mut words = trimmed
            .split(u8::is_ascii_whitespace)
            .filter(|w| !w.is_empty());
        match words.next() {
            Some(b"element") => {
                let name = String::from_utf8_lossy(words.next().unwrap_or_default()).into_owned();
                if names.iter().any(|(e, _)| *e == name) {
                    return Err(header_error(format!("element '{name}' is declared twice")));
                }
                names.push((name, Vec::new()));
            }
            Some(b"property") => {
                if let (Some((element, props)), Some(last)) = (names.last_mut(), words.next_back())
                {
                    let name = String::from_utf8_lossy(last).into_owned();
                    if props.contains(&name) {
                        return Err(header_error(format!(
                            "element '{element}' declares property '{name}' twice"
                        )));
                    }
                    props.push(name);
                }
            }
            _ => {}
        }
    }
    let header = Parser::<SkipRecord>::new()
        .read_header(&mut Reader::new(text.as_slice()))
        .map_err(|e| header_error(flatten(&e)))?;
    Ok((header, lines, text.len() as u64))
}

/// The start of a line, for an error message.
fn preview(line: &[u8]) -> String {
    String::from_utf8_lossy(line.get(..16).unwrap_or(line)).into_owned()
}

/// A `ply-rs-bw` error message on one line. (It quotes header lines with their line break.)
fn flatten(e: &ParseError) -> String {
    let msg = e.to_string().replace("\r\n'", "'").replace("\n'", "'");
    msg.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("; ")
}

/// A property type as a PLY header writes it.
fn type_name(t: &PropertyType) -> String {
    fn scalar(s: &ScalarType) -> &'static str {
        match s {
            ScalarType::Char => "char",
            ScalarType::UChar => "uchar",
            ScalarType::Short => "short",
            ScalarType::UShort => "ushort",
            ScalarType::Int => "int",
            ScalarType::UInt => "uint",
            ScalarType::Float => "float",
            ScalarType::Double => "double",
        }
    }
    match t {
        PropertyType::Scalar(s) => scalar(s).to_owned(),
        PropertyType::List(count, item) => format!("list {} {}", scalar(count), scalar(item)),
    }
}

fn is_integer(s: &ScalarType) -> bool {
    !matches!(s, ScalarType::Float | ScalarType::Double)
}

/// What the vertex element provides.
struct VertexLayout {
    /// `red`, `green` and `blue` are all present.
    has_color: bool,
    /// ASCII columns of x, y, z, when no list precedes them (to recognise `nan` and `inf`).
    coord_columns: Option<[usize; 3]>,
}

impl VertexLayout {
    fn new(file: &str, def: &ElementDef) -> Result<Self, PlyError> {
        let missing = |property: &str| PlyError::MissingProperty {
            file: file.to_owned(),
            element: def.name.clone(),
            property: property.to_owned(),
        };
        let mistyped = |property: &str, t: &PropertyType, expected| PlyError::PropertyType {
            file: file.to_owned(),
            element: def.name.clone(),
            property: property.to_owned(),
            found: type_name(t),
            expected,
        };
        let column = |name: &str| {
            let mut column = 0;
            for p in def.properties.values() {
                if p.name == name {
                    return Some(column);
                }
                match p.data_type {
                    PropertyType::Scalar(_) => column += 1,
                    PropertyType::List(..) => return None,
                }
            }
            None
        };
        let mut coord_columns = Some([0; 3]);
        for (axis, name) in ["x", "y", "z"].into_iter().enumerate() {
            let p = def.properties.get(name).ok_or_else(|| missing(name))?;
            if matches!(p.data_type, PropertyType::List(..)) {
                return Err(mistyped(name, &p.data_type, "a number"));
            }
            let col = column(name);
            if let (Some(cols), Some(col)) = (coord_columns.as_mut(), col) {
                if let Some(slot) = cols.get_mut(axis) {
                    *slot = col;
                }
            } else {
                coord_columns = None;
            }
        }
        let channels = ["red", "green", "blue"];
        let has_color = channels.iter().any(|c| def.properties.contains_key(*c));
        if has_color {
            for name in channels {
                let p = def.properties.get(name).ok_or_else(|| missing(name))?;
                if !matches!(
                    p.data_type,
                    PropertyType::Scalar(
                        ScalarType::UChar | ScalarType::Float | ScalarType::Double
                    )
                ) {
                    return Err(mistyped(
                        name,
                        &p.data_type,
                        "'uchar', or 'float' or 'double' in 0..1",
                    ));
                }
            }
        }
        Ok(Self {
            has_color,
            coord_columns,
        })
    }
}

/// The face list property, in order of preference.
const FACE_LISTS: [&str; 2] = ["vertex_indices", "vertex_index"];

/// Checks the face element and returns the name of the list it is read from.
fn check_face(file: &str, def: &ElementDef) -> Result<String, PlyError> {
    let Some(p) = FACE_LISTS.iter().find_map(|name| def.properties.get(*name)) else {
        return Err(PlyError::MissingProperty {
            file: file.to_owned(),
            element: def.name.clone(),
            property: FACE_LISTS[0].to_owned(),
        });
    };
    match &p.data_type {
        PropertyType::List(count, item) if is_integer(count) && is_integer(item) => {
            Ok(p.name.clone())
        }
        t => Err(PlyError::PropertyType {
            file: file.to_owned(),
            element: def.name.clone(),
            property: p.name.clone(),
            found: type_name(t),
            expected: "a list of integers with an integer count",
        }),
    }
}

// ---------------------------------------------------------------------------------------------
// Body

/// The body reader: one record at a time, so that errors know the record.
struct Body<'a, B> {
    file: &'a str,
    reader: B,
    encoding: Encoding,
    /// The current ASCII line (reused).
    line: Vec<u8>,
    /// Number of lines read so far (header included), for ASCII error messages.
    line_no: usize,
}

impl<B: BufRead> Body<'_, B> {
    /// Reads every record of `def` and hands it to `each` with its index. `face_list` names the
    /// list a face is read from: a binary record whose list there has other than 3 entries is
    /// [`PlyError::NotTriangle`] before any entry is read.
    fn read_records<E: PropertyAccess>(
        &mut self,
        def: &ElementDef,
        coord_columns: Option<[usize; 3]>,
        face_list: Option<&str>,
        mut each: impl FnMut(usize, E) -> Result<(), PlyError>,
    ) -> Result<(), PlyError> {
        if def.properties.is_empty() && self.encoding != Encoding::Ascii {
            // Zero bytes per record: nothing to read, however large the count.
            return Ok(());
        }
        let parser = Parser::<E>::new();
        for index in 0..def.count {
            let record = match self.encoding {
                Encoding::Ascii => self.ascii_record(&parser, def, index, coord_columns)?,
                Encoding::BinaryLittleEndian => self.binary_record(def, index, face_list, false)?,
                Encoding::BinaryBigEndian => self.binary_record(def, index, face_list, true)?,
            };
            each(index, record)?;
        }
        Ok(())
    }

    /// Skips every record of `def` without decoding it: in ASCII one line each, in binary by the
    /// byte sizes of its scalars and lists (in one stretch when it has no list).
    fn skip_records(&mut self, def: &ElementDef) -> Result<(), PlyError> {
        if self.encoding == Encoding::Ascii {
            return self.skip_lines(def);
        }
        let big = self.encoding == Encoding::BinaryBigEndian;
        let fixed: Option<u64> = def
            .properties
            .values()
            .map(|p| match &p.data_type {
                PropertyType::Scalar(t) => Some(scalar_bytes(t)),
                PropertyType::List(..) => None,
            })
            .sum();
        match fixed {
            Some(0) => Ok(()),
            Some(size) => {
                let total = u64::try_from(def.count as u128 * u128::from(size)).unwrap_or(u64::MAX);
                let skipped = self
                    .skip_bytes(total)
                    .map_err(|e| self.io_error(def, 0, &e))?;
                if skipped < total {
                    return Err(self.truncated(def, (skipped / size) as usize));
                }
                Ok(())
            }
            None => {
                for index in 0..def.count {
                    for p in def.properties.values() {
                        let n = match &p.data_type {
                            PropertyType::Scalar(t) => scalar_bytes(t),
                            PropertyType::List(c, i) => {
                                self.list_count(def, index, c, big)? * scalar_bytes(i)
                            }
                        };
                        let skipped = self
                            .skip_bytes(n)
                            .map_err(|e| self.io_error(def, index, &e))?;
                        if skipped < n {
                            return Err(self.truncated(def, index));
                        }
                    }
                }
                Ok(())
            }
        }
    }

    /// Skips up to `n` bytes; returns how many there were.
    fn skip_bytes(&mut self, n: u64) -> io::Result<u64> {
        let mut left = n;
        while left > 0 {
            let buf = self.reader.fill_buf()?;
            if buf.is_empty() {
                break;
            }
            let k = buf.len().min(usize::try_from(left).unwrap_or(usize::MAX));
            self.reader.consume(k);
            left -= k as u64;
        }
        Ok(n - left)
    }

    /// Skips `def.count` lines (the last may end without its line break).
    fn skip_lines(&mut self, def: &ElementDef) -> Result<(), PlyError> {
        let mut left = def.count;
        // Bytes of a line not yet ended have been skipped.
        let mut pending = false;
        while left > 0 {
            let buf = match self.reader.fill_buf() {
                Ok(buf) => buf,
                Err(e) => return Err(self.io_error(def, def.count - left, &e)),
            };
            if buf.is_empty() {
                if pending && left == 1 {
                    break;
                }
                return Err(self.truncated(def, def.count - left));
            }
            let breaks = buf.iter().filter(|&&b| b == b'\n').count();
            let used = if breaks < left {
                left -= breaks;
                pending = buf.last() != Some(&b'\n');
                buf.len()
            } else {
                // The line that ends the element ends inside this buffer.
                let mut seen = 0;
                let end = buf
                    .iter()
                    .position(|&b| {
                        seen += usize::from(b == b'\n');
                        seen == left
                    })
                    .map_or(buf.len(), |i| i + 1);
                left = 0;
                end
            };
            self.reader.consume(used);
        }
        self.line_no = self.line_no.saturating_add(def.count);
        Ok(())
    }

    /// Reads `N` bytes of record `index` of `def`.
    fn take<const N: usize>(
        &mut self,
        def: &ElementDef,
        index: usize,
    ) -> Result<[u8; N], PlyError> {
        let mut b = [0u8; N];
        match self.reader.read_exact(&mut b) {
            Ok(()) => Ok(b),
            Err(e) => Err(self.io_error(def, index, &e)),
        }
    }

    /// A list's entry count, as a non-negative integer.
    fn list_count(
        &mut self,
        def: &ElementDef,
        index: usize,
        t: &ScalarType,
        big: bool,
    ) -> Result<u64, PlyError> {
        let v: i64 = match t {
            ScalarType::Char => i64::from(self.take::<1>(def, index)?[0] as i8),
            ScalarType::UChar => i64::from(self.take::<1>(def, index)?[0]),
            ScalarType::Short => {
                let b = self.take::<2>(def, index)?;
                i64::from(if big {
                    i16::from_be_bytes(b)
                } else {
                    i16::from_le_bytes(b)
                })
            }
            ScalarType::UShort => {
                let b = self.take::<2>(def, index)?;
                i64::from(if big {
                    u16::from_be_bytes(b)
                } else {
                    u16::from_le_bytes(b)
                })
            }
            ScalarType::Int => {
                let b = self.take::<4>(def, index)?;
                i64::from(if big {
                    i32::from_be_bytes(b)
                } else {
                    i32::from_le_bytes(b)
                })
            }
            ScalarType::UInt => {
                let b = self.take::<4>(def, index)?;
                i64::from(if big {
                    u32::from_be_bytes(b)
                } else {
                    u32::from_le_bytes(b)
                })
            }
            ScalarType::Float | ScalarType::Double => {
                return Err(self.body_error(def, index, "a list count must be an integer".into()))
            }
        };
        u64::try_from(v)
            .map_err(|_| self.body_error(def, index, format!("list count {v} is negative")))
    }

    /// Decodes one binary record: scalars into `E`, the face list (3 entries, or
    /// [`PlyError::NotTriangle`]) too, other lists skipped by their size.
    fn binary_record<E: PropertyAccess>(
        &mut self,
        def: &ElementDef,
        index: usize,
        face_list: Option<&str>,
        big: bool,
    ) -> Result<E, PlyError> {
        let mut rec = E::new();
        for p in def.properties.values() {
            let name = p.name.as_str();
            match &p.data_type {
                PropertyType::Scalar(t) => {
                    self.binary_scalar(&mut rec, name, t, def, index, big)?
                }
                PropertyType::List(c, item) => {
                    let n = self.list_count(def, index, c, big)?;
                    if face_list == Some(name) {
                        if n != 3 {
                            return Err(PlyError::NotTriangle {
                                file: self.file.to_owned(),
                                face: index,
                                count: usize::try_from(n).unwrap_or(usize::MAX),
                            });
                        }
                        self.binary_face_list(&mut rec, name, item, def, index, big)?;
                    } else {
                        let bytes = n * scalar_bytes(item);
                        let skipped = self
                            .skip_bytes(bytes)
                            .map_err(|e| self.io_error(def, index, &e))?;
                        if skipped < bytes {
                            return Err(self.truncated(def, index));
                        }
                    }
                }
            }
        }
        Ok(rec)
    }

    fn binary_scalar<E: PropertyAccess>(
        &mut self,
        rec: &mut E,
        name: &str,
        t: &ScalarType,
        def: &ElementDef,
        index: usize,
        big: bool,
    ) -> Result<(), PlyError> {
        macro_rules! get {
            ($ty:ty, $n:literal) => {{
                let b = self.take::<$n>(def, index)?;
                if big {
                    <$ty>::from_be_bytes(b)
                } else {
                    <$ty>::from_le_bytes(b)
                }
            }};
        }
        match t {
            ScalarType::Char => rec.set_char(name, get!(i8, 1)),
            ScalarType::UChar => rec.set_uchar(name, get!(u8, 1)),
            ScalarType::Short => rec.set_short(name, get!(i16, 2)),
            ScalarType::UShort => rec.set_ushort(name, get!(u16, 2)),
            ScalarType::Int => rec.set_int(name, get!(i32, 4)),
            ScalarType::UInt => rec.set_uint(name, get!(u32, 4)),
            ScalarType::Float => rec.set_float(name, get!(f32, 4)),
            ScalarType::Double => rec.set_double(name, get!(f64, 8)),
        };
        Ok(())
    }

    /// The three entries of a face list, of integer type `item` (checked by [`check_face`]).
    fn binary_face_list<E: PropertyAccess>(
        &mut self,
        rec: &mut E,
        name: &str,
        item: &ScalarType,
        def: &ElementDef,
        index: usize,
        big: bool,
    ) -> Result<(), PlyError> {
        macro_rules! three {
            ($ty:ty, $n:literal) => {{
                let mut v = Vec::with_capacity(3);
                for _ in 0..3 {
                    let b = self.take::<$n>(def, index)?;
                    v.push(if big {
                        <$ty>::from_be_bytes(b)
                    } else {
                        <$ty>::from_le_bytes(b)
                    });
                }
                v
            }};
        }
        match item {
            ScalarType::Char => rec.set_list_char(name, three!(i8, 1)),
            ScalarType::UChar => rec.set_list_uchar(name, three!(u8, 1)),
            ScalarType::Short => rec.set_list_short(name, three!(i16, 2)),
            ScalarType::UShort => rec.set_list_ushort(name, three!(u16, 2)),
            ScalarType::Int => rec.set_list_int(name, three!(i32, 4)),
            ScalarType::UInt => rec.set_list_uint(name, three!(u32, 4)),
            ScalarType::Float | ScalarType::Double => {
                return Err(self.body_error(def, index, "face indices must be integers".into()))
            }
        };
        Ok(())
    }

    fn ascii_record<E: PropertyAccess>(
        &mut self,
        parser: &Parser<E>,
        def: &ElementDef,
        index: usize,
        coord_columns: Option<[usize; 3]>,
    ) -> Result<E, PlyError> {
        self.line.clear();
        let n = (&mut self.reader)
            .take(MAX_LINE_BYTES)
            .read_until(b'\n', &mut self.line);
        let n = n.map_err(|e| self.io_error(def, index, &e))?;
        if n == 0 {
            return Err(self.truncated(def, index));
        }
        self.line_no += 1;
        let complete = self.line.last() == Some(&b'\n');
        if !complete && n as u64 == MAX_LINE_BYTES {
            return Err(self.body_error(
                def,
                index,
                format!(
                    "line {} is longer than {MAX_LINE_BYTES} bytes",
                    self.line_no
                ),
            ));
        }
        let Ok(text) = std::str::from_utf8(&self.line) else {
            return Err(self.body_error(def, index, format!("line {} is not text", self.line_no)));
        };
        let text = text.trim_end_matches(['\n', '\r']);
        if let Some(record) = ascii_fast(text, def) {
            return Ok(record);
        }
        parser.read_ascii_element(text, def).map_err(|e| {
            if let Some(columns) = coord_columns {
                // The crate's number grammar has no `nan` / `inf`: say what `validate` would say.
                let tokens: Vec<&str> = text.split_ascii_whitespace().collect();
                let non_finite = |c: usize| {
                    tokens
                        .get(c)
                        .and_then(|t| t.parse::<f64>().ok())
                        .is_some_and(|v| !v.is_finite())
                };
                if columns.into_iter().any(non_finite) {
                    return PlyError::Mesh {
                        file: self.file.to_owned(),
                        error: MeshError::NonFinite { vertex: index },
                    };
                }
            }
            if complete {
                self.body_error(
                    def,
                    index,
                    format!("line {}: {}", self.line_no, flatten(&e)),
                )
            } else {
                // The last line, cut short.
                self.truncated(def, index)
            }
        })
    }

    fn io_error(&self, def: &ElementDef, index: usize, e: &io::Error) -> PlyError {
        if let Some(limit) = capped(self.file, e) {
            return limit;
        }
        if e.kind() == io::ErrorKind::UnexpectedEof {
            self.truncated(def, index)
        } else {
            self.body_error(def, index, format!("cannot read: {e}"))
        }
    }

    fn truncated(&self, def: &ElementDef, index: usize) -> PlyError {
        PlyError::Truncated {
            file: self.file.to_owned(),
            element: def.name.clone(),
            index,
            count: def.count,
        }
    }

    fn body_error(&self, def: &ElementDef, index: usize, what: String) -> PlyError {
        PlyError::Body {
            file: self.file.to_owned(),
            element: def.name.clone(),
            index,
            what,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Records: what `ply-rs-bw` decodes each vertex and face into.

/// Whether `t` is a number as the PLY crate's ASCII grammar has it:
/// `[-+]?[0-9]+(.[0-9]+)?([eE][-+]?[0-9]+)?`.
fn is_ply_number(t: &[u8]) -> bool {
    fn digits(t: &[u8], i: &mut usize) -> bool {
        let start = *i;
        while t.get(*i).is_some_and(u8::is_ascii_digit) {
            *i += 1;
        }
        *i > start
    }
    let mut i = usize::from(matches!(t.first(), Some(b'-' | b'+')));
    if !digits(t, &mut i) {
        return false;
    }
    if t.get(i) == Some(&b'.') {
        i += 1;
        if !digits(t, &mut i) {
            return false;
        }
    }
    if matches!(t.get(i), Some(b'e' | b'E')) {
        i += 1;
        if matches!(t.get(i), Some(b'-' | b'+')) {
            i += 1;
        }
        if !digits(t, &mut i) {
            return false;
        }
    }
    i == t.len()
}

/// One ASCII record read as the PLY crate reads it (the same tokens, the same `FromStr` of each
/// declared type, the same setters) without its grammar, which takes most of a big ASCII read.
/// `None` for anything else (a token that is not a number, a missing or unparsable value, a type the
/// record does not take): the crate's parser then reads the line and says what is wrong.
fn ascii_fast<E: PropertyAccess>(text: &str, def: &ElementDef) -> Option<E> {
    let mut tokens = text.split([' ', '\t']).filter(|t| !t.is_empty());
    if !text
        .split([' ', '\t'])
        .filter(|t| !t.is_empty())
        .all(|t| is_ply_number(t.as_bytes()))
    {
        return None;
    }
    let mut rec = E::new();
    let ok = |r: PropertyAccessResult| !matches!(r, PropertyAccessResult::UnsupportedType);
    for p in def.properties.values() {
        let name = p.name.as_str();
        let t = tokens.next()?;
        match &p.data_type {
            PropertyType::Scalar(ty) => {
                let set = match ty {
                    ScalarType::Char => rec.set_char(name, t.parse().ok()?),
                    ScalarType::UChar => rec.set_uchar(name, t.parse().ok()?),
                    ScalarType::Short => rec.set_short(name, t.parse().ok()?),
                    ScalarType::UShort => rec.set_ushort(name, t.parse().ok()?),
                    ScalarType::Int => rec.set_int(name, t.parse().ok()?),
                    ScalarType::UInt => rec.set_uint(name, t.parse().ok()?),
                    ScalarType::Float => rec.set_float(name, t.parse().ok()?),
                    ScalarType::Double => rec.set_double(name, t.parse().ok()?),
                };
                if !ok(set) {
                    return None;
                }
            }
            PropertyType::List(_, item) => {
                let count: usize = t.parse().ok()?;
                macro_rules! list {
                    ($begin:ident, $set:ident) => {{
                        if !matches!(rec.$begin(name, count), BeginList::UseSetter) {
                            return None;
                        }
                        let mut v = Vec::with_capacity(count.min(16));
                        for _ in 0..count {
                            v.push(tokens.next()?.parse().ok()?);
                        }
                        rec.$set(name, v)
                    }};
                }
                let set = match item {
                    ScalarType::Char => list!(begin_list_char, set_list_char),
                    ScalarType::UChar => list!(begin_list_uchar, set_list_uchar),
                    ScalarType::Short => list!(begin_list_short, set_list_short),
                    ScalarType::UShort => list!(begin_list_ushort, set_list_ushort),
                    ScalarType::Int => list!(begin_list_int, set_list_int),
                    ScalarType::UInt => list!(begin_list_uint, set_list_uint),
                    ScalarType::Float => list!(begin_list_float, set_list_float),
                    ScalarType::Double => list!(begin_list_double, set_list_double),
                };
                if !ok(set) {
                    return None;
                }
            }
        }
    }
    Some(rec)
}

/// One vertex: position and (if the file has one) colour.
#[derive(Default, Debug, PartialEq)]
struct VertexRecord {
    position: [f64; 3],
    color: [u8; 3],
}

impl VertexRecord {
    fn coordinate(&mut self, name: &str, value: f64) -> PropertyAccessResult {
        let slot = match name {
            "x" => &mut self.position[0],
            "y" => &mut self.position[1],
            "z" => &mut self.position[2],
            _ => return PropertyAccessResult::Ignored,
        };
        *slot = value;
        PropertyAccessResult::Set
    }

    fn channel(&mut self, name: &str) -> Option<&mut u8> {
        match name {
            "red" => Some(&mut self.color[0]),
            "green" => Some(&mut self.color[1]),
            "blue" => Some(&mut self.color[2]),
            _ => None,
        }
    }

    /// A float colour channel in 0..1 (clamped; NaN gives 0).
    fn unit_color(&mut self, name: &str, value: f64) -> PropertyAccessResult {
        match self.channel(name) {
            Some(c) => {
                *c = (value.clamp(0.0, 1.0) * 255.0).round() as u8;
                PropertyAccessResult::Set
            }
            None => self.coordinate(name, value),
        }
    }
}

impl PropertyAccess for VertexRecord {
    fn new() -> Self {
        Self::default()
    }
    fn set_char(&mut self, name: &str, value: i8) -> PropertyAccessResult {
        self.coordinate(name, value.into())
    }
    fn set_uchar(&mut self, name: &str, value: u8) -> PropertyAccessResult {
        match self.channel(name) {
            Some(c) => {
                *c = value;
                PropertyAccessResult::Set
            }
            None => self.coordinate(name, value.into()),
        }
    }
    fn set_short(&mut self, name: &str, value: i16) -> PropertyAccessResult {
        self.coordinate(name, value.into())
    }
    fn set_ushort(&mut self, name: &str, value: u16) -> PropertyAccessResult {
        self.coordinate(name, value.into())
    }
    fn set_int(&mut self, name: &str, value: i32) -> PropertyAccessResult {
        self.coordinate(name, value.into())
    }
    fn set_uint(&mut self, name: &str, value: u32) -> PropertyAccessResult {
        self.coordinate(name, value.into())
    }
    fn set_float(&mut self, name: &str, value: f32) -> PropertyAccessResult {
        self.unit_color(name, value.into())
    }
    fn set_double(&mut self, name: &str, value: f64) -> PropertyAccessResult {
        self.unit_color(name, value)
    }
}

/// One face: its vertex count and its first three indices.
#[derive(Default, Debug, PartialEq)]
struct FaceRecord {
    corners: [i64; 3],
    count: usize,
    /// Set from `vertex_indices`, which wins over `vertex_index` if a file has both.
    preferred: bool,
}

impl FaceRecord {
    fn set_list<T: Copy + Into<i64>>(&mut self, name: &str, list: &[T]) -> PropertyAccessResult {
        let preferred = match name {
            "vertex_indices" => true,
            "vertex_index" if !self.preferred => false,
            _ => return PropertyAccessResult::Ignored,
        };
        self.preferred = preferred;
        self.count = list.len();
        for (corner, &v) in self.corners.iter_mut().zip(list) {
            *corner = v.into();
        }
        PropertyAccessResult::Set
    }

    /// The triangle, or why face `face` is not one. Indices past the last vertex are left to
    /// [`TriMesh::validate`].
    fn triangle(&self, file: &str, face: usize) -> Result<[u32; 3], PlyError> {
        if self.count != 3 {
            return Err(PlyError::NotTriangle {
                file: file.to_owned(),
                face,
                count: self.count,
            });
        }
        let mut t = [0u32; 3];
        for (slot, &index) in t.iter_mut().zip(&self.corners) {
            // Every PLY integer type fits in u32 once it is not negative.
            *slot = u32::try_from(index).map_err(|_| PlyError::NegativeIndex {
                file: file.to_owned(),
                face,
                index,
            })?;
        }
        Ok(t)
    }
}

impl PropertyAccess for FaceRecord {
    fn new() -> Self {
        Self::default()
    }
    fn set_list_char(&mut self, name: &str, value: Vec<i8>) -> PropertyAccessResult {
        self.set_list(name, &value)
    }
    fn set_list_uchar(&mut self, name: &str, value: Vec<u8>) -> PropertyAccessResult {
        self.set_list(name, &value)
    }
    fn set_list_short(&mut self, name: &str, value: Vec<i16>) -> PropertyAccessResult {
        self.set_list(name, &value)
    }
    fn set_list_ushort(&mut self, name: &str, value: Vec<u16>) -> PropertyAccessResult {
        self.set_list(name, &value)
    }
    fn set_list_int(&mut self, name: &str, value: Vec<i32>) -> PropertyAccessResult {
        self.set_list(name, &value)
    }
    fn set_list_uint(&mut self, name: &str, value: Vec<u32>) -> PropertyAccessResult {
        self.set_list(name, &value)
    }
}

/// A record of an element the mesh does not use: decoded (to advance the reader) and dropped.
struct SkipRecord;

impl PropertyAccess for SkipRecord {
    fn new() -> Self {
        SkipRecord
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ply_rs_bw::ply::{Addable, PropertyDef};

    fn def(props: &[(&str, PropertyType)]) -> ElementDef {
        let mut d = ElementDef::new("e".into());
        for (name, t) in props {
            d.properties
                .add(PropertyDef::new((*name).into(), t.clone()));
        }
        d
    }

    /// The fast path gives the crate's record whenever the crate reads the line, and leaves every
    /// line the crate refuses to the crate (so its errors stay what they were).
    fn same_as_the_crate<E: PropertyAccess + PartialEq + std::fmt::Debug>(
        d: &ElementDef,
        lines: &[&str],
    ) {
        let parser = Parser::<E>::new();
        for line in lines {
            let fast = ascii_fast::<E>(line, d);
            match parser.read_ascii_element(line, d) {
                Ok(slow) => assert_eq!(fast, Some(slow), "{line:?}"),
                Err(_) => assert_eq!(fast, None, "{line:?}"),
            }
        }
    }

    #[test]
    fn the_fast_ascii_path_reads_exactly_what_the_crate_reads() {
        let f = || PropertyType::Scalar(ScalarType::Float);
        let vertex = def(&[
            ("x", f()),
            ("y", f()),
            ("z", f()),
            ("confidence", f()),
            ("red", PropertyType::Scalar(ScalarType::UChar)),
            ("v", PropertyType::Scalar(ScalarType::Double)),
        ]);
        same_as_the_crate::<VertexRecord>(
            &vertex,
            &[
                "-0.0378297 0.12794 0.00447467 0.850855 200 0.5",
                "  1.5e3\t-2 +3 0 255 1E-7  ",
                "1 2 3 4 5 6 7 8",
                "1 2 3 4 256 6",
                "1 2 3 4 -1 6",
                "1. 2 3 4 5 6",
                ".5 2 3 4 5 6",
                "1 2 3 4 5",
                "1e400 2 3 4 5 6",
                "1 2 3 4 5.0 6",
                "nan 2 3 4 5 6",
                "inf 2 3 4 5 6",
                "0x1 2 3 4 5 6",
                "1,2,3,4,5,6",
                "",
                "   ",
                "1 2 3 4 5 6 x",
                "1 2 3 4 5 6e",
                "\u{661} 2 3 4 5 6",
            ],
        );
        let face = def(&[
            (
                "vertex_indices",
                PropertyType::List(ScalarType::UChar, ScalarType::Int),
            ),
            ("flags", PropertyType::Scalar(ScalarType::UShort)),
        ]);
        same_as_the_crate::<FaceRecord>(
            &face,
            &[
                "3 0 1 2 7",
                "3 21216 21215 20399 0",
                "4 0 1 2 3 9",
                "3 0 1 2",
                "3 0 1",
                "3 -1 2 3 0",
                "3 0 1 2 70000",
                "-3 0 1 2 0",
                "0 5",
                "3 0 1 2.5 0",
                "3 2147483648 1 2 0",
                "300 0 1 2 0",
            ],
        );
    }
}
