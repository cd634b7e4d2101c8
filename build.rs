//! Build script: links Embree 4 when the `embree` feature is on (and does nothing otherwise).
//!
//! The library comes from `scripts/setup-embree.sh`, which extracts it into `.embree/lib/`
//! (or `$LIMITRAY_EMBREE_LIB` when set). The rpath makes the binaries find it at run time
//! without `LD_LIBRARY_PATH`.

use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=LIMITRAY_EMBREE_LIB");
    if std::env::var_os("CARGO_FEATURE_EMBREE").is_none() {
        return;
    }
    let lib = match std::env::var_os("LIMITRAY_EMBREE_LIB") {
        Some(dir) => PathBuf::from(dir),
        None => PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap()).join(".embree/lib"),
    };
    let so = lib.join("libembree4.so");
    println!("cargo:rerun-if-changed={}", so.display());
    if !so.exists() {
        eprintln!(
            "error: the `embree` feature needs Embree 4.4 in {}: run scripts/setup-embree.sh",
            lib.display()
        );
        panic!(
            "Embree 4 not found ({} is missing): run scripts/setup-embree.sh",
            so.display()
        );
    }
    let lib = lib.canonicalize().unwrap_or(lib);
    println!("cargo:rustc-link-search=native={}", lib.display());
    println!("cargo:rustc-link-lib=dylib=embree4");
    println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib.display());
}
