//! The fuzz corpora as ordinary tests: every seed (`fuzz/seeds/<target>/`) and every committed
//! crash input (`fuzz/regressions/<target>/`) runs through the same function as the cargo-fuzz
//! target of that name (fuzz/src/harness.rs for the scene importers and the bake, shards.rs for
//! shard parts, plans and checkpoints, cli.rs for the command line's own input files;
//! fuzz/runtime/src/operators.rs, kernels.rs, trace.rs and capi.rs for the runtime and its C
//! interface, included here), on stable, in CI. Each must be accepted or refused with an
//! error, never panic.

use std::path::{Path, PathBuf};

use crate::util::{root, temp_dir};

#[path = "../../../fuzz/runtime/src/capi.rs"]
mod capi;
#[path = "../../../fuzz/src/cli.rs"]
mod cli;
#[path = "../../../fuzz/src/harness.rs"]
mod harness;
#[path = "../../../fuzz/runtime/src/kernels.rs"]
mod kernels;
#[path = "../../../fuzz/runtime/src/operators.rs"]
mod operators;
#[path = "../../../fuzz/reader.rs"]
mod reader;
#[path = "../../../fuzz/src/shards.rs"]
mod shards;
#[path = "../../../fuzz/runtime/src/trace.rs"]
mod trace;

const TARGETS: [&str; 16] = [
    "kernels",
    "operator_bytes",
    "operator_mutated",
    "trace_mutated",
    "capi_calls",
    "obj_import",
    "scene_description",
    "gltf_import",
    "bake_geometry",
    "shard_part",
    "shard_plan",
    "checkpoint_resume",
    "probe_points",
    "emission_json",
    "reference_json",
    "animation_toml",
];

/// Runs one input through the target's body; `true` when it was accepted.
fn run(target: &str, data: &[u8], dir: &Path) -> bool {
    match target {
        "kernels" => kernels::kernels(data),
        "operator_bytes" => operators::operator_bytes(data),
        "operator_mutated" => operators::operator_mutated(data),
        "trace_mutated" => trace::trace_mutated(data),
        "capi_calls" => capi::capi_calls(data),
        "obj_import" => harness::obj_import(data, dir),
        "scene_description" => harness::scene_description(data, dir),
        "gltf_import" => harness::gltf_import(data, dir),
        "bake_geometry" => harness::bake_geometry(data, dir),
        "shard_part" => shards::shard_part(data, dir),
        "shard_plan" => shards::shard_plan(data, dir),
        "checkpoint_resume" => shards::checkpoint_resume(data, dir),
        "probe_points" => cli::probe_points(data, dir),
        "emission_json" => cli::emission_json(data, dir),
        "reference_json" => cli::reference_json(data, dir),
        "animation_toml" => cli::animation_toml(data, dir),
        other => panic!("fuzz folder {other} is not a fuzz target"),
    }
}

/// The files of `fuzz/<folder>/<target>/`, sorted; none when the folder does not exist.
fn inputs(folder: &str, target: &str) -> Vec<PathBuf> {
    let dir = root().join("fuzz").join(folder).join(target);
    let Ok(entries) = std::fs::read_dir(&dir) else {
        return Vec::new();
    };
    let mut files: Vec<PathBuf> = entries
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file() && !p.file_name().unwrap().to_str().unwrap().starts_with('.'))
        .collect();
    files.sort();
    files
}

#[test]
fn every_fuzz_folder_names_a_target() {
    for folder in ["seeds", "regressions"] {
        for entry in std::fs::read_dir(root().join("fuzz").join(folder)).unwrap() {
            let path = entry.unwrap().path();
            let name = path.file_name().unwrap().to_str().unwrap();
            assert!(
                !path.is_dir() || TARGETS.contains(&name),
                "fuzz/{folder}/{name} is not one of the targets {TARGETS:?}"
            );
        }
    }
    for target in TARGETS {
        assert!(
            !inputs("seeds", target).is_empty(),
            "fuzz/seeds/{target} has no seed"
        );
    }
}

