//! The part of Wavefront OBJ a blade mesh needs: `v` vertices, `f` faces (polygons
//! fan-triangulated; `v`, `v/vt`, `v//vn` and `v/vt/vn` index forms, negative indices counting
//! back from the last vertex read) and `l` polylines. Every other statement (`vt`, `vn`, `o`,
//! `g`, `s`, `usemtl`, `mtllib`, comments) is skipped: a blade has no texture or material.

use crate::math::Vec3;

/// What an OBJ file holds, with the line each face and polyline came from (for messages).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Obj {
    pub vertices: Vec<Vec3>,
    /// Triangles as vertex indices, and the 1-based line of the face each came from.
    pub triangles: Vec<([u32; 3], usize)>,
    /// Polylines as vertex indices, and their 1-based line.
    pub polylines: Vec<(Vec<u32>, usize)>,
}

/// A line that is not valid OBJ (1-based line number).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("line {line}: {message}")]
pub struct ObjError {
    pub line: usize,
    pub message: String,
}

/// Parses OBJ text.
pub fn parse(text: &str) -> Result<Obj, ObjError> {
    let mut obj = Obj::default();
    for (index, raw) in text.lines().enumerate() {
        let line = index + 1;
        let error = |message: String| ObjError { line, message };
        let content = raw.split('#').next().unwrap_or("");
        let mut words = content.split_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        match keyword {
            "v" => {
                let coords: Vec<f32> = words
                    .by_ref()
                    .take(3)
                    .map(|w| {
                        w.parse::<f32>()
                            .map_err(|_| error(format!("vertex coordinate {w:?} is not a number")))
                    })
                    .collect::<Result<_, _>>()?;
                if coords.len() != 3 || coords.iter().any(|c| !c.is_finite()) {
                    return Err(error(
                        "a vertex needs three finite coordinates (x y z, m)".into(),
                    ));
                }
                obj.vertices
                    .push(Vec3::new(coords[0], coords[1], coords[2]));
            }
            "f" => {
                let corners = words
                    .map(|w| vertex_index(w, obj.vertices.len()).map_err(&error))
                    .collect::<Result<Vec<_>, _>>()?;
                if corners.len() < 3 {
                    return Err(error(format!(
                        "a face needs at least 3 vertices, this one has {}",
                        corners.len()
                    )));
                }
                for k in 1..corners.len() - 1 {
                    obj.triangles
                        .push(([corners[0], corners[k], corners[k + 1]], line));
                }
            }
            "l" => {
                let points = words
                    .map(|w| vertex_index(w, obj.vertices.len()).map_err(&error))
                    .collect::<Result<Vec<_>, _>>()?;
                if points.len() < 2 {
                    return Err(error("a polyline needs at least 2 vertices".into()));
                }
                obj.polylines.push((points, line));
            }
            "vt" | "vn" | "vp" | "o" | "g" | "s" | "usemtl" | "mtllib" => {}
            other => return Err(error(format!("unknown statement {other:?}"))),
        }
    }
    Ok(obj)
}

/// The 0-based vertex index of one `f` or `l` corner (`v`, `v/vt`, `v//vn`, `v/vt/vn`),
/// given the vertices read so far.
fn vertex_index(word: &str, vertices_so_far: usize) -> Result<u32, String> {
    let first = word.split('/').next().unwrap_or("");
    let index: i64 = first
        .parse()
        .map_err(|_| format!("vertex reference {word:?} is not an index"))?;
    let resolved = match index {
        i if i > 0 => i - 1,
        i if i < 0 => vertices_so_far as i64 + i,
        _ => return Err("vertex index 0 (OBJ counts from 1)".into()),
    };
    if (0..vertices_so_far as i64).contains(&resolved) {
        Ok(resolved as u32)
    } else {
        Err(format!(
            "vertex reference {word:?} is outside the {vertices_so_far} vertices defined so far"
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn faces_are_fan_triangulated_in_every_index_form() {
        let text = "# a quad and a polyline\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\n\
                    vn 0 1 0\nf 1/1/1 2//1 3/2 -1\nl 1 2\n";
        let obj = parse(text).unwrap();
        assert_eq!(obj.vertices.len(), 4);
        assert_eq!(obj.triangles, vec![([0, 1, 2], 7), ([0, 2, 3], 7)]);
        assert_eq!(obj.polylines, vec![(vec![0, 1], 8)]);
    }

    #[test]
    fn errors_name_the_line() {
        let cases = [
            ("v 0 0\n", 1),
            ("v 0 0 0\nv 1 0 0\nf 1 2\n", 3),
            ("v 0 0 0\n\nf 1 2 4\n", 3),
            ("v 0 0 0\nf 0 1 1\n", 2),
            ("v 0 0 x\n", 1),
            ("v 0 0 0\nl 1\n", 2),
            ("v 0 0 0\ncurv 1 2\n", 2),
        ];
        for (text, line) in cases {
            let err = parse(text).unwrap_err();
            assert_eq!(err.line, line, "{text:?}: {err}");
        }
    }
}
