//! The body: one record at a time, decoded here in binary (lists refused or skipped by their byte
//! size) and through the fast path or the crate's parser in ASCII, so that every error knows its
//! record.

use std::io::{self, BufRead, Read};

use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{ElementDef, Encoding, PropertyAccess, PropertyType, ScalarType};
use pocketsplat_core::bake::MeshError;

use super::error::PlyError;
use super::header::{flatten, scalar_bytes};
use super::reader::capped;
use super::records::ascii_fast;

/// Longest line accepted in an ASCII body, in bytes.
pub const MAX_LINE_BYTES: u64 = 1 << 20;

/// The body reader: one record at a time, so that errors know the record.
pub(super) struct Body<'a, B> {
    pub(super) file: &'a str,
    pub(super) reader: B,
    pub(super) encoding: Encoding,
    /// The current ASCII line (reused).
    pub(super) line: Vec<u8>,
    /// Number of lines read so far (header included), for ASCII error messages.
    pub(super) line_no: usize,
}

impl<B: BufRead> Body<'_, B> {
    /// Reads every record of `def` and hands it to `each` with its index. `face_list` names the
    /// list a face is read from: a binary record whose list there has other than 3 entries is
    /// [`PlyError::NotTriangle`] before any entry is read.
    pub(super) fn read_records<E: PropertyAccess>(
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
    pub(super) fn skip_records(&mut self, def: &ElementDef) -> Result<(), PlyError> {
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