#[test]
fn seeds_and_crash_inputs_give_ok_or_an_error_never_a_panic() {
    let dir = temp_dir("fuzz-replay");
    harness::prepare_scene_dir(&dir);
    let mut failures = Vec::new();
    for target in TARGETS {
        for folder in ["seeds", "regressions"] {
            let files = inputs(folder, target);
            let mut accepted = 0;
            for file in &files {
                let data = std::fs::read(file).unwrap();
                let outcome =
                    std::panic::catch_unwind(|| run(target, &data, &dir)).map_err(|payload| {
                        payload
                            .downcast_ref::<&str>()
                            .map(|s| s.to_string())
                            .or_else(|| payload.downcast_ref::<String>().cloned())
                            .unwrap_or_default()
                    });
                match outcome {
                    Ok(ok) => accepted += usize::from(ok),
                    Err(message) => failures.push(format!("{}: {message}", file.display())),
                }
            }
            println!(
                "{target}: {} {folder}, {accepted} accepted, {} refused",
                files.len(),
                files.len() - accepted
            );
        }
    }
    assert!(
        failures.is_empty(),
        "inputs that panic:\n{}",
        failures.join("\n")
    );
}

/// xorshift64* from `seed`: the random inputs' bytes.
fn xorshift(mut state: u64) -> impl FnMut() -> u64 {
    move || {
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        state.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
}

/// The `kernels` target on stable, without the fuzzer: inputs drawn at random (xorshift64*,
/// fixed seed), so CI runs the scalar and AVX2 kernels against each other and against the f64
/// evaluation on a few hundred operators and emissions each time.
#[test]
fn kernels_agree_on_random_operators_and_emissions() {
    let mut next = xorshift(0x9e37_79b9_7f4a_7c15);
    let mut loaded = 0;
    for i in 0..300 {
        let len = 16 + (next() % 240) as usize;
        let mut data: Vec<u8> = (0..len).map(|_| next() as u8).collect();
        // Few edits on most inputs, so that most operators stay valid and reach the kernels.
        data[9] %= if i % 4 == 0 { 16 } else { 2 };
        loaded += usize::from(kernels::kernels(&data));
    }
    println!("kernels: 300 inputs, {loaded} operators loaded and evaluated");
    if !lrr_runtime::SimdLevel::Avx2.supported() {
        println!(
            "kernels: this CPU lacks AVX2 (+FMA, F16C): the scalar kernels alone were checked"
        );
    }
    assert!(
        loaded >= 150,
        "only {loaded} of 300 random operators loaded: the test is shallow"
    );
}

/// The `bake_geometry` target on stable (issue #31: hostile geometry through meshing): 80
/// random inputs (fixed seed) whose coordinates come from a palette of eight values, so that
/// needles, slivers, coincident vertices, duplicated and zero-area faces are common, at scales
/// 1e-6 to 1e6, through the whole bake; each is refused or makes a file that passes its checks.
#[test]
fn hostile_geometry_bakes_or_is_refused() {
    let dir = temp_dir("fuzz-bake-geometry");
    let mut next = xorshift(0x51a7_c0de_0031_0031);
    let palette: [i16; 8] = [-100, -99, 0, 1, 2, 50, 100, 101];
    let mut baked = 0;
    for _ in 0..80 {
        let mut data = vec![next() as u8, next() as u8];
        for _ in 0..9 * (1 + next() % 12) {
            let v = if next().is_multiple_of(4) {
                next() as i16
            } else {
                palette[(next() % 8) as usize]
            };
            data.extend(v.to_le_bytes());
        }
        baked += usize::from(harness::bake_geometry(&data, &dir));
    }
    println!("bake_geometry: 80 random inputs, {baked} baked, the others refused");
    assert!(baked >= 20, "only {baked} of 80 baked: the test is shallow");
}

/// The `trace_mutated` target on stable: 300 random edits of the tracer's base files (fixed
/// seed), each loaded, made into a tracer and rendered when accepted, so CI runs the tracer's
/// checks of damaged display sections every time; every base renders untouched.
#[test]
fn the_tracer_refuses_or_renders_damaged_files() {
    for variant in 0..16 {
        assert!(
            trace::trace_mutated(&[variant]),
            "base {variant} does not render"
        );
    }
    let mut next = xorshift(0x5851_f42d_4c95_7f2d);
    let mut rendered = 0;
    for _ in 0..300 {
        let len = 2 + (next() % 24) as usize;
        let data: Vec<u8> = (0..len).map(|_| next() as u8).collect();
        rendered += usize::from(trace::trace_mutated(&data));
    }
    println!("trace_mutated: 300 inputs, {rendered} files rendered");
    assert!(
        rendered >= 30,
        "only {rendered} of 300 edited files rendered: shallow"
    );
}

#[test]
fn mutation_bases_are_valid_operator_files() {
    // `operator_mutated` starts from these; an invalid base would leave the fuzzer shallow.
    for variant in 0..8 {
        assert!(
            operators::operator_bytes(&operators::base_file(variant)),
            "base {variant} does not load"
        );
    }
    // No edits: the base itself; the reseal bit alone changes nothing.
    assert_eq!(operators::mutate(&[3]), operators::base_file(3));
    assert_eq!(operators::mutate(&[0x83]), operators::base_file(3));
}

/// Rewrites the operator seeds: the mutation bases and a real bake of a seed scene. Run by hand
/// after a format change: `cargo test --release -p lrr-tests -- --ignored write_operator_seeds`
/// (bake-lightmap.lrr: a glTF floor with TEXCOORD_1, format 1.3; bake-lights.lrr: spot,
/// directional lights and a sky, format 1.5).
#[test]
#[ignore = "writes fuzz/seeds/operator_bytes/"]
fn write_operator_seeds() {
    let dir = root().join("fuzz/seeds/operator_bytes");
    std::fs::create_dir_all(&dir).unwrap();
    for (name, variant) in [("base-f32-grey", 0), ("base-f16-rgb", 3), ("base-k3", 4)] {
        std::fs::write(
            dir.join(format!("{name}.lrr")),
            operators::base_file(variant),
        )
        .unwrap();
    }
    let scene = root().join("fuzz/seeds/scene_description/two-squares.toml");
    let out = dir.join("bake-two-squares.lrr");
    crate::util::bake(&scene, &out, &[]).unwrap();
    // Format 1.3: a bake with the scene's lightmap coordinates (section LIGHTMAP).
    let gltf = crate::util::temp_dir("operator-seeds").join("floor.glb");
    std::fs::write(&gltf, super::scene_lightmap::lit_floor().glb()).unwrap();
    let out = dir.join("bake-lightmap.lrr");
    let coarse = ["--element-size", "1", "--patch-size", "2"];
    crate::util::bake(&gltf, &out, &coarse).unwrap();
    // Format 1.5: lights that are not surfaces (DIRECT_LIGHTS) and the sky's transfer
    // (SKY_TRANSFER).
    let scene = root().join("fuzz/seeds/scene_description/lights.toml");
    crate::util::bake(&scene, &dir.join("bake-lights.lrr"), &[]).unwrap();
}

/// Rewrites the seeds of the targets of the shard parts, plans and checkpoints, the command
/// line's input files and the C interface (`fuzz/seeds/<target>/`). Run by hand after a change
/// of those formats or of the harnesses' input layout:
/// `cargo test --release -p lrr-tests --test e2e -- --ignored write_input_seeds`.
#[test]
#[ignore = "writes fuzz/seeds/"]
fn write_input_seeds() {
    let write = |target: &str, name: &str, bytes: &[u8]| {
        let dir = root().join("fuzz/seeds").join(target);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join(name), bytes).unwrap();
    };
    for (name, bytes) in capi::seeds() {
        write("capi_calls", name, &bytes);
    }
    // Parts: the bases untouched (one shard; two; the first twice), a resealed edit of the
    // skeleton's first byte, and the one-shard part as raw bytes.
    write("shard_part", "one-shard", &[0]);
    write("shard_part", "two-shards", &[1]);
    write("shard_part", "repeated-part", &[3]);
    write(
        "shard_part",
        "second-part-edited-resealed",
        &[0x85, 0, 0, 1, 1, 0xff],
    );
    let mut raw = vec![2];
    raw.extend_from_slice(&shards::base_parts()[0]);
    write("shard_part", "raw-one-shard", &raw);
    // Plans: the base for both shard specs, a resealed edit, the base as raw bytes.
    write("shard_plan", "one-shard", &[0]);
    write("shard_plan", "second-of-two", &[2]);
    write("shard_plan", "edited-resealed", &[0x80, 1, 0x00, 0x02, 9]);
    let mut raw = vec![1];
    raw.extend_from_slice(shards::base_plan());
    write("shard_plan", "raw", &raw);
    // Checkpoints: every block of each valid checkpoint (index, length, values, checksum
    // modes 0), the rows' with the blocks out of order and one repeated, with a NaN.
    let blocks = |head: u8, order: &[u8]| {
        let mut v = vec![head];
        for &i in order {
            v.extend([i, 0, 0, 0]);
        }
        v
    };
    write(
        "checkpoint_resume",
        "rows-complete",
        &blocks(0, &[0, 1, 2, 3, 4]),
    );
    write(
        "checkpoint_resume",
        "first-pass-complete",
        &blocks(1, &[0, 1, 2, 3, 4]),
    );
    write(
        "checkpoint_resume",
        "rows-shuffled",
        &blocks(0, &[3, 1, 3, 0]),
    );
    write(
        "checkpoint_resume",
        "rows-nan",
        &[0, 0, 0, 0, 0, 1, 0, 6, 0, 0, 0],
    );
    // The command line's files.
    let points = br#"[{"position": [0.5, 0.5, 0.0], "normal": [0, 0, 1]},
 {"position": [0.4, 0.4, 0.5], "normal": [0, 0, -1]},
 {"position": [0.5, 0.5, 1.0], "normal": [0, 0, -1]},
 {"position": [1e30, -3, 0.5], "normal": [0, 0, 0]}]"#;
    write("probe_points", "points.json", points);
    write("probe_points", "empty.json", b"[]");
    let op = lrr_runtime::Operator::from_bytes(cli::base_operator()).unwrap();
    let emission = serde_json::to_string(&op.baked_emission()).unwrap();
    write("emission_json", "baked.json", emission.as_bytes());
    let zeros = serde_json::to_string(&vec![[0.0f32; 3]; op.n()]).unwrap();
    write("emission_json", "dark.json", zeros.as_bytes());
    let reference = br#"{"scene": "fuzz shards", "points": [
 {"surface": "floor", "position": [0.5, 0.5, 0.0], "normal": [0, 0, 1], "radiosity": [1, 2, 3], "stderr": [0.01, 0.01, 0.01]},
 {"surface": "shade", "position": [0.4, 0.4, 0.5], "normal": [0, 0, -1], "radiosity": [0.5, 1, 1.5], "stderr": [0.01, 0.01, 0.01]},
 {"surface": "floor", "position": [0.9, 0.1, 0.0], "normal": [0, 0, 1], "radiosity": [1, 1, 1], "stderr": [0, 0, 0]}]}"#;
    write("reference_json", "three-points.json", reference);
    let animation = br#"fps = 2.0
