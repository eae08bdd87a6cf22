//! Sharded bakes (docs/DISTRIBUTED.md): shards run as separate processes through GNU
//! parallel and merged into the very bytes of a single bake, a shard killed and resumed,
//! parts that do not make one bake named, a merge under a memory cap smaller than `F_k`; and
//! (ignored unless scripts/setup-slurm.sh ran) the documented Slurm job array and merge job.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::util::{bake, cornell, generated_scene, lrr, lrr_binary, root, temp_dir};

/// GNU parallel, which scripts/setup-parallel.sh installs (.ci/run runs it): required, never
/// skipped.
fn gnu_parallel() -> &'static str {
    let version = Command::new("parallel").arg("--version").output();
    match version {
        Ok(o) if String::from_utf8_lossy(&o.stdout).contains("GNU parallel") => "parallel",
        _ => panic!(
            "GNU parallel is missing (or `parallel` is another program, e.g. moreutils'): \
             run scripts/setup-parallel.sh"
        ),
    }
}

fn s(p: &Path) -> &str {
    p.to_str().expect("UTF-8 path")
}

/// How a shard learns its index.
#[derive(Clone, Copy, PartialEq)]
enum Index {
    /// `--shard I/N -o part-I.bin`, I written by GNU parallel.
    Flag,
    /// `--shard env/N -o part-{i}.bin` with I in `JOB_COMPLETION_INDEX`, as a Kubernetes
    /// indexed Job sets it (deploy/kubernetes/bake-indexed-job.yaml): lrr reads the variable
    /// and replaces `{i}` itself.
    Environment,
}

/// Runs shards `indices` of `count` through GNU parallel (2 jobs at a time), each writing
/// `dir/part-I.bin` and `dir/report-I.json`.
fn run_shards(
    scene: &Path,
    dir: &Path,
    count: usize,
    indices: &[usize],
    extra: &[&str],
    index: Index,
) {
    let mut cmd = Command::new(gnu_parallel());
    cmd.args(["--will-cite", "--halt", "now,fail=1", "-j", "2"]);
    if index == Index::Environment {
        // SLURM_ARRAY_TASK_ID would be read first: unset it in case this runs under Slurm.
        cmd.args([
            "env",
            "-u",
            "SLURM_ARRAY_TASK_ID",
            "JOB_COMPLETION_INDEX={}",
        ]);
    }
    let (spec, part) = match index {
        Index::Flag => (format!("{{}}/{count}"), "part-{}.bin"),
        Index::Environment => (format!("env/{count}"), "part-{i}.bin"),
    };
    cmd.arg(lrr_binary())
        .args(["bake", s(scene), "-q", "--shard", &spec])
        .arg("-o")
        .arg(dir.join(part))
        .arg("--report")
        .arg(dir.join("report-{}.json"))
        .args(extra)
        .arg(":::")
        .args(indices.iter().map(|i| i.to_string()));
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "parallel failed: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

fn parts(dir: &Path, count: usize) -> Vec<PathBuf> {
    (0..count)
        .map(|i| dir.join(format!("part-{i}.bin")))
        .collect()
}

fn merge(parts: &[PathBuf], out: &Path, extra: &[&str]) -> Result<String, String> {
    let mut args = vec!["merge"];
    args.extend(parts.iter().map(|p| s(p)));
    args.extend(["-o", s(out), "-q"]);
    args.extend_from_slice(extra);
    lrr(&args)
}

fn report(dir: &Path, i: usize) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join(format!("report-{i}.json"))).unwrap();
    serde_json::from_str(&text).unwrap()
}

