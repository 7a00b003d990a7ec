//! Normal cones (QSplat §2.1: "a normal cone … to cull backfacing subtrees"): for every interior
//! cell, the class of the widest angle between its normal and the normal of any sample below it.
//!
//! The angle is measured between the *decoded* normal codes ([`NORMALS_Q14`]), the normals the
//! traversal tests, over the whole subtree (every level below, since the level of detail may stop
//! at any of them), so a cone that says "all of the subtree faces away" is true of every splat it
//! could draw. Each level's subtree is a contiguous index range at every deeper level (FORMAT.md:
//! breadth-first), so the ranges follow from the counts of children alone.

use std::vec::Vec;

use rayon::prelude::*;

use super::BakedGrid;
use crate::normal::NORMALS_Q14;
use crate::tg::frame::CONE_ANGLES_DEG;

/// The unit normal of a code, f64.
fn unit(code: u16) -> [f64; 3] {
    let n = NORMALS_Q14[usize::from(code) & (crate::normal::NORMAL_COUNT - 1)].map(f64::from);
    let l = libm::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    n.map(|c| c / l)
}

/// The class (1..=7, [`CONE_ANGLES_DEG`]) of a cone whose narrowest cosine is `min_cos`.
fn class(min_cos: f64) -> u8 {
    (1..7)
        .find(|&k| min_cos >= libm::cos(CONE_ANGLES_DEG[k].to_radians()))
        .unwrap_or(7) as u8
}

/// Cone classes per interior level (`0..depth`), one per cell in file order.
pub fn cone_classes(grid: &BakedGrid) -> Vec<Vec<u8>> {
    let depth = grid.levels.len() - 1;
    let normals: Vec<Vec<[f64; 3]>> = grid
        .levels
        .iter()
        .map(|l| l.attrs.par_iter().map(|&a| unit(a)).collect())
        .collect();
    // first[L][i]: index at level L + 1 of cell i's first child; first[L][count] = count at L + 1.
    let first: Vec<Vec<u32>> = grid.levels[..depth]
        .iter()
        .map(|l| {
            let mut f = Vec::with_capacity(l.masks.len() + 1);
            let mut at = 0u32;
            for m in &l.masks {
                f.push(at);
                at += m.count_ones();
            }
            f.push(at);
            f
        })
        .collect();
    (0..depth)
        .map(|level| {
            (0..grid.levels[level].attrs.len())
                .into_par_iter()
                .map(|i| {
                    let a = normals[level][i];
                    let mut min_cos = 1.0f64;
                    let (mut lo, mut hi) = (i as u32, i as u32 + 1);
                    for below in level + 1..=depth {
                        (lo, hi) = (first[below - 1][lo as usize], first[below - 1][hi as usize]);
                        for n in &normals[below][lo as usize..hi as usize] {
                            min_cos = min_cos.min(a[0] * n[0] + a[1] * n[1] + a[2] * n[2]);
                        }
                    }
                    class(min_cos)
                })
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classes_bound_the_angle() {
        assert_eq!(class(1.0), 1);
        for k in 1..7 {
            let c = libm::cos(CONE_ANGLES_DEG[k].to_radians());
            assert_eq!(class(c), k as u8);
            assert_eq!(class(c - 1e-9), k as u8 + 1);
        }
        assert_eq!(class(-1.0), 7);
    }
}
