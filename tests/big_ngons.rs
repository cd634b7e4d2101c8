//! Faces with more than 256 vertices (issue 13: the sub-face index was a `u8`, which left
//! holes, folded triangles and wrong `k` on hits). A closed n-gon prism (two n-gon caps, n
//! quads) for n = 257 and 1000 is diced and traced: every ray aimed into the top cap hits it,
//! from the side the face winds towards, and every hit's `(face, k, u, v)` evaluates back to
//! the hit point.

use limitray::bvh::{MeshBvh, Ray};
use limitray::dice::{dice, DiceOptions, DiceRate};
use limitray::mesh::MeshBuilder;
use limitray::patch::{PatchOptions, PatchTable};
use limitray::FaceCoord;

/// A prism of height 0.5 over the regular n-gon of radius 1: top cap (face 0, counter-
/// clockwise seen from +z), bottom cap (face 1), then the sides. The rims are infinitely
/// sharp creases, so the caps' limit surfaces are exactly planar (the crease rule uses rim
/// points only).
fn prism(n: usize) -> limitray::mesh::ControlMesh {
    let mut p = Vec::with_capacity(2 * n);
    for z in [0.25, -0.25] {
        for i in 0..n {
            let a = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
            p.push([a.cos(), a.sin(), z]);
        }
    }
    let n32 = n as u32;
    let mut sizes = vec![n, n];
    let mut idx: Vec<u32> = (0..n32).collect();
    idx.extend((0..n32).rev().map(|i| n32 + i));
    for i in 0..n32 {
        let j = (i + 1) % n32;
        sizes.push(4);
        idx.extend_from_slice(&[i, n32 + i, n32 + j, j]);
    }
    let mut b = MeshBuilder::new().positions(p).faces(&sizes, &idx);
    for i in 0..n32 {
        let j = (i + 1) % n32;
        b = b.crease(i, j, 10.0).crease(n32 + i, n32 + j, 10.0);
    }
    b.build().unwrap()
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

#[test]
fn ngons_of_257_and_1000_sides_dice_and_trace_correctly() {
    for n in [257usize, 1000] {
        let mesh = prism(n);
        let table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
        let d = dice(
            &table,
            &mesh,
            &DiceOptions {
                rate: DiceRate::Uniform(8),
                max_rate: 64,
                displace: None,
            },
        )
        .unwrap();
        // Every sub-face of both caps is diced: each contributes triangles with its own k.
        let mut ks = vec![false; 2 * n];
        for t in &d.tri_info {
            if t.face < 2 {
                assert!((t.k as usize) < n, "k = {} on a {n}-gon", t.k);
                ks[t.face as usize * n + t.k as usize] = true;
            }
        }
        assert!(
            ks.iter().all(|&x| x),
            "{n}-gon: some sub-faces have no triangles"
        );
        let bvh = MeshBvh::build(d);
        let mut rng = limitray::harness::rng::SplitMix64(n as u64);
        let mut hits_per_k = vec![0u32; n];
        for _ in 0..4000 {
            // Straight down onto the top cap, inside radius 0.6 (well inside the rim).
            let (r, a) = (
                0.6 * rng.next_f64().sqrt(),
                2.0 * std::f64::consts::PI * rng.next_f64(),
            );
            let o = [(r * a.cos()) as f32, (r * a.sin()) as f32, 3.0];
            let h = bvh
                .intersect(&Ray::new(o, [0.0, 0.0, -1.0]))
                .unwrap_or_else(|| panic!("{n}-gon: a ray at {o:?} went through the cap"));
            assert_eq!(h.face, 0, "{n}-gon: ray at {o:?}");
            assert!((h.k as usize) < n);
            hits_per_k[h.k as usize] += 1;
            // Wound counter-clockwise seen from +z: the geometric normal points up (a folded
            // triangle would point down).
            assert!(h.ng[2] > 0.99, "{n}-gon: ng = {:?}", h.ng);
            let p = [o[0] as f64, o[1] as f64, (o[2] - h.t) as f64];
            let s = table
                .eval(FaceCoord::new(h.face, h.k, h.u as f64, h.v as f64))
                .unwrap();
            // The hit's parameters evaluate back to the hit point: the cap is planar, so
            // only the parameterisation's non-linearity across one micro-triangle separates
            // them; bound: a quarter of the hit triangle's longest edge. (A `k` wrapped at
            // 256 lands about 256 sectors, 1.6 rad, away.)
            let tri = bvh.diced.triangles[h.triangle as usize]
                .map(|i| bvh.diced.positions[i as usize].map(|c| c as f64));
            let longest = (0..3)
                .map(|i| dist(tri[i], tri[(i + 1) % 3]))
                .fold(0.0, f64::max);
            let e = dist(s.p, p);
            assert!(
                e <= 0.25 * longest + 1e-6,
                "{n}-gon: hit {p:?} evaluates to {:?} ({e} > {longest}/4)",
                s.p
            );
            // Sub-face k spans the sector around vertex k, from edge midpoint k-1/2 to k+1/2
            // (straight spokes by symmetry). Checked away from the centre, where the f32
            // hit point's angle is accurate to far below the 1e-3-sector slack.
            if p[0].hypot(p[1]) < 0.05 {
                continue;
            }
            let angle =
                (p[1].atan2(p[0]) / (2.0 * std::f64::consts::PI) * n as f64).rem_euclid(n as f64);
            let off = (angle - h.k as f64).rem_euclid(n as f64);
            assert!(
                !(0.5 + 1e-3..n as f64 - 0.5 - 1e-3).contains(&off),
                "{n}-gon: hit at sector {angle:.3} reported in sub-face {}",
                h.k
            );
        }
        // Rays land in sub-faces all around, including those past 256.
        assert!(hits_per_k[256..].iter().any(|&c| c > 0), "{n}-gon");
    }
}
