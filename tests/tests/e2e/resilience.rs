//! Nothing is lost: atomic outputs under SIGKILL, checkpoint/resume, determinism, refusing
//! bakes that do not fit in memory.

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::util::{bake, cornell, lrr_binary, temp_dir};

/// `lrr bake` of the Cornell box into `out`, quiet, with `extra` flags.
fn bake_command(out: &std::path::Path, extra: &[&str]) -> Command {
    let mut command = Command::new(lrr_binary());
    command
        .args([
            "bake",
            cornell().to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "-q",
        ])
        .args(extra);
    command
}

fn spawn_bake(out: &std::path::Path, extra: &[&str]) -> Child {
    bake_command(out, extra)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap()
}

/// Waits until `cond` holds or the child exits; true if `cond` held.
fn wait_for(child: &mut Child, cond: impl Fn() -> bool) -> bool {
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(120) {
        if cond() {
            return true;
        }
        if child.try_wait().unwrap().is_some() {
            return cond();
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    false
}

/// Bakes to `out` with `extra` flags and kills the bake once `file` holds more than `bytes`
/// bytes; true if it did before the bake ended.
fn kill_bake_when(
    out: &std::path::Path,
    extra: &[&str],
    file: &std::path::Path,
    bytes: u64,
) -> bool {
    let mut child = spawn_bake(out, extra);
    let saved = wait_for(&mut child, || {
        std::fs::metadata(file)
            .map(|m| m.len() > bytes)
            .unwrap_or(false)
    });
    let _ = child.kill();
    child.wait().unwrap();
    saved
}

#[test]
fn a_bake_killed_while_writing_leaves_the_previous_file_intact() {
    let dir = temp_dir("sigkill");
    let out = dir.join("cornell.lrr");
    bake(&cornell(), &out, &["--samples", "1"]).unwrap();
    let old = std::fs::read(&out).unwrap();
    // Kill the next bake as soon as its temporary output appears (mid-write).
    let mut caught = 0;
    for attempt in 0..5 {
        let mut child = spawn_bake(&out, &["--samples", "4"]);
        let temp_exists = || {
            std::fs::read_dir(&dir)
                .unwrap()
                .filter_map(|e| e.ok())
                .any(|e| {
                    let name = e.file_name().to_string_lossy().to_string();
                    name != "cornell.lrr"
                        && name.contains("cornell.lrr")
                        && !name.ends_with(".ckpt")
                })
        };
        if wait_for(&mut child, temp_exists) {
            caught += 1;
        }
        let _ = child.kill();
        child.wait().unwrap();
        let now = std::fs::read(&out).unwrap();
        // Either the old file or (if the rename won the race) a complete new one: never a torn file.
        assert!(
            now == old || lrr_runtime::Operator::from_bytes(&now).is_ok(),
            "attempt {attempt}: torn output"
        );
        if now == old {
            assert!(lrr_runtime::Operator::from_bytes(&now).is_ok());
        }
    }
    println!("killed {caught} of 5 bakes while their temporary output existed");
    assert!(caught > 0, "never caught a bake mid-write");
}

#[test]
fn a_killed_bake_resumes_to_the_same_bytes() {
    let dir = temp_dir("resume");
    let whole = dir.join("whole.lrr");
    bake(&cornell(), &whole, &["--checkpoint-rows", "32"]).unwrap();
    assert!(
        !dir.join("whole.lrr.ckpt").exists(),
        "a finished bake removes its checkpoint"
    );
    let out = dir.join("cut.lrr");
    let ckpt = dir.join("cut.lrr.ckpt");
    // Kill once a few blocks are saved (header 40 bytes + records of 32 rows).
    let flags = ["--checkpoint-rows", "32", "--threads", "1"];
    let saved = kill_bake_when(&out, &flags, &ckpt, 200_000);
    assert!(
        saved && ckpt.exists(),
        "the bake finished before it could be killed"
    );
    assert!(!out.exists());
    // The default bake refines where light changes: its first pass was saved whole before
    // the form factors began.
    let first = dir.join("cut.lrr.first-pass.ckpt");
    assert!(first.exists(), "the first pass's checkpoint is kept");
    let text = bake(&cornell(), &out, &["--checkpoint-rows", "32", "--resume"]).unwrap();
    assert!(text.contains("baked"));
    assert_eq!(
        std::fs::read(&out).unwrap(),
        std::fs::read(&whole).unwrap(),
        "resumed bake differs"
    );
    assert!(!ckpt.exists() && !first.exists());
    // Rows were taken from the checkpoints, not integrated again: some of F_k's, all of the
    // first pass's.
    let [rows, n, first_rows, n0] = resumed(&text);
    assert!(rows > 0 && rows < n, "{text}");
    assert!(first_rows == n0 && n0 > 0 && n0 < n, "{text}");
    // A checkpoint of another bake is refused.
    kill_bake_when(&out, &flags, &ckpt, 0);
    let err = bake(
        &cornell(),
        &out,
        &["--samples", "9", "--checkpoint-rows", "32", "--resume"],
    )
    .unwrap_err();
    assert!(err.contains("different bake"), "{err}");
}

/// `(F_k rows resumed, n, first-pass rows resumed, unrefined n)` from a resumed bake's output.
fn resumed(text: &str) -> [u64; 4] {
    let line = text
        .lines()
        .find(|l| l.starts_with("resumed: "))
        .unwrap_or_else(|| panic!("no resumed line: {text}"));
    let numbers: Vec<u64> = line
        .split_whitespace()
        .filter_map(|w| w.parse().ok())
        .collect();
    numbers
        .try_into()
        .unwrap_or_else(|_| panic!("four counts expected: {line}"))
}

/// A bake killed during `--refine`'s first pass resumes it from its checkpoint and writes the
/// bytes of an uninterrupted bake; a finished bake leaves no checkpoint behind.
#[test]
fn a_bake_killed_in_its_first_pass_resumes_it() {
    let dir = temp_dir("resume-first");
    let whole = dir.join("whole.lrr");
    bake(&cornell(), &whole, &["--checkpoint-rows", "16"]).unwrap();
    assert!(!dir.join("whole.lrr.first-pass.ckpt").exists());
    let out = dir.join("cut.lrr");
    let first = dir.join("cut.lrr.first-pass.ckpt");
    // Header 40 bytes, then records of 16 rows × k values: kill after a few.
    let flags = ["--checkpoint-rows", "16", "--threads", "1"];
    let saved = kill_bake_when(&out, &flags, &first, 100_000);
    assert!(
        saved && first.exists(),
        "the bake finished before it could be killed"
    );
    let text = bake(&cornell(), &out, &["--checkpoint-rows", "16", "--resume"]).unwrap();
    assert_eq!(
        std::fs::read(&out).unwrap(),
        std::fs::read(&whole).unwrap(),
        "resumed bake differs"
    );
    let [_, n, first_rows, n0] = resumed(&text);
    // 100 kB of rows of 8·k bytes, in records of 16 rows, is at least 32 rows for any k up to
    // 333 (the Cornell box's default k is 167 since 2MSC's merge rule: about 74 rows).
    assert!(first_rows >= 32 && first_rows <= n0 && n0 < n, "{text}");
    assert!(!first.exists() && !dir.join("cut.lrr.ckpt").exists());
    // Nothing left to resume: refused, saying so.
    let err = bake(&cornell(), &out, &["--resume"]).unwrap_err();
    assert!(err.contains("no interrupted bake"), "{err}");
}

/// A refined mesh follows the materials (the first pass's light), so a scene edited between a
/// killed bake and its resumption can give the same `n` and `k` with other elements: the
/// checkpoint's key holds the mesh itself, and the rows are refused, never mixed.
#[test]
fn a_checkpoint_of_other_materials_is_refused() {
    let dir = temp_dir("resume-materials");
    let out = dir.join("cut.lrr");
    let ckpt = dir.join("cut.lrr.ckpt");
    // 2MF: k does not follow the materials (2MSC's patches do), so only the elements differ.
    let flags = ["--method", "2mf", "--checkpoint-rows", "32"];
    let saved = kill_bake_when(
        &out,
        &[&flags[..], &["--threads", "1"]].concat(),
        &ckpt,
        100_000,
    );
    assert!(saved, "the bake finished before it could be killed");
    // The same geometry, the white surfaces a darker grey.
    let text = std::fs::read_to_string(cornell()).unwrap();
    assert!(text.contains("reflectance = [0.725, 0.71, 0.68]"));
    let edited = dir.join("edited.toml");
    std::fs::write(
        &edited,
        text.replace(
            "reflectance = [0.725, 0.71, 0.68]",
            "reflectance = [0.2, 0.2, 0.2]",
        ),
    )
    .unwrap();
    let err = bake(&edited, &out, &[&flags[..], &["--resume"]].concat()).unwrap_err();
    assert!(err.contains("different bake"), "{err}");
    // Both bakes have n = 2539 and k = 242, so only the mesh in the key tells them apart.
    for (scene, name) in [(edited, "edited.lrr"), (cornell(), "original.lrr")] {
        let text = bake(&scene, &dir.join(name), &flags).unwrap();
        assert!(
            text.contains("n = 2539 elements, k = 242 patches"),
            "{text}"
        );
    }
}

/// A first-pass checkpoint left by another bake is stale, not an error: a shard (which always
/// resumes) and `lrr bake --resume` start the first pass over and finish; a later unrefined
/// bake removes a stale one.
#[test]
fn a_foreign_first_pass_checkpoint_is_started_over() {
    let dir = temp_dir("first-pass-foreign");
    let whole = dir.join("whole.lrr");
    bake(&cornell(), &whole, &[]).unwrap();
    // A checkpoint header of another bake (magic, then key, n, k and block rows all zero).
    let foreign = [b"LRRCKPT1".as_slice(), &[0u8; 32]].concat();
    let out = dir.join("cut.lrr");
    let first = dir.join("cut.lrr.first-pass.ckpt");
    std::fs::write(&first, &foreign).unwrap();
    bake(&cornell(), &out, &["--resume"]).unwrap();
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&whole).unwrap());
    assert!(!first.exists());
    let part = dir.join("part.bin");
    let part_first = dir.join("part.bin.first-pass.ckpt");
    std::fs::write(&part_first, &foreign).unwrap();
    let text = bake(&cornell(), &part, &["--shard", "0/3"]).unwrap();
    assert!(part.exists() && !part_first.exists(), "{text}");
    std::fs::write(&first, &foreign).unwrap();
    bake(&cornell(), &out, &["--refine", "0"]).unwrap();
    assert!(
        !first.exists(),
        "an unrefined bake leaves a stale first pass behind"
    );
}

