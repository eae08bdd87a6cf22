// The same rpath to Embree as the `lrr` binary's (feature `embree`): one build script, two packages.
include!("../cli/build.rs");
