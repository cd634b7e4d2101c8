//! Control meshes of the bundled scenes, generated in code (see `examples/make_scenes.rs`,
//! which writes them to `scenes/`), and an OBJ writer that keeps the tags.

use super::{ControlMesh, EdgeCrease, SHARPNESS_INFINITE};
use std::f64::consts::PI;
use std::io::Write;

fn mesh(positions: Vec<[f64; 3]>, faces: &[Vec<u32>], creases: Vec<EdgeCrease>) -> ControlMesh {
    let mut face_offsets = vec![0u32];
    let mut face_verts = Vec::new();
    for f in faces {
        face_verts.extend_from_slice(f);
        face_offsets.push(face_verts.len() as u32);
    }
    ControlMesh {
        positions,
        face_offsets,
        face_verts,
        creases,
        ..ControlMesh::default()
    }
}

fn crease(v0: u32, v1: u32, sharpness: f32) -> EdgeCrease {
    EdgeCrease { v0, v1, sharpness }
}

/// A cube `[-1, 1]³` (8 vertices, 6 quads, outward winding) whose 12 edges all have
/// sharpness `sharpness` (none for 0; `f32::INFINITY` or ≥ 10 is infinitely sharp): the
/// "rounded box" of RenderMan's semi-sharp creases.
pub fn rounded_box(sharpness: f32) -> ControlMesh {
    let p = vec![
        [-1.0, -1.0, 1.0],
        [1.0, -1.0, 1.0],
        [-1.0, 1.0, 1.0],
        [1.0, 1.0, 1.0],
        [-1.0, 1.0, -1.0],
        [1.0, 1.0, -1.0],
        [-1.0, -1.0, -1.0],
        [1.0, -1.0, -1.0],
    ];
    let faces = [
        vec![0, 1, 3, 2],
        vec![2, 3, 5, 4],
        vec![4, 5, 7, 6],
        vec![6, 7, 1, 0],
        vec![1, 7, 5, 3],
        vec![6, 0, 2, 4],
    ];
    let s = sharpness.min(SHARPNESS_INFINITE);
    let mut creases = Vec::new();
    if s > 0.0 {
        for (a, b) in [
            (0, 1),
            (1, 3),
            (3, 2),
            (2, 0),
            (4, 5),
            (5, 7),
            (7, 6),
            (6, 4),
            (0, 6),
            (1, 7),
            (3, 5),
            (2, 4),
        ] {
            creases.push(crease(a, b, s));
        }
    }
    mesh(p, &faces, creases)
}

