//! With the cargo feature `embree` only: tells the linker where Embree 4 is (search path and
//! rpath, so binaries and tests run without LD_LIBRARY_PATH). The folder is `LRR_EMBREE_DIR`,
//! by default `.embree/` in the repository, which scripts/setup-embree.sh fills. Without the
//! feature this script does nothing. (tests/build.rs repeats the rpath for the lrr-tests
//! binaries: link arguments do not propagate to dependent packages.)

use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=LRR_EMBREE_DIR");
    if std::env::var_os("CARGO_FEATURE_EMBREE").is_none() {
        return;
    }
    let dir = match std::env::var_os("LRR_EMBREE_DIR") {
        Some(d) => PathBuf::from(d),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../.embree"),
    };
    let lib = dir.join("libembree4.so");
    println!("cargo:rerun-if-changed={}", lib.display());
    if !lib.exists() {
        eprintln!(
            "error: the `embree` feature needs Embree 4, and {} does not exist.\n\
             Run scripts/setup-embree.sh (it downloads the library into .embree/), or set \
             LRR_EMBREE_DIR to a folder holding libembree4.so. Without the feature, lrr uses \
             its pure-Rust visibility (--visibility obvhs).",
            lib.display()
        );
        std::process::exit(1);
    }
    let dir = dir.canonicalize().unwrap_or(dir);
    println!("cargo:rustc-link-search=native={}", dir.display());
    println!("cargo:rustc-link-arg=-Wl,-rpath,{}", dir.display());
}