#[test]
fn bakes_are_identical_across_runs_and_thread_counts() {
    let dir = temp_dir("threads");
    let mut files = Vec::new();
    for (i, threads) in ["1", "2", "4", "2"].iter().enumerate() {
        let out = dir.join(format!("t{i}.lrr"));
        bake(&cornell(), &out, &["--threads", threads]).unwrap();
        files.push(std::fs::read(&out).unwrap());
    }
    assert!(
        files.windows(2).all(|w| w[0] == w[1]),
        "bakes differ across runs or thread counts 1, 2, 4"
    );
}

/// A dense mesh (the dense sphere of 5 120 triangles, each smaller than the element size):
/// since issue #31 its small faces are grouped into elements of about the element size, so
/// the refusal advises a larger element size, and following it the bake fits the same
/// memory.
#[test]
fn a_refusal_on_a_dense_mesh_gives_advice_that_works() {
    // 5 120 triangles, each smaller than the element size: before issue #31 every one was an
    // element whatever the size, and the advice had to say so; now they are grouped into
    // elements of about the element size, and a larger size is what helps.
    let dir = temp_dir("memory-dense");
    let scene =
        crate::util::generated_scene(&dir, "sphere", &["dense-sphere", "--subdivisions", "4"]);
    let out = dir.join("sphere.lrr");
    // 12 MiB: the occlusion BVH and the smooth weights of its 5 130 faces plan 5 MiB each;
    // meshing at 0.03 plans 34 368 pieces, 36 MiB; at the description's 0.125, 8 MiB and
    // 2MSC's probes 0.9 MiB beside it.
    let err = bake(
        &scene,
        &out,
        &["--max-memory", "12M", "--element-size", "0.03"],
    )
    .unwrap_err();
    assert!(err.contains("meshing (5130 faces"), "{err}");
    // The advice names the smallest element size whose meshing fits in three quarters of the
    // limit; following it, the whole bake fits.
    let size = err
        .split("use --element-size ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .unwrap_or_else(|| panic!("no element size in: {err}"));
    assert!(size.parse::<f64>().is_ok_and(|h| h > 0.03), "{err}");
    bake(
        &scene,
        &out,
        &["--max-memory", "12M", "--element-size", size],
    )
    .unwrap_or_else(|e| panic!("the advice did not make the bake fit: {e}"));
    assert!(out.exists());
}

/// The import, the BVHs, meshing's faces and the smooth weights follow the input, not the
/// element size: a model too dense for the memory is refused before any of them is built,
/// with advice about the model.
#[test]
fn a_model_too_dense_for_memory_is_refused_before_its_bvh() {
    let dir = temp_dir("memory-bvh");
    let scene =
        crate::util::generated_scene(&dir, "sphere", &["dense-sphere", "--subdivisions", "4"]);
    let out = dir.join("sphere.lrr");
    // The description (254 kB, its 2 562 vertices and 5 120 faces written out) plans its parse
    // (16 bytes a byte) and its faces (640 bytes each): 7.0 MiB.
    let err = bake(&scene, &out, &["--max-memory", "4M"]).unwrap_err();
    assert!(
        err.contains("importing ")
            && err.contains("but only 4.0 MiB")
            && err.contains("simplify the model"),
        "{err}"
    );
    // With room for the import (7.0 MiB) and the occlusion BVH (5.0 MiB), meshing: each face
    // is a piece at least (1.5 KiB a face, 8.0 MiB), so a larger element size cannot help.
    let err = bake(&scene, &out, &["--max-memory", "7.8M"]).unwrap_err();
    assert!(
        err.contains("meshing (5130 faces") && err.contains("simplify the model"),
        "{err}"
    );
    assert!(!out.exists());
    // Boxes are six faces in a few lines: 1 024 of them in a room import in 5.1 MiB (88 kB of
    // text, 6 151 faces) but need an occlusion BVH of 12 MiB (two triangles a face).
    let mut text = String::from(
        "[[material]]\nname = \"w\"\nreflectance = [0.5, 0.5, 0.5]\n\
         [[material]]\nname = \"l\"\nreflectance = [0.0, 0.0, 0.0]\nradiance = [1.0, 1.0, 1.0]\n\
         [[box]]\nname = \"room\"\nmaterial = \"w\"\nmin = [0.0, 0.0, 0.0]\n\
         max = [40.0, 10.0, 40.0]\ninward = true\n\
         [[surface]]\nname = \"lamp\"\nmaterial = \"l\"\npolygons = [[[10.0, 9.9, 10.0], \
         [10.0, 9.9, 30.0], [30.0, 9.9, 30.0], [30.0, 9.9, 10.0]]]\n",
    );
    for i in 0..32 {
        for j in 0..32 {
            let (x, z) = (1.0 + 1.2 * f64::from(i), 1.0 + 1.2 * f64::from(j));
            text += &format!(
                "[[box]]\nname = \"b{i}_{j}\"\nmaterial = \"w\"\nmin = [{x:.1}, 0.0, {z:.1}]\n\
                 max = [{:.1}, 0.5, {:.1}]\n",
                x + 0.5,
                z + 0.5
            );
        }
    }
    let boxes = dir.join("boxes.toml");
    std::fs::write(&boxes, text).unwrap();
    let err = bake(&boxes, &out, &["--max-memory", "8M"]).unwrap_err();
    assert!(
        err.contains("the occlusion BVH (6151 faces) needs about 12.0 MiB but only 8.0 MiB")
            && err.contains("simplify the model"),
        "{err}"
    );
    assert!(!out.exists());
}

/// 2MSC's probes (the 2MF patches at the patch size, with their dense solve) are planned
/// before they are built: a patch size as small as the elements makes as many probes as
/// elements, which is refused; the advice (a patch size so many times larger: twice is
/// more than it asks) makes the bake fit.
#[test]
fn probes_over_the_memory_limit_are_refused_with_advice_that_works() {
    let dir = temp_dir("memory-probes");
    let out = dir.join("cornell.lrr");
    // The element size of the Cornell box's description is 48: probes of that size number
    // n = 2 116 (24 q² + 8 n q bytes: 137 MiB).
    let err = bake(
        &cornell(),
        &out,
        &["--max-memory", "64M", "--patch-size", "48"],
    )
    .unwrap_err();
    assert!(
        err.contains("2MSC's probing (q = 2116 probes, n = 2116 elements)")
            && err.contains("--patch-size about"),
        "{err}"
    );
    assert!(!out.exists());
    // The advice names a factor; twice the patch size follows it.
    let factor: f64 = err
        .split("--patch-size about ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|x| x.parse().ok())
        .unwrap_or_else(|| panic!("no factor in: {err}"));
    assert!((1.0..=2.0).contains(&factor), "{err}");
    bake(
        &cornell(),
        &out,
        &["--max-memory", "64M", "--patch-size", "96"],
    )
    .unwrap_or_else(|e| panic!("the advice did not make the bake fit: {e}"));
    assert!(out.exists());
}

#[test]
fn a_bake_larger_than_memory_is_refused_before_allocating() {
    let dir = temp_dir("memory");
    let out = dir.join("big.lrr");
    // By 2MF, which has no probes (2MSC's are refused in
    // probes_over_the_memory_limit_are_refused_with_advice_that_works), at 3 MiB: meshing
    // (2 288 pieces at 1 KiB, 2.2 MiB) fits, the first pass's n × k matrix (3.9 MiB) does
    // not. Under 2.2 MiB meshing is refused first (a_refusal_on_a_dense_mesh_gives_advice_
    // that_works follows its advice).
    let err = bake(&cornell(), &out, &["--max-memory", "3M", "--method", "2mf"]).unwrap_err();
    assert!(
        err.contains("the first pass")
            && err.contains("MiB but only 3.0 MiB")
            && err.contains("--element-size"),
        "{err}"
    );
    let err = bake(&cornell(), &out, &["--element-size", "1e-4"]).unwrap_err();
    assert!(
        err.contains("elements") && err.contains("--element-size"),
        "{err}"
    );
    assert!(!out.exists());
}

/// Without `--max-memory` the limit is 80% of what the machine has, and commands such as
/// `lrr accuracy` have no flag to move it: the refusal says so and names
/// `LRR_MEMORY_LIMIT`, which sets what counts as available. 4 MiB available (3.2 MiB usable)
/// refuses the Cornell box's bake, which needs more; with the flag given, the words are the
/// flag's alone.
#[test]
fn a_refusal_without_max_memory_names_what_sets_the_limit() {
    let dir = temp_dir("machine-limit");
    let out = dir.join("cb.lrr");
    let run = |extra: &[&str]| {
        bake_command(&out, extra)
            .env("LRR_MEMORY_LIMIT", (4u64 << 20).to_string())
            .output()
            .unwrap()
    };
    let refused = run(&[]);
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success(), "{err}");
    assert!(
        err.contains("but only 3.2 MiB can be used (80% of the memory available")
            && err.contains("LRR_MEMORY_LIMIT"),
        "{err}"
    );
    let refused = run(&["--max-memory", "3M"]);
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(
        err.contains("but only 3.0 MiB can be used;") && !err.contains("LRR_MEMORY_LIMIT"),
        "{err}"
    );
    assert!(!out.exists());
}

/// The file's writing is planned before the form factors: the plain layout in f16 makes its
/// `Y_k` in f32 and f16 beside `F_k` (11.6 MiB on the Cornell box, more than any stage before
/// it, whose largest is meshing at 7.5 MiB), so at 9 MiB the bake is refused before its form
/// factors run, and the advice (the factored layout: 5.3 MiB) bakes within the same limit.
/// Already the unrefined mesh's 2 116 elements need 9.9 MiB to write, so the refusal comes
/// before the refinement's first pass too.
#[test]
fn a_file_too_large_to_write_is_refused_before_the_form_factors() {
    let dir = temp_dir("memory-write");
    let out = dir.join("cb.lrr");
    let limit = ["--max-memory", "9M"];
    let plain = [&limit[..], &["--layout", "plain", "--precision", "f16"]].concat();
    let err = bake(&cornell(), &out, &plain).unwrap_err();
    assert!(
        err.contains("writing the operator file in the plain layout (n = ")
            && err.contains("but only 9.0 MiB can be used")
            && err.contains("use the factored layout"),
        "{err}"
    );
    assert!(!out.exists());
    // Refused before `--refine`'s first pass (refinement keeps k and adds elements, so the
    // unrefined mesh's write is a lower bound), and so before the form factors: both open
    // their checkpoints first.
    assert!(err.contains("elements before refinement"), "{err}");
    assert!(!dir.join("cb.lrr.first-pass.ckpt").exists());
    assert!(!dir.join("cb.lrr.ckpt").exists());
    let factored = [&limit[..], &["--precision", "f16"]].concat();
    bake(&cornell(), &out, &factored).unwrap();
    assert!(out.exists());
}
