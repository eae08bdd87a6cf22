//! A reference for 2MSC's split rule (issue #14; docs/MESHING.md, "An oracle that knows the
//! answer"): an *oracle* that knows the exact fine-mesh form factors `F` (n×n) and radiosity
//! `B` refines the same hierarchy as [`two_msc`](super::two_msc) (the same roots and children),
//! best first: it always splits the patch whose exact error (below) is largest. It shows what
//! an exact estimate in [`Ctx::error`] would give under a greedy rule. It is not a proof of
//! the best partition: the per-node error is first order (one gather, no solve) and neither
//! additive over patches nor monotone from parent to child, so another order or measure can
//! beat it (one variant of 2MSC beats its coherence form on the Cornell box: docs).
//!
//! A patch `P` kept whole makes the receiver `i` gather `F(i → P) B̄_P` instead of
//! `Σ_{e∈P} F_ie B_e`. The oracle's node error is `Σ_i Σ_c (ρ_ic (F(i → P) B̄_Pc − Σ_e F_ie B_ec))²`,
//! with `F(i → P)` either the sum of the exact factors (`LRR_ORACLE_ERROR=coherence`: what the
//! covariance of the module docs estimates) or the bake's own element-to-patch factor
//! (`total`, the default: coherence and the sampling of a large patch's visibility together).
//! Every partition it reaches, and 2MF's and 2MSC's, is then solved through the low-rank
//! operator and compared with the exact solve, as `lrr accuracy` does (relative L2 over the
//! elements and channels; the rows of enclosed elements rescaled to sum to one, as a bake
//! does), with the bake's element-to-patch factors (`LRR_ORACLE_FACTORS=real`, the default) or
//! the sums of the exact ones (`ideal`).
//!
//! ```text
//! LRR_ORACLE_SCENE=scene.toml LRR_ORACLE_DIV=10 cargo test --release -p lrr-precompute --lib \
//!     oracle_refinement -- --ignored --nocapture 2> curves.txt
//! python3 scripts/k-ratio.py curves.txt
//! ```
//!
//! [`merge_oracle`] does the same for the merge rule ([`super::merge`]): every element a patch,
//! touching patches of one surface joined cheapest first by the exact error of the join (the
//! same node error, summed over every element as receiver), against 2MF, the split rule and
//! the merge rule itself (`rule` lines, `LRR_MERGE_THRESHOLDS`). `LRR_MERGE_RECEIVERS=probes`
//! takes the probes as receivers, `LRR_MERGE_B=coarse` the radiosity of a 2MF low-rank solve,
//! `LRR_MERGE_ESTIMATE=1` (with probes) the bake's own estimate: centroid factors with rays and
//! the gathered radiosity; `LRR_MERGE_ONLY_RULE=1` stops after the rule's curve.
//!
//! `LRR_ORACLE_DIV=D` sets the element size to the scene's diagonal over `D` (10: `lrr
//! accuracy --quick`'s mesh), `LRR_ORACLE_H` to a length; neither: the bake's default.
//! Memory about `32 n²` bytes at the peak (the exact factors, the LU's copies, and 2MF's
//! k = n partition); the Cornell box's default mesh (n = 2 116) takes about two minutes on two
//! cores.

use super::merge::touch;
use super::*;
use crate::formfactor::FormFactors;
use crate::geometry::Polygon;
use crate::patches::Mesh;
use crate::patches::PatchMethod;
use crate::radiosity::{ElementData, relative_l2, solve_dense};
use crate::visibility::obvhs::ObvhsOccluder;
use faer::Mat;
use faer::linalg::solvers::Solve;
use std::path::{Path, PathBuf};

/// The exact answer on the fine mesh and what the oracle needs to measure a partition.
struct Truth<'a> {
    n: usize,
    /// Exact fine-mesh factors, n×n row-major (original ids).
    f: &'a [f64],
    area: Vec<f64>,
    rho: &'a [[f64; 3]],
    emission: &'a [[f64; 3]],
    /// The exact solve.
    b: &'a [[f64; 3]],
    polygons: &'a [Polygon],
    /// The bake's element-to-patch factors (enclosed rows rescaled to sum to one).
    ff: FormFactors<'a>,
    /// The same factors one column at a time, for the oracle's `total` error: not rescaled
    /// (a rescale needs the whole row), so the columns are the bake's up to that factor.
    column: FormFactors<'a>,
    real_factors: bool,
    total_error: bool,
}

