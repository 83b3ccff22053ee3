//! A simple tissue surface: the faces between cells that hold particles and cells that do
//! not, two triangles each, wound so that normals point out of the tissue.

use std::collections::HashSet;

/// Triangles (three vertices each, flattened) of the boundary of the cells of size `cell`
/// (m) that contain at least one of `positions`.
pub fn boundary_faces(positions: &[[f32; 3]], cell: f32) -> Vec<[f32; 3]> {
    let key = |p: &[f32; 3]| {
        [
            (p[0] / cell).floor() as i32,
            (p[1] / cell).floor() as i32,
            (p[2] / cell).floor() as i32,
        ]
    };
    let occupied: HashSet<[i32; 3]> = positions
        .iter()
        .filter(|p| p.iter().all(|v| v.is_finite()))
        .map(key)
        .collect();
    let mut cells: Vec<[i32; 3]> = occupied.iter().copied().collect();
    cells.sort_unstable();
    let mut triangles = Vec::new();
    for c in cells {
        for axis in 0..3 {
            for side in [-1i32, 1] {
                let mut n = c;
                n[axis] += side;
                if occupied.contains(&n) {
                    continue;
                }
                push_face(&mut triangles, c, axis, side, cell);
            }
        }
    }
    triangles
}

fn push_face(out: &mut Vec<[f32; 3]>, c: [i32; 3], axis: usize, side: i32, cell: f32) {
    let u = (axis + 1) % 3;
    let v = (axis + 2) % 3;
    let corner = |du: i32, dv: i32| {
        let mut p = [0.0f32; 3];
        p[axis] = (c[axis] + i32::from(side > 0)) as f32 * cell;
        p[u] = (c[u] + du) as f32 * cell;
        p[v] = (c[v] + dv) as f32 * cell;
        p
    };
    let (a, b, cc, d) = (corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1));
    // (u, v, axis) is right-handed: a→b→c is counter-clockwise seen from +axis.
    if side > 0 {
        out.extend_from_slice(&[a, b, cc, a, cc, d]);
    } else {
        out.extend_from_slice(&[a, cc, b, a, d, cc]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn normal(t: &[[f32; 3]]) -> [f32; 3] {
        let e1 = [t[1][0] - t[0][0], t[1][1] - t[0][1], t[1][2] - t[0][2]];
        let e2 = [t[2][0] - t[0][0], t[2][1] - t[0][1], t[2][2] - t[0][2]];
        [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ]
    }

    #[test]
    fn a_single_cell_is_a_closed_outward_cube() {
        let tris = boundary_faces(&[[0.5, 0.5, 0.5]], 1.0);
        assert_eq!(tris.len(), 6 * 2 * 3);
        for t in tris.chunks(3) {
            let n = normal(t);
            let centre = [
                (t[0][0] + t[1][0] + t[2][0]) / 3.0 - 0.5,
                (t[0][1] + t[1][1] + t[2][1]) / 3.0 - 0.5,
                (t[0][2] + t[1][2] + t[2][2]) / 3.0 - 0.5,
            ];
            let dot = n[0] * centre[0] + n[1] * centre[1] + n[2] * centre[2];
            assert!(dot > 0.0, "inward face {t:?}");
        }
    }

    #[test]
    fn shared_faces_are_dropped() {
        let tris = boundary_faces(&[[0.5, 0.5, 0.5], [1.5, 0.5, 0.5], [1.6, 0.4, 0.5]], 1.0);
        assert_eq!(tris.len(), 10 * 2 * 3);
        assert!(boundary_faces(&[[f32::NAN, 0.0, 0.0]], 1.0).is_empty());
    }
}
