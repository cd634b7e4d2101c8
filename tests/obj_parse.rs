//! Tests of the OBJ reader: every accepted form, every malformed case, a property test that
//! nothing panics, and (when present) OpenSubdiv's regression shapes.

use limitray::mesh::obj::{parse_obj, write_obj};
use limitray::mesh::{BoundaryInterpolation, ControlMesh, CreaseMethod, EdgeCrease, VertexCorner};
use limitray::{Error, ErrorKind};
use proptest::prelude::*;
use std::path::Path;

const CUBE: &str = "\
v -1 -1 1
v 1 -1 1
v -1 1 1
v 1 1 1
v -1 1 -1
v 1 1 -1
v -1 -1 -1
v 1 -1 -1
f 1 2 4 3
f 3 4 6 5
f 5 6 8 7
f 7 8 2 1
f 2 8 6 4
f 7 1 3 5
";

fn ok(text: &str) -> ControlMesh {
    match parse_obj(text, Some("test.obj")) {
        Ok(m) => m,
        Err(e) => panic!("expected Ok, got error: {e}"),
    }
}

fn err(text: &str) -> Error {
    match parse_obj(text, Some("test.obj")) {
        Ok(m) => panic!("expected an error, got a mesh with {} faces", m.num_faces()),
        Err(e) => e,
    }
}

/// Asserts kind, line and element of an error, and that the file is named.
fn check(e: &Error, kind: ErrorKind, line: usize, element: &str) {
    assert_eq!(e.kind, kind, "kind of {e}");
    assert_eq!(e.line, Some(line), "line of {e}");
    assert_eq!(e.element.as_deref(), Some(element), "element of {e}");
    assert_eq!(e.file.as_deref(), Some("test.obj"), "file of {e}");
}

fn faces(m: &ControlMesh) -> Vec<Vec<u32>> {
    (0..m.num_faces()).map(|f| m.face(f).to_vec()).collect()
}

// ---------------------------------------------------------------------------------------------
// Accepted forms

#[test]
fn cube_positions_faces_and_provenance() {
    let m = ok(CUBE);
    assert_eq!(m.num_vertices(), 8);
    assert_eq!(m.num_faces(), 6);
    assert_eq!(m.positions[1], [1.0, -1.0, 1.0]);
    assert_eq!(m.face(0), &[0, 1, 3, 2]);
    assert_eq!(m.face_offsets, vec![0, 4, 8, 12, 16, 20, 24]);
    assert_eq!(m.provenance.file.as_deref(), Some("test.obj"));
    assert_eq!(m.provenance.vertex_lines, (1..=8).collect::<Vec<u32>>());
    assert_eq!(m.provenance.face_lines, (9..=14).collect::<Vec<u32>>());
    assert!(m.face_uvs.is_empty());
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    assert_eq!(m.options.boundary, BoundaryInterpolation::EdgeAndCorner);
    assert_eq!(m.options.crease_method, CreaseMethod::Uniform);
}

#[test]
fn ngons_triangles_and_extra_w() {
    let m = ok(
        "v 0 0 0 1\nv 1 0 0 1\nv 1 1 0\nv 0 1 0\nv 0.5 2 0\nv -1 0.5 0\n\
                f 1 2 3\nf 1 3 5 4 6\nf 1 2 3 4 5 6\n",
    );
    assert_eq!(
        faces(&m),
        vec![vec![0, 1, 2], vec![0, 2, 4, 3, 5], vec![0, 1, 2, 3, 4, 5]]
    );
    assert_eq!(m.positions[0], [0.0, 0.0, 0.0]);
}

#[test]
fn comments_blank_lines_crlf_and_ignored_statements() {
    let text = "# header\r\n\r\nmtllib a.mtl\r\no obj\r\ng grp\r\ns 1\r\ns off\r\nusemtl m\r\n\
                v 0 0 0 # trailing comment\r\nv 1 0 0\r\n   \t \r\nv 0 1 0\r\nf 1 2 3#c\r\n";
    let m = ok(text);
    assert_eq!(m.num_vertices(), 3);
    assert_eq!(faces(&m), vec![vec![0, 1, 2]]);
    assert_eq!(m.provenance.vertex_lines, vec![9, 10, 12]);
    assert_eq!(m.provenance.face_lines, vec![13]);
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
}

#[test]
fn number_forms() {
    let m = ok("v 1e2 -2.5E-1 +3\nv .5 5. -0\nv 1 2 3\nf 1 2 3\n");
    assert_eq!(m.positions[0], [100.0, -0.25, 3.0]);
    assert_eq!(m.positions[1][0], 0.5);
    assert_eq!(m.positions[1][1], 5.0);
}