impl Truth<'_> {
    /// The oracle's error of keeping `ids` (shape `shape`) as one patch (module docs).
    fn node_error(&self, ids: &[usize], shape: &Region) -> f64 {
        let a: f64 = ids.iter().map(|&e| self.area[e]).sum();
        let mut mean = [0.0; 3];
        for &e in ids {
            for (c, m) in mean.iter_mut().enumerate() {
                *m += self.area[e] * self.b[e][c] / a;
            }
        }
        let to_patch: Vec<f64> = if self.total_error {
            let all: Vec<u32> = (0..self.n as u32).collect();
            let mut column = vec![0.0; self.n];
            let shape = std::slice::from_ref(shape);
            self.column
                .matrix(self.polygons, &all, shape, &mut column, &|_| {});
            column
        } else {
            (0..self.n)
                .map(|i| ids.iter().map(|&e| self.f[i * self.n + e]).sum())
                .collect()
        };
        let mut total = 0.0;
        for (i, to_patch) in to_patch.iter().enumerate() {
            let row = &self.f[i * self.n..(i + 1) * self.n];
            for (c, mean) in mean.iter().enumerate() {
                let exact: f64 = ids.iter().map(|&e| row[e] * self.b[e][c]).sum();
                total += (self.rho[i][c] * (to_patch * mean - exact)).powi(2);
            }
        }
        total
    }

    /// `k` and the relative L2 error against the exact solve of the low-rank solution for a
    /// partition: the patch of every element (original ids) and the patches' shapes.
    fn measure(&self, patch_of: &[u32], shapes: &[Region]) -> (usize, f64) {
        (
            shapes.len(),
            relative_l2(&self.solve(patch_of, shapes), self.b),
        )
    }

    /// The low-rank solution for a partition (see [`Truth::measure`]).
    fn solve(&self, patch_of: &[u32], shapes: &[Region]) -> Vec<[f64; 3]> {
        let (n, k) = (self.n, shapes.len());
        let mut fnk = vec![0.0; n * k];
        if self.real_factors {
            let ids: Vec<u32> = (0..n as u32).collect();
            self.ff
                .matrix(self.polygons, &ids, shapes, &mut fnk, &|_| {});
        } else {
            for i in 0..n {
                for e in 0..n {
                    fnk[i * k + patch_of[e] as usize] += self.f[i * n + e];
                }
            }
        }
        let mut patch_area = vec![0.0; k];
        for (e, &p) in patch_of.iter().enumerate() {
            patch_area[p as usize] += self.area[e];
        }
        let mut out = vec![[0.0; 3]; n];
        for c in 0..3 {
            // (I − W ρ F_nk) b = W E with W_pe = A_e / A_p; then B = E + ρ F_nk b.
            let mut m = Mat::<f64>::identity(k, k);
            let mut rhs = Mat::<f64>::zeros(k, 1);
            for (e, &p) in patch_of.iter().enumerate() {
                let p = p as usize;
                let w = self.area[e] / patch_area[p];
                rhs[(p, 0)] += w * self.emission[e][c];
                for q in 0..k {
                    m[(p, q)] -= w * self.rho[e][c] * fnk[e * k + q];
                }
            }
            let b = m.partial_piv_lu().solve(&rhs);
            for (i, out) in out.iter_mut().enumerate() {
                let gathered: f64 = (0..k).map(|q| fnk[i * k + q] * b[(q, 0)]).sum();
                out[c] = self.emission[i][c] + self.rho[i][c] * gathered;
            }
        }
        out
    }
}

fn env(name: &str) -> Option<String> {
    std::env::var(name).ok()
}

/// Element ids of a node.
fn node_ids(ctx: &Ctx, node: &Node) -> Vec<usize> {
    let range = |first: u32, count: u32| first as usize..(first + count) as usize;
    match node {
        Node::Polygon { first, count, .. } => range(*first, *count).collect(),
        Node::Cluster { pieces } => pieces
            .iter()
            .flat_map(|&p| range(ctx.pieces[p].first, ctx.pieces[p].count))
            .collect(),
    }
}

