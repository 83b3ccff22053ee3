//! The blades of a scene's mesh slicers on the device (see [`crate::tools::mesh_slicer`]):
//! each blade is rigid in its tool frame, so it is uploaded once per world into one storage
//! buffer (`blades`, an array of vec4), and a tool finds its blade by the record's first
//! index (`GpuTool::kind.z`). `crack.wgsl` reads the triangles and cutting edge to mark
//! cracks, `common.wgsl` the spine for the tool's contact.
//!
//! A blade's record, in vec4s from its first index `o`:
//! - `o`: the counts (u32 bits): triangles, cutting-edge segments, spine segments, 0;
//! - `o + 1`, `o + 2`: the surface's bounding box in the tool frame (least, greatest);
//! - 4 per triangle: corners a, b, c (a's w: the feature flags below, as u32 bits), and
//!   the unit normal;
//! - 2 per cutting-edge segment, then 2 per spine segment: its two ends.

use crate::mpm::Vec3;
use crate::tools::mesh_slicer::BladeMesh;
use crate::tools::Shape;

/// Triangle flag bits: edge e (0 AB, 1 BC, 2 AC) on the surface's boundary is bit e, corner
/// i a boundary vertex is bit 3 + i.
const CORNER_FLAG_SHIFT: u32 = 3;

/// vec4s before a blade's triangles.
pub const HEADER: u32 = 3;

fn v4(v: Vec3, w: f32) -> [f32; 4] {
    [v.x, v.y, v.z, w]
}

/// Appends `mesh`'s record to `out`.
fn pack_blade(mesh: &BladeMesh, out: &mut Vec<[f32; 4]>) {
    let count = |n: usize| f32::from_bits(n as u32);
    out.push([
        count(mesh.triangle_count()),
        count(mesh.cutting_edges().len()),
        count(mesh.spine_segments().len()),
        0.0,
    ]);
    let (least, greatest) = mesh.bounds();
    out.push(v4(least, 0.0));
    out.push(v4(greatest, 0.0));
    for t in mesh.triangles() {
        let mut flags = 0u32;
        for i in 0..3 {
            flags |= (t.boundary_edges[i] as u32) << i;
            flags |= (t.boundary_corners[i] as u32) << (CORNER_FLAG_SHIFT + i as u32);
        }
        let [a, b, c] = t.corners;
        out.push(v4(a, f32::from_bits(flags)));
        out.push(v4(b, 0.0));
        out.push(v4(c, 0.0));
        out.push(v4(t.normal, 0.0));
    }
    for [a, b] in mesh.cutting_edges().iter().chain(mesh.spine_segments()) {
        out.push(v4(*a, 0.0));
        out.push(v4(*b, 0.0));
    }
}

/// The device records of the blades of `shapes` (a scene's tools in order), and per tool
/// the first index of its blade's record (0 for a tool that is not a mesh slicer). Empty
/// when no tool is a mesh slicer. Two tools with the same blade file share one record.
pub fn pack(shapes: &[Shape]) -> (Vec<[f32; 4]>, Vec<u32>) {
    let mut data = Vec::new();
    let mut packed: Vec<(&BladeMesh, u32)> = Vec::new();
    let offsets = shapes
        .iter()
        .map(|shape| {
            let Shape::MeshSlicer { file, .. } = shape else {
                return 0;
            };
            let mesh = file.mesh();
            if let Some(&(_, at)) = packed.iter().find(|(m, _)| std::ptr::eq(*m, mesh)) {
                return at;
            }
            let at = data.len() as u32;
            pack_blade(mesh, &mut data);
            packed.push((mesh, at));
            at
        })
        .collect();
    (data, offsets)
}

/// The record layout's constants, for the WGSL prelude.
pub fn wgsl_constants() -> String {
    format!(
        "const BLADE_HEADER: u32 = {HEADER}u;\nconst BLADE_CORNER_FLAG_SHIFT: u32 = {CORNER_FLAG_SHIFT}u;\n"
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tools::mesh_slicer::BladeFile;
    use crate::tools::obj;
    use std::path::Path;

    #[test]
    fn a_blade_record_holds_counts_bounds_triangles_and_segments() {
        // Two triangles (one quad), spine along the top: 2 triangles, 3 cutting-edge
        // segments, 1 spine segment.
        let text = "v 0 0 0\nv 0 0 -1\nv 1 0 -1\nv 1 0 0\nf 1 2 3 4\nl 1 4\n";
        let mesh = BladeMesh::from_obj(obj::parse(text).unwrap(), Path::new("q.obj"));
        let shape = Shape::MeshSlicer {
            file: BladeFile::loaded("q.obj", mesh),
            thickness: 0.01,
        };
        let sphere = Shape::Sphere { radius: 1.0 };
        let (data, offsets) = pack(&[sphere, shape, shape]);
        assert_eq!(offsets, vec![0, 0, 0], "one record, shared");
        let counts: Vec<u32> = data[0].iter().map(|c| c.to_bits()).collect();
        assert_eq!(counts, vec![2, 3, 1, 0]);
        assert_eq!(data.len() as u32, HEADER + 2 * 4 + (3 + 1) * 2);
        assert_eq!(data[1], [0.0, 0.0, -1.0, 0.0]);
        assert_eq!(data[2], [1.0, 0.0, 0.0, 0.0]);
        // First triangle (1 2 3): AB and BC are boundary edges, AC the diagonal is not;
        // every corner is on the boundary.
        let flags = data[HEADER as usize][3].to_bits();
        assert_eq!(flags, 0b111_011);
        // The spine segment is last.
        let spine = &data[data.len() - 2..];
        assert_eq!(spine[0][..3], [0.0, 0.0, 0.0]);
        assert_eq!(spine[1][..3], [1.0, 0.0, 0.0]);
        assert_eq!(pack(&[sphere]).0.len(), 0);
    }
}
