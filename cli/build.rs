// With the cargo feature `embree`: an rpath to Embree 4 for the `lrr` binary and the test
// binaries of this package (precompute/build.rs adds the link search path, which propagates;
// link arguments do not). tests/build.rs includes this file.

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
    let dir = dir.canonicalize().unwrap_or(dir);
    println!("cargo:rustc-link-arg=-Wl,-rpath,{}", dir.display());
}
