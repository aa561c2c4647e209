//! VTK's interpolation inside one cell: barycentric (linear) in a tetrahedron, and the
//! isoparametric shape functions of `vtkHexahedron`, `vtkWedge` and `vtkPyramid` in
//! their parametric coordinates `(r, s, t)`, found from a world point by Newton's
//! method as VTK's `EvaluatePosition` does.

use crate::vtk::CellType;
use glam::{DMat3, DVec3};

/// Shape functions and their parametric derivatives: `(N, dN/dr, dN/ds, dN/dt)`, the
/// first `ty.points()` entries used.
pub fn shape(ty: CellType, r: f64, s: f64, t: f64) -> [[f64; 8]; 4] {
    let mut n = [[0.0; 8]; 4];
    match ty {
        CellType::Tetra => {
            n[0][..4].copy_from_slice(&[1.0 - r - s - t, r, s, t]);
            n[1][..4].copy_from_slice(&[-1.0, 1.0, 0.0, 0.0]);
            n[2][..4].copy_from_slice(&[-1.0, 0.0, 1.0, 0.0]);
            n[3][..4].copy_from_slice(&[-1.0, 0.0, 0.0, 1.0]);
        }
        CellType::Hexahedron => {
            let (rm, sm, tm) = (1.0 - r, 1.0 - s, 1.0 - t);
            n[0] = [
                rm * sm * tm,
                r * sm * tm,
                r * s * tm,
                rm * s * tm,
                rm * sm * t,
                r * sm * t,
                r * s * t,
                rm * s * t,
            ];
            n[1] = [
                -sm * tm,
                sm * tm,
                s * tm,
                -s * tm,
                -sm * t,
                sm * t,
                s * t,
                -s * t,
            ];
            n[2] = [
                -rm * tm,
                -r * tm,
                r * tm,
                rm * tm,
                -rm * t,
                -r * t,
                r * t,
                rm * t,
            ];
            n[3] = [
                -rm * sm,
                -r * sm,
                -r * s,
                -rm * s,
                rm * sm,
                r * sm,
                r * s,
                rm * s,
            ];
        }
        CellType::Wedge => {
            let (u, tm) = (1.0 - r - s, 1.0 - t);
            n[0][..6].copy_from_slice(&[u * tm, r * tm, s * tm, u * t, r * t, s * t]);
            n[1][..6].copy_from_slice(&[-tm, tm, 0.0, -t, t, 0.0]);
            n[2][..6].copy_from_slice(&[-tm, 0.0, tm, -t, 0.0, t]);
            n[3][..6].copy_from_slice(&[-u, -r, -s, u, r, s]);
        }
        CellType::Pyramid => {
            let (rm, sm, tm) = (1.0 - r, 1.0 - s, 1.0 - t);
            n[0][..5].copy_from_slice(&[rm * sm * tm, r * sm * tm, r * s * tm, rm * s * tm, t]);
            n[1][..5].copy_from_slice(&[-sm * tm, sm * tm, s * tm, -s * tm, 0.0]);
            n[2][..5].copy_from_slice(&[-rm * tm, -r * tm, r * tm, rm * tm, 0.0]);
            n[3][..5].copy_from_slice(&[-rm * sm, -r * sm, -r * s, -rm * s, 1.0]);
        }
    }
    n
}

/// The parametric centre VTK starts Newton from.
pub fn centre(ty: CellType) -> DVec3 {
    match ty {
        CellType::Tetra => DVec3::splat(0.25),
        CellType::Hexahedron => DVec3::splat(0.5),
        CellType::Wedge => DVec3::new(1.0 / 3.0, 1.0 / 3.0, 0.5),
        CellType::Pyramid => DVec3::new(0.5, 0.5, 0.2),
    }
}

/// `x(ξ)` and the Jacobian `∂x/∂ξ` (columns r, s, t) of a cell with corners `xs`.
pub fn map(ty: CellType, xs: &[DVec3], xi: DVec3) -> (DVec3, DMat3) {
    let n = shape(ty, xi.x, xi.y, xi.z);
    let mut x = DVec3::ZERO;
    let mut cols = [DVec3::ZERO; 3];
    for (i, p) in xs.iter().enumerate() {
        x += *p * n[0][i];
        for (c, col) in cols.iter_mut().enumerate() {
            *col += *p * n[c + 1][i];
        }
    }
    (x, DMat3::from_cols(cols[0], cols[1], cols[2]))
}