/// The scene (`LRR_ORACLE_SCENE`, default the Cornell box) and its mesh sizes.
fn scene_and_sizes() -> (PathBuf, crate::scene::Scene, MeshSizes) {
    let path = env("LRR_ORACLE_SCENE")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box/cornell-box.toml")
        });
    let scene = crate::scene::load(&path).unwrap();
    let h = env("LRR_ORACLE_H")
        .map(|s| s.parse::<f64>().unwrap())
        .or_else(|| env("LRR_ORACLE_DIV").map(|d| scene.extent() / d.parse::<f64>().unwrap()));
    let sizes = MeshSizes::resolve(&scene, h, None).unwrap();
    (path, scene, sizes)
}

/// Samples per pair of the exact factors and of the bake's, as in `lrr accuracy`'s sweep.
const SAMPLES: u32 = 16;

/// The exact fine-mesh factors and solve, on the 2MF mesh's elements (original ids).
struct Exact {
    polygons: Vec<Polygon>,
    /// Per element id: whether its rows are rescaled to sum to one (the bake's enclosure test).
    closed: Vec<bool>,
    f: Vec<f64>,
    rho: Vec<[f64; 3]>,
    emission: Vec<[f64; 3]>,
    b: Vec<[f64; 3]>,
}

impl Exact {
    fn new(scene: &crate::scene::Scene, sizes: MeshSizes, occ: &ObvhsOccluder) -> Self {
        let base = Mesh::two_fixed(scene, sizes).unwrap();
        let n = base.n();
        let (rho, emission) = base.element_materials(scene);
        let polygons: Vec<Polygon> = base.elements.iter().map(|e| e.polygon).collect();
        let closed = crate::formfactor::enclosure::Enclosure::probe(occ, &polygons).closed;
        let ff = Self::factors(&closed, occ);
        let ids: Vec<u32> = (0..n as u32).collect();
        let singles: Vec<Region> = polygons.iter().map(|&p| Region::single(p)).collect();
        let mut f = vec![0.0; n * n];
        ff.matrix(&polygons, &ids, &singles, &mut f, &|_| {});
        let data = ElementData {
            reflectance: &rho,
            emission: &emission,
        };
        let b = solve_dense(&f, &data).unwrap();
        Self {
            polygons,
            closed,
            f,
            rho,
            emission,
            b,
        }
    }

    /// The bake's factors: [`SAMPLES`] per pair, the rows of `closed` elements rescaled.
    fn factors<'a>(closed: &'a [bool], occ: &'a ObvhsOccluder) -> FormFactors<'a> {
        FormFactors::new(SAMPLES, Some(occ)).with_enclosure(Some(closed))
    }

    fn truth<'a>(&'a self, occ: &'a ObvhsOccluder, real: bool, total: bool) -> Truth<'a> {
        Truth {
            n: self.polygons.len(),
            f: &self.f,
            area: self.polygons.iter().map(Polygon::area).collect(),
            rho: &self.rho,
            emission: &self.emission,
            b: &self.b,
            polygons: &self.polygons,
            ff: Self::factors(&self.closed, occ),
            column: FormFactors::new(SAMPLES, Some(occ)),
            real_factors: real,
            total_error: total,
        }
    }
}

/// Prints the curves the oracles are compared with: 2MF at patch multiples 1–8 and the split
/// rule at thresholds 3e-3 … 3e-6 (`k`, error as `of_mesh` measures them).
fn baselines(
    scene: &crate::scene::Scene,
    sizes: MeshSizes,
    occ: &ObvhsOccluder,
    of_mesh: &dyn Fn(&Mesh) -> (usize, f64),
) {
    let h = sizes.element_size;
    for m in [1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0] {
        let s = MeshSizes {
            element_size: h,
            patch_size: m * h,
        };
        let (k, error) = of_mesh(&Mesh::two_fixed(scene, s).unwrap());
        eprintln!("2mf k {k} error {error:.4e} multiple {m}");
    }
    for threshold in [3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6] {
        let method = PatchMethod::SpatialCoherence {
            threshold,
            min_patch_area: None,
            rule: crate::patches::CoherenceRule::Split,
        };
        let (k, error) = of_mesh(&Mesh::build(scene, sizes, method, Some(occ)).unwrap());
        eprintln!("2msc k {k} error {error:.4e} threshold {threshold:e}");
    }
}

