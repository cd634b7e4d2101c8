//! Writes `limitray::mesh::generate::star(n, r)` (a disc of `n` sectors of `r × r` quads
//! around one interior vertex of valence `n`) as OBJ on standard output:
//!
//!     cargo run --release --example star -- N R > starN.obj
//!
//! `scripts/bench-ev.sh` measures evaluation near extraordinary vertices on these.

use limitray::mesh::{generate, shapes};
use std::io::Write;

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("usage: star N R (integers)"))
        .collect();
    let [n, r] = args[..] else {
        panic!("usage: star N R");
    };
    assert!(n >= 3 && r >= 1, "star: needs N >= 3 and R >= 1");
    let mesh = generate::star(n, r);
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    shapes::write_tagged_obj(&mut out, &mesh, &format!("generate::star({n}, {r})")).unwrap();
    out.flush().unwrap();
}