#[test]
fn texture_indices_kept() {
    let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0 0\nvt 1 1\nvt 0 1\n\
                f 1/1 2/2 3/3 4/4\n";
    let m = ok(text);
    assert_eq!(m.uvs, vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
    assert_eq!(m.face_uvs, vec![0, 1, 2, 3]);
    assert!(m.warnings.is_empty());
}

#[test]
fn texture_and_normal_indices() {
    let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 1\n\
                f 1/3/1 2/2/1 3/1/1\n";
    let m = ok(text);
    assert_eq!(m.face(0), &[0, 1, 2]);
    assert_eq!(m.face_uvs, vec![2, 1, 0]);
}

#[test]
fn normal_only_indices() {
    let m = ok("v 0 0 0\nv 1 0 0\nv 1 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n");
    assert_eq!(m.face(0), &[0, 1, 2]);
    assert!(m.face_uvs.is_empty());
    assert!(m.warnings.is_empty());
}

#[test]
fn vt_with_one_coordinate() {
    let m = ok("v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0.25\nf 1/1 2/1 3/1\n");
    assert_eq!(m.uvs, vec![[0.25, 0.0]]);
}

#[test]
fn mixed_texture_indices_dropped_with_warning() {
    let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/1\nf 1 3 4\n";
    let m = ok(text);
    assert!(m.face_uvs.is_empty());
    assert_eq!(m.uvs.len(), 1);
    assert_eq!(m.warnings.len(), 1, "{:?}", m.warnings);
    assert!(m.warnings[0].starts_with("test.obj:7:"), "{:?}", m.warnings);
    assert!(m.warnings[0].contains("texture"), "{:?}", m.warnings);
}

#[test]
fn negative_indices_are_relative() {
    let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nf -3 -2 -1\nv 0 1 0\nvt 0 0\nvt 1 1\n\
                f -4/-2 -2/-1 -1/-1\n";
    let m = ok(text);
    assert!(m.face_uvs.is_empty()); // the first face has none
    assert_eq!(faces(&m), vec![vec![0, 1, 2], vec![0, 2, 3]]);
    let m = ok("v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 1\nf -3/-2 -2/-1 -1/-1\n");
    assert_eq!(m.face_uvs, vec![0, 1, 1]);
}

#[test]
fn forward_reference_is_accepted() {
    // OBJ indices are checked against the final vertex count.
    let m = ok("v 0 0 0\nf 1 2 3\nv 1 0 0\nv 1 1 0\n");
    assert_eq!(m.face(0), &[0, 1, 2]);
}

#[test]
fn tag_crease_pairs_one_sharpness() {
    let m = ok(&format!("{CUBE}t crease 4/1 0 1 1 3 2.5\n"));
    assert_eq!(
        m.creases,
        vec![
            EdgeCrease {
                v0: 0,
                v1: 1,
                sharpness: 2.5
            },
            EdgeCrease {
                v0: 1,
                v1: 3,
                sharpness: 2.5
            }
        ]
    );
    assert_eq!(m.provenance.crease_lines, vec![15, 15]);
}

#[test]
fn tag_crease_one_sharpness_per_pair_and_three_counts() {
    let m = ok(&format!(
        "{CUBE}t crease 2/1/0 0 1 1\nt crease 4/2/0 2 3 4 5 3 10\n"
    ));
    let got: Vec<(u32, u32, f32)> = m
        .creases
        .iter()
        .map(|c| (c.v0, c.v1, c.sharpness))
        .collect();
    assert_eq!(got, vec![(0, 1, 1.0), (2, 3, 3.0), (4, 5, 10.0)]);
    assert_eq!(m.provenance.crease_lines, vec![15, 16, 16]);
}

#[test]
fn tag_crease_large_sharpness_kept_as_given() {
    let m = ok(&format!(
        "{CUBE}t crease 2/1 0 1 25\nt crease 2/1 2 3 inf\n"
    ));
    assert_eq!(m.creases[0].sharpness, 25.0);
    assert_eq!(m.creases[1].sharpness, f32::INFINITY);
}

#[test]
fn tag_corner() {
    let m = ok(&format!(
        "{CUBE}t corner 1/1/0 3 4.5\nt corner 2/1 0 7 10\n"
    ));
    assert_eq!(
        m.corners,
        vec![
            VertexCorner {
                vertex: 3,
                sharpness: 4.5
            },
            VertexCorner {
                vertex: 0,
                sharpness: 10.0
            },
            VertexCorner {
                vertex: 7,
                sharpness: 10.0
            }
        ]
    );
    assert_eq!(m.provenance.corner_lines, vec![15, 16, 16]);
    let m = ok(&format!("{CUBE}t corner 2/2 0 7 1 2\n"));
    assert_eq!(m.corners[1].sharpness, 2.0);
}

#[test]
fn tag_hole() {
    let m = ok(&format!("{CUBE}t hole 2/0/0 0 5\nt hole 1/0 3\n"));
    assert_eq!(m.holes, vec![0, 5, 3]);
    assert_eq!(m.provenance.hole_lines, vec![15, 15, 16]);
}

#[test]
fn tag_interpolateboundary() {
    for (v, want) in [
        (0, BoundaryInterpolation::None),
        (1, BoundaryInterpolation::EdgeAndCorner),
        (2, BoundaryInterpolation::EdgeOnly),
    ] {
        let m = ok(&format!("{CUBE}t interpolateboundary 1/0/0 {v}\n"));
        assert_eq!(m.options.boundary, want);
    }
}

#[test]
fn tag_creasemethod() {
    let m = ok(&format!("{CUBE}t creasemethod 0/0/1 chaikin\n"));
    assert_eq!(m.options.crease_method, CreaseMethod::Chaikin);
    let m = ok(&format!(
        "{CUBE}t creasemethod 0/0/1 chaikin\nt creasemethod 0/0/1 normal\n"
    ));
    assert_eq!(m.options.crease_method, CreaseMethod::Uniform);
    let m = ok(&format!("{CUBE}t creasemethod 0/0/1 \"uniform\"\n"));
    assert_eq!(m.options.crease_method, CreaseMethod::Uniform);
}

#[test]
fn hierarchical_edits_are_read() {
    use limitray::mesh::{EditKind, EditOp, HierarchicalEdit};
    let text = format!(
        "{CUBE}t vertexedit 3/3/3 2 0 1 0 0 1 add P value\n\
         t edgeedit 8/2/3 3 2 3 1 3 5 2 0 2.5 10 set P sharpness\n\
         t faceedit 4/0/1 3 4 1 1 hole\n\
         t vertexedit 4/2/6 3 0 0 2 3 1 set P sharpness subtract P sharpness\n"
    );
    let m = ok(&text);
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    let e = |face, path: &[u32], kind| HierarchicalEdit {
        face,
        path: path.to_vec(),
        kind,
    };
    assert_eq!(
        m.edits,
        vec![
            e(
                0,
                &[],
                EditKind::Position {
                    corner: 1,
                    op: EditOp::Add,
                    value: [0.0, 0.0, 1.0]
                }
            ),
            e(
                2,
                &[3],
                EditKind::EdgeSharpness {
                    edge: 1,
                    op: EditOp::Set,
                    value: 2.5
                }
            ),
            e(
                5,
                &[2],
                EditKind::EdgeSharpness {
                    edge: 0,
                    op: EditOp::Set,
                    value: 10.0
                }
            ),
            e(4, &[1, 1], EditKind::Hole),
            e(
                0,
                &[0],
                EditKind::VertexSharpness {
                    corner: 2,
                    op: EditOp::Set,
                    value: 3.0
                }
            ),
            e(
                0,
                &[0],
                EditKind::VertexSharpness {
                    corner: 2,
                    op: EditOp::Subtract,
                    value: 1.0
                }
            ),
        ]
    );
    assert_eq!(m.provenance.edit_lines, vec![15, 16, 16, 17, 18, 18]);
}

#[test]
fn malformed_hierarchical_edits() {
    // Path running past the ints, too short, bad operation, too few floats.
    for (tag, msg) in [
        ("t vertexedit 4/3/3 5 0 1 0 0 0 1 add P value", "runs past"),
        ("t vertexedit 1/0/3 1 add P value", "too short"),
        (
            "t vertexedit 3/3/3 2 0 1 0 0 1 multiply P value",
            "unknown operation",
        ),
        ("t vertexedit 3/2/3 2 0 1 0 0 add P value", "need 3 floats"),
        ("t vertexedit 3/3/2 2 0 1 0 0 1 add P", "triples"),
    ] {
        let e = err(&format!("{CUBE}{tag}\n"));
        check(&e, ErrorKind::Parse, 15, "tag vertexedit");
        assert!(e.to_string().contains(msg), "{tag}: {e}");
    }
    // Paths that leave the mesh: the face, a sub-face, a corner, an edge.
    for (tag, msg) in [
        (
            "t vertexedit 3/3/3 2 6 1 0 0 1 add P value",
            "face 6 is out of range",
        ),
        ("t faceedit 4/0/1 3 0 1 4 hole", "sub-face 4 at depth 2"),
        ("t vertexedit 4/3/3 3 0 1 4 0 0 1 add P value", "corner 4"),
        ("t edgeedit 4/1/3 3 0 1 7 2 set P sharpness", "edge 7"),
    ] {
        let e = err(&format!("{CUBE}{tag}\n"));
        check(&e, ErrorKind::Topology, 15, "hierarchical edit 1");
        assert!(e.to_string().contains(msg), "{tag}: {e}");
    }
    // Hbr's files carry more floats than they use (catmark_square_hedit0): a warning.
    let m = ok(&format!(
        "{CUBE}t vertexedit 3/6/3 2 0 1 0 0 1 0 0 1 add P value\n"
    ));
    assert_eq!(m.edits.len(), 1);
    assert!(
        m.warnings[0].contains("the first 3 used"),
        "{:?}",
        m.warnings
    );
    // Edits of other primvars are ignored with a warning.
    let m = ok(&format!(
        "{CUBE}t vertexedit 3/2/3 2 0 1 0.5 0.5 set st value\n"
    ));
    assert!(
        m.edits.is_empty() && m.warnings[0].contains("not supported"),
        "{:?}",
        m.warnings
    );
}

#[test]
fn unsupported_and_unknown_tags_warn() {
    let text = format!(
        "{CUBE}t facevaryinginterpolateboundary 1/0/0 1\n\
         t facevaryingpropagatecorners 1/0/0 1\n\
         t frobnicate 1/1/1 3 0.5 word\n"
    );
    let m = ok(&text);
    assert_eq!(m.warnings.len(), 3, "{:?}", m.warnings);
    for w in &m.warnings[..2] {
        assert!(w.contains("not supported, ignored"), "{w}");
    }
    assert!(m.warnings[2].contains("frobnicate"), "{}", m.warnings[2]);
    assert!(
        m.warnings[2].starts_with("test.obj:17:"),
        "{}",
        m.warnings[2]
    );
}

#[test]
fn smoothtriangles_tag() {
    assert!(!ok(CUBE).options.smooth_triangles);
    let m = ok(&format!("{CUBE}t smoothtriangles 0/0/1 smooth\n"));
    assert!(m.options.smooth_triangles && m.warnings.is_empty());
    let m = ok(&format!(
        "{CUBE}t smoothtriangles 0/0/1 smooth\nt smoothtriangles 0/0/1 catmark\n"
    ));
    assert!(!m.options.smooth_triangles);
    let e = limitray::mesh::obj::parse_obj(
        &format!("{CUBE}t smoothtriangles 0/0/1 loop\n"),
        Some("test.obj"),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("test.obj:15") && e.contains("'loop'"), "{e}");
}

#[test]
fn unknown_statements_warn_and_are_capped() {
    let mut text = CUBE.to_string();
    for _ in 0..20 {
        text.push_str("l 1 2\n");
    }
    text.push_str("vp 0.5\n");
    let m = ok(&text);
    assert!(
        m.warnings[0].starts_with("test.obj:15:"),
        "{:?}",
        m.warnings
    );
    assert!(m.warnings[0].contains("'l'"), "{:?}", m.warnings);
    assert!(m.warnings.iter().any(|w| w.contains("'vp'")));
    assert!(m.warnings.len() < 10, "{:?}", m.warnings);
    assert!(m.warnings.iter().any(|w| w.contains("more 'l'")));
}

#[test]
fn warnings_without_file_name_line() {
    let m = parse_obj(&format!("{CUBE}xyz\n"), None).unwrap();
    assert_eq!(m.warnings.len(), 1);
    assert!(m.warnings[0].starts_with("line 15:"), "{:?}", m.warnings);
}

#[test]
fn embree_edge_crease() {
    let m = ok(&format!("{CUBE}ec 2.5 1 2\nec 10 -1 -2\n"));
    assert_eq!(
        m.creases,
        vec![
            EdgeCrease {
                v0: 0,
                v1: 1,
                sharpness: 2.5
            },
            EdgeCrease {
                v0: 7,
                v1: 6,
                sharpness: 10.0
            }
        ]
    );
    assert_eq!(m.provenance.crease_lines, vec![15, 16]);
}

#[test]
fn write_then_read_round_trips() {
    let m = ok(&format!(
        "{CUBE}v 0.1 1e-300 -123456.789012345678\nf 9 1 2\n"
    ));
    let mut buf = Vec::new();
    write_obj(&mut buf, &m.positions, &m.face_offsets, &m.face_verts).unwrap();
    let text = String::from_utf8(buf).unwrap();
    let back = ok(&text);
    assert_eq!(back.positions, m.positions);
    assert_eq!(back.face_offsets, m.face_offsets);
    assert_eq!(back.face_verts, m.face_verts);
    assert!(text.contains("\nf 9 1 2\n"), "{text}");
}

#[test]
fn write_rejects_bad_offsets() {
    let mut buf = Vec::new();
    assert!(write_obj(&mut buf, &[[0.0; 3]], &[0, 5], &[0, 0]).is_err());
    assert!(write_obj(&mut buf, &[[0.0; 3]], &[2, 1], &[0, 0]).is_err());
}

// ---------------------------------------------------------------------------------------------
// Malformed input: one test per case, each checking kind, line and element.

const TRI: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\n";

#[test]
fn bad_number_in_vertex() {
    let e = err("v 0 0 0\nv 1 abc 0\n");
    check(&e, ErrorKind::Parse, 2, "v");
    assert!(e.message.contains("invalid number 'abc'"), "{e}");
}

#[test]
fn bad_number_in_vt() {
    let e = err(&format!("{TRI}vt 0 x\n"));
    check(&e, ErrorKind::Parse, 4, "vt");
}

#[test]
fn too_few_coordinates() {
    let e = err("v 0 0 0\n\nv 1 2\n");
    check(&e, ErrorKind::Parse, 3, "v");
    assert!(e.message.contains("expected 3 numbers, found 2"), "{e}");
}

#[test]
fn vertex_without_coordinates() {
    let e = err("v\n");
    check(&e, ErrorKind::Parse, 1, "v");
}

#[test]
fn nan_coordinate() {
    let e = err(&format!("{TRI}v nan 0 0\n"));
    check(&e, ErrorKind::Parse, 4, "v");
    assert!(e.message.contains("not finite"), "{e}");
}

#[test]
fn inf_coordinate() {
    let e = err(&format!("{TRI}v 0 inf 0\n"));
    check(&e, ErrorKind::Parse, 4, "v");
    let e = err(&format!("{TRI}v 0 0 1e400\n"));
    check(&e, ErrorKind::Parse, 4, "v");
}

#[test]
fn index_zero() {
    let e = err(&format!("{TRI}f 0 1 2\n"));
    check(&e, ErrorKind::Parse, 4, "f");
    assert!(
        e.message
            .contains("vertex index 0 is invalid (OBJ indices start at 1)"),
        "{e}"
    );
}

#[test]
fn texture_index_zero() {
    let e = err(&format!("{TRI}vt 0 0\nf 1/0 2/1 3/1\n"));
    check(&e, ErrorKind::Parse, 5, "f");
}

#[test]
fn relative_index_before_first() {
    let e = err(&format!("{TRI}f 1 2 -5\n"));
    check(&e, ErrorKind::Parse, 4, "f");
    assert!(
        e.message
            .contains("relative index -5 refers before the first vertex"),
        "{e}"
    );
}

#[test]
fn relative_texture_index_before_first() {
    let e = err(&format!("{TRI}vt 0 0\nf 1/-2 2/-1 3/-1\n"));
    check(&e, ErrorKind::Parse, 5, "f");
}

#[test]
fn bad_face_index() {
    let e = err(&format!("{TRI}f 1 2 x\n"));
    check(&e, ErrorKind::Parse, 4, "f");
    let e = err(&format!("{TRI}f 1 2 3/1/1/1\n"));
    check(&e, ErrorKind::Parse, 4, "f");
    let e = err(&format!("{TRI}f 1 2 /1\n"));
    check(&e, ErrorKind::Parse, 4, "f");
    let e = err(&format!("{TRI}f 1 2 3/\n"));
    check(&e, ErrorKind::Parse, 4, "f");
    let e = err(&format!("{TRI}f 1 2 99999999999\n"));
    check(&e, ErrorKind::Parse, 4, "f");
}

#[test]
fn out_of_range_index() {
    let e = err(&format!("{TRI}f 1 2 3\nf 1 2 4\n"));
    check(&e, ErrorKind::Topology, 5, "face 2");
    assert!(e.message.contains("out of range"), "{e}");
}

#[test]
fn out_of_range_texture_index() {
    let e = err(&format!("{TRI}vt 0 0\nf 1/1 2/1 3/2\n"));
    check(&e, ErrorKind::Topology, 5, "face 1");
}

#[test]
fn face_with_no_vertices() {
    let e = err(&format!("{TRI}f\n"));
    check(&e, ErrorKind::Parse, 4, "f");
}

#[test]
fn face_with_two_vertices() {
    let e = err(&format!("{TRI}f 1 2 3\n# note\nf 1 2\n"));
    check(&e, ErrorKind::Topology, 6, "face 2");
    assert!(e.message.contains("2 vertices"), "{e}");
}

#[test]
fn repeated_vertex_in_face() {
    // OpenSubdiv accepts a face that repeats a vertex: the edges it uses twice get a second
    // instance each, and all four are non-manifold (so infinitely sharp).
    let m = ok(&format!("{TRI}v 0 1 0\nf 1 2 3 2\n"));
    let t =
        limitray::mesh::topology::Topology::new(m.num_vertices(), &m.face_offsets, &m.face_verts)
            .unwrap();
    let face_edges = t.face_edge_list(0);
    assert_eq!(face_edges.len(), 4);
    let mut distinct = face_edges.to_vec();
    distinct.sort();
    distinct.dedup();
    assert_eq!(
        distinct.len(),
        4,
        "every use is an edge of its own: {face_edges:?}"
    );
    assert!(face_edges.iter().all(|&e| t.edge_nonmanifold[e as usize]));
}

#[test]
fn negative_sharpness() {
    let e = err(&format!("{CUBE}t crease 2/1 0 1 -1\n"));
    check(&e, ErrorKind::Parse, 15, "tag crease");
    let e = err(&format!("{CUBE}t corner 1/1 0 -0.5\n"));
    check(&e, ErrorKind::Parse, 15, "tag corner");
    let e = err(&format!("{CUBE}ec -2 1 2\n"));
    check(&e, ErrorKind::Parse, 15, "ec");
}

#[test]
fn nan_sharpness() {
    let e = err(&format!("{CUBE}t crease 2/1 0 1 nan\n"));
    check(&e, ErrorKind::Parse, 15, "tag crease");
}

#[test]
fn bad_sharpness_number() {
    let e = err(&format!("{CUBE}t crease 2/1 0 1 sharp\n"));
    check(&e, ErrorKind::Parse, 15, "tag crease");
    assert!(e.message.contains("invalid number 'sharp'"), "{e}");
}

#[test]
fn tag_count_mismatch() {
    let e = err(&format!("{CUBE}t crease 2/1/0 0 1\n"));
    check(&e, ErrorKind::Parse, 15, "tag crease");
    let e = err(&format!("{CUBE}t crease 2/1/0 0 1 2 3\n"));
    check(&e, ErrorKind::Parse, 15, "tag crease");
    let e = err(&format!("{CUBE}t corner 99999999999/1 0 1\n"));
    check(&e, ErrorKind::Parse, 15, "tag corner");
    let e = err(&format!(
        "{CUBE}t corner 18446744073709551615/18446744073709551615/2 0 1\n"
    ));
    check(&e, ErrorKind::Parse, 15, "tag corner");
}

#[test]
fn tag_missing_or_bad_count_field() {
    let e = err(&format!("{CUBE}t crease\n"));
    check(&e, ErrorKind::Parse, 15, "tag crease");
    let e = err(&format!("{CUBE}t crease 2 0 1\n"));
    check(&e, ErrorKind::Parse, 15, "tag crease");
    let e = err(&format!("{CUBE}t crease 2/x 0 1\n"));
    check(&e, ErrorKind::Parse, 15, "tag crease");
    let e = err(&format!("{CUBE}t crease 2/1/0/0 0 1 1\n"));
    check(&e, ErrorKind::Parse, 15, "tag crease");
    let e = err(&format!("{CUBE}t\n"));
    check(&e, ErrorKind::Parse, 15, "t");
}

#[test]
fn crease_odd_ints_or_wrong_float_count() {
    let e = err(&format!("{CUBE}t crease 3/1 0 1 2 1\n"));
    check(&e, ErrorKind::Parse, 15, "tag crease");
    let e = err(&format!("{CUBE}t crease 6/2 0 1 1 2 2 3 1 1\n"));
    check(&e, ErrorKind::Parse, 15, "tag crease");
    let e = err(&format!("{CUBE}t crease 2/0 0 1\n"));
    check(&e, ErrorKind::Parse, 15, "tag crease");
}

#[test]
fn crease_negative_or_bad_vertex() {
    let e = err(&format!("{CUBE}t crease 2/1 0 -1 1\n"));
    check(&e, ErrorKind::Parse, 15, "tag crease");
    let e = err(&format!("{CUBE}t crease 2/1 0 a 1\n"));
    check(&e, ErrorKind::Parse, 15, "tag crease");
}

#[test]
fn crease_out_of_range_reports_tag_line() {
    let e = err(&format!("{CUBE}\nt crease 2/1 0 8 1\n"));
    check(&e, ErrorKind::Topology, 16, "tag crease");
}

#[test]
fn hole_out_of_range_reports_tag_line() {
    let e = err(&format!("{CUBE}t hole 1/0 6\n"));
    check(&e, ErrorKind::Topology, 15, "tag hole");
}

#[test]
fn bad_interpolateboundary_value() {
    let e = err(&format!("{CUBE}t interpolateboundary 1/0/0 3\n"));
    check(&e, ErrorKind::Parse, 15, "tag interpolateboundary");
    let e = err(&format!("{CUBE}t interpolateboundary 2/0/0 1 1\n"));
    check(&e, ErrorKind::Parse, 15, "tag interpolateboundary");
}

#[test]
fn unknown_creasemethod() {
    let e = err(&format!("{CUBE}t creasemethod 0/0/1 loop\n"));
    check(&e, ErrorKind::Parse, 15, "tag creasemethod");
    assert!(e.message.contains("'loop'"), "{e}");
}

#[test]
fn bad_ec_line() {
    let e = err(&format!("{CUBE}ec 1 2\n"));
    check(&e, ErrorKind::Parse, 15, "ec");
    let e = err(&format!("{CUBE}ec 1 0 2\n"));
    check(&e, ErrorKind::Parse, 15, "ec");
}

#[test]
fn error_display_names_file_line_and_element() {
    let e = err("v 0 0 0\nv 1 abc 0\n");
    assert_eq!(e.to_string(), "test.obj:2: v: invalid number 'abc'");
}

#[test]
fn long_tokens_are_shortened_in_messages() {
    let long = "x".repeat(10_000);
    let e = err(&format!("v 0 0 {long}\n"));
    assert!(e.message.len() < 200, "{}", e.message.len());
}

// ---------------------------------------------------------------------------------------------
// Nothing panics

const TAGGED: &str = "\
# tagged cube
v -1 -1 1
v 1 -1 1
v -1 1 1
v 1 1 1
v -1 1 -1
v 1 1 -1
v -1 -1 -1
v 1 -1 -1
vt 0 0
vt 1 0
vn 0 0 1
f 1/1 2/2 4/2 3/1
f 3//1 4//1 6//1 5//1
f 5/1/1 6/2/1 8/2/1 7/1/1
f -2 -1 2 1
f 2 8 6 4
f 7 1 3 5
t crease 2/1/0 0 1 2.5
t crease 4/2 2 3 4 5 1 10
t corner 1/1/0 3 4
t hole 1/0/0 5
t interpolateboundary 1/0/0 2
t creasemethod 0/0/1 chaikin
t vertexedit 3/3/3 2 0 1 0 0 1 add P value
ec 3 1 2
";

const PIECES: &[&str] = &[
    "v",
    "vt",
    "vn",
    "f",
    "t",
    "ec",
    "g",
    "#",
    "/",
    "//",
    "-1",
    "0",
    "1",
    "-99999999999",
    "99999999999/1",
    "18446744073709551616",
    "nan",
    "inf",
    "-inf",
    "1e999",
    "crease",
    "corner",
    "hole",
    "interpolateboundary",
    "creasemethod",
    "faceedit",
    "2/1",
    "0/0/1",
    "\n",
    " ",
    "\t",
    "\r",
    "é",
    "\u{0}",
    "\u{2028}",
    "\u{a0}",
    "1/2/3",
];

#[derive(Debug, Clone)]
enum Mutation {
    InsertChar(usize, char),
    DeleteChar(usize),
    ReplaceChar(usize, char),
    InsertToken(usize, usize),
    DeleteToken(usize),
    ReplaceToken(usize, usize),
    SwapLines(usize, usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let c = prop_oneof![
        proptest::char::range(' ', '~'),
        Just('\n'),
        proptest::char::any()
    ];
    let n = PIECES.len();
    prop_oneof![
        (any::<usize>(), c.clone()).prop_map(|(i, c)| Mutation::InsertChar(i, c)),
        any::<usize>().prop_map(Mutation::DeleteChar),
        (any::<usize>(), c).prop_map(|(i, c)| Mutation::ReplaceChar(i, c)),
        (any::<usize>(), 0..n).prop_map(|(i, p)| Mutation::InsertToken(i, p)),
        any::<usize>().prop_map(Mutation::DeleteToken),
        (any::<usize>(), 0..n).prop_map(|(i, p)| Mutation::ReplaceToken(i, p)),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::SwapLines(a, b)),
    ]
}

fn apply(text: &str, m: &Mutation) -> String {
    match *m {
        Mutation::InsertChar(i, c) | Mutation::ReplaceChar(i, c) => {
            let mut chars: Vec<char> = text.chars().collect();
            let k = i % (chars.len() + 1);
            if matches!(m, Mutation::ReplaceChar(..)) && k < chars.len() {
                chars[k] = c;
            } else {
                chars.insert(k, c);
            }
            chars.into_iter().collect()
        }
        Mutation::DeleteChar(i) => {
            let mut chars: Vec<char> = text.chars().collect();
            if !chars.is_empty() {
                let k = i % chars.len();
                chars.remove(k);
            }
            chars.into_iter().collect()
        }
        Mutation::InsertToken(i, p) | Mutation::ReplaceToken(i, p) => {
            let mut tokens: Vec<&str> = text.split(' ').collect();
            let k = i % (tokens.len() + 1);
            if matches!(m, Mutation::ReplaceToken(..)) && k < tokens.len() {
                tokens[k] = PIECES[p];
            } else {
                tokens.insert(k, PIECES[p]);
            }
            tokens.join(" ")
        }
        Mutation::DeleteToken(i) => {
            let mut tokens: Vec<&str> = text.split(' ').collect();
            let k = i % tokens.len();
            tokens.remove(k);
            tokens.join(" ")
        }
        Mutation::SwapLines(a, b) => {
            let mut lines: Vec<&str> = text.lines().collect();
            let (a, b) = (a % lines.len(), b % lines.len());
            lines.swap(a, b);
            lines.join("\n")
        }
    }
}

#[test]
fn tagged_template_parses() {
    let m = ok(TAGGED);
    assert_eq!(m.num_faces(), 6);
    assert_eq!(m.creases.len(), 4);
    assert_eq!(m.corners.len(), 1);
    assert_eq!(m.holes, vec![5]);
    assert_eq!(m.options.boundary, BoundaryInterpolation::EdgeOnly);
    assert_eq!(m.options.crease_method, CreaseMethod::Chaikin);
    // Some faces have vt indices and others not: dropped with a warning; and `ec 3 1 2`
    // repeating the edge 0-1 of the first crease tag (the later value is used). The edit is
    // read.
    assert!(m.face_uvs.is_empty());
    assert_eq!(m.edits.len(), 1);
    assert_eq!(m.warnings.len(), 2, "{:?}", m.warnings);
    assert!(
        m.warnings.iter().any(|w| w.starts_with(
            "test.obj:26: ec: the edge between vertices 0 and 1 (0-based) is already tagged \
             with sharpness 2.5 at line 19; the later sharpness 3 is used"
        )),
        "{:?}",
        m.warnings
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn random_ascii_never_panics(s in "[ -~\n\t]{0,200}") {
        let _ = parse_obj(&s, Some("random.obj"));
    }

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        let s = String::from_utf8_lossy(&bytes);
        let _ = parse_obj(&s, None);
    }

    #[test]
    fn random_statements_never_panic(
        lines in proptest::collection::vec(
            proptest::collection::vec(0..PIECES.len(), 0..8), 0..12)
    ) {
        let text: String = lines
            .iter()
            .map(|l| l.iter().map(|&p| PIECES[p]).collect::<Vec<_>>().join(" ") + "\n")
            .collect();
        let _ = parse_obj(&text, Some("pieces.obj"));
    }

    #[test]
    fn mutated_obj_never_panics(muts in proptest::collection::vec(mutation(), 1..6)) {
        let mut text = TAGGED.to_string();
        for m in &muts {
            text = apply(&text, m);
        }
        match parse_obj(&text, Some("mutated.obj")) {
            Ok(mesh) => prop_assert!(mesh.validate().is_ok()),
            Err(e) => {
                // Every error names the file unless it is a whole-mesh error.
                prop_assert!(e.line.is_none() || e.file.as_deref() == Some("mutated.obj"));
                let _ = e.to_string();
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// OpenSubdiv's regression shapes, when the shared corpus is present.

/// Shapes whose faces repeat a vertex (`f 4 3 5 5`): OpenSubdiv tests degenerate faces with
/// them; they load (the repeated vertex makes a degenerate, non-manifold edge).
const DEGENERATE_FACE_SHAPES: &[&str] = &[
    "catmark_nonman_edges.obj",
    "catmark_nonman_quadpole360.obj",
    "catmark_nonman_quadpole64.obj",
    "catmark_nonman_quadpole8.obj",
    "loop_nonman_edges.obj",
];

#[test]
fn opensubdiv_shapes_parse() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/models/opensubdiv");
    if !dir.is_dir() {
        println!("skipping: ../shared not present");
        return;
    }
    let mut paths: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "obj"))
        .collect();
    paths.sort();
    assert!(!paths.is_empty());
    let mut failures = Vec::new();
    let (mut catmark, mut warnings, mut parsed) = (0, 0, 0);
    for path in &paths {
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        let degenerate = DEGENERATE_FACE_SHAPES.contains(&name.as_str());
        catmark += usize::from(name.starts_with("catmark_"));
        match limitray::mesh::obj::read_obj(path) {
            Ok(m) => {
                parsed += 1;
                warnings += m.warnings.len();
                if !m.warnings.is_empty() {
                    println!("{name}: {} warnings", m.warnings.len());
                }
                if m.num_faces() == 0 {
                    failures.push(format!("{name}: no faces"));
                }
                if degenerate {
                    let t = limitray::mesh::topology::Topology::new(
                        m.num_vertices(),
                        &m.face_offsets,
                        &m.face_verts,
                    )
                    .unwrap();
                    let degenerate_edges = t.edge_verts.iter().filter(|e| e[0] == e[1]).count();
                    if degenerate_edges == 0 {
                        failures.push(format!("{name}: no degenerate edge found"));
                    }
                    for (e, ev) in t.edge_verts.iter().enumerate() {
                        if ev[0] == ev[1] && !t.edge_nonmanifold[e] {
                            failures.push(format!("{name}: degenerate edge {e} not non-manifold"));
                        }
                    }
                }
            }
            Err(e) => {
                println!("{name}: error: {e}");
                if name.starts_with("catmark_") || e.kind == ErrorKind::Parse {
                    failures.push(e.to_string());
                }
            }
        }
    }
    println!(
        "{} files ({catmark} catmark_), {parsed} parsed, {warnings} warnings in all",
        paths.len()
    );
    assert!(failures.is_empty(), "failures: {failures:#?}");
}

// --- Hostile input (issue 13) -------------------------------------------------------------

#[test]
fn byte_order_mark_is_skipped() {
    let m = ok(&format!("\u{feff}{CUBE}"));
    assert_eq!(m.num_vertices(), 8);
    assert_eq!(m.positions[0], [-1.0, -1.0, 1.0]);
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
}

#[test]
fn text_that_is_not_obj_is_an_error() {
    let e = err("");
    assert_eq!(e.kind, ErrorKind::Parse);
    assert_eq!(
        e.to_string(),
        "test.obj:1: file: not an OBJ mesh: no 'v' or 'f' statement in 0 statements"
    );
    let e = err("[camera]\nposition = [0, 1, 5]\nfov = 40\n");
    assert_eq!(
        e.to_string(),
        "test.obj:1: file: not an OBJ mesh: no 'v' or 'f' statement in 3 statements (the \
         first, at line 1, is '[camera]')"
    );
    // Mostly prose with a stray line that happens to start with "v".
    let text = "This is a README.\nIt has lines.\nv 0 0 0\nAnd more lines.\n";
    let e = err(text);
    assert!(
        e.to_string()
            .starts_with("test.obj:1: file: not an OBJ mesh: 3 of 4 statements are not OBJ"),
        "{e}"
    );
    // Binary data (a NUL byte), on its line.
    let e = err("v 0 0 0\nv 1 0 0\n\u{0}\u{1}\u{2}");
    assert_eq!(
        e.to_string(),
        "test.obj:3: file: contains a NUL byte: this is binary data, not an OBJ file"
    );
    // Vertices without faces: no surface.
    let e = err("v 0 0 0\nv 1 0 0\nv 0 1 0\n");
    assert_eq!(
        e.to_string(),
        "test.obj:3: file: no faces: 3 vertices but no 'f' statement, so there is no surface"
    );
    // Other OBJ statements (lines, points, free-form curves) are OBJ: warned about, not refused.
    let m = ok(&format!("{CUBE}l 1 2\np 3\ncstype bspline\n"));
    assert_eq!(m.num_faces(), 6);
}

#[test]
fn non_utf8_bytes_are_located() {
    // A Latin-1 comment is harmless; a Latin-1 byte in a number is an error on its line.
    let dir = std::env::temp_dir().join(format!("limitray-obj-utf8-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let good = dir.join("latin1-comment.obj");
    let mut bytes = b"# cr\xe9\xe9 par un outil\n".to_vec();
    bytes.extend_from_slice(CUBE.as_bytes());
    std::fs::write(&good, &bytes).unwrap();
    assert_eq!(limitray::mesh::obj::read_obj(&good).unwrap().num_faces(), 6);
    let bad = dir.join("latin1-number.obj");
    let mut bytes = CUBE.as_bytes().to_vec();
    bytes.extend_from_slice(b"v 1\xb70 0 0\n");
    std::fs::write(&bad, &bytes).unwrap();
    let e = limitray::mesh::obj::read_obj(&bad).unwrap_err();
    assert_eq!(e.line, Some(15), "{e}");
    assert!(e.to_string().contains("invalid number"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn coordinates_outside_the_numeric_contract_are_refused() {
    // 1e39 overflows f32, 1e20 made obvhs panic, 3e13 gave `hit inf`: all beyond 2^32.
    for (x, shown) in [("1e39", "1e39"), ("-1e20", "-1e20"), ("3e13", "3e13")] {
        let text = CUBE.replacen("v 1 1 1", &format!("v {x} 1 1"), 1);
        let e = err(&text);
        assert_eq!(e.line, Some(4), "{e}");
        assert_eq!(e.element.as_deref(), Some("vertex 3"), "{e}");
        assert!(
            e.to_string()
                .contains(&format!("coordinate {shown} 1e0 1e0 is out of range")),
            "{e}"
        );
        assert!(e.to_string().contains("2^32"), "{e}");
    }
    // The bound itself is accepted.
    let text = CUBE.replacen("v 1 1 1", "v 4294967296 -4294967296 1", 1);
    assert_eq!(ok(&text).positions[3], [4294967296.0, -4294967296.0, 1.0]);
}

#[test]
fn repeated_tags_warn_and_the_later_value_wins() {
    let m = ok(&format!(
        "{CUBE}t crease 2/1 0 1 2\nt crease 2/1 1 0 4\nt corner 1/1 2 1\nt corner 1/1 2 3\n"
    ));
    assert_eq!(m.creases.len(), 2);
    assert_eq!(m.warnings.len(), 2, "{:?}", m.warnings);
    assert_eq!(
        m.warnings[0],
        "test.obj:16: tag crease: the edge between vertices 0 and 1 (0-based) is already \
         tagged with sharpness 2 at line 15; the later sharpness 4 is used, as in OpenSubdiv"
    );
    assert!(m.warnings[1].starts_with("test.obj:18: tag corner: vertex 2 (0-based)"));
    // The later sharpness is the one refinement uses.
    let (level, _) = limitray::refine::Level::base(&m, &m.options).unwrap();
    let e = level.topo.find_edge(0, 1).unwrap() as usize;
    assert_eq!(level.edge_sharpness[e], 4.0);
    assert_eq!(level.vertex_sharpness[2], 3.0);
}
