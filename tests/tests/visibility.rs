//! The visibility backends: Embree against obvhs on the rays bakes cast (feature `embree`),
//! bakes with either backend, the `--visibility` flag and `lrr bench visibility`.

#[path = "e2e/util.rs"]
#[allow(dead_code)]
mod util;

use util::lrr_json;
#[cfg(not(feature = "embree"))]
use util::{bake, cornell, temp_dir};

/// Without the feature, asking for Embree is an error that says how to get it.
#[cfg(not(feature = "embree"))]
#[test]
fn visibility_embree_without_the_feature_says_how_to_rebuild() {
    let dir = temp_dir("no-embree");
    let out = dir.join("c.lrr");
    let err = bake(&cornell(), &out, &["--visibility", "embree"]).unwrap_err();
    assert!(
        err.contains("scripts/setup-embree.sh") && err.contains("--features embree"),
        "{err}"
    );
    assert!(!out.exists());
}

/// `lrr bench visibility --json` has one row per scene, backend and thread count (each its own
/// measurement: no backend timed twice under two names), Embree's exactly when the build has
/// it, every run's ratio to Embree, and every backend answered the same rays.
#[test]
fn bench_visibility_rows_cover_the_backends_embree_when_built() {
    let rows = lrr_json(&[
        "bench",
        "visibility",
        "--rays",
        "20000",
        "--runs",
        "2",
        "--threads",
        "2",
        "--json",
    ]);
    let rows = rows.as_array().unwrap();
    let mut backends = vec!["obvhs"];
    if cfg!(feature = "embree") {
        backends.push("embree");
    }
    for scene in ["cornell", "cluttered"] {
        for threads in [1, 2] {
            for backend in &backends {
                let row = rows
                    .iter()
                    .find(|r| {
                        r["scene"] == scene && r["backend"] == *backend && r["threads"] == threads
                    })
                    .unwrap_or_else(|| panic!("no row {scene} {backend} {threads}"));
                assert!(row["rays_per_s"].as_f64().unwrap() > 0.0, "{row}");
                assert!(row["rays"].as_u64().unwrap() >= 20_000, "{row}");
                let blocked = row["blocked"].as_u64().unwrap();
                assert!(
                    blocked > 0 && blocked < row["rays"].as_u64().unwrap(),
                    "{row}"
                );
                assert_eq!(row["runs"], 2, "{row}");
                let ratios = row["ratios_vs_embree"].as_array().unwrap();
                if cfg!(feature = "embree") {
                    assert_eq!(ratios.len(), 2, "{row}");
                    assert!(ratios.iter().all(|r| r.as_f64().unwrap() > 0.0), "{row}");
                    if *backend == "embree" {
                        assert!(ratios.iter().all(|r| r.as_f64() == Some(1.0)), "{row}");
                    }
                } else {
                    assert!(
                        ratios.is_empty() && row["ratio_vs_embree"].is_null(),
                        "{row}"
                    );
                }
                if *backend == "obvhs" {
                    assert_eq!(row["differs_from_obvhs"], 0, "{row}");
                }
            }
        }
    }
    assert_eq!(rows.len(), 2 * 2 * backends.len());
}

#[cfg(feature = "embree")]
mod embree {
    use super::util::{bake, cornell, lrr, temp_dir};
    use lrr_cli::record::record;
    use lrr_precompute::bake::{DEFAULT_SAMPLES, Prepared};
    use lrr_precompute::mesh::MeshSizes;
    use lrr_precompute::patches::PatchMethod;
    use lrr_precompute::progress::Progress;
    use lrr_precompute::scene::{Scene, procedural};
    use lrr_precompute::visibility::Backend;

    /// Largest share of rays on which the backends may differ. Embree decides in f32 what
    /// obvhs decides in f64: rays that graze a triangle's edge within f32 rounding (~1e-7
    /// of the scene) can go either way; nothing else may differ (the own-face rule and
    /// crossings next to the end points are decided identically, see visibility/embree.rs).
    const MAX_DISAGREEMENT: f64 = 1e-5;

    fn agreement(name: &str, scene: &Scene) {
        let sizes = MeshSizes::resolve(scene, None, None).unwrap();
        let p = Prepared::new(
            scene,
            sizes,
            PatchMethod::TwoFixed,
            Backend::Obvhs,
            &Progress::hidden(),
        )
        .unwrap();
        // The rays a default bake casts, at least 10⁶ of them.
        let set = record(&p, DEFAULT_SAMPLES, 1_000_000);
        assert!(set.rays() >= 1_000_000, "{name}: {} rays", set.rays());
        let obvhs = set.answer_single(p.occluder.as_deref().unwrap());
        let embree_occ = Backend::Embree.build(scene).unwrap();
        let embree = set.answer_single(&*embree_occ);
        let blocked = obvhs.iter().filter(|&&b| b).count();
        let differ: Vec<usize> = (0..set.rays()).filter(|&i| obvhs[i] != embree[i]).collect();
        let leaks = differ.iter().filter(|&&i| obvhs[i]).count();
        println!(
            "{name}: {} rays, {blocked} blocked, {} disagreements ({} blocked only by obvhs, \
             {} only by embree), rate {:.1e}",
            set.rays(),
            differ.len(),
            leaks,
            differ.len() - leaks,
            differ.len() as f64 / set.rays() as f64
        );
        // Not vacuous: a good share of the rays is blocked, a good share is not.
        assert!(blocked > set.rays() / 100 && blocked < set.rays() * 99 / 100);
        assert!(
            differ.len() as f64 <= MAX_DISAGREEMENT * set.rays() as f64,
            "{name}: {} of {} rays differ",
            differ.len(),
            set.rays()
        );
    }

