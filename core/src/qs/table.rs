//! The position/radius table: 13 bits name a child sphere relative to its parent (QSplat §3.1).
//!
//! For size `s = 1..=13` (outermost), then `x`, `y`, `z` each `0..=13 − s`, the candidate is the cube
//! of `s` cells at cell `(x, y, z)` of the parent's 13-cell grid: centre `(s + 2x)/13 − 1` (likewise y,
//! z) and radius `s/13`, in parent radii. It is kept unless `X² + Y² + Z² > (1 + √3·R)²`. With
//! `A = s + 2x − 13` (likewise `B`, `C`) and `L = A² + B² + C² − 169 − 3s²`, that test is
//! `L > 0 ∧ L² > 2028·s²`: exact in integers, so the table is built at compile time and has no float
//! rounding to disagree about. 7621 entries survive.
#![deny(clippy::float_arithmetic)]

/// Number of entries (13-bit indices `0..7621`).
pub const SPHERE_COUNT: usize = 7621;

/// Cells across the parent's diameter.
pub const GRID: i32 = 13;

/// The table, packed `s << 12 | x << 8 | y << 4 | z`.
pub static SPHERES: [u16; SPHERE_COUNT] = build();

const fn build() -> [u16; SPHERE_COUNT] {
    let mut t = [0u16; SPHERE_COUNT];
    let mut n = 0;
    let mut s = 1;
    while s <= 13 {
        let mut x = 0;
        while x <= 13 - s {
            let mut y = 0;
            while y <= 13 - s {
                let mut z = 0;
                while z <= 13 - s {
                    let (a, b, c) = (s + 2 * x - 13, s + 2 * y - 13, s + 2 * z - 13);
                    let l = a * a + b * b + c * c - 169 - 3 * s * s;
                    if !(l > 0 && l * l > 2028 * s * s) {
                        assert!(n < SPHERE_COUNT, "too many table entries");
                        t[n] = (s << 12 | x << 8 | y << 4 | z) as u16;
                        n += 1;
                    }
                    z += 1;
                }
                y += 1;
            }
            x += 1;
        }
        s += 1;
    }
    assert!(n == SPHERE_COUNT, "the table must have 7621 entries");
    t
}

/// One decoded entry: the child's centre is the parent's plus `(a, b, c)/13` parent radii, its radius
/// `s/13` parent radii.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SphereOffset {
    /// Centre offset along x, thirteenths of the parent radius (`−12..=12`).
    pub a: i8,
    /// Along y.
    pub b: i8,
    /// Along z.
    pub c: i8,
    /// Radius, thirteenths of the parent radius (`1..=13`).
    pub s: u8,
}

impl SphereOffset {
    /// The entry's grid cell `(s, x, y, z)`.
    pub const fn cell(self) -> (u8, u8, u8, u8) {
        let s = self.s as i32;
        (
            self.s,
            ((self.a as i32 + 13 - s) / 2) as u8,
            ((self.b as i32 + 13 - s) / 2) as u8,
            ((self.c as i32 + 13 - s) / 2) as u8,
        )
    }
}

/// Unpacks a packed entry.
#[inline(always)]
pub const fn unpack(packed: u16) -> SphereOffset {
    let s = (packed >> 12) as i32;
    let x = (packed >> 8 & 15) as i32;
    let y = (packed >> 4 & 15) as i32;
    let z = (packed & 15) as i32;
    SphereOffset {
        a: (s + 2 * x - 13) as i8,
        b: (s + 2 * y - 13) as i8,
        c: (s + 2 * z - 13) as i8,
        s: s as u8,
    }
}

/// The entry at `index`, or `None` past the table's end.
#[inline]
pub fn sphere(index: u16) -> Option<SphereOffset> {
    SPHERES.get(usize::from(index)).map(|&p| unpack(p))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    #[allow(clippy::float_arithmetic)]
    fn table_has_7621_entries_by_the_float_rule_in_order() {
        // The rule as written, in f64, against the integer table: same entries, same order.
        let mut n = 0;
        for s in 1..=13i32 {
            for x in 0..=13 - s {
                for y in 0..=13 - s {
                    for z in 0..=13 - s {
                        let f = |i: i32| f64::from(s + 2 * i) / 13.0 - 1.0;
                        let (xx, yy, zz, r) = (f(x), f(y), f(z), f64::from(s) / 13.0);
                        let bound = (1.0 + 3f64.sqrt() * r) * (1.0 + 3f64.sqrt() * r);
                        let keep = xx * xx + yy * yy + zz * zz <= bound;
                        if keep {
                            let e = sphere(n as u16).expect("entry");
                            assert_eq!(e.cell(), (s as u8, x as u8, y as u8, z as u8), "entry {n}");
                            n += 1;
                        }
                    }
                }
            }
        }
        assert_eq!(n, SPHERE_COUNT);
        assert_eq!(n, 7621);
        assert!(sphere(7621).is_none() && sphere(8191).is_none());
        // First and last: the smallest corner cube, and the parent itself.
        assert_eq!(sphere(0).map(|e| e.s), Some(1));
        assert_eq!(
            sphere(7620),
            Some(SphereOffset {
                a: 0,
                b: 0,
                c: 0,
                s: 13
            })
        );
    }

    #[test]
    fn every_size_has_entries_and_offsets_stay_on_the_grid() {
        let mut per_size = [0u32; 14];
        for i in 0..SPHERE_COUNT as u16 {
            let e = sphere(i).unwrap();
            per_size[usize::from(e.s)] += 1;
            assert!((-12..=12).contains(&e.a) && (e.a as i32 + e.s as i32 - 13) % 2 == 0);
        }
        assert!(per_size[1..].iter().all(|&n| n > 0));
        assert_eq!(per_size[13], 1);
    }
}
