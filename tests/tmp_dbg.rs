use limitray::mesh::{Options, Scheme};
use limitray::patch::approx::{Approximation, TriApprox};
use limitray::patch::LoopSurface;
#[test]
fn dbg() {
    let m = limitray::mesh::obj::read_obj(std::path::Path::new("scenes/meshes/rounded_box_s2_tri.obj")).unwrap();
    let e = LoopSurface::new(&m, Options { scheme: Scheme::Loop, ..m.options }).unwrap();
    for k in [Approximation::Pn, Approximation::Gregory] {
        let s = TriApprox::new(&e, k).unwrap();
        let g = s.patch(0).unwrap();
        println!("{k}: p {:?}\n e+ {:?}\n e- {:?}\n f+ {:?}\n f- {:?}", g.p, g.e_plus, g.e_minus, g.f_plus, g.f_minus);
    }
    for (u,v) in [(0.0,0.0),(1.0,0.0),(0.0,1.0),(0.5,0.0)] {
        let s = e.eval(limitray::FaceCoord::new(0,0,u,v)).unwrap();
        println!("exact at {u},{v}: {:?} du {:?} dv {:?}", s.p, s.du, s.dv);
    }
}
