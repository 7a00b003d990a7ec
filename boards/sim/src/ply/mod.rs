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
//! The modules, in the order the bytes meet them: `reader` (read-ahead, the byte cap, the magic),
//! `header` (the header, the layout the mesh needs, the declared counts against the limits), `body`
//! (one record at a time), `records` (what a vertex and a face decode into, the fast ASCII path),
//! `error` ([`PlyError`]); this module puts them together ([`load_mesh`]).
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

mod body;
mod error;
mod header;
mod reader;
mod records;

use std::fs::File;
use std::io::{self, BufRead, BufReader, Read};
use std::path::Path;

use flate2::read::MultiGzDecoder;
use pocketsplat_core::bake::{Orientation, TriMesh};

use crate::limits::{self, Limits};
use body::Body;
use header::{check_counts, check_face, read_header, VertexLayout};
use reader::{capped, read_ahead, read_prefix, Capped};
use records::{FaceRecord, VertexRecord};

pub use body::MAX_LINE_BYTES;
pub use error::PlyError;
pub use header::MAX_HEADER_BYTES;

/// Most records reserved up front from a header count (the count is not trusted until read).
const MAX_RESERVE: usize = 1 << 20;

/// First two bytes of every gzip member (RFC 1952 §2.3.1).
const GZIP_MAGIC: [u8; 2] = [0x1f, 0x8b];

/// Read buffer size.
const BUFFER_BYTES: usize = 1 << 16;

/// Reads a PLY mesh from a file; gzip-compressed files are recognised by their magic bytes.
///
/// Vertices need `x`, `y`, `z` (any numeric type); `red`, `green`, `blue` (`uchar`, or `float` /
/// `double` in 0..1) become per-vertex colours. Faces need a `vertex_indices` (or `vertex_index`)
/// list of integers with exactly three entries. Other elements and properties are skipped. Zero-area
/// faces and duplicate or unreferenced vertices are kept as they are. The triangles are then wound
/// outward ([`TriMesh::orient`]): a mesh written inward, or with triangles wound both ways, loads
/// as the same mesh written outward, so its bake and its reference agree on which side is lit.
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
    load_mesh_oriented(path, limits).map(|(mesh, _)| mesh)
}

/// [`load_mesh_with`], with what orienting the mesh did (a bake says how many triangles turned).
///
/// # Errors
/// As [`load_mesh_with`].
pub fn load_mesh_oriented(
    path: &Path,
    limits: &Limits,
) -> Result<(TriMesh, Orientation), PlyError> {
    let (file, reader, len) = open(path)?;
    load(&file, reader, limits, Some(len))
}

/// Opens a mesh file if it is a regular file: its name for errors, the file, its length.
fn open(path: &Path) -> Result<(String, File, u64), PlyError> {
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
    Ok((file, reader, len))
}

/// Reads a PLY mesh from any reader, compressed or not, within the limits in force; `name` stands
/// for the file in errors.
///
/// # Errors
/// As [`load_mesh_with`].
pub fn load_mesh_from_reader(name: &str, reader: impl Read + Send) -> Result<TriMesh, PlyError> {
    load(name, reader, &limits::current(), None).map(|(mesh, _)| mesh)
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
    load(name, reader, limits, None).map(|(mesh, _)| mesh)
}

/// `len`: the reader's length in bytes when known (a regular file).
fn load(
    name: &str,
    reader: impl Read + Send,
    limits: &Limits,
    len: Option<u64>,
) -> Result<(TriMesh, Orientation), PlyError> {
    let mut sink = MeshBuilder::default();
    read_into(name, reader, limits, len, &mut sink)?;
    let mut mesh = sink.mesh;
    mesh.colors = sink.colors;
    mesh.validate().map_err(|error| PlyError::Mesh {
        file: name.to_owned(),
        error,
    })?;
    // Wound outward whatever way the file winds it: what the bake, the device and the f64
    // reference then all see (core `bake::orient`).
    let orientation = mesh.orient();
    Ok((mesh, orientation))
}