#[test]
#[ignore = "experiment (minutes): prints the k/error curves of 2MF, 2MSC and the oracle"]
fn oracle_refinement() {
    let (path, scene, sizes) = scene_and_sizes();
    let h = sizes.element_size;
    let occ = ObvhsOccluder::build(&scene);
    let exact = Exact::new(&scene, sizes, &occ);
    let n = exact.polygons.len();
    let truth = exact.truth(
        &occ,
        env("LRR_ORACLE_FACTORS").as_deref() != Some("ideal"),
        env("LRR_ORACLE_ERROR").as_deref() != Some("coherence"),
    );
    eprintln!(
        "# {}: n = {n}, h = {h}, factors {}, oracle error {}",
        path.display(),
        if truth.real_factors { "real" } else { "ideal" },
        if truth.total_error {
            "total"
        } else {
            "coherence"
        },
    );
    let of_mesh = |mesh: &Mesh| {
        let patch_of: Vec<u32> = mesh.elements.iter().map(|e| e.patch).collect();
        let shapes: Vec<Region> = mesh.patches.iter().map(|p| p.shape.clone()).collect();
        truth.measure(&patch_of, &shapes)
    };
    baselines(&scene, sizes, &occ, &of_mesh);

    if env("LRR_ORACLE_SKIP").is_some() {
        return; // 2MF and 2MSC only
    }
    // The oracle: the same roots and children as `two_msc`, best first by the node's error.
    let (_, pieces, _) = crate::mesh::fine_mesh(&scene, sizes).unwrap();
    let ctx = Ctx {
        pieces: &pieces,
        units: pieces.iter().map(|p| Unit::of(&p.polygon)).collect(),
        materials: &[],
        element_size: h,
    };
    // (error, node, children); a node without children has error −1 and is never split.
    let score = |node: Node| {
        let children = ctx.children(&node);
        let error = if children.len() < 2 {
            -1.0
        } else {
            truth.node_error(&node_ids(&ctx, &node), &ctx.patch(&node).1.shape)
        };
        (error, node, children)
    };
    let mut live: Vec<(f64, Node, Vec<Node>)> =
        roots(&pieces, sizes).into_par_iter().map(score).collect();
    for budget in [40, 60, 100, 150, 250, 350, 500, 700] {
        while live.len() < budget {
            let worst = (0..live.len())
                .max_by(|&a, &b| live[a].0.total_cmp(&live[b].0))
                .expect("patches");
            if live[worst].0 < 0.0 {
                break; // every patch is one element
            }
            let (_, _, children) = live.swap_remove(worst);
            let scored: Vec<_> = children.into_par_iter().map(score).collect();
            live.extend(scored);
        }
        let mut patch_of = vec![0; n];
        let mut shapes = Vec::with_capacity(live.len());
        for (p, (_, node, _)) in live.iter().enumerate() {
            for e in node_ids(&ctx, node) {
                patch_of[e] = p as u32;
            }
            shapes.push(ctx.patch(node).1.shape);
        }
        let (k, error) = truth.measure(&patch_of, &shapes);
        eprintln!("oracle k {k} error {error:.4e}");
    }
}

