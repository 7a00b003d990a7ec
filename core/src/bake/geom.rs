//! Exact geometry for the baker, in f64: the triangle–box overlap test and the closest point on a
//! triangle (Duguet §4.1's *IntersectAxisAlignedBox* and *GetSampleAt*).

pub(crate) type V3 = [f64; 3];

pub(crate) fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub(crate) fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
pub(crate) fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
pub(crate) fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub(crate) fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The cross product of a triangle's edges: its normal, twice its area long (what vertex normals
/// sum, area-weighted).
pub fn triangle_normal(c: &[V3; 3]) -> V3 {
    cross(sub(c[1], c[0]), sub(c[2], c[0]))
}

/// Whether triangle `t` intersects the closed axis-aligned box with centre `c` and half-size `h`
/// (separating-axis test of Akenine-Möller 2001: 3 box axes, the triangle's normal, 9 edge crosses).
/// Touching counts as intersecting.
pub(crate) fn tri_box_overlap(t: &[V3; 3], c: V3, h: f64) -> bool {
    let v = [sub(t[0], c), sub(t[1], c), sub(t[2], c)];
    // Box face normals: the triangle's bounds against the box.
    for a in 0..3 {
        let lo = v[0][a].min(v[1][a]).min(v[2][a]);
        let hi = v[0][a].max(v[1][a]).max(v[2][a]);
        if lo > h || hi < -h {
            return false;
        }
    }
    let e = [sub(v[1], v[0]), sub(v[2], v[1]), sub(v[0], v[2])];
    // Edge × box axis: axis = e × unit(a).
    for ei in &e {
        for a in 0..3 {
            let mut axis = [0.0; 3];
            // cross(e, u_a)
            let (b, c2) = ((a + 1) % 3, (a + 2) % 3);
            axis[b] = ei[c2];
            axis[c2] = -ei[b];
            let p = [dot(v[0], axis), dot(v[1], axis), dot(v[2], axis)];
            let r = h * (axis[0].abs() + axis[1].abs() + axis[2].abs());
            let lo = p[0].min(p[1]).min(p[2]);
            let hi = p[0].max(p[1]).max(p[2]);
            if lo > r || hi < -r {
                return false;
            }
        }
    }
    // The triangle's plane.
    let n = cross(e[0], e[1]);
    let d = dot(n, v[0]);
    let r = h * (n[0].abs() + n[1].abs() + n[2].abs());
    d.abs() <= r
}

/// The point of triangle `t` closest to `p`, as barycentric weights `(u, v, w)` of `t[0], t[1], t[2]`
/// (Ericson, *Real-Time Collision Detection* §5.1.5, by Voronoi regions).
pub(crate) fn closest_on_triangle(p: V3, t: &[V3; 3]) -> V3 {
    let [a, b, c] = *t;
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return [1.0 - v, v, 0.0];
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - w, w];
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    [1.0 - v - w, v, w]
}

/// Point from barycentric weights.
pub(crate) fn at_bary(t: &[V3; 3], w: V3) -> V3 {
    add(add(scale(t[0], w[0]), scale(t[1], w[1])), scale(t[2], w[2]))
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: [V3; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

    #[test]
    fn overlap_cases() {
        assert!(tri_box_overlap(&T, [0.2, 0.2, 0.0], 0.1));
        assert!(
            !tri_box_overlap(&T, [0.2, 0.2, 0.5], 0.1),
            "above the plane"
        );
        assert!(tri_box_overlap(&T, [0.2, 0.2, 0.1], 0.1), "touching counts");
        assert!(
            !tri_box_overlap(&T, [0.8, 0.8, 0.0], 0.1),
            "beyond the hypotenuse (edge axis)"
        );
        assert!(
            tri_box_overlap(&T, [0.5, 0.5, 0.0], 0.01),
            "on the hypotenuse"
        );
        assert!(
            tri_box_overlap(&T, [0.3, 0.3, 0.0], 10.0),
            "box contains triangle"
        );
    }

    #[test]
    fn closest_point_regions() {
        let check = |p: V3, want: V3| {
            let got = at_bary(&T, closest_on_triangle(p, &T));
            assert!(
                (0..3).all(|a| (got[a] - want[a]).abs() < 1e-12),
                "{p:?}: {got:?} != {want:?}"
            );
        };
        check([0.2, 0.3, 5.0], [0.2, 0.3, 0.0]);
        check([-1.0, -1.0, 0.0], [0.0, 0.0, 0.0]);
        check([2.0, -1.0, 0.0], [1.0, 0.0, 0.0]);
        check([1.0, 1.0, 0.0], [0.5, 0.5, 0.0]);
        check([0.5, -2.0, 1.0], [0.5, 0.0, 0.0]);
    }

    #[test]
    fn overlap_agrees_with_brute_force_sampling() {
        // A fine sample of the triangle: any sample inside the box implies overlap.
        let t = [[0.13, 0.71, 0.2], [0.9, 0.05, 0.6], [0.4, 0.95, 0.93]];
        let mut seen_both = [false; 2];
        for cx in 0..10 {
            for cy in 0..10 {
                for cz in 0..10 {
                    let c = [
                        cx as f64 * 0.1 + 0.05,
                        cy as f64 * 0.1 + 0.05,
                        cz as f64 * 0.1 + 0.05,
                    ];
                    let mut hit = false;
                    for i in 0..=200 {
                        for j in 0..=200 - i {
                            let (u, v) = (i as f64 / 200.0, j as f64 / 200.0);
                            let p = at_bary(&t, [1.0 - u - v, u, v]);
                            hit |= (0..3).all(|a| (p[a] - c[a]).abs() <= 0.05);
                        }
                    }
                    let exact = tri_box_overlap(&t, c, 0.05);
                    if hit {
                        assert!(exact, "sampled point inside box {c:?}, test says no");
                    }
                    seen_both[exact as usize] = true;
                }
            }
        }
        assert_eq!(seen_both, [true, true]);
    }
}
