//! Random control meshes for the differential test against OpenSubdiv Far: small closed and
//! open meshes of quads, triangles and n-gons with valences 2 to 12 and poles, random
//! semi-sharp and infinitely sharp crease chains that end, cross and meet, corners, holes, all
//! three boundary modes and both crease rules. Written as OBJ with OpenSubdiv's tags so that
//! both sides read the same text.

use limitray::harness::rng::SplitMix64;
use std::collections::BTreeMap;
use std::fmt::Write;

/// The generator's random stream: the library's SplitMix64 from a scrambled seed, with the
/// draws the generator needs (`below` by remainder, which the recorded seeds depend on).
#[derive(Clone, Debug)]
pub struct Rng(SplitMix64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(SplitMix64::new(seed ^ 0x9e37_79b9_7f4a_7c15))
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }
    /// Uniform in `0..n` (`n > 0`).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    /// Uniform in `[0, 1)`.
    pub fn unit(&mut self) -> f64 {
        self.0.next_f64()
    }
    pub fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }
    pub fn range(&mut self, lo: usize, hi: usize) -> usize {
        lo + self.below(hi - lo + 1)
    }
}

/// Which generator features are on (the ones the library handles).
#[derive(Clone, Copy, Debug)]
pub struct Features {
    /// `t smoothtriangles 0/0/1 smooth` on some meshes with triangles.
    pub smooth_triangles: bool,
    /// Turn Chaikin meshes with `interpolateboundary 0` into the other boundary modes (as the
    /// first regression tests were found; Far's adaptive patches are approximate on such
    /// meshes, see `chaikin_with_boundary_none_far_is_approximate`).
    pub skip_chaikin_boundary_none: bool,
    /// Non-manifold edges (a fin face on an existing edge) and degenerate faces (a triangle
    /// whose last vertex is repeated, as in the corpus's catmark_nonman_quadpole shapes), drawn
    /// from a stream of their own so that the other features' meshes stay as they were.
    pub nonmanifold: bool,
}

/// A generated control mesh with its tags.
#[derive(Clone, Debug, Default)]
pub struct GenMesh {
    pub positions: Vec<[f64; 3]>,
    pub faces: Vec<Vec<u32>>,
    /// Edge (low, high) → sharpness.
    pub creases: BTreeMap<(u32, u32), f32>,
    pub corners: BTreeMap<u32, f32>,
    pub holes: Vec<u32>,
    /// `interpolateboundary`: 0 none, 1 edge-and-corner, 2 edge-only.
    pub boundary: u8,
    pub chaikin: bool,
    pub smooth_triangles: bool,
    /// What the generator built, for messages.
    pub recipe: String,
}

fn key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

impl GenMesh {
    /// A parsed mesh (positions, faces, creases, corners, holes and options) as a case mesh.
    pub fn from_control_mesh(m: &limitray::mesh::ControlMesh) -> GenMesh {
        use limitray::mesh::{BoundaryInterpolation, CreaseMethod};
        GenMesh {
            positions: m.positions.clone(),
            faces: (0..m.num_faces()).map(|f| m.face(f).to_vec()).collect(),
            creases: m
                .creases
                .iter()
                .map(|c| (key(c.v0, c.v1), c.sharpness))
                .collect(),
            corners: m.corners.iter().map(|c| (c.vertex, c.sharpness)).collect(),
            holes: m.holes.clone(),
            boundary: match m.options.boundary {
                BoundaryInterpolation::None => 0,
                BoundaryInterpolation::EdgeAndCorner => 1,
                BoundaryInterpolation::EdgeOnly => 2,
            },
            chaikin: m.options.crease_method == CreaseMethod::Chaikin,
            smooth_triangles: m.options.smooth_triangles,
            recipe: String::from("parsed mesh"),
        }
    }