#[test]
#[ignore = "experiment: 2MSC's estimate against the oracle's error, node by node"]
fn estimate_against_oracle() {
    let (_, scene, sizes) = scene_and_sizes();
    let h = sizes.element_size;
    let occ = ObvhsOccluder::build(&scene);
    let exact = Exact::new(&scene, sizes, &occ);
    let (n, polygons) = (exact.polygons.len(), &exact.polygons);
    // The coherence error by default (what 2MSC's covariance estimates); LRR_ORACLE_ERROR=total
    // for the oracle's default. The receivers printed below always use the exact factors.
    let truth = exact.truth(
        &occ,
        true,
        env("LRR_ORACLE_ERROR").as_deref() == Some("total"),
    );
    // The probes and materials as `Mesh::two_msc` makes them.
    let (elements, pieces, _) = crate::mesh::fine_mesh(&scene, sizes).unwrap();
    let (probes, materials, _) =
        crate::patches::msc_inputs(&scene, sizes, &pieces, &elements, Some(&occ), (0, None))
            .unwrap();
    let ctx = Ctx {
        pieces: &pieces,
        units: pieces.iter().map(|p| Unit::of(&p.polygon)).collect(),
        materials: &materials,
        element_size: h,
    };
    // Every splittable node down to `LRR_ORACLE_MIN` elements (default 4).
    let min: usize = env("LRR_ORACLE_MIN").map_or(4, |s| s.parse().unwrap());
    let mut nodes = Vec::new();
    let mut stack = roots(&pieces, sizes);
    while let Some(node) = stack.pop() {
        let children = ctx.children(&node);
        if children.len() < 2 || node_ids(&ctx, &node).len() < min {
            continue;
        }
        stack.extend(children.iter().cloned());
        nodes.push((node, children));
    }
    struct Row {
        estimate: f64,
        oracle: f64,
        elements: usize,
        point: DVec3,
        face: u32,
    }
    let rows: Vec<Row> = nodes
        .par_iter()
        .map(|(node, children)| {
            let ids = node_ids(&ctx, node);
            let patch = ctx.patch(node).1;
            Row {
                estimate: ctx.error(node, children, &probes),
                oracle: truth.node_error(&ids, &patch.shape).sqrt(),
                elements: ids.len(),
                point: ctx.representative(node).0,
                face: patch.face,
            }
        })
        .collect();
    // Ranks (0 = smallest) and Spearman's rank correlation.
    let rank = |key: fn(&Row) -> f64| {
        let mut order: Vec<usize> = (0..rows.len()).collect();
        order.sort_by(|&a, &b| key(&rows[a]).total_cmp(&key(&rows[b])));
        let mut r = vec![0.0; rows.len()];
        for (i, &o) in order.iter().enumerate() {
            r[o] = i as f64;
        }
        r
    };
    let (re, ro) = (rank(|r| r.estimate), rank(|r| r.oracle));
    let m = rows.len() as f64;
    let d2: f64 = re.iter().zip(&ro).map(|(a, b)| (a - b).powi(2)).sum();
    let spearman = 1.0 - 6.0 * d2 / (m * (m * m - 1.0));
    eprintln!("# {} nodes, Spearman {spearman:.3}", rows.len());
    let mut order: Vec<usize> = (0..rows.len()).collect();
    order.sort_by(|&a, &b| (ro[b] - re[b]).total_cmp(&(ro[a] - re[a])));
    let show = |label: &str, i: usize| {
        let r = &rows[i];
        eprintln!(
            "{label} ranks: oracle {} estimate {}; {} elements of face {} at {:?}: estimate \
             {:.2e}, oracle {:.2e}",
            ro[i], re[i], r.elements, r.face, r.point, r.estimate, r.oracle
        );
    };
    for &i in order.iter().take(20) {
        show("under", i);
    }
    for &i in order.iter().rev().take(10) {
        show("over", i);
    }
    // The most under-estimated node: its elements, its children's estimates, the receivers
    // that carry its error (first channel).
    let worst = order[0];
    let (node, children) = &nodes[worst];
    let ids = node_ids(&ctx, node);
    for &e in &ids {
        let (x, b) = (polygons[e].centroid(), truth.b[e][0]);
        eprintln!("# element {e} at {x:?}: B {b:.4}");
    }
    let piece = match node {
        Node::Polygon { piece, .. } => *piece as usize,
        Node::Cluster { pieces } => pieces[0],
    };
    let material = ctx.materials[piece];
    for c in children {
        let (x, normal, _) = ctx.representative(c);
        let mut f = vec![0.0; probes.targets.len()];
        view(&probes, x, normal, &mut f);
        let gathered: f64 = f.iter().zip(&probes.radiosity).map(|(f, b)| f * b).sum();
        let b = material.emission + material.reflectance * gathered;
        eprintln!("# child at {x:?}: estimated b {b:.4}");
    }
    let area: f64 = ids.iter().map(|&e| truth.area[e]).sum();
    let mean: f64 = ids
        .iter()
        .map(|&e| truth.area[e] * truth.b[e][0])
        .sum::<f64>()
        / area;
    let mut receivers: Vec<(f64, usize)> = (0..n)
        .map(|i| {
            let row = &truth.f[i * n..(i + 1) * n];
            let to_patch: f64 = ids.iter().map(|&e| row[e]).sum();
            let exact: f64 = ids.iter().map(|&e| row[e] * truth.b[e][0]).sum();
            (truth.rho[i][0] * (to_patch * mean - exact), i)
        })
        .collect();
    receivers.sort_by(|x, y| y.0.abs().total_cmp(&x.0.abs()));
    for &(d, i) in receivers.iter().take(8) {
        let row = &truth.f[i * n..(i + 1) * n];
        let f: Vec<String> = ids.iter().map(|&e| format!("{:.4}", row[e])).collect();
        let (x, b) = (polygons[i].centroid(), truth.b[i][0]);
        eprintln!(
            "# receiver {i} at {x:?}, B {b:.4}: error {d:.3e}, F to the elements {}",
            f.join(" ")
        );
    }
}

