//! The fuzz corpora as ordinary tests: every seed (`fuzz/seeds/<target>/`) and every committed
//! crash input (`fuzz/regressions/<target>/`) runs through the same function as the cargo-fuzz
//! target of that name (fuzz/src/harness.rs for the scene importers and the bake, fuzz/runtime/src/
//! operators.rs, kernels.rs and trace.rs for the runtime, included here), on stable, in CI. Each must be accepted or refused with an error, never panic.

use std::path::{Path, PathBuf};

use crate::util::{root, temp_dir};

#[path = "../../../fuzz/src/harness.rs"]
mod harness;
#[path = "../../../fuzz/runtime/src/kernels.rs"]
mod kernels;
#[path = "../../../fuzz/runtime/src/operators.rs"]
mod operators;
#[path = "../../../fuzz/runtime/src/trace.rs"]
mod trace;

const TARGETS: [&str; 8] = [
    "kernels",
    "operator_bytes",
    "operator_mutated",
    "trace_mutated",
    "obj_import",
    "scene_description",
    "gltf_import",
    "bake_geometry",
];

/// Runs one input through the target's body; `true` when it was accepted.
fn run(target: &str, data: &[u8], dir: &Path) -> bool {
    match target {
        "kernels" => kernels::kernels(data),
        "operator_bytes" => operators::operator_bytes(data),
        "operator_mutated" => operators::operator_mutated(data),
        "trace_mutated" => trace::trace_mutated(data),
        "obj_import" => harness::obj_import(data, dir),
        "scene_description" => harness::scene_description(data, dir),
        "gltf_import" => harness::gltf_import(data, dir),
        "bake_geometry" => harness::bake_geometry(data, dir),
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