/// A geodesic sphere: an icosahedron with each triangle split into `4^level` triangles,
/// projected onto the unit sphere. Returns positions and triangles.
fn icosphere(level: u32) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let t = (1.0 + 5.0f64.sqrt()) / 2.0;
    let mut p: Vec<[f64; 3]> = vec![
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let norm = |v: [f64; 3]| {
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        [v[0] / l, v[1] / l, v[2] / l]
    };
    for v in &mut p {
        *v = norm(*v);
    }
    for _ in 0..level {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::with_capacity(tris.len() * 4);
        let mut midpoint = |a: u32, b: u32, p: &mut Vec<[f64; 3]>| -> u32 {
            let key = (a.min(b), a.max(b));
            *mid.entry(key).or_insert_with(|| {
                let (pa, pb) = (p[a as usize], p[b as usize]);
                p.push(norm([
                    (pa[0] + pb[0]) * 0.5,
                    (pa[1] + pb[1]) * 0.5,
                    (pa[2] + pb[2]) * 0.5,
                ]));
                (p.len() - 1) as u32
            })
        };
        for [a, b, c] in tris {
            let ab = midpoint(a, b, &mut p);
            let bc = midpoint(b, c, &mut p);
            let ca = midpoint(c, a, &mut p);
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    (p, tris)
}

/// `m` with every face of more than three vertices cut into a fan of triangles from its first
/// vertex (quads along their diagonal 0–2), for the Loop scheme; positions, creases and
/// corners are kept (every original edge is still an edge), holes and options too.
pub fn triangulated(m: &ControlMesh) -> ControlMesh {
    let mut out = m.clone();
    out.face_offsets = vec![0];
    out.face_verts.clear();
    out.face_uvs.clear();
    out.holes.clear();
    out.provenance = Default::default();
    for f in 0..m.num_faces() {
        let fv = &m.face_verts[m.face_offsets[f] as usize..m.face_offsets[f + 1] as usize];
        let hole = m.holes.contains(&(f as u32));
        for i in 1..fv.len() - 1 {
            if hole {
                out.holes.push(out.num_faces() as u32);
            }
            out.face_verts.extend_from_slice(&[fv[0], fv[i], fv[i + 1]]);
            out.face_offsets.push(out.face_verts.len() as u32);
        }
    }
    out
}

/// A closed triangle spindle whose two poles have valence `n` (3 or more): three rings of `n`
/// vertices between them (the middle one twisted by half a step and rippled), so the rings'
/// vertices have valence 5 to 7. For measuring approximations around poles of any valence.
pub fn spindle(n: usize) -> ControlMesh {
    assert!(n >= 3, "a spindle's poles need valence 3 or more");
    let tau = std::f64::consts::TAU;
    let mut p = vec![[0.0, 0.0, 1.6], [0.0, 0.0, -1.4]];
    let rings = [(0.9, 0.85, 0.0), (0.0, 1.1, 0.5), (-0.9, 0.8, 0.0)];
    for (z, r, twist) in rings {
        for k in 0..n {
            let a = tau * (k as f64 + twist) / n as f64;
            let r = r * (1.0 + 0.12 * (2.0 * a).sin());
            p.push([r * a.cos(), r * a.sin(), z + 0.08 * (3.0 * a).cos()]);
        }
    }
    let ring = |i: usize, k: usize| (2 + i * n + k % n) as u32;
    let mut faces: Vec<Vec<u32>> = Vec::new();
    for k in 0..n {
        faces.push(vec![0, ring(0, k), ring(0, k + 1)]);
        faces.push(vec![1, ring(2, k + 1), ring(2, k)]);
        for i in 0..2 {
            let (a, b) = (ring(i, k), ring(i, k + 1));
            let (c, d) = (ring(i + 1, k), ring(i + 1, k + 1));
            faces.push(vec![a, c, d]);
            faces.push(vec![a, d, b]);
        }
    }
    mesh(p, &faces, Vec::new())
}

/// A smooth organic blob: a geodesic sphere (12 valence-5 and many valence-6 vertices; as a
/// Catmull-Clark control mesh of triangles each face also gets a valence-3 centre) pulled
/// out into five rounded lobes of different lengths and gently rippled. No tags.
pub fn blob() -> ControlMesh {
    let (mut p, tris) = icosphere(2);
    let lobes: [([f64; 3], f64); 5] = [
        ([0.0, 1.0, 0.2], 0.9),
        ([0.9, -0.3, 0.4], 0.7),
        ([-0.8, -0.2, 0.6], 0.6),
        ([-0.2, -0.4, -1.0], 0.8),
        ([0.6, 0.2, -0.7], 0.5),
    ];
    for v in &mut p {
        let mut r = 1.0;
        for (dir, len) in lobes {
            let l = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
            let c = (v[0] * dir[0] + v[1] * dir[1] + v[2] * dir[2]) / l;
            if c > 0.0 {
                r += len * c.powi(6);
            }
        }
        r += 0.06 * (5.0 * v[0]).sin() * (4.0 * v[1] + 1.0).sin() * (3.0 * v[2] + 2.0).cos();
        *v = [v[0] * r, v[1] * r, v[2] * r];
    }
    let faces: Vec<Vec<u32>> = tris.iter().map(|t| t.to_vec()).collect();
    mesh(p, &faces, Vec::new())
}

/// A spur gear with a bore: `teeth` trapezoidal teeth, outer (tip) radius 1.25, root radius
/// 1.0, a flat ring of radius 0.7 on both faces, bore radius 0.4, thickness 0.5 (z from -0.25
/// to 0.25). All quads, genus one. Semi-sharp creases everywhere a machinist would break an
/// edge: tooth tips 3, flanks 2, roots 1.5 on both rims, vertical tooth edges 2.5 at the tips and
/// 1 at the roots, bore rims 1, the hub ring 0.5.
pub fn gear(teeth: usize) -> ControlMesh {
    let teeth = teeth.max(3);
    let n = 4 * teeth;
    let h = 0.25;
    let step = 2.0 * PI / teeth as f64;
    let frac = [0.0, 0.25, 0.5, 0.75];
    let angle = |i: usize| step * (i / 4) as f64 + step * frac[i % 4];
    let outer_r = |i: usize| if i % 4 == 1 || i % 4 == 2 { 1.25 } else { 1.0 };
    // Rings: 0 outer top, 1 mid top, 2 inner top, 3 outer bottom, 4 mid bottom, 5 inner bottom.
    let mut p = Vec::with_capacity(6 * n);
    for ring in 0..6 {
        let z = if ring < 3 { h } else { -h };
        for i in 0..n {
            let a = angle(i);
            let r = match ring % 3 {
                0 => outer_r(i),
                1 => 0.7,
                _ => 0.4,
            };
            p.push([r * a.cos(), r * a.sin(), z]);
        }
    }
    let v = |ring: usize, i: usize| (ring * n + (i % n)) as u32;
    let mut faces = Vec::new();
    for i in 0..n {
        let j = i + 1;
        // Top (+z), outer to mid and mid to inner.
        faces.push(vec![v(0, i), v(0, j), v(1, j), v(1, i)]);
        faces.push(vec![v(1, i), v(1, j), v(2, j), v(2, i)]);
        // Bottom (-z), reversed.
        faces.push(vec![v(3, i), v(4, i), v(4, j), v(3, j)]);
        faces.push(vec![v(4, i), v(5, i), v(5, j), v(4, j)]);
        // Outer side (outward) and bore (facing the axis).
        faces.push(vec![v(3, i), v(3, j), v(0, j), v(0, i)]);
        faces.push(vec![v(5, j), v(5, i), v(2, i), v(2, j)]);
    }
    let mut creases = Vec::new();
    for i in 0..n {
        let j = i + 1;
        let rim = match i % 4 {
            1 => 3.0,
            0 | 2 => 2.0,
            _ => 1.5,
        };
        creases.push(crease(v(0, i), v(0, j), rim));
        creases.push(crease(v(3, i), v(3, j), rim));
        creases.push(crease(v(2, i), v(2, j), 1.0));
        creases.push(crease(v(5, i), v(5, j), 1.0));
        creases.push(crease(v(1, i), v(1, j), 0.5));
        creases.push(crease(v(4, i), v(4, j), 0.5));
        let vertical = if i % 4 == 1 || i % 4 == 2 { 2.5 } else { 1.0 };
        creases.push(crease(v(3, i), v(0, i), vertical));
    }
    mesh(p, &faces, creases)
}

/// A photographer's cyclorama: a floor of depth `depth` in front of `z = 0` (towards `+z`)
/// that sweeps up smoothly into a back wall of height `height` behind it, `width` wide, facing
/// `+y` / `+z`. Its boundary is infinitely sharp (edge-and-corner), so the outline stays put;
/// the bend is rounded by subdivision.
pub fn cyclorama(width: f64, depth: f64, height: f64) -> ControlMesh {
    // Profile in (z, y), from the front edge to the top of the wall.
    let profile = [
        (depth, 0.0),
        (0.0, 0.0),
        (-0.35 * depth, 0.0),
        (-0.5 * depth, 0.0),
        (-0.5 * depth, 0.15 * height),
        (-0.5 * depth, height),
    ];
    let cols = [-0.5 * width, 0.0, 0.5 * width];
    let mut p = Vec::new();
    for &(z, y) in &profile {
        for &x in &cols {
            p.push([x, y, z]);
        }
    }
    let nc = cols.len() as u32;
    let mut faces = Vec::new();
    for r in 0..profile.len() as u32 - 1 {
        for c in 0..nc - 1 {
            let a = r * nc + c;
            // Winding so that the floor faces +y: (x+, z-) order.
            faces.push(vec![a, a + 1, a + nc + 1, a + nc]);
        }
    }
    let mut m = mesh(p, &faces, Vec::new());
    // Keep the floor flat up to the bend: a semi-sharp crease across the floor's third row.
    for c in 0..nc - 1 {
        m.creases.push(crease(2 * nc + c, 2 * nc + c + 1, 1.0));
    }
    m
}

/// The rounded box (edges at sharpness 2) carrying hierarchical edits (paper 001 §6.3): on
/// its front face (z = +1) a raised square made at level 2 (its edges set infinitely sharp at
/// level 2) with a dimple pressed in at level 3, and on a side face a bump at level 1 with a sharp
/// corner at level 2. Closed: no edit makes a hole.
pub fn edited_box() -> ControlMesh {
    use super::{EditKind, EditOp, HierarchicalEdit};
    let mut m = rounded_box(2.0);
    let edit = HierarchicalEdit::new;
    let up = |corner: u32, h: f64| EditKind::Position {
        corner,
        op: EditOp::Add,
        value: [0.0, 0.0, h],
    };
    // Face 0 is the front (z = +1): its four level-1 quads' inner level-2 children form a
    // square around the centre; raise their corners and make their edges creases.
    for k in 0..4u32 {
        let inner = (k + 2) % 4;
        for c in 0..4 {
            m.edits.push(edit(0, &[k, inner], up(c, 0.1)));
            m.edits.push(edit(
                0,
                &[k, inner],
                EditKind::EdgeSharpness {
                    edge: c,
                    op: EditOp::Set,
                    value: 10.0,
                },
            ));
        }
    }
    m.edits.push(edit(0, &[0, 2, 2], up(2, -0.2)));
    // Face 4 (x = +1): a bump at level 1 and a sharp corner on it at level 2.
    let out = |corner: u32| EditKind::Position {
        corner,
        op: EditOp::Add,
        value: [0.25, 0.0, 0.0],
    };
    m.edits.push(edit(4, &[1], out(2)));
    m.edits.push(edit(
        4,
        &[1, 2],
        EditKind::VertexSharpness {
            corner: 0,
            op: EditOp::Set,
            value: 10.0,
        },
    ));
    atlas_uvs(&mut m);
    m
}

/// Gives each face of a six-quad box its own tile of a 3 × 2 texture atlas (face `i` in column
/// `i % 3`, row `i / 3`, inset by 1/32 of a tile so that filtering stays inside it): texture
/// coordinates with a seam along every edge of the box.
pub fn atlas_uvs(m: &mut ControlMesh) {
    m.uvs.clear();
    m.face_uvs.clear();
    for f in 0..m.num_faces() {
        let (c, r) = ((f % 3) as f64, ((f / 3) % 2) as f64);
        let inset = 1.0 / 32.0;
        let corners = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        for k in 0..m.face_size(f) {
            let [x, y] = corners[k % 4];
            let x = inset + x * (1.0 - 2.0 * inset);
            let y = inset + y * (1.0 - 2.0 * inset);
            m.uvs.push([(c + x) / 3.0, (r + y) / 2.0]);
            m.face_uvs.push((m.uvs.len() - 1) as u32);
        }
    }
}

/// Writes a control mesh as OBJ with OpenSubdiv tags (`t crease 2/1 a b s`,
/// `t corner 1/1 v s`, `t hole 1/0 f`, edits), positions and texture coordinates (`vt`, faces
/// `f v/vt`) in shortest round-trip form, `header`
/// lines as comments first.
pub fn write_tagged_obj(w: &mut impl Write, m: &ControlMesh, header: &str) -> std::io::Result<()> {
    let mut o = super::obj::ObjWriter::new(w);
    o.comment(header)?;
    o.vertices("v", &m.positions)?;
    if m.face_uvs.is_empty() {
        o.faces(&m.face_offsets, &m.face_verts, false)?;
    } else {
        o.vertices("vt", &m.uvs)?;
        o.faces_with_uvs(&m.face_offsets, &m.face_verts, &m.face_uvs)?;
    }
    o.tags(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn round_trip(m: &ControlMesh) {
        m.validate().unwrap();
        let mut buf = Vec::new();
        write_tagged_obj(&mut buf, m, "test").unwrap();
        let back = crate::mesh::obj::parse_obj(std::str::from_utf8(&buf).unwrap(), None).unwrap();
        assert_eq!(back.positions, m.positions);
        assert_eq!(back.face_verts, m.face_verts);
        assert_eq!(back.creases, m.creases);
        assert_eq!(back.edits, m.edits);
        assert_eq!(back.uvs, m.uvs);
        assert_eq!(back.face_uvs, m.face_uvs);
    }

    #[test]
    fn shapes_are_valid_and_round_trip() {
        for s in [0.0, 1.0, 3.5, f32::INFINITY] {
            round_trip(&rounded_box(s));
        }
        assert_eq!(rounded_box(0.0).creases.len(), 0);
        assert_eq!(rounded_box(f32::INFINITY).creases[0].sharpness, 10.0);
        let b = blob();
        assert_eq!(b.num_vertices(), 162);
        assert_eq!(b.num_faces(), 320);
        round_trip(&b);
        let g = gear(12);
        assert_eq!(g.num_vertices(), 6 * 48);
        assert_eq!(g.num_faces(), 6 * 48);
        round_trip(&g);
        round_trip(&cyclorama(20.0, 10.0, 8.0));
        round_trip(&edited_box());
    }

    #[test]
    fn closed_shapes_are_closed() {
        for m in [rounded_box(2.0), blob(), gear(8), edited_box()] {
            let topo = crate::mesh::Topology::new(m.num_vertices(), &m.face_offsets, &m.face_verts)
                .unwrap();
            assert!((0..topo.num_edges() as u32).all(|e| topo.edge_face_count(e) == 2));
            assert!(
                topo.edge_nonmanifold.iter().all(|&b| !b),
                "inconsistent winding"
            );
        }
    }
}
