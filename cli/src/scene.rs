//! `lrr scene`: write generated scene descriptions (and, for `building`, the glTF geometry and
//! the animation beside the description).

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::{Args, Subcommand};

use lrr_precompute::scene::{building, procedural, showcase};

#[derive(Debug, Args)]
pub struct SceneArgs {
    #[command(subcommand)]
    pub kind: SceneKind,
    /// File to write (.toml); standard output when absent.
    #[arg(short, long, global = true, value_name = "FILE")]
    pub output: Option<PathBuf>,
}

#[derive(Debug, Subcommand)]
pub enum SceneKind {
    /// A closed unit cube with uniform reflectance and emission: B = E / (1 - ρ) exactly.
    Furnace {
        #[arg(long, default_value_t = 0.5)]
        reflectance: f64,
        /// Emitted radiance Ke (exitance is π·Ke).
        #[arg(long, default_value_t = 1.0)]
        radiance: f64,
    },
    /// Two directly opposed parallel squares.
    Parallel {
        #[arg(long, default_value_t = 1.0)]
        side: f64,
        #[arg(long, default_value_t = 1.0)]
        distance: f64,
    },
    /// Two perpendicular rectangles sharing an edge.
    Perpendicular {
        /// Length of the shared edge.
        #[arg(long, default_value_t = 1.0)]
        length: f64,
        /// Width of the base rectangle.
        #[arg(long, default_value_t = 1.0)]
        width: f64,
        /// Height of the wall rectangle.
        #[arg(long, default_value_t = 1.0)]
        height: f64,
    },
    /// A dense mesh: an icosphere of 20·4^N small triangles in a closed room with a ceiling
    /// light (patches are built by clustering).
    DenseSphere {
        /// Icosphere subdivision levels N (0 to 6; 3 gives 1 280 triangles).
        #[arg(long, default_value_t = 3)]
        subdivisions: u32,
    },
    /// A room cluttered with boxes, upright, leaning and horizontal zero-thickness panels
    /// (visibility tests and `lrr bench visibility`).
    Cluttered {
        /// Objects per side of the floor grid.
        #[arg(long, default_value_t = 4)]
        grid: usize,
        /// Seed of the objects' kinds, sizes and angles.
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// The Cornell box with its short block made of glass, a mirror on the green wall, the
    /// classic camera and a point light at the lamp (ray tracer showcase).
    CornellGlass,
    /// A block and a geodesic sphere of about N triangles in a lit room, with a camera: the
    /// series of growing triangle counts (`--triangles 1000`, `10000`, `100000`, …).
    BoxSphere {
        /// Sphere triangles (rounded to the nearest geodesic sphere, 20·m² for frequency m).
        #[arg(long, default_value_t = 1000)]
        triangles: usize,
    },
    /// Objects spread very unevenly (a uniform grid's weak case): a 100 × 20 × 100 hall, three
    /// large blocks far apart and 256 small boxes in one square metre, camera on the cluster.
    Uneven,
    /// A dense mesh of 100 820 sphere triangles (box-sphere) whose [bake] table asks for 2
    /// samples and patches of 0.35, so that it bakes in minutes (README, Scenes).
    Dense,
    /// Messy real-world geometry: needle strips, fans, T-junctions, interpenetrating boxes, a
    /// non-planar quad with a far vertex, a zero-area and a duplicated face (meshing tests).
    Messy,
    /// A two-floor house of nine rooms (walls, doorways, windows, a stair, furniture, a light
    /// group per room, cameras): writes FILE.toml, the geometry FILE.glb and FILE-animation.toml
    /// (for `lrr relight`) beside it; its [bake] table gives about 24 000 elements and 1 400
    /// patches.
    Building,
    /// A scene description (.toml) with every polygon and box face written as triangles.
    Triangulate {
        /// The scene description to rewrite.
        input: PathBuf,
        /// Fans over extra rim points with slivers at every corner, instead of two triangles
        /// per quad.
        #[arg(long)]
        fans: bool,
        /// Each polygon cut into an N × N grid of triangle pairs (N² times the triangles of
        /// the same surface: the tessellation benchmark, scripts/bench-tessellation).
        #[arg(long, value_name = "N", conflicts_with = "fans")]
        grid: Option<u32>,
    },
}

pub fn run(a: &SceneArgs, out: &mut dyn Write) -> Result<()> {
    let d = match &a.kind {
        SceneKind::Building => return building(a.output.as_deref(), out),
        SceneKind::Furnace {
            reflectance,
            radiance,
        } => procedural::furnace(*reflectance, *radiance),
        SceneKind::Parallel { side, distance } => procedural::parallel_squares(*side, *distance),
        SceneKind::Perpendicular {
            length,
            width,
            height,
        } => procedural::perpendicular(*length, *width, *height),
        SceneKind::DenseSphere { subdivisions } => {
            if *subdivisions > procedural::MAX_SPHERE_SUBDIVISIONS {
                anyhow::bail!(
                    "--subdivisions {subdivisions} is too fine: at most {} ({} triangles)",
                    procedural::MAX_SPHERE_SUBDIVISIONS,
                    20u64 << (2 * procedural::MAX_SPHERE_SUBDIVISIONS)
                );
            }
            procedural::dense_sphere(*subdivisions)
        }
        SceneKind::Cluttered { grid, seed } => {
            if *grid == 0 || *grid > 64 {
                anyhow::bail!("--grid {grid}: use 1 to 64 objects per side");
            }
            procedural::cluttered(*grid, *seed)
        }
        SceneKind::Messy => procedural::messy(),
        SceneKind::CornellGlass => showcase::cornell_glass(),
        SceneKind::BoxSphere { triangles } => showcase::box_sphere(*triangles)?,
        SceneKind::Uneven => showcase::uneven(),
        SceneKind::Dense => showcase::dense(),
        SceneKind::Triangulate { input, fans, grid } => {
            let origin = input.display().to_string();
            let text = std::fs::read_to_string(input)
                .with_context(|| format!("reading the scene description {origin}"))?;
            let d = lrr_precompute::scene::description::SceneDescription::parse(&text, &origin)?;
            // Its own errors (a face index out of range, …) are the input's, named as such.
            d.build(&origin, input.parent().unwrap_or(std::path::Path::new(".")))?;
            let how = if let Some(g) = grid {
                if !(1..=64).contains(g) {
                    anyhow::bail!("--grid {g}: use 1 to 64 cells per side");
                }
                procedural::Triangulation::Grid(*g)
            } else if *fans {
                procedural::Triangulation::Fans
            } else {
                procedural::Triangulation::Pairs
            };
            procedural::triangulated(&d, how)
        }
    };
    // Build once so a bad parameter is reported here, not at bake time.
    d.build("generated scene", std::path::Path::new("."))?;
    let text = d.to_toml();
    match &a.output {
        Some(path) => lrr_formats::write_atomic(path, text.as_bytes())
            .with_context(|| format!("writing {}", path.display()))?,
        None => write!(out, "{text}")?,
    }
    Ok(())
}

/// `lrr scene building -o FILE.toml`: the three files, the description last, then loaded
/// back (the include and the light groups checked).
fn building(output: Option<&Path>, out: &mut dyn Write) -> Result<()> {
    let Some(toml_path) = output else {
        anyhow::bail!(
            "lrr scene building writes three files (FILE.toml, FILE.glb, FILE-animation.toml): \
             name the first with -o, e.g. -o building/building.toml"
        );
    };
    let stem = toml_path
        .file_stem()
        .and_then(|s| s.to_str())
        .filter(|_| toml_path.extension().is_some_and(|e| e == "toml"))
        .with_context(|| {
            format!(
                "-o {}: name a .toml file (UTF-8 name); the .glb and the animation go beside it",
                toml_path.display()
            )
        })?;
    let dir = toml_path.parent().unwrap_or(Path::new(""));
    if !dir.as_os_str().is_empty() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let glb_name = format!("{stem}.glb");
    let b = building::building(&glb_name)?;
    let animation = dir.join(format!("{stem}-animation.toml"));
    let description = format!(
        "# A two-floor house of nine rooms, written by `lrr scene building` \
         (precompute/src/scene/building/):\n\
         # do not edit. Metres, y up. The geometry is {glb_name} (a node per room and per \
         ceiling lamp);\n\
         # the lights of each room are one light group; {stem}-animation.toml animates them \
         for `lrr relight`.\n\n{}",
        b.description.to_toml()
    );
    for (path, bytes) in [
        (dir.join(&glb_name), &b.glb[..]),
        (animation.clone(), b.animation.as_bytes()),
        (toml_path.to_path_buf(), description.as_bytes()),
    ] {
        lrr_formats::write_atomic(&path, bytes)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    let scene = crate::load_scene(toml_path)?;
    writeln!(
        out,
        "wrote {} ({} faces, {} surfaces, {} light groups, {} cameras), {} and {}",
        toml_path.display(),
        scene.faces.len(),
        scene.surfaces.len(),
        b.description.light_groups.len(),
        scene.cameras.len(),
        dir.join(&glb_name).display(),
        animation.display()
    )?;
    Ok(())
}