#[test]
#[ignore = "experiment (minutes): bottom-up merges with exact errors, against 2MF and 2MSC"]
fn merge_oracle() {
    let (path, scene, sizes) = scene_and_sizes();
    let h = sizes.element_size;
    let occ = ObvhsOccluder::build(&scene);
    let exact = Exact::new(&scene, sizes, &occ);
    let n = exact.polygons.len();
    let truth = exact.truth(
        &occ,
        env("LRR_ORACLE_FACTORS").as_deref() != Some("ideal"),
        false,
    );
    let cone: f64 = env("LRR_ORACLE_CONE").map_or(45.0, |s| s.parse().unwrap());
    let cos_cone = cone.to_radians().cos();
    eprintln!(
        "# {}: n = {n}, h = {h}, factors {}, merge oracle, cone {cone}",
        path.display(),
        if truth.real_factors { "real" } else { "ideal" },
    );
    let of_mesh = |mesh: &Mesh| {
        let patch_of: Vec<u32> = mesh.elements.iter().map(|e| e.patch).collect();
        let shapes: Vec<Region> = mesh.patches.iter().map(|p| p.shape.clone()).collect();
        truth.measure(&patch_of, &shapes)
    };
    if env("LRR_ORACLE_SKIP").is_none() {
        baselines(&scene, sizes, &occ, &of_mesh);
    }
    let thresholds = env("LRR_MERGE_THRESHOLDS")
        .unwrap_or("1e-2,5e-3,3e-3,2e-3,1.5e-3,1e-3,7e-4,5e-4,3e-4".into());
    for threshold in thresholds.split(',').map(|t| t.parse::<f64>().unwrap()) {
        let method = PatchMethod::SpatialCoherence {
            threshold,
            min_patch_area: None,
            rule: crate::patches::CoherenceRule::Merge,
        };
        let t = std::time::Instant::now();
        let mesh = Mesh::build(&scene, sizes, method, Some(&occ)).unwrap();
        let seconds = t.elapsed().as_secs_f64();
        let (k, error) = of_mesh(&mesh);
        eprintln!("rule k {k} error {error:.4e} threshold {threshold:e} mesh {seconds:.2} s");
    }
    if env("LRR_MERGE_ONLY_RULE").is_some() {
        return;
    }
    let polygons = &exact.polygons;
    let eps = 1e-6 * scene.extent();
    // Neighbours: touching elements.
    let neighbours: Vec<Vec<usize>> = (0..n)
        .into_par_iter()
        .map(|a| {
            (0..n)
                .filter(|&b| b != a && touch(&polygons[a], &polygons[b], eps))
                .collect()
        })
        .collect();
    // Per patch: members, area, Σ A_e B_e, s_i = Σ_e F_ie, t_ic = Σ_e F_ie B_ec, error.
    struct Agg {
        members: Vec<usize>,
        area: f64,
        ab: [f64; 3],
        normal: DVec3,
        s: Vec<f64>,
        t: Vec<[f64; 3]>,
        error: f64,
    }
    // Receivers: every element (exact) or the probes (2MF patches at the patch size), each
    // with the area-weighted mean of its elements' exact factors, weighted by its elements.
    let base = Mesh::two_fixed(&scene, sizes).unwrap();
    let probes = env("LRR_MERGE_RECEIVERS").as_deref() == Some("probes");
    let (receiver_of, r): (Vec<usize>, usize) = if probes {
        (
            base.elements.iter().map(|e| e.patch as usize).collect(),
            base.patches.len(),
        )
    } else {
        ((0..n).collect(), n)
    };
    let mut r_area = vec![0.0; r];
    let mut r_count = vec![0.0; r];
    let mut r_rho = vec![[0.0; 3]; r];
    for i in 0..n {
        let j = receiver_of[i];
        r_area[j] += truth.area[i];
        r_count[j] += 1.0;
        for c in 0..3 {
            r_rho[j][c] += truth.area[i] * truth.rho[i][c];
        }
    }
    for j in 0..r {
        r_rho[j] = r_rho[j].map(|x| x / r_area[j]);
    }
    // The radiosity the merges see: exact, or 2MF's low-rank solution at the patch size.
    let coarse: Vec<[f64; 3]>;
    let mut estimated: Vec<[f64; 3]> = Vec::new();
    let b: &[[f64; 3]] = if env("LRR_MERGE_B").as_deref() == Some("coarse") {
        let patch_of: Vec<u32> = base.elements.iter().map(|e| e.patch).collect();
        let shapes: Vec<Region> = base.patches.iter().map(|p| p.shape.clone()).collect();
        coarse = truth.solve(&patch_of, &shapes);
        eprintln!("# coarse B: error {:.3e}", relative_l2(&coarse, truth.b));
        &coarse
    } else {
        truth.b
    };
    eprintln!("# receivers {r}");
    // What a bake can know: each element's point-to-probe factors from its centroid (rays as
    // 2MSC casts them) and its radiosity gathered from the probes' coarse solve (grey).
    let estimate = env("LRR_MERGE_ESTIMATE").is_some();
    let views: Vec<Vec<f64>> = if estimate {
        assert!(probes, "the estimate needs LRR_MERGE_RECEIVERS=probes");
        let (elements, pieces, _) = crate::mesh::fine_mesh(&scene, sizes).unwrap();
        let (pr, _, _) =
            crate::patches::msc_inputs(&scene, sizes, &pieces, &elements, Some(&occ), (0, None))
                .unwrap();
        assert_eq!(pr.targets.len(), r);
        let views: Vec<Vec<f64>> = (0..n)
            .into_par_iter()
            .map(|e| {
                let mut f = vec![0.0; r];
                view(&pr, polygons[e].centroid(), polygons[e].normal, &mut f);
                f
            })
            .collect();
        estimated = (0..n)
            .map(|e| {
                let grey = |v: [f64; 3]| v.iter().sum::<f64>() / 3.0;
                let g: f64 = views[e].iter().zip(&pr.radiosity).map(|(f, b)| f * b).sum();
                [grey(truth.emission[e]) + grey(truth.rho[e]) * g; 3]
            })
            .collect();
        eprintln!(
            "# estimated B: error {:.3e}",
            relative_l2(&estimated, truth.b)
        );
        views
    } else {
        Vec::new()
    };
    let b: &[[f64; 3]] = if estimate { &estimated } else { b };
    let column = |e: usize| -> (Vec<f64>, Vec<[f64; 3]>) {
        let mut s = vec![0.0; r];
        if estimate {
            for j in 0..r {
                s[j] = truth.area[e] * views[e][j] / r_area[j];
            }
        } else {
            for i in 0..n {
                let j = receiver_of[i];
                s[j] += truth.area[i] * truth.f[i * n + e] / r_area[j];
            }
        }
        let t = s.iter().map(|&x| b[e].map(|bc| x * bc)).collect();
        (s, t)
    };
    let error_of = |a: &Agg| -> f64 {
        let mean = a.ab.map(|x| x / a.area);
        let mut total = 0.0;
        for j in 0..r {
            for c in 0..3 {
                total += r_count[j] * (r_rho[j][c] * (a.s[j] * mean[c] - a.t[j][c])).powi(2);
            }
        }
        total
    };
    let union = |a: &Agg, b: &Agg| -> Option<Agg> {
        let normal = a.normal + b.normal;
        let axis = normal.normalize();
        let members: Vec<usize> = a.members.iter().chain(&b.members).copied().collect();
        if members
            .iter()
            .any(|&e| polygons[e].normal.dot(axis) < cos_cone)
        {
            return None;
        }
        let mut u = Agg {
            members,
            area: a.area + b.area,
            ab: std::array::from_fn(|c| a.ab[c] + b.ab[c]),
            normal,
            s: a.s.iter().zip(&b.s).map(|(x, y)| x + y).collect(),
            t: a.t
                .iter()
                .zip(&b.t)
                .map(|(x, y)| std::array::from_fn(|c| x[c] + y[c]))
                .collect(),
            error: 0.0,
        };
        u.error = error_of(&u);
        Some(u)
    };
    let mut patches: Vec<Option<Agg>> = (0..n)
        .into_par_iter()
        .map(|e| {
            let area = truth.area[e];
            let (s, t) = column(e);
            Some(Agg {
                members: vec![e],
                area,
                ab: std::array::from_fn(|c| area * b[e][c]),
                normal: polygons[e].normal * area,
                s,
                t,
                error: 0.0,
            })
        })
        .collect();
    let mut patch_of: Vec<usize> = (0..n).collect();
    let mut version = vec![0u32; n];
    // Candidate merges (cost, a, b, version a, version b), smallest cost first.
    #[derive(PartialEq)]
    struct Cand(f64, usize, usize, u32, u32);
    impl Eq for Cand {}
    impl PartialOrd for Cand {
        fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
            Some(self.cmp(o))
        }
    }
    impl Ord for Cand {
        fn cmp(&self, o: &Self) -> std::cmp::Ordering {
            o.0.total_cmp(&self.0)
        }
    }
    let cost = |a: &Agg, b: &Agg| union(a, b).map(|u| u.error - a.error - b.error);
    let mut heap = std::collections::BinaryHeap::new();
    let pairs: Vec<(usize, usize)> = (0..n)
        .flat_map(|a| {
            neighbours[a]
                .iter()
                .filter(move |&&b| b > a)
                .map(move |&b| (a, b))
        })
        .collect();
    let costs: Vec<Option<f64>> = pairs
        .par_iter()
        .map(|&(a, b)| cost(patches[a].as_ref().unwrap(), patches[b].as_ref().unwrap()))
        .collect();
    for (&(a, b), c) in pairs.iter().zip(costs) {
        if let Some(c) = c {
            heap.push(Cand(c, a, b, 0, 0));
        }
    }
    let mut live = n;
    let budgets = [700, 500, 350, 250, 150, 100, 60, 40];
    for budget in budgets {
        while live > budget {
            let Some(Cand(_, a, b, va, vb)) = heap.pop() else {
                break;
            };
            if version[a] != va || version[b] != vb || patches[a].is_none() || patches[b].is_none()
            {
                continue;
            }
            let u = union(patches[a].as_ref().unwrap(), patches[b].as_ref().unwrap()).unwrap();
            for &e in &patches[b].as_ref().unwrap().members {
                patch_of[e] = a;
            }
            patches[b] = None;
            patches[a] = Some(u);
            version[a] += 1;
            live -= 1;
            // New candidates with every patch touching the union.
            let mut near: Vec<usize> = patches[a]
                .as_ref()
                .unwrap()
                .members
                .iter()
                .flat_map(|&e| neighbours[e].iter().map(|&x| patch_of[x]))
                .filter(|&p| p != a)
                .collect();
            near.sort_unstable();
            near.dedup();
            let pa = patches[a].as_ref().unwrap();
            let new: Vec<(usize, Option<f64>)> = near
                .par_iter()
                .map(|&p| (p, cost(pa, patches[p].as_ref().unwrap())))
                .collect();
            for (p, c) in new {
                if let Some(c) = c {
                    let (x, y) = (a.min(p), a.max(p));
                    heap.push(Cand(c, x, y, version[x], version[y]));
                }
            }
        }
        if live > budget {
            eprintln!("# no more merges at k {live}");
            break;
        }
        let ids: Vec<usize> = (0..n).filter(|&p| patches[p].is_some()).collect();
        let mut index = vec![0u32; n];
        for (j, &p) in ids.iter().enumerate() {
            index[p] = j as u32;
        }
        let of: Vec<u32> = (0..n).map(|e| index[patch_of[e]]).collect();
        let shapes: Vec<Region> = ids
            .iter()
            .map(|&p| {
                let m = &patches[p].as_ref().unwrap().members;
                Region::new(m.iter().map(|&e| polygons[e]).collect())
            })
            .collect();
        let (k, error) = truth.measure(&of, &shapes);
        eprintln!("merge k {k} error {error:.4e}");
    }
}
