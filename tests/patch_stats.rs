//! Paper 000's Figure 2 as a test: on the Car model (314 creases), the number of patches with
//! single-crease patches grows linearly with the crease sharpness, while isolating the creases
//! by subdivision alone grows exponentially.

mod common;

use limitray::mesh::obj::read_obj;
use limitray::patch::{PatchOptions, PatchTable};

fn patches(sharpness: f32, single_crease: bool) -> usize {
    let models = common::shared_models().unwrap();
    let mut mesh = read_obj(&models.join("opensubdiv/catmark_car.obj")).unwrap();
    for c in &mut mesh.creases {
        c.sharpness = sharpness;
    }
    let t = PatchTable::new(
        &mesh,
        PatchOptions {
            max_level: 10,
            single_crease,
            ..PatchOptions::default()
        },
    )
    .unwrap();
    t.patches.len()
}

#[test]
fn single_crease_patches_grow_linearly_with_sharpness() {
    if common::shared_models().is_none() {
        return;
    }
    let (s0, s2, s4) = (patches(0.0, true), patches(2.0, true), patches(4.0, true));
    let s8 = patches(8.0, true);
    let (n2, n4) = (patches(2.0, false), patches(4.0, false));
    println!("single-crease: {s0} {s2} {s4} {s8}; subdivision only: {s0} {n2} {n4}");
    // Extraordinary vertices are Stam patches wherever they are isolated (no refinement to the
    // maximum level around them), so the crease-free count is small and what creases add
    // shows: with single-crease patches only the crease ends, where sharpness varies, refine,
    // one more ring of patches per unit of sharpness, so the extra patches grow linearly
    // (measured ×1.88 from S = 2 to S = 4 and ×1.93 from S = 4 to S = 8).
    let extra = |n: usize| (n - s0) as f64;
    assert!(s0 < s2 && s2 < s4 && s4 < s8, "{s0} {s2} {s4} {s8}");
    assert!(extra(s4) <= 2.2 * extra(s2), "{s2} {s4} over {s0}");
    assert!(extra(s8) <= 2.2 * extra(s4), "{s4} {s8} over {s0}");
    // Subdivision only: the extra patches grow exponentially, at least ×4 per two levels of
    // sharpness (measured ×5.0 from S = 2 to S = 4), and at S = 2 already outnumber those of
    // single-crease patches at S = 4.
    assert!(extra(n4) > 4.0 * extra(n2), "{n2} {n4} over {s0}");
    assert!(
        n2 > s4,
        "{n2} subdivision-only at S = 2, {s4} single-crease at S = 4"
    );
}
