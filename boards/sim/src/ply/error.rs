//! Why a PLY file could not be imported ([`PlyError`]): every message names the file, and the
//! element and record when there is one.

use std::io;

use pocketsplat_core::bake::MeshError;

use crate::limits::Exceeded;

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
    /// [`MeshError::IndexOutOfRange`] by [`TriMesh::validate`](pocketsplat_core::bake::TriMesh::validate).)
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
    /// The mesh was read but fails [`TriMesh::validate`](pocketsplat_core::bake::TriMesh::validate): empty, a non-finite vertex, a face index
    /// out of range, or no triangle with any area.
    #[error("{file}: {error}")]
    Mesh {
        /// The file.
        file: String,
        /// What `validate` found; it names the vertex or face.
        error: MeshError,
    },
    /// What a [`super::MeshSink`] refused (a spill file it cannot write), in its words.
    #[error("{file}: {what}")]
    Sink {
        /// The file.
        file: String,
        /// What went wrong.
        what: String,
    },
}