/// What a PLY file's records are handed to, one at a time, in the order of the file: the
/// in-memory [`TriMesh`] ([`load_mesh`]) or an out-of-core bake's scan, which keeps the vertices
/// and spills the faces. Nothing is validated for the sink beyond the record's own syntax (a
/// face is a triangle with indices that are not negative): indices past the last vertex, and the
/// checks of [`TriMesh::validate`], are the sink's.
pub trait MeshSink: Send {
    /// The vertex element starts: `count` records as the header declares them, `color` when
    /// they have `red`, `green` and `blue`, `exact_f32` when every coordinate is of a type that
    /// an `f32` holds exactly (`float`, or an integer of at most 16 bits).
    ///
    /// # Errors
    /// Whatever the sink refuses (a count over its budget), naming the file.
    fn begin_vertices(
        &mut self,
        count: usize,
        color: bool,
        exact_f32: bool,
    ) -> Result<(), PlyError>;
    /// One vertex: its position and (black without colours) its colour.
    ///
    /// # Errors
    /// Whatever the sink refuses, naming the file.
    fn vertex(&mut self, position: [f64; 3], color: [u8; 3]) -> Result<(), PlyError>;
    /// The face element starts with `count` records.
    ///
    /// # Errors
    /// Whatever the sink refuses, naming the file.
    fn begin_faces(&mut self, count: usize) -> Result<(), PlyError>;
    /// Face `index`: a triangle's vertex indices, not checked against the vertex count.
    ///
    /// # Errors
    /// Whatever the sink refuses (a spill file that cannot be written), naming the file.
    fn face(&mut self, index: usize, triangle: [u32; 3]) -> Result<(), PlyError>;
}

/// The sink of [`load_mesh`]: every record into a [`TriMesh`].
#[derive(Default)]
struct MeshBuilder {
    mesh: TriMesh,
    colors: Option<Vec<[u8; 3]>>,
}

impl MeshSink for MeshBuilder {
    fn begin_vertices(&mut self, count: usize, color: bool, _: bool) -> Result<(), PlyError> {
        self.mesh.positions.reserve(count.min(MAX_RESERVE));
        if color {
            self.colors = Some(Vec::with_capacity(count.min(MAX_RESERVE)));
        }
        Ok(())
    }
    fn vertex(&mut self, position: [f64; 3], color: [u8; 3]) -> Result<(), PlyError> {
        self.mesh.positions.push(position);
        if let Some(c) = &mut self.colors {
            c.push(color);
        }
        Ok(())
    }
    fn begin_faces(&mut self, count: usize) -> Result<(), PlyError> {
        self.mesh.triangles.reserve(count.min(MAX_RESERVE));
        Ok(())
    }
    fn face(&mut self, _: usize, triangle: [u32; 3]) -> Result<(), PlyError> {
        self.mesh.triangles.push(triangle);
        Ok(())
    }
}

/// Reads a PLY file into `sink`, record by record, within `limits` (see [`load_mesh_with`]; the
/// file is opened as it opens it, and gzip is recognised by its magic).
///
/// # Errors
/// As [`load_mesh_with`], but for what [`TriMesh::validate`] checks, which is the sink's.
pub fn read_file_into(
    path: &Path,
    limits: &Limits,
    sink: &mut impl MeshSink,
) -> Result<(), PlyError> {
    let (name, reader, len) = open(path)?;
    read_into(&name, reader, limits, Some(len), sink)
}

/// [`read_file_into`] with the bytes of the file counted into `read` as they are read (before
/// decompression), for a progress bar.
///
/// # Errors
/// As [`read_file_into`].
pub fn read_file_counted(
    path: &Path,
    limits: &Limits,
    sink: &mut impl MeshSink,
    read: &(dyn Fn(u64) + Sync),
) -> Result<(), PlyError> {
    let (name, reader, len) = open(path)?;
    let counted = Counted {
        inner: reader,
        read,
    };
    read_into(&name, counted, limits, Some(len), sink)
}

/// A reader that reports the bytes it passes on.
struct Counted<'a, R> {
    inner: R,
    read: &'a (dyn Fn(u64) + Sync),
}