    #[test]
    fn embree_and_obvhs_agree_on_cornell_box_form_factor_rays() {
        let scene = lrr_precompute::scene::load(&cornell()).unwrap();
        agreement("cornell", &scene);
    }

    #[test]
    fn embree_and_obvhs_agree_on_cluttered_room_form_factor_rays() {
        let scene = procedural::cluttered(4, 1)
            .build("cluttered", std::path::Path::new("."))
            .unwrap();
        agreement("cluttered", &scene);
    }

    fn radiosity(path: &std::path::Path) -> Vec<f64> {
        let op = lrr_runtime::Operator::load(path).unwrap();
        op.evaluate_baked()
            .iter()
            .flat_map(|b| b.map(f64::from))
            .collect()
    }

    fn relative_l2(a: &[f64], b: &[f64]) -> f64 {
        let d: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
        let n: f64 = b.iter().map(|y| y * y).sum();
        (d / n).sqrt()
    }

    /// Cornell box bakes with either backend agree within the sampling error.
    ///
    /// The bound: the bake's sampling error is measured here as the difference between two
    /// obvhs bakes that differ only in their samples (16 and 25 per pair: other quadrature
    /// points and rays). The backends answer all but ≤ 1e-5 of the same rays identically, so
    /// their bakes must differ far less than that: we ask for a tenth of it (and below 1e-4
    /// relative L2 in any case). Embree bakes on 1 and 2 threads are byte-identical.
    #[test]
    fn embree_bake_of_the_cornell_box_matches_obvhs_within_sampling_error() {
        let dir = temp_dir("embree-bake");
        let scene = cornell();
        let bake = |name: &str, extra: &[&str]| {
            let out = dir.join(name);
            let mut args = vec![
                "bake",
                scene.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
                "-q",
            ];
            args.extend_from_slice(extra);
            lrr(&args).unwrap();
            out
        };
        let obvhs = bake("obvhs.lrr", &[]);
        let obvhs25 = bake("obvhs25.lrr", &["--samples", "25"]);
        let embree1 = bake("embree1.lrr", &["--visibility", "embree", "--threads", "1"]);
        let embree2 = bake("embree2.lrr", &["--visibility", "embree", "--threads", "2"]);
        assert!(
            std::fs::read(&embree1).unwrap() == std::fs::read(&embree2).unwrap(),
            "embree bakes differ between 1 and 2 threads"
        );
        let info = super::lrr_json(&["info", embree1.to_str().unwrap(), "--json"]);
        assert!(
            info.to_string().contains("\"visibility\":\"embree\""),
            "{info}"
        );
        let (b_obvhs, b_25, b_embree) =
            (radiosity(&obvhs), radiosity(&obvhs25), radiosity(&embree1));
        let sampling = relative_l2(&b_25, &b_obvhs);
        let backends = relative_l2(&b_embree, &b_obvhs);
        println!(
            "Cornell box radiosity, relative L2: embree vs obvhs {backends:.2e}, \
             obvhs 25 vs 16 samples {sampling:.2e}"
        );
        assert!(sampling > 0.0);
        assert!(
            backends <= 0.1 * sampling && backends <= 1e-4,
            "backends differ by {backends:.2e}, sampling error {sampling:.2e}"
        );
    }

    /// A scene where nothing occludes casts no rays, whichever backend is asked for.
    #[test]
    fn embree_asked_for_a_convex_scene_casts_no_rays() {
        let dir = temp_dir("embree-furnace");
        let scene = dir.join("furnace.toml");
        lrr(&["scene", "furnace", "-o", scene.to_str().unwrap()]).unwrap();
        let report = dir.join("r.json");
        let out = dir.join("f.lrr");
        bake(
            &scene,
            &out,
            &[
                "--visibility",
                "embree",
                "--report",
                report.to_str().unwrap(),
            ],
        )
        .unwrap();
        let r: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
        assert_eq!(r["rays"], 0, "{r}");
        assert_eq!(r["visibility"], "none (nothing occludes)", "{r}");
    }
}

/// `lrr scene cluttered` writes a scene that loads, has its objects and needs rays.
#[test]
fn scene_cluttered_writes_a_room_with_occluders() {
    let dir = util::temp_dir("cluttered");
    let write = |path: &std::path::Path| {
        let out = path.to_str().unwrap();
        util::lrr(&[
            "scene",
            "cluttered",
            "--grid",
            "3",
            "--seed",
            "7",
            "-o",
            out,
        ])
        .unwrap();
    };
    let path = dir.join("cluttered.toml");
    write(&path);
    let scene = lrr_precompute::scene::load(&path).unwrap();
    // The room's six walls, the lamp and at least one face per object.
    assert!(scene.faces.len() >= 6 + 1 + 9, "{}", scene.faces.len());
    assert!(!lrr_precompute::visibility::nothing_occludes(&scene));
    let again = dir.join("again.toml");
    write(&again);
    assert_eq!(
        std::fs::read(&path).unwrap(),
        std::fs::read(&again).unwrap(),
        "same seed, same scene"
    );
    let err = util::lrr(&["scene", "cluttered", "--grid", "0"]).unwrap_err();
    assert!(err.contains("--grid"), "{err}");
}
