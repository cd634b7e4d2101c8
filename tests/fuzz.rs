//! Bounded fuzzers (proptest), run with the ordinary tests: arbitrary bytes and
//! structure-aware mutations of valid input for the scene reader and the EXR reader, and
//! hostile numbers in OBJ text carried through the whole pipeline (table, dicing, BVH, a ray).
//! Each property is "no panic, and an accepted input is within the contract"; the case counts
//! keep the file under a few seconds. (The OBJ reader's own byte and statement fuzzers are in
//! `tests/obj_parse.rs`.)

use limitray::bvh::{MeshBvh, Ray};
use limitray::dice::{dice, DiceOptions, DiceRate};
use limitray::mesh::obj::parse_obj;
use limitray::patch::{PatchOptions, PatchTable};
use limitray::render::scene::parse_scene;
use proptest::prelude::*;
use std::path::{Path, PathBuf};

const SCENE: &str = r#"
[render]
width = 64
height = 32
spp = 4
max_depth = 3

[camera]
position = [0, 1, 5]
look_at = [0, 0, 0]
fov = 40
aperture = 0.1

[materials.clay]
type = "diffuse"
albedo = [0.5, 0.4, 0.3]

[materials.gold]
type = "conductor"
preset = "gold"
roughness = 0.3

[[mesh]]
file = "box.obj"
material = "clay"
translate = [1, 0, 0]
rotate = [0, 90, 0]
scale = 2
rate = 4

[[light]]
type = "quad"
corner = [-1, 3, -1]
edge1 = [2, 0, 0]
edge2 = [0, 0, 2]
radiance = [5, 5, 5]

[environment]
map = "sky.exr"
intensity = 2
"#;

/// Tokens a mutation may put in place of a value or key.
const SCENE_PIECES: &[&str] = &[
    "1e39",
    "-1e20",
    "3e13",
    "nan",
    "inf",
    "-inf",
    "0",
    "-1",
    "4294967297",
    "1e-45",
    "\"x\"",
    "[1, 2]",
    "[1, 2, 3, 4]",
    "[]",
    "{}",
    "true",
    "[[mesh]]",
    "[render]",
    "=",
    "\"\"",
    "rate",
    "matrix = [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]",
    "max_level = 99",
    "spp = 0",
    "width = 16385",
    "\u{feff}",
    "\0",
];

fn mutate_scene(text: &str, ops: &[(usize, usize, bool)]) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    for &(line, piece, value_only) in ops {
        let i = line % lines.len();
        let p = SCENE_PIECES[piece % SCENE_PIECES.len()];
        match lines[i].split_once('=') {
            Some((k, _)) if value_only => lines[i] = format!("{k}= {p}"),
            _ => lines.insert(i, p.to_string()),
        }
    }
    lines.join("\n")
}

fn check_scene(text: &str) {
    if let Ok(s) = parse_scene(text, Path::new("fuzz/scene.toml")) {
        // Accepted values are within the contract.
        assert!(s.render.width >= 1 && s.render.width <= 16384);
        assert!(s.render.spp >= 1);
        let p = s.camera.position;
        assert!(limitray::numeric::in_range([
            p.x as f64, p.y as f64, p.z as f64
        ]));
        assert!(s.camera.fov > 0.0 && s.camera.fov < 180.0);
    }
}