impl<R: Read> Read for Counted<'_, R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        (self.read)(n as u64);
        Ok(n)
    }
}

/// Any reader into `sink`, compressed or not; `len`: the reader's length in bytes when known.
fn read_into(
    name: &str,
    mut reader: impl Read + Send,
    limits: &Limits,
    len: Option<u64>,
    sink: &mut impl MeshSink,
) -> Result<(), PlyError> {
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
            read_ply(name, &mut reader, limits, None, sink)?;
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
            Ok(())
        })
    } else {
        if let Some(len) = len {
            check_size(name, limits, len)?;
        }
        let mut reader = BufReader::with_capacity(BUFFER_BYTES, Capped::new(stream, limits.ply));
        read_ply(name, &mut reader, limits, len, sink)
    }
}

/// A file of `len` bytes against the `ply` limit.
fn check_size(name: &str, limits: &Limits, len: u64) -> Result<(), PlyError> {
    limits
        .check("ply", "size in bytes", len)
        .map_err(|error| PlyError::Limit {
            file: name.to_owned(),
            error,
        })
}

fn read_ply(
    file: &str,
    reader: &mut impl BufRead,
    limits: &Limits,
    len: Option<u64>,
    sink: &mut impl MeshSink,
) -> Result<(), PlyError> {
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
                sink.begin_vertices(def.count, layout.has_color, layout.exact_f32)?;
                body.read_records(def, layout.coord_columns, None, |_, v: VertexRecord| {
                    sink.vertex(v.position, v.color)
                })?;
            }
            ("face", _) => {
                sink.begin_faces(def.count)?;
                body.read_records(def, None, face_list.as_deref(), |face, f: FaceRecord| {
                    sink.face(face, f.triangle(file, face)?)
                })?;
            }
            _ => body.skip_records(def)?,
        }
    }
    Ok(())
}

/// What a PLY header declares, read without the body ([`read_counts`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DeclaredCounts {
    /// Vertices declared (0 without a vertex element).
    pub vertices: u64,
    /// Faces declared (0 without a face element).
    pub faces: u64,
    /// The vertices have colours.
    pub color: bool,
    /// Every coordinate fits an `f32` exactly ([`MeshSink::begin_vertices`]).
    pub exact_f32: bool,
}

/// Reads the header of a PLY file (gzipped or not) and returns what it declares, checked against
/// `limits` as [`load_mesh_with`] checks it, so that a bake can choose its path before it reads the
/// body.
///
/// # Errors
/// As [`load_mesh_with`] for the file and its header.
pub fn read_counts(path: &Path, limits: &Limits) -> Result<DeclaredCounts, PlyError> {
    let (name, mut reader, len) = open(path)?;
    let mut magic = [0u8; 2];
    let n = read_prefix(&mut reader, &mut magic).map_err(|error| PlyError::Io {
        file: name.clone(),
        error,
    })?;
    let prefix = magic.get(..n).unwrap_or_default();
    let stream = prefix.chain(reader);
    let (header, len, header_bytes) = if prefix == GZIP_MAGIC {
        let (h, _, bytes) = read_header(&name, &mut BufReader::new(MultiGzDecoder::new(stream)))?;
        (h, None, bytes)
    } else {
        check_size(&name, limits, len)?;
        let (h, _, bytes) = read_header(&name, &mut BufReader::new(stream))?;
        (h, Some(len), bytes)
    };
    if let Some(def) = header.elements.get("face") {
        check_face(&name, def)?;
    }
    check_counts(&name, &header, limits, len, header_bytes)?;
    let vertex = header
        .elements
        .get("vertex")
        .map(|def| VertexLayout::new(&name, def))
        .transpose()?;
    let count = |e: &str| header.elements.get(e).map_or(0, |d| d.count as u64);
    Ok(DeclaredCounts {
        vertices: count("vertex"),
        faces: count("face"),
        color: vertex.as_ref().is_some_and(|v| v.has_color),
        exact_f32: vertex.as_ref().is_none_or(|v| v.exact_f32),
    })
}
