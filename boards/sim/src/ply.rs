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
    ElementDef, Encoding, Header, PropertyAccess, PropertyAccessResult, PropertyType, ScalarType,
};
use pocketsplat_core::bake::{MeshError, TriMesh};

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
    let file = path.display().to_string();
    let reader = File::open(path).map_err(|error| PlyError::Io {
        file: file.clone(),
        error,
    })?;
    load_mesh_from_reader(&file, reader)
}

/// Reads a PLY mesh from any reader, compressed or not; `name` stands for the file in errors.
///
/// # Errors
/// As [`load_mesh`].
pub fn load_mesh_from_reader(name: &str, mut reader: impl Read) -> Result<TriMesh, PlyError> {
    let mut magic = [0u8; 2];
    let n = read_prefix(&mut reader, &mut magic).map_err(|error| PlyError::Io {
        file: name.to_owned(),
        error,
    })?;
    let prefix = magic.get(..n).unwrap_or_default();
    let stream = prefix.chain(reader);
    if prefix == GZIP_MAGIC {
        // Multi-member, as `gzip` itself reads concatenated files.
        read_ply(
            name,
            BufReader::with_capacity(BUFFER_BYTES, MultiGzDecoder::new(stream)),
        )
    } else {
        read_ply(name, BufReader::with_capacity(BUFFER_BYTES, stream))
    }
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

fn read_ply(file: &str, mut reader: impl BufRead) -> Result<TriMesh, PlyError> {
    let (header, header_lines) = read_header(file, &mut reader)?;
    let vertex = header
        .elements
        .get("vertex")
        .map(|def| VertexLayout::new(file, def))
        .transpose()?;
    if let Some(def) = header.elements.get("face") {
        check_face(file, def)?;
    }

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
                body.read_records(def, layout.coord_columns, |_, v: VertexRecord| {
                    mesh.positions.push(v.position);
                    if layout.has_color {
                        colors.push(v.color);
                    }
                    Ok(())
                })?;
            }
            ("face", _) => {
                mesh.triangles.reserve(def.count.min(MAX_RESERVE));
                body.read_records(def, None, |face, f: FaceRecord| {
                    mesh.triangles.push(f.triangle(file, face)?);
                    Ok(())
                })?;
            }
            _ => body.read_records(def, None, |_, _: SkipRecord| Ok(()))?,
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

// ---------------------------------------------------------------------------------------------
// Header

/// Reads the header (through `end_header`) with a length limit, checks for repeated names, and parses
/// it with `ply-rs-bw`. Returns the header and its number of lines.
fn read_header(file: &str, reader: &mut impl BufRead) -> Result<(Header, usize), PlyError> {
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
    Ok((header, lines))
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

fn check_face(file: &str, def: &ElementDef) -> Result<(), PlyError> {
    let Some(p) = FACE_LISTS.iter().find_map(|name| def.properties.get(*name)) else {
        return Err(PlyError::MissingProperty {
            file: file.to_owned(),
            element: def.name.clone(),
            property: FACE_LISTS[0].to_owned(),
        });
    };
    match &p.data_type {
        PropertyType::List(count, item) if is_integer(count) && is_integer(item) => Ok(()),
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
    /// Reads every record of `def` and hands it to `each` with its index.
    fn read_records<E: PropertyAccess>(
        &mut self,
        def: &ElementDef,
        coord_columns: Option<[usize; 3]>,
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
                Encoding::BinaryLittleEndian => parser
                    .read_little_endian_element(&mut self.reader, def)
                    .map_err(|e| self.binary_error(def, index, &e))?,
                Encoding::BinaryBigEndian => parser
                    .read_big_endian_element(&mut self.reader, def)
                    .map_err(|e| self.binary_error(def, index, &e))?,
            };
            each(index, record)?;
        }
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

    fn binary_error(&self, def: &ElementDef, index: usize, e: &ParseError) -> PlyError {
        if e.kind() == io::ErrorKind::UnexpectedEof {
            self.truncated(def, index)
        } else {
            self.body_error(def, index, flatten(e))
        }
    }

    fn io_error(&self, def: &ElementDef, index: usize, e: &io::Error) -> PlyError {
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

/// One vertex: position and (if the file has one) colour.
#[derive(Default)]
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
#[derive(Default)]
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
