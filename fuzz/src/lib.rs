//! Support for the fuzz targets of the bake crates in `fuzz_targets/`: the shared bodies
//! ([`harness`]: the scene importers and the bake; [`shards`]: shard parts, plans and
//! checkpoints; [`cli`]: the files only the command line reads; all also replayed by the
//! end-to-end tests) and a scratch folder per process. The operator file, kernel and C
//! interface targets are in `runtime/`.

pub mod cli;
pub mod harness;
#[path = "../reader.rs"]
pub mod reader;
pub mod shards;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// A folder of this process for the files the importer targets write (created once).
pub fn scratch_dir(name: &str) -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("lrr-fuzz-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("cannot create the fuzz scratch folder");
        harness::prepare_scene_dir(&dir);
        dir
    })
}