/// Starts shard `index` of `count` alone and SIGKILLs it once its checkpoint holds two
/// blocks; true if it was caught mid-way (it may finish first on a fast machine).
fn kill_mid_way(scene: &Path, dir: &Path, index: usize, count: usize, extra: &[&str]) -> bool {
    let part = dir.join(format!("part-{index}.bin"));
    let ckpt = dir.join(format!("part-{index}.bin.ckpt"));
    let _ = std::fs::remove_file(&part);
    let _ = std::fs::remove_file(&ckpt);
    let mut child = Command::new(lrr_binary())
        .args([
            "bake",
            s(scene),
            "-q",
            "--shard",
            &format!("{index}/{count}"),
        ])
        .arg("-o")
        .arg(&part)
        .args(extra)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Header (40 bytes) + two records of 8 rows × k patches (24 + 8·k·8 bytes each). The
    // Cornell box's default bake has k = 167 (2MSC by merging); 333 was the split rule's k, so
    // this waits for four records, which is still "some rows saved, the bake unfinished".
    let two_blocks = 40 + 2 * (24 + 8 * 333 * 8);
    let start = Instant::now();
    let mut caught = false;
    while start.elapsed() < Duration::from_secs(120) {
        if std::fs::metadata(&ckpt).is_ok_and(|m| m.len() >= two_blocks) {
            caught = true;
            break;
        }
        if child.try_wait().unwrap().is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    let _ = child.kill();
    child.wait().unwrap();
    caught && !part.exists()
}

#[test]
fn shards_run_by_gnu_parallel_merge_into_the_bytes_of_a_single_bake() {
    let dir = temp_dir("shards");
    let scene = cornell();
    let extra = ["--samples", "4", "--checkpoint-rows", "8"];
    let single = dir.join("single.lrr");
    bake(&scene, &single, &extra).unwrap();
    let expected = std::fs::read(&single).unwrap();
    for count in [1usize, 3, 7] {
        let sub = dir.join(format!("n{count}"));
        std::fs::create_dir_all(&sub).unwrap();
        let mut resumed = None;
        if count == 3 {
            // Shard 1 is killed mid-way, then run again with the others: it resumes.
            let caught = (0..5).any(|_| kill_mid_way(&scene, &sub, 1, 3, &extra));
            assert!(caught, "never caught shard 1/3 mid-way in 5 attempts");
            resumed = Some(1);
        }
        // 7 shards as a Kubernetes indexed Job runs them: `--shard env/7 -o part-{i}.bin`.
        let index = if count == 7 {
            Index::Environment
        } else {
            Index::Flag
        };
        let all: Vec<usize> = (0..count).collect();
        run_shards(&scene, &sub, count, &all, &extra, index);
        let merged = sub.join("merged.lrr");
        let text = merge(&parts(&sub, count), &merged, &[]).unwrap();
        assert!(text.contains(&format!("merged {count} parts")), "{text}");
        assert!(
            std::fs::read(&merged).unwrap() == expected,
            "{count} shards: the merged file differs from the single bake"
        );
        let mut covered = 0;
        for i in 0..count {
            let r = report(&sub, i);
            let rows = r["rows"].as_array().unwrap();
            let (a, b) = (rows[0].as_u64().unwrap(), rows[1].as_u64().unwrap());
            assert_eq!(r["shard"].as_u64(), Some(i as u64), "report-{i}.json");
            assert_eq!(a, covered, "shard {i}/{count} starts where the last ended");
            covered = b;
            let resumed_rows = r["resumed_rows"].as_u64().unwrap();
            if Some(i) == resumed {
                assert!(
                    resumed_rows >= 16 && resumed_rows < b - a,
                    "shard {i}/{count}: {resumed_rows} of {} rows resumed",
                    b - a
                );
            } else {
                assert_eq!(resumed_rows, 0, "shard {i}/{count} resumed");
            }
            // The cut balances the estimated cost: every shard within 15% of the mean.
            let share = r["estimated_cost"].as_f64().unwrap() * count as f64
                / r["estimated_total_cost"].as_f64().unwrap();
            assert!((0.85..=1.15).contains(&share), "shard {i}/{count}: {share}");
            assert!(!sub.join(format!("part-{i}.bin.ckpt")).exists());
            assert!(!sub.join(format!("part-{i}.bin.first-pass.ckpt")).exists());
        }
        // The default bake's refined mesh (n0 = 2116 and 423 new elements).
        assert_eq!(covered, 2539, "the shards cover every row");
    }
}

/// Bakes shard `index` of `count` in-process.
fn shard(scene: &Path, part: &Path, index: usize, count: usize, extra: &[&str]) {
    let spec = format!("{index}/{count}");
    let mut args = vec!["bake", s(scene), "-o", s(part), "-q", "--shard", &spec];
    args.extend_from_slice(extra);
    lrr(&args).unwrap();
}

/// The merge fails naming `name` and every word of `words`, and writes nothing.
fn refused(parts: &[PathBuf], out: &Path, name: &str, words: &[&str]) {
    let err = merge(parts, out, &[]).unwrap_err();
    assert!(err.contains(name), "the error does not name {name}: {err}");
    for w in words {
        assert!(err.contains(w), "'{w}' missing from: {err}");
    }
    assert!(!out.exists(), "{err}: yet {} was written", out.display());
    let leftovers: Vec<_> = std::fs::read_dir(out.parent().unwrap())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
}

#[test]
fn a_merge_of_parts_that_are_not_one_bake_names_them_and_writes_nothing() {
    let dir = temp_dir("shard-errors");
    let scene = cornell();
    let extra = ["--samples", "1", "--element-size", "100"];
    let p: Vec<PathBuf> = (0..3).map(|i| dir.join(format!("p{i}.bin"))).collect();
    for (i, part) in p.iter().enumerate() {
        shard(&scene, part, i, 3, &extra);
    }
    let out = dir.join("out.lrr");
    merge(&p, &out, &[]).unwrap();
    std::fs::remove_file(&out).unwrap();

    // Missing: shard 1 is not given.
    refused(
        &[p[0].clone(), p[2].clone()],
        &out,
        "p0.bin",
        &["missing", "shard 1/3", "rows", "--shard 1/3"],
    );
    // Repeated: shard 1 twice, under two names.
    let copy = dir.join("copy-of-p1.bin");
    std::fs::copy(&p[1], &copy).unwrap();
    refused(
        &[p[0].clone(), p[1].clone(), copy.clone(), p[2].clone()],
        &out,
        "copy-of-p1.bin",
        &["repeated", "shard 1/3", "p1.bin"],
    );
    // Truncated: the last 100 bytes of shard 2 are gone.
    let short = dir.join("short.bin");
    let bytes = std::fs::read(&p[2]).unwrap();
    std::fs::write(&short, &bytes[..bytes.len() - 100]).unwrap();
    refused(
        &[p[0].clone(), p[1].clone(), short.clone()],
        &out,
        "short.bin",
        &["truncated", "shard 2/3"],
    );
    // Damaged: one byte of a row flipped (same length: the record's checksum catches it).
    let damaged = dir.join("damaged.bin");
    let mut bad = bytes.clone();
    let at = bad.len() - 20;
    bad[at] ^= 0x40;
    std::fs::write(&damaged, &bad).unwrap();
    refused(
        &[p[0].clone(), p[1].clone(), damaged.clone()],
        &out,
        "damaged.bin",
        &["checksum", "shard 2/3"],
    );
    // Mismatched: shard 1 baked with other samples; shard 1 of another scene; not a part.
    let other_settings = dir.join("other-settings.bin");
    shard(
        &scene,
        &other_settings,
        1,
        3,
        &["--samples", "2", "--element-size", "100"],
    );
    refused(
        &[p[0].clone(), other_settings.clone(), p[2].clone()],
        &out,
        "other-settings.bin",
        &["foreign", "other bake settings", "2 samples"],
    );
    let furnace = generated_scene(&dir, "furnace", &["furnace"]);
    let other_scene = dir.join("other-scene.bin");
    shard(&furnace, &other_scene, 1, 3, &["--samples", "1"]);
    refused(
        &[p[0].clone(), other_scene.clone(), p[2].clone()],
        &out,
        "other-scene.bin",
        &["foreign", "another scene"],
    );
    let other_cut = dir.join("other-cut.bin");
    shard(&scene, &other_cut, 1, 4, &extra);
    refused(
        &[p[0].clone(), other_cut.clone(), p[2].clone()],
        &out,
        "other-cut.bin",
        &["foreign", "4 shards, not 3"],
    );
    let stranger = dir.join("single.lrr");
    bake(&scene, &stranger, &extra).unwrap();
    refused(
        &[p[0].clone(), p[1].clone(), stranger.clone()],
        &out,
        "single.lrr",
        &["not a part"],
    );
    // And the good parts still merge.
    merge(&p, &out, &[]).unwrap();
}

#[test]
fn a_merge_streams_within_a_memory_cap_smaller_than_f_k() {
    let dir = temp_dir("shard-memory");
    let scene = generated_scene(&dir, "furnace", &["furnace"]);
    // n = 24576 elements, k = 384 patches: F_k is 75 MB in f64 (as baked), 38 MB in f32 (as
    // stored); the merge gets 35.9 MiB, just under F_k in f32 (the skeleton holds the BVH and
    // the smooth weights too, 3 copies each; compacting them in parts would leave more room).
    // 2MF (a uniformly lit furnace is one coherent patch per wall to 2MSC), unrefined (it
    // would split nothing here). No lightmap: its coordinates (32 bytes per face, in every
    // copy of the skeleton) would take the merge's need past F_k in f32 itself (36.4 MiB
    // measured with them), and what this holds is that F_k streams.
    let extra = [
        "--no-lightmap",
        "--samples",
        "1",
        "--element-size",
        "0.02",
        "--patch-size",
        "0.2",
        "--method",
        "2mf",
        "--refine",
        "0",
    ];
    let single = dir.join("single.lrr");
    bake(&scene, &single, &extra).unwrap();
    let p: Vec<PathBuf> = (0..2).map(|i| dir.join(format!("p{i}.bin"))).collect();
    for (i, part) in p.iter().enumerate() {
        shard(&scene, part, i, 2, &extra);
    }
    let cap: u64 = (35.9 * (1u64 << 20) as f64) as u64;
    let (n, k) = (24576u64, 384u64);
    assert!(n * k * 4 > cap && n * k * 8 > cap);
    let out = dir.join("merged.lrr");
    // Through the binary: its peak resident memory is its own, not the test's.
    let run = Command::new(lrr_binary())
        .arg("merge")
        .args(&p)
        .args(["-o", s(&out), "-q", "--max-memory", "35.9M"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&run.stdout).to_string();
    assert!(
        run.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(
        text.contains(&format!("n = {n} elements, k = {k} patches")),
        "{text}"
    );
    assert!(std::fs::read(&out).unwrap() == std::fs::read(&single).unwrap());
    // "peak resident 20.8 MiB (21803008 bytes)"
    let peak: u64 = text
        .split("peak resident ")
        .nth(1)
        .and_then(|t| t.split('(').nth(1))
        .and_then(|t| t.split(' ').next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("no peak memory in: {text}"));
    assert!(
        peak <= cap,
        "peak resident {peak} bytes above the cap {cap}: {text}"
    );
    // A cap below what the merge needs besides F_k is refused, and nothing is written.
    std::fs::remove_file(&out).unwrap();
    let err = merge(&p, &out, &["--max-memory", "12M"]).unwrap_err();
    assert!(
        err.contains("--max-memory") && err.contains("12.0 MiB"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn shards_of_a_2msc_bake_read_one_plan_and_merge_into_the_bytes_of_a_single_bake() {
    let dir = temp_dir("shard-plan");
    let scene = cornell();
    let extra = ["--method", "2msc", "--samples", "2"];
    let single = dir.join("single.lrr");
    bake(&scene, &single, &extra).unwrap();
    let plan = dir.join("cornell.plan");
    let mut args = vec!["plan", s(&scene), "-o", s(&plan), "-q"];
    args.extend_from_slice(&extra);
    lrr(&args).unwrap();
    let with_plan = [&extra[..], &["--plan", s(&plan)]].concat();
    let p: Vec<PathBuf> = (0..3).map(|i| dir.join(format!("p{i}.bin"))).collect();
    for (i, part) in p.iter().enumerate() {
        shard(&scene, part, i, 3, &with_plan);
    }
    let out = dir.join("merged.lrr");
    merge(&p, &out, &[]).unwrap();
    assert!(std::fs::read(&out).unwrap() == std::fs::read(&single).unwrap());
    // A plan made with other flags is refused by name.
    let spec = "0/3";
    let part = dir.join("x.bin");
    let err = lrr(&[
        "bake",
        s(&scene),
        "-o",
        s(&part),
        "-q",
        "--shard",
        spec,
        "--plan",
        s(&plan),
        "--samples",
        "2",
        "--method",
        "2mf",
    ])
    .unwrap_err();
    assert!(
        err.contains("cornell.plan") && err.contains("other settings"),
        "{err}"
    );
    assert!(!part.exists());
}

/// Runs `sbatch ARGS…` in `dir` with `LRR` naming the binary under test (the job scripts run
/// `${LRR:-lrr}`; sbatch passes the environment on); its standard output, trimmed.
fn sbatch(dir: &Path, args: &[&str]) -> Result<String, String> {
    // `timeout`: a node that never runs the job must fail the test, not hang it.
    let out = Command::new("timeout")
        .args(["600", "sbatch"])
        .args(args)
        .current_dir(dir)
        .env("LRR", lrr_binary())
        .output()
        .map_err(|e| format!("cannot run sbatch (run scripts/setup-slurm.sh): {e}"))?;
    let text = String::from_utf8_lossy(&out.stdout).trim().to_string();
    if out.status.success() {
        Ok(text)
    } else {
        Err(format!(
            "sbatch {args:?}: {}\n{text}\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        ))
    }
}

/// The job outputs (`*.out`) in `dir`, by name, for a failure's message.
fn job_outputs(dir: &Path) -> String {
    let mut names: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "out"))
        .collect();
    names.sort();
    names
        .iter()
        .map(|p| format!("{}:\n{}", p.display(), std::fs::read_to_string(p).unwrap()))
        .collect()
}

/// The Slurm example of docs/DISTRIBUTED.md as written: `sbatch --array=0-6` of
/// deploy/slurm/bake.sbatch (every task runs `lrr bake --shard env/7 -o PARTS/part-{i}.bin`,
/// the index from `SLURM_ARRAY_TASK_ID`), then deploy/slurm/merge.sbatch after it
/// (`--dependency=afterok`), on the one-node cluster of scripts/setup-slurm.sh; the merged file
/// is the single bake's bytes. scripts/test runs it when Slurm is set up, through
/// `scripts/slurm-node.sh run` (which starts and stops the daemons).
#[test]
#[ignore = "needs Slurm running: scripts/setup-slurm.sh, then scripts/slurm-node.sh run cargo test --release -p lrr-tests --test e2e -- --ignored on_slurm"]
fn a_slurm_job_array_and_its_merge_job_give_the_bytes_of_a_single_bake_on_slurm() {
    let dir = temp_dir("slurm");
    let scene = cornell();
    let count = 7;
    let extra = ["--samples", "4"];
    let single = dir.join("single.lrr");
    let text = bake(&scene, &single, &extra).unwrap();
    println!("single bake: {}", text.lines().next().unwrap_or(""));
    let parts_dir = dir.join("parts");
    let merged = dir.join("merged.lrr");
    let bake_job = root().join("deploy/slurm/bake.sbatch");
    let merge_job = root().join("deploy/slurm/merge.sbatch");
    let array = format!("--array=0-{}", count - 1);
    let mut args = vec!["--parsable", &array, s(&bake_job), s(&scene), s(&parts_dir)];
    args.extend_from_slice(&extra);
    let array_id = sbatch(&dir, &args).unwrap();
    // `--parsable` prints `ID` or `ID;CLUSTER`.
    let array_id = array_id.split(';').next().unwrap().to_string();
    println!("sbatch {array} deploy/slurm/bake.sbatch: job array {array_id}");
    let after = format!("--dependency=afterok:{array_id}");
    let merge_args = [
        "--parsable",
        "--wait",
        &after,
        s(&merge_job),
        s(&parts_dir),
        s(&merged),
    ];
    let merge_id = match sbatch(&dir, &merge_args) {
        Ok(id) => id.split(';').next().unwrap().to_string(),
        Err(e) => {
            let _ = Command::new("scancel").arg(&array_id).status();
            panic!("{e}\njob outputs:\n{}", job_outputs(&dir));
        }
    };
    println!("sbatch {after} --wait deploy/slurm/merge.sbatch: job {merge_id}");
    for i in 0..count {
        let out = dir.join(format!("lrr-bake-{array_id}_{i}.out"));
        let text = std::fs::read_to_string(&out)
            .unwrap_or_else(|e| panic!("{}: {e}\n{}", out.display(), job_outputs(&dir)));
        print!("task {i}: {text}");
        // The index came from SLURM_ARRAY_TASK_ID, and `{i}` in -o became it.
        let part = parts_dir.join(format!("part-{i}.bin"));
        assert!(
            text.contains(&format!(
                "baked shard {i}/{count} of cornell-box → {}",
                s(&part)
            )),
            "task {i}: {text}"
        );
    }
    let text = std::fs::read_to_string(dir.join(format!("lrr-merge-{merge_id}.out"))).unwrap();
    print!("merge: {text}");
    assert!(text.contains(&format!("merged {count} parts")), "{text}");
    assert!(
        std::fs::read(&merged).unwrap() == std::fs::read(&single).unwrap(),
        "the merge of the Slurm array's parts differs from the single bake"
    );
    println!(
        "merged.lrr and single.lrr: the same {} bytes",
        std::fs::metadata(&merged).unwrap().len()
    );
    // Kept when the test fails (the job outputs, the parts); 20 MB when it passes.
    std::fs::remove_dir_all(&dir).unwrap();
}