fn temp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("limitray-fuzz-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A small valid EXR (R, G, B) to mutate.
fn valid_exr() -> Vec<u8> {
    let d = temp("seed");
    let p = d.join("seed.exr");
    let planes = ["R", "G", "B"]
        .iter()
        .enumerate()
        .map(|(c, n)| (*n, (0..24).map(|i| (i * (c + 1)) as f32 * 0.25).collect()))
        .collect();
    limitray::io::exr::write_planes(&p, 6, 4, planes).unwrap();
    let bytes = std::fs::read(&p).unwrap();
    std::fs::remove_dir_all(&d).ok();
    bytes
}

fn check_exr(bytes: &[u8], name: &str) {
    let d = temp("exr");
    let p = d.join(name);
    std::fs::write(&p, bytes).unwrap();
    if let Ok((w, h, t)) = limitray::io::exr::read_rgb(&p) {
        assert_eq!(t.len(), w * h);
    }
    std::fs::remove_file(&p).ok();
}

/// Numbers for OBJ coordinates: ordinary, at the contract's edge and beyond it.
fn coordinate() -> impl Strategy<Value = String> {
    prop_oneof![
        4 => (-3.0f64..3.0).prop_map(|x| format!("{x}")),
        1 => Just("4294967296".to_string()),
        1 => Just("-4294967295.5".to_string()),
        1 => Just("4294967297".to_string()),
        1 => Just("3e13".to_string()),
        1 => Just("-1e20".to_string()),
        1 => Just("1e39".to_string()),
        1 => Just("1e-300".to_string()),
        1 => Just("nan".to_string()),
        1 => Just("inf".to_string()),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn scene_reader_survives_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        check_scene(&String::from_utf8_lossy(&bytes));
    }

    #[test]
    fn scene_reader_survives_mutations(
        ops in proptest::collection::vec((any::<usize>(), any::<usize>(), any::<bool>()), 1..6)
    ) {
        check_scene(&mutate_scene(SCENE, &ops));
    }

    #[test]
    fn exr_reader_survives_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        // Half of the cases start with the EXR magic number and version, to get past it.
        let mut b = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
        b.extend_from_slice(&bytes);
        check_exr(&b, "magic.exr");
        check_exr(&bytes, "raw.exr");
    }

    #[test]
    fn exr_reader_survives_corruption(
        flips in proptest::collection::vec((any::<usize>(), any::<u8>()), 1..8),
        cut in any::<usize>(),
    ) {
        let mut b = valid_exr();
        for (i, x) in flips {
            let k = i % b.len();
            b[k] ^= x;
        }
        let keep = b.len() - cut % (b.len() / 4);
        b.truncate(keep);
        check_exr(&b, "corrupt.exr");
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 60, failure_persistence: None, ..ProptestConfig::default() })]

    /// A quad (or a pentagon) with hostile coordinates: refused at load, or carried through
    /// table, dicing and BVH with finite results.
    #[test]
    fn hostile_coordinates_through_the_pipeline(
        coords in proptest::collection::vec(coordinate(), 15),
        pentagon in any::<bool>(),
        bom in any::<bool>(),
    ) {
        let n = if pentagon { 5 } else { 4 };
        let mut text = if bom { "\u{feff}".to_string() } else { String::new() };
        for v in 0..n {
            text.push_str(&format!("v {} {} {}\n", coords[3 * v], coords[3 * v + 1], coords[3 * v + 2]));
        }
        text.push_str(if pentagon { "f 1 2 3 4 5\n" } else { "f 1 2 3 4\n" });
        let Ok(mesh) = parse_obj(&text, Some("fuzz.obj")) else {
            return Ok(());
        };
        prop_assert_eq!(mesh.num_vertices(), n);
        prop_assert!(mesh.positions.iter().all(|p| limitray::numeric::in_range(*p)));
        let Ok(table) = PatchTable::new(&mesh, PatchOptions::default()) else {
            return Ok(());
        };
        let Ok(d) = dice(&table, &mesh, &DiceOptions { rate: DiceRate::Uniform(3), max_rate: 8, displace: None }) else {
            return Ok(());
        };
        prop_assert!(d.positions.iter().flatten().all(|c| c.is_finite()));
        let bvh = MeshBvh::build(d);
        let [lo, hi] = bvh.bounds();
        if lo[0] <= hi[0] {
            let c: [f32; 3] = std::array::from_fn(|i| 0.5 * lo[i] + 0.5 * hi[i]);
            let o = [c[0], c[1], c[2] + 1.0 + 2.0 * (hi[2] - lo[2]).abs()];
            if let Some(h) = bvh.intersect(&Ray::new(o, [0.0, 0.0, -1.0])) {
                prop_assert!(h.t.is_finite());
                prop_assert!(h.ng.iter().all(|x| x.is_finite()));
            }
        }
    }
}

