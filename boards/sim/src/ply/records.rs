//! The records: what a vertex and a face decode into, and the fast ASCII path that reads a line as
//! the PLY crate reads it, without its grammar.

use ply_rs_bw::ply::{
    BeginList, ElementDef, PropertyAccess, PropertyAccessResult, PropertyType, ScalarType,
};

use super::error::PlyError;

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
pub(super) fn ascii_fast<E: PropertyAccess>(text: &str, def: &ElementDef) -> Option<E> {
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
pub(super) struct VertexRecord {
    pub(super) position: [f64; 3],
    pub(super) color: [u8; 3],
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
pub(super) struct FaceRecord {
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
    pub(super) fn triangle(&self, file: &str, face: usize) -> Result<[u32; 3], PlyError> {
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
pub(super) struct SkipRecord;

impl PropertyAccess for SkipRecord {
    fn new() -> Self {
        SkipRecord
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ply_rs_bw::parser::Parser;
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
