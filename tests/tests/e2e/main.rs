//! End-to-end tests across the crates: scene files in, `lrr` commands (run in-process through
//! `lrr_cli::run`), operator files, the runtime.

mod accuracy;
mod analytic;
mod building;
mod capi;
mod cornell;
mod display;
mod files;
mod furnace;
mod fuzz_replay;
mod gltf;
mod gltf_textures;
mod import;
mod lights;
mod meshing;
mod real_scenes;
mod reference;
mod refine;
mod render_reference;
mod resilience;
mod scene_description;
mod scene_lightmap;
mod shards;
mod storage;
mod tessellation;
mod util;