/// One hierarchical edit tag from fuzzed parts: kind, path ints (lengths and indices that
/// may leave the mesh), values (hostile numbers included) and operation; three times in four
/// well-formed (values as many as the paths need), so that most cases reach the pipeline.
fn edit_tag() -> impl Strategy<Value = String> {
    let value = prop_oneof![
        Just("0.5".to_string()),
        Just("-3".to_string()),
        Just("2".to_string()),
        Just("1e300".to_string()),
        coordinate()
    ];
    let tag = |kind: &str, ints: &[u32], floats: &[String], op: &str| {
        let strings: Vec<&str> = op.split(' ').collect();
        let mut t = format!("t {kind} {}/{}/{}", ints.len(), floats.len(), strings.len());
        for i in ints {
            t.push_str(&format!(" {i}"));
        }
        for f in floats {
            t.push_str(&format!(" {f}"));
        }
        for s in &strings {
            t.push_str(&format!(" {s}"));
        }
        t
    };
    let kind = prop_oneof![Just("vertexedit"), Just("edgeedit"), Just("faceedit")];
    let ints = proptest::collection::vec(prop_oneof![0u32..6, Just(7), Just(4_000_000_000)], 0..9);
    let floats = proptest::collection::vec(value, 0..7);
    let op = prop_oneof![
        Just("add P value"),
        Just("set P value"),
        Just("set P sharpness"),
        Just("subtract P sharpness"),
        Just("hole"),
        Just("add st value"),
        Just("multiply P value"),
    ];
    let random = (kind, ints, floats, op).prop_map(move |(k, i, f, o)| tag(k, &i, &f, o));
    // (kind, operation, values per path, paths carry an element)
    let form = prop_oneof![
        Just(("vertexedit", "add P value", 3usize, true)),
        Just(("vertexedit", "set P value", 3, true)),
        Just(("vertexedit", "set P sharpness", 1, true)),
        Just(("edgeedit", "add P sharpness", 1, true)),
        Just(("faceedit", "hole", 0, false)),
    ];
    // Paths: face, 1–3 sub-faces, element, inside the mesh (the random tags leave it).
    let path = (0u32..6, proptest::collection::vec(0u32..4, 1..4), 0u32..4);
    let paths = proptest::collection::vec(path, 1..3);
    let pool = proptest::collection::vec(
        prop_oneof![
            Just("0.5".to_string()),
            Just("-3".to_string()),
            Just("2".to_string()),
            Just("12".to_string())
        ],
        6,
    );
    let formed = (form, paths, pool).prop_map(move |((kind, op, width, element), paths, pool)| {
        let mut ints = Vec::new();
        for (f, subs, x) in &paths {
            ints.push(subs.len() as u32 + 1 + element as u32);
            ints.push(*f);
            ints.extend(subs);
            if element {
                ints.push(*x);
            }
        }
        let floats: Vec<String> = (0..width * paths.len())
            .map(|i| pool[i % 6].clone())
            .collect();
        tag(kind, &ints, &floats, op)
    });
    prop_oneof![1 => random, 3 => formed]
}

/// Fuzzed edit sets that parsed with at least one edit (the property must reach the pipeline).
static ACCEPTED: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

#[test]
fn hierarchical_edit_fuzzing_reaches_the_pipeline() {
    hierarchical_edits_through_the_pipeline();
    let n = ACCEPTED.load(std::sync::atomic::Ordering::Relaxed);
    println!("{n} of 200 fuzzed edit sets parsed");
    assert!(n >= 50, "only {n} fuzzed edit sets parsed");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, failure_persistence: None, ..ProptestConfig::default() })]

    /// Fuzzed hierarchical edits on a cube with a pentagon: refused at load with an error, or
    /// honoured by refinement and the patch table (an evaluation and dicing) without a panic
    /// and with finite results.
    #[test]
    fn hierarchical_edits_through_the_pipeline(tags in proptest::collection::vec(edit_tag(), 1..4)) {
        let mut text = String::from(
            "v -1 -1 1\nv 1 -1 1\nv -1 1 1\nv 1 1 1\nv -1 1 -1\nv 1 1 -1\nv -1 -1 -1\nv 1 -1 -1\nv 0 1.5 0\n\
             f 1 2 4 3\nf 3 4 6 9 5\nf 5 6 8 7\nf 7 8 2 1\nf 2 8 6 4\nf 7 1 3 5\n",
        );
        for t in &tags {
            text.push_str(t);
            text.push('\n');
        }
        let Ok(mesh) = parse_obj(&text, Some("fuzz.obj")) else {
            return Ok(());
        };
        if !mesh.edits.is_empty() {
            ACCEPTED.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
        if let Ok(r) = limitray::refine::Refiner::new(&mesh, 4) {
            let p = r.refine_positions(&mesh.positions, 4);
            prop_assert!(p.iter().flatten().all(|c| c.is_finite()));
        }
        let Ok(table) = PatchTable::new(&mesh, PatchOptions::default()) else {
            return Ok(());
        };
        if let Ok(s) = table.eval(limitray::FaceCoord::new(0, 0, 0.3, 0.6)) {
            prop_assert!(s.p.iter().all(|c| c.is_finite()));
        }
        if let Ok(d) = dice(&table, &mesh, &DiceOptions { rate: DiceRate::Uniform(4), max_rate: 8, displace: None }) {
            prop_assert!(d.positions.iter().flatten().all(|c| c.is_finite()));
        }
    }
}