    /// The mesh as OBJ text with OpenSubdiv tags (0-based tag indices).
    pub fn to_obj(&self) -> String {
        let mut s = String::new();
        writeln!(s, "# limitray oracle mesh: {}", self.recipe).unwrap();
        for p in &self.positions {
            writeln!(s, "v {:?} {:?} {:?}", p[0], p[1], p[2]).unwrap();
        }
        for f in &self.faces {
            s.push('f');
            for &v in f {
                write!(s, " {}", v + 1).unwrap();
            }
            s.push('\n');
        }
        for (&(a, b), &w) in &self.creases {
            writeln!(s, "t crease 2/1/0 {a} {b} {w:?}").unwrap();
        }
        for (&v, &w) in &self.corners {
            writeln!(s, "t corner 1/1/0 {v} {w:?}").unwrap();
        }
        for &h in &self.holes {
            writeln!(s, "t hole 1/0/0 {h}").unwrap();
        }
        writeln!(s, "t interpolateboundary 1/0/0 {}", self.boundary).unwrap();
        if self.chaikin {
            writeln!(s, "t creasemethod 0/0/1 chaikin").unwrap();
        }
        if self.smooth_triangles {
            writeln!(s, "t smoothtriangles 0/0/1 smooth").unwrap();
        }
        s
    }

    /// Every edge of the faces, once, as (low, high).
    pub fn edges(&self) -> Vec<(u32, u32)> {
        let mut set = std::collections::BTreeSet::new();
        for f in &self.faces {
            for i in 0..f.len() {
                set.insert(key(f[i], f[(i + 1) % f.len()]));
            }
        }
        set.into_iter().collect()
    }

    /// Drops vertices no face uses, tags on edges, vertices and faces that are gone.
    pub fn compact(&mut self) {
        let mut used = vec![false; self.positions.len()];
        for f in &self.faces {
            for &v in f {
                used[v as usize] = true;
            }
        }
        let mut map = vec![u32::MAX; self.positions.len()];
        let mut pos = Vec::new();
        for (v, &u) in used.iter().enumerate() {
            if u {
                map[v] = pos.len() as u32;
                pos.push(self.positions[v]);
            }
        }
        self.positions = pos;
        for f in &mut self.faces {
            for v in f.iter_mut() {
                *v = map[*v as usize];
            }
        }
        let edges: std::collections::BTreeSet<_> = self.edges().into_iter().collect();
        self.creases = std::mem::take(&mut self.creases)
            .into_iter()
            .filter_map(|((a, b), w)| {
                let (a, b) = (map[a as usize], map[b as usize]);
                (a != u32::MAX && b != u32::MAX && edges.contains(&key(a, b)))
                    .then_some((key(a, b), w))
            })
            .collect();
        self.corners = std::mem::take(&mut self.corners)
            .into_iter()
            .filter_map(|(v, w)| (map[v as usize] != u32::MAX).then_some((map[v as usize], w)))
            .collect();
        let nf = self.faces.len() as u32;
        self.holes.retain(|&h| h < nf);
    }

    fn add_vertex(&mut self, p: [f64; 3]) -> u32 {
        self.positions.push(p);
        (self.positions.len() - 1) as u32
    }

    fn centroid(&self, f: &[u32]) -> [f64; 3] {
        let mut c = [0.0; 3];
        for &v in f {
            for (ck, pk) in c.iter_mut().zip(self.positions[v as usize]) {
                *ck += pk / f.len() as f64;
            }
        }
        c
    }
}

