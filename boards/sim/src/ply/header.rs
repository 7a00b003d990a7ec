//! The header: read with a length limit, repeated names refused, parsed by `ply-rs-bw`; the vertex
//! layout and the face list the mesh needs; the declared counts checked against the limits and
//! the bytes that can follow.

use std::io::{BufRead, Read};

use ply_rs_bw::parser::{ParseError, Parser, Reader};
use ply_rs_bw::ply::{ElementDef, Encoding, Header, PropertyType, ScalarType};

use super::error::PlyError;
use super::records::SkipRecord;
use crate::limits::Limits;

/// Longest header accepted, in bytes (comments included).
pub const MAX_HEADER_BYTES: u64 = 1 << 20;

/// Checks the header's counts before the body is read: `vertices` and `triangles` against their
/// limits, and every element's records at their smallest against the bytes that can follow the
/// header: what is left of a file of `len` bytes, else the `ply` limit.
pub(super) fn check_counts(
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
pub(super) fn scalar_bytes(t: &ScalarType) -> u64 {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// Reads the header (through `end_header`) with a length limit, checks for repeated names, and parses
/// it with `ply-rs-bw`. Returns the header, its number of lines and its bytes.
pub(super) fn read_header(
    file: &str,
    reader: &mut impl BufRead,
) -> Result<(Header, usize, u64), PlyError> {
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
pub(super) fn flatten(e: &ParseError) -> String {
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
pub(super) struct VertexLayout {
    /// `red`, `green` and `blue` are all present.
    pub(super) has_color: bool,
    /// ASCII columns of x, y, z, when no list precedes them (to recognise `nan` and `inf`).
    pub(super) coord_columns: Option<[usize; 3]>,
    /// Every coordinate's type is one an `f32` holds exactly (`float`, or an integer of at most
    /// 16 bits), so that an out-of-core bake keeps positions in half the memory.
    pub(super) exact_f32: bool,
}

impl VertexLayout {
    pub(super) fn new(file: &str, def: &ElementDef) -> Result<Self, PlyError> {
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
        let mut exact_f32 = true;
        for (axis, name) in ["x", "y", "z"].into_iter().enumerate() {
            let p = def.properties.get(name).ok_or_else(|| missing(name))?;
            match &p.data_type {
                PropertyType::List(..) => return Err(mistyped(name, &p.data_type, "a number")),
                PropertyType::Scalar(t) => {
                    exact_f32 &= matches!(
                        t,
                        ScalarType::Float
                            | ScalarType::Char
                            | ScalarType::UChar
                            | ScalarType::Short
                            | ScalarType::UShort
                    );
                }
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
            exact_f32,
        })
    }
}

/// The face list property, in order of preference.
const FACE_LISTS: [&str; 2] = ["vertex_indices", "vertex_index"];

/// Checks the face element and returns the name of the list it is read from.
pub(super) fn check_face(file: &str, def: &ElementDef) -> Result<String, PlyError> {
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