duration = 2.0
[[group]]
name = "lamp"
keys = [
  { time = 0.0, intensity = 1.0 },
  { time = 1.0, intensity = 0.2, colour = [1.0, 0.6, 0.3] },
]
[[light]]
name = "torch"
kind = "point"
keys = [
  { time = 0.0, position = [0.1, 0.1, 0.8], intensity = [5.0, 4.0, 3.0] },
  { time = 2.0, position = [0.9, 0.9, 0.8], intensity = [5.0, 4.0, 3.0] },
]
[[light]]
name = "spot"
kind = "spot"
inner_cone_deg = 10.0
outer_cone_deg = 30.0
keys = [{ time = 0.0, position = [0.5, 0.5, 0.9], direction = [0.0, 0.0, -1.0], intensity = [2.0, 2.0, 2.0] }]
[[light]]
name = "sun"
kind = "sun"
keys = [
  { time = 0.0, direction = [0.0, 0.0, -1.0], intensity = [1.0, 1.0, 1.0] },
  { time = 2.0, direction = [1.0, 0.0, 0.0], intensity = [1.0, 1.0, 1.0] },
]
"#;
    write("animation_toml", "lamp-and-lights.toml", animation);
    write(
        "animation_toml",
        "long.toml",
        b"fps = 24.0\nduration = 3600.0\n[[group]]\nname = \"lamp\"\nkeys = [{ time = 0.0, intensity = 1.0 }, { time = 3600.0, intensity = 0.0 }]\n",
    );
}