/// An open `w × h` grid, wrapped in u (a tube) and v (a torus) on request.
fn grid(w: usize, h: usize, wrap_u: bool, wrap_v: bool) -> GenMesh {
    let nu = if wrap_u { w } else { w + 1 };
    let nv = if wrap_v { h } else { h + 1 };
    let mut m = GenMesh::default();
    for j in 0..nv {
        for i in 0..nu {
            let (x, y) = (i as f64, j as f64);
            let p = match (wrap_u, wrap_v) {
                (false, _) => [x, y, 0.0],
                (true, false) => {
                    let a = std::f64::consts::TAU * x / w as f64;
                    [a.cos() * w as f64 / 4.0, a.sin() * w as f64 / 4.0, y]
                }
                (true, true) => {
                    let a = std::f64::consts::TAU * x / w as f64;
                    let b = std::f64::consts::TAU * y / h as f64;
                    let r = 2.0 + b.cos();
                    [r * a.cos(), r * a.sin(), b.sin()]
                }
            };
            m.positions.push(p);
        }
    }
    let id = |i: usize, j: usize| ((j % nv) * nu + (i % nu)) as u32;
    for j in 0..h {
        for i in 0..w {
            m.faces
                .push(vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    m
}

/// A disk of quads around one vertex of valence `n` (2..12), open.
fn fan(n: usize) -> GenMesh {
    let mut m = GenMesh::default();
    m.positions.push([0.0, 0.0, 0.3]);
    for i in 0..n {
        let a = std::f64::consts::TAU * i as f64 / n as f64;
        m.positions.push([a.cos(), a.sin(), 0.0]);
    }
    for i in 0..n {
        let a = std::f64::consts::TAU * (i as f64 + 0.5) / n as f64;
        m.positions.push([1.6 * a.cos(), 1.6 * a.sin(), -0.2]);
    }
    let r = |i: usize| (1 + i % n) as u32;
    let o = |i: usize| (1 + n + i % n) as u32;
    for i in 0..n {
        m.faces.push(vec![0, r(i), o(i), r(i + 1)]);
    }
    m
}

/// A closed prism over an `n`-gon (n-gon caps, quad sides).
fn prism(n: usize) -> GenMesh {
    let mut m = GenMesh::default();
    for z in [0.0, 1.0] {
        for i in 0..n {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            m.positions.push([a.cos(), a.sin(), z]);
        }
    }
    let b = |i: usize| (i % n) as u32;
    let t = |i: usize| (n + i % n) as u32;
    m.faces.push((0..n).rev().map(b).collect());
    m.faces.push((0..n).map(t).collect());
    for i in 0..n {
        m.faces.push(vec![b(i), b(i + 1), t(i + 1), t(i)]);
    }
    m
}

/// A closed bipyramid: two poles of valence `n` joined by a ring, all triangles.
fn bipyramid(n: usize) -> GenMesh {
    let mut m = GenMesh::default();
    m.positions.push([0.0, 0.0, 1.0]);
    m.positions.push([0.0, 0.0, -1.0]);
    for i in 0..n {
        let a = std::f64::consts::TAU * i as f64 / n as f64;
        m.positions.push([a.cos(), a.sin(), 0.0]);
    }
    let r = |i: usize| (2 + i % n) as u32;
    for i in 0..n {
        m.faces.push(vec![0, r(i), r(i + 1)]);
        m.faces.push(vec![1, r(i + 1), r(i)]);
    }
    m
}

/// Splits quad `f` (a, b, c, d) into (a, b, c, x) and (a, x, c, d): `x` has valence 2.
fn valence2(m: &mut GenMesh, f: usize) {
    let q = m.faces[f].clone();
    let x = m.add_vertex(m.centroid(&q));
    m.faces[f] = vec![q[0], q[1], q[2], x];
    m.faces.push(vec![q[0], x, q[2], q[3]]);
}

/// Splits quad `f` along its diagonal into two triangles.
fn triangulate(m: &mut GenMesh, f: usize) {
    let q = m.faces[f].clone();
    m.faces[f] = vec![q[0], q[1], q[2]];
    m.faces.push(vec![q[0], q[2], q[3]]);
}

/// Replaces face `f` by a fan of triangles around a new vertex (a pole of its size).
fn poke(m: &mut GenMesh, f: usize) {
    let q = m.faces[f].clone();
    let mut c = m.centroid(&q);
    c[2] += 0.2;
    let x = m.add_vertex(c);
    let n = q.len();
    m.faces[f] = vec![q[0], q[1], x];
    for i in 1..n {
        m.faces.push(vec![q[i], q[(i + 1) % n], x]);
    }
}

/// Merges face `f` with a neighbour across one shared edge into an n-gon (n ≤ 8), when they
/// share exactly that edge.
fn merge(m: &mut GenMesh, f: usize, rng: &mut Rng) {
    let a = m.faces[f].clone();
    let n = a.len();
    let start = rng.below(n);
    for d in 0..n {
        let i = (start + d) % n;
        let (u, v) = (a[i], a[(i + 1) % n]);
        let Some(g) = (0..m.faces.len()).find(|&g| {
            g != f && {
                let b = &m.faces[g];
                (0..b.len()).any(|j| b[j] == v && b[(j + 1) % b.len()] == u)
            }
        }) else {
            continue;
        };
        let b = m.faces[g].clone();
        let shared = a.iter().filter(|x| b.contains(x)).count();
        if shared != 2 || n + b.len() - 2 > 8 {
            continue;
        }
        // a: ... u v ...; b: ... v u ...; merged: a from v round to u, then b from u to v
        // exclusive of both.
        let j = (0..b.len())
            .find(|&j| b[j] == v && b[(j + 1) % b.len()] == u)
            .unwrap();
        let mut out = Vec::new();
        for k in 0..n {
            out.push(a[(i + 1 + k) % n]);
        }
        for k in 2..b.len() {
            out.push(b[(j + k) % b.len()]);
        }
        m.faces[f] = out;
        m.faces.remove(g);
        return;
    }
}

fn sharpness(rng: &mut Rng) -> f32 {
    match rng.below(6) {
        0 => 10.0,
        1 => rng.range(1, 3) as f32,
        2 => (rng.unit() * 0.9 + 0.05) as f32,
        _ => ((rng.unit() * 4.0 * 64.0).round() / 64.0 + 0.01) as f32,
    }
}

/// One random mesh for `seed`.
pub fn generate(seed: u64, features: Features) -> GenMesh {
    let mut rng = Rng::new(seed);
    let base = rng.below(6);
    let mut m = match base {
        0 => grid(rng.range(1, 4), rng.range(1, 3), false, false),
        1 => grid(rng.range(3, 5), rng.range(1, 3), true, false),
        2 => grid(rng.range(3, 5), rng.range(3, 4), true, true),
        3 => fan(rng.range(2, 12)),
        4 => prism(rng.range(3, 7)),
        _ => bipyramid(rng.range(3, 8)),
    };
    let mut recipe = format!("seed {seed} base {base}");
    for _ in 0..rng.below(4) {
        let f = rng.below(m.faces.len());
        let op = rng.below(4);
        let quad = m.faces[f].len() == 4;
        match op {
            0 if quad => valence2(&mut m, f),
            1 if quad => triangulate(&mut m, f),
            2 if m.faces.len() < 40 => poke(&mut m, f),
            3 => merge(&mut m, f, &mut rng),
            _ => continue,
        }
        write!(recipe, " op{op}@{f}").unwrap();
    }
    // Jitter the positions so that nothing is symmetric or planar by accident.
    for p in &mut m.positions {
        for c in p.iter_mut() {
            *c += (rng.unit() - 0.5) * 0.3;
        }
    }
    // Crease chains: random walks that end anywhere, cross and meet.
    let edges = m.edges();
    let mut adj: BTreeMap<u32, Vec<u32>> = BTreeMap::new();
    for &(a, b) in &edges {
        adj.entry(a).or_default().push(b);
        adj.entry(b).or_default().push(a);
    }
    for _ in 0..rng.below(5) {
        let mut v = edges[rng.below(edges.len())].0;
        let constant = rng.chance(0.6);
        let mut s = sharpness(&mut rng);
        for _ in 0..rng.range(1, 5) {
            let next = &adj[&v];
            let w = next[rng.below(next.len())];
            if !constant {
                s = sharpness(&mut rng);
            }
            m.creases.insert(key(v, w), s);
            v = w;
        }
    }
    for _ in 0..rng.below(3) {
        if rng.chance(0.5) {
            let v = rng.below(m.positions.len()) as u32;
            m.corners.insert(v, sharpness(&mut rng));
        }
    }
    if m.faces.len() > 2 && rng.chance(0.2) {
        for _ in 0..rng.range(1, 2) {
            m.holes.push(rng.below(m.faces.len()) as u32);
        }
        m.holes.sort();
        m.holes.dedup();
    }
    m.boundary = rng.below(3) as u8;
    m.chaikin = rng.chance(0.3);
    if features.skip_chaikin_boundary_none && m.chaikin && m.boundary == 0 {
        // Keep the mesh, change the mode.
        m.boundary = 1 + rng.below(2) as u8;
    }
    if features.smooth_triangles && m.faces.iter().any(|f| f.len() == 3) {
        m.smooth_triangles = rng.chance(0.5);
    }
    if features.nonmanifold {
        let mut r2 = Rng::new(seed ^ 0x6e6f_6e6d_616e_0000);
        if r2.chance(0.15) {
            fin(&mut m, &mut r2);
            recipe.push_str(" fin");
        }
        if r2.chance(0.15) {
            if let Some(f) = (0..m.faces.len()).find(|&f| m.faces[f].len() == 3) {
                let last = m.faces[f][2];
                m.faces[f].push(last);
                write!(recipe, " degenerate@{f}").unwrap();
            }
        }
    }
    m.compact();
    m.recipe = recipe;
    m
}

/// Adds a quad "fin" on a random edge of the mesh: the edge then has one face more (three on
/// a closed mesh), which makes it non-manifold.
fn fin(m: &mut GenMesh, rng: &mut Rng) {
    let edges = m.edges();
    let (a, b) = edges[rng.below(edges.len())];
    let (pa, pb) = (m.positions[a as usize], m.positions[b as usize]);
    let off = [0.1, 0.35, 0.25];
    let c = m.add_vertex([pb[0] + off[0], pb[1] + off[1], pb[2] + off[2]]);
    let d = m.add_vertex([pa[0] + off[0], pa[1] + off[1], pa[2] + off[2]]);
    m.faces.push(vec![a, b, c, d]);
}

/// `(face, k, u, v)` samples over the mesh, biased towards corners, edges and points close to
/// them (where patches of different kinds and levels meet).
pub fn samples(m: &GenMesh, rng: &mut Rng, count: usize) -> Vec<(usize, usize, f64, f64)> {
    let coord = |rng: &mut Rng| -> f64 {
        match rng.below(8) {
            0 => 0.0,
            1 => 1.0,
            2 => 0.5f64.powi(rng.range(1, 14) as i32),
            3 => 1.0 - 0.5f64.powi(rng.range(1, 14) as i32),
            4 => 0.5,
            _ => rng.unit(),
        }
    };
    (0..count)
        .map(|_| {
            let f = rng.below(m.faces.len());
            let n = m.faces[f].len();
            let k = if n == 4 { 0 } else { rng.below(n) };
            (f, k, coord(rng), coord(rng))
        })
        .collect()
}

/// A random triangle mesh for the Loop scheme: the mesh of `generate(seed, ..)` (without the
/// smooth-triangle tag, which Loop ignores) with every quad split along a random diagonal and
/// every larger face poked into a fan around a lifted centre; a hole face's triangles are all
/// holes, and creases stay on the edges that remain.
pub fn generate_loop(seed: u64, features: Features) -> GenMesh {
    let src = generate(
        seed,
        Features {
            smooth_triangles: false,
            ..features
        },
    );
    let mut rng = Rng::new(seed ^ 0x6c6f_6f70_0000_0000);
    let mut m = GenMesh {
        positions: src.positions.clone(),
        creases: src.creases.clone(),
        corners: src.corners.clone(),
        boundary: src.boundary,
        chaikin: src.chaikin,
        ..GenMesh::default()
    };
    for (f, face) in src.faces.iter().enumerate() {
        let first = m.faces.len();
        match face.len() {
            3 => m.faces.push(face.clone()),
            4 => {
                let r = rng.below(2);
                let q: Vec<u32> = (0..4).map(|i| face[(i + r) % 4]).collect();
                m.faces.push(vec![q[0], q[1], q[2]]);
                m.faces.push(vec![q[0], q[2], q[3]]);
            }
            n => {
                let mut c = m.centroid(face);
                c[2] += 0.15;
                let x = m.add_vertex(c);
                for i in 0..n {
                    m.faces.push(vec![face[i], face[(i + 1) % n], x]);
                }
            }
        }
        if src.holes.contains(&(f as u32)) {
            m.holes.extend(first as u32..m.faces.len() as u32);
        }
    }
    m.compact();
    m.recipe = format!("{}, triangulated for Loop", src.recipe);
    m
}