/// Parametric coordinates of the world point `x` in the cell, by Newton's method from
/// `start` (converged to 1e-14 in ξ, or the last iterate after 40 steps; a singular
/// Jacobian stops it).
pub fn parametric(ty: CellType, xs: &[DVec3], x: DVec3, start: DVec3) -> DVec3 {
    let mut xi = start;
    for _ in 0..40 {
        let (fx, j) = map(ty, xs, xi);
        let det = j.determinant();
        if !(det.abs() > 0.0) || !det.is_finite() {
            break;
        }
        let step = j.inverse() * (x - fx);
        if !step.is_finite() {
            break;
        }
        xi += step;
        if step.abs().max_element() < 1e-14 {
            break;
        }
    }
    xi
}

/// VTK's interpolation of the point values `vals` at parametric `xi`.
pub fn interpolate(ty: CellType, vals: &[f64], xi: DVec3) -> f64 {
    let n = shape(ty, xi.x, xi.y, xi.z);
    vals.iter().zip(n[0].iter()).map(|(v, w)| v * w).sum()
}

/// Barycentric weights of `x` in the tetrahedron `v` (the weights of v1, v2, v3; v0's is
/// one minus their sum), or `None` for a flat tetrahedron.
pub fn barycentric(v: &[DVec3; 4], x: DVec3) -> Option<DVec3> {
    let m = DMat3::from_cols(v[1] - v[0], v[2] - v[0], v[3] - v[0]);
    let det = m.determinant();
    if !(det.abs() > 0.0) {
        return None;
    }
    Some(m.inverse() * (x - v[0]))
}

/// Sign of the Jacobian determinant at the parametric centre: the cell's orientation
/// in VTK's convention for its type (0 for a degenerate cell).
pub fn orientation(ty: CellType, xs: &[DVec3]) -> f64 {
    let (_, j) = map(ty, xs, centre(ty));
    let d = j.determinant();
    if d > 0.0 {
        1.0
    } else if d < 0.0 {
        -1.0
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each shape function is 1 at its own corner and 0 at the others, they sum to 1
    /// everywhere, and the derivatives match finite differences.
    #[test]
    #[allow(clippy::needless_range_loop)]
    fn shape_functions_are_a_partition_of_unity_with_their_derivatives() {
        let corners: Vec<(CellType, Vec<[f64; 3]>)> = vec![
            (
                CellType::Hexahedron,
                vec![
                    [0., 0., 0.],
                    [1., 0., 0.],
                    [1., 1., 0.],
                    [0., 1., 0.],
                    [0., 0., 1.],
                    [1., 0., 1.],
                    [1., 1., 1.],
                    [0., 1., 1.],
                ],
            ),
            (
                CellType::Wedge,
                vec![
                    [0., 0., 0.],
                    [1., 0., 0.],
                    [0., 1., 0.],
                    [0., 0., 1.],
                    [1., 0., 1.],
                    [0., 1., 1.],
                ],
            ),
            (
                CellType::Pyramid,
                vec![
                    [0., 0., 0.],
                    [1., 0., 0.],
                    [1., 1., 0.],
                    [0., 1., 0.],
                    [0., 0., 1.],
                ],
            ),
        ];
        for (ty, cs) in corners {
            for (i, c) in cs.iter().enumerate() {
                let n = shape(ty, c[0], c[1], c[2]);
                for j in 0..ty.points() {
                    let want = if i == j { 1.0 } else { 0.0 };
                    assert!((n[0][j] - want).abs() < 1e-15, "{ty:?} {i} {j}");
                }
            }
            let p = [0.21, 0.33, 0.4];
            let n = shape(ty, p[0], p[1], p[2]);
            assert!((n[0].iter().sum::<f64>() - 1.0).abs() < 1e-15);
            for d in 0..3 {
                let mut q = p;
                q[d] += 1e-6;
                let m = shape(ty, q[0], q[1], q[2]);
                for (j, (a, b)) in m[0].iter().zip(n[0]).enumerate().take(ty.points()) {
                    let fd = (a - b) / 1e-6;
                    assert!((fd - n[d + 1][j]).abs() < 1e-5, "{ty:?} d{d} N{j}");
                }
            }
        }
    }

    /// Newton finds the parametric point of a distorted hexahedron's interior point.
    #[test]
    fn newton_inverts_the_map() {
        let xs: Vec<DVec3> = [
            [0., 0., 0.],
            [1.2, 0.1, 0.],
            [1.1, 1.0, 0.1],
            [0., 0.9, 0.],
            [0.1, 0., 1.],
            [1., 0., 1.2],
            [1.3, 1.1, 1.],
            [0., 1., 0.9],
        ]
        .iter()
        .map(|a| DVec3::from_array(*a))
        .collect();
        let xi = DVec3::new(0.3, 0.7, 0.45);
        let (x, _) = map(CellType::Hexahedron, &xs, xi);
        let got = parametric(CellType::Hexahedron, &xs, x, centre(CellType::Hexahedron));
        assert!((got - xi).length() < 1e-12, "{got}");
    }
}
