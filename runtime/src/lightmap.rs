//! Lightmaps filled every frame: the way an engine that rasterises the scene takes the light.
//!
//! A [`Lightmap`] is built once from an operator file's lightmap coordinates (section LIGHTMAP,
//! with the atlas of section ATLAS: the scene's own `TEXCOORD_1` or the charts the bake packed)
//! and then turns each frame's radiosity into texels with [`Lightmap::fill`]: one pass over a
//! sparse table, no allocation.
//!
//! What a texel holds is the exitant radiance `B/π` of the surface under its centre (the
//! operator's emission units per steradian, linear RGB), as `lrr export`'s EXR holds it:
//! 1. **Samples.** A texel whose centre lies inside a display face's image in the atlas (the
//!    face's corners mapped to their coordinates: a convex polygon, either orientation, within
//!    1e-9 texels) is a sample of the first such face in file order, at the point of the face
//!    with the same barycentric coordinates (the first non-degenerate corner triangle's). A
//!    face too small to hold a texel centre samples its centroid into the texel under it, if
//!    that texel is still empty. Faces of elements that are black in every frame (they see no
//!    patch and emit nothing: the floor under a block) take no texels.
//! 2. **Reconstruction.** Smooth (the default when the file has SMOOTH weights): the sample's
//!    mean value coordinates over its face's corners, each corner a smooth vertex whose value
//!    is a weighted sum of element values ([`Reconstruction`](crate::Reconstruction)); a frame
//!    computes the vertex values once, then each sample is at most four products. Flat: the
//!    element's value.
//! 3. **Dilation.** `padding` rings around what the samples cover: each empty texel with a
//!    filled 8-neighbour takes the mean of those neighbours, ring by ring, so that bilinear
//!    filtering at a chart's edge never reads black. The bake packs charts `2 × padding` texels
//!    apart, so rings never cross from one chart into another.
//!
//! Every other texel is zero. [`Lightmap::fill_samples`] and [`Lightmap::dilate`] are the two
//! halves of [`Lightmap::fill`], for callers that add light of their own at the samples
//! ([`Lightmap::samples`]: the direct light of point lights, sharper than the elements) before
//! dilating.
//!
//! ```
//! # use lrr_runtime::{Operator, Lightmap};
//! # fn show(op: &Operator) -> Result<(), lrr_runtime::RuntimeError> {
//! let mut lightmap = Lightmap::new(op.file(), None)?; // once: the file's atlas
//! let mut texels = vec![[0.0f32; 3]; lightmap.width() * lightmap.height()];
//! let b = op.evaluate_baked(); // per frame: radiosity per element, original ids
//! lightmap.fill(&b, &mut texels)?; // rows top to bottom (v = 0 the first row)
//! # Ok(()) }
//! ```

use lrr_formats::{OperatorData, OperatorFile};

use crate::error::{RuntimeError, input};
use crate::smooth::mean_value_weights;

/// How a lightmap reconstructs values inside elements.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LightmapValues {
    /// Smooth-vertex values interpolated by mean value coordinates (needs SMOOTH).
    Smooth,
    /// The element's value over each of its faces.
    Flat,
}

/// A [`Lightmap`] as the GPU's fill reads it ([`Lightmap::gpu_table`]; the layout is
/// `lightmap.wgsl`'s).
#[cfg(feature = "gpu")]
#[derive(Debug, Default)]
pub(crate) struct GpuTable {
    /// Per sample its run, and (smooth) its four weights (f32 bits).
    pub samples: Vec<u32>,
    /// Per run its first texel minus its first sample (wrapping).
    pub run_base: Vec<u32>,
    /// Per run four sources: smooth vertices, or the element and three zeros (flat).
    pub run_index: Vec<u32>,
    /// Per dilated texel: the texel, and the end of its terms.
    pub rings: Vec<u32>,
    /// Per term of a dilated texel: its source and weight (f32 bits).
    pub ring_source: Vec<u32>,
    pub ring_weight: Vec<u32>,
}

/// A smooth [`Lightmap`] in tiles as `lightmap_tiles.wgsl` reads it ([`Lightmap::gpu_tiles`];
/// pairs and quadruples flattened, the layout is the shader's).
#[cfg(feature = "gpu")]
#[derive(Debug, Default)]
pub(crate) struct TileTable {
    /// Per tile its first texel item and its first vertex in `tile_vertices`, and one pair
    /// more that ends the last tile.
    pub tiles: Vec<u32>,
    /// Per tile its smooth vertices, each as the range of its weights in `entries` (pairs).
    pub tile_vertices: Vec<u32>,
    /// Per weight of SMOOTH's rows: its element's original id and the weight (f32 bits).
    pub entries: Vec<u32>,
    /// Per texel item: the texel (with [`TILE_DILATED`] for a dilated texel), and (a sample)
    /// its corners' indices in its tile's list, a byte each.
    pub items: Vec<u32>,
    /// Per texel item four words: a sample's weights times 1/π (f32 bits), or a dilated
    /// texel's terms' start and end, and two zeros.
    pub slots: Vec<u32>,
    /// Per term of a dilated texel: the index in its tile's list and the weight (f32 bits).
    pub terms: Vec<u32>,
}

/// Texels a tile holds at most (`TILE_LANES` of `lightmap_tiles.wgsl`).
#[cfg(feature = "gpu")]
pub(crate) const TILE_LANES: usize = lrr_shaders::TILE_LANES as usize;
/// The blocks of texels (across, down) that [`Lightmap::gpu_tiles`] makes tiles of: at most
/// a workgroup's lanes.
#[cfg(feature = "gpu")]
pub(crate) const TILE_BLOCK: (usize, usize) = (16, 8);
#[cfg(feature = "gpu")]
const _: () = assert!(TILE_BLOCK.0 * TILE_BLOCK.1 <= TILE_LANES);
/// Smooth vertices a tile reads at most (`TILE_VERTICES` of `lightmap_tiles.wgsl`; a byte
/// indexes them).
#[cfg(feature = "gpu")]
pub(crate) const TILE_VERTICES: usize = lrr_shaders::TILE_VERTICES as usize;
/// The bit of a [`TileTable`] item's texel that marks a dilated texel (`DILATED` of
/// `lightmap_tiles.wgsl`).
#[cfg(feature = "gpu")]
pub(crate) const TILE_DILATED: u32 = lrr_shaders::TILE_DILATED;

/// One sample of a [`Lightmap`]: a texel whose value comes from a point of a display face.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightmapSample {
    /// Texel index, `y * width + x`.
    pub texel: usize,
    /// The display face ([`OperatorFile::faces`]).
    pub face: usize,
    /// The point of the face the texel shows.
    pub point: [f32; 3],
}

/// A lightmap of one operator file: built once, filled every frame. See the module docs.
#[derive(Debug, Clone)]
pub struct Lightmap {
    pub(crate) width: usize,
    pub(crate) height: usize,
    pub(crate) padding: usize,
    pub(crate) values: LightmapValues,
    /// The samples in runs, in increasing texel order: a run is consecutive texels of one row
    /// that one face covers. Run `r` holds samples `run_start[r]..run_start[r + 1]` at texels
    /// from `run_texel[r]` on, of face `run_face[r]`, and reads `run_index[4 * r..4 * r + 4]`
    /// (smooth: the face's corners' smooth vertices, unused corners 0) or `run_index[r]`
    /// (flat: the element's original id).
    run_start: Vec<u32>,
    run_texel: Vec<u32>,
    run_face: Vec<u32>,
    run_index: Vec<u32>,
    /// Per sample: the point it shows and (smooth) its corners' weights times 1/π (unused
    /// corners 0).
    point: Vec<[f32; 3]>,
    weight: Vec<[f32; 4]>,
    /// One past the largest element id a fill reads (0: none).
    elements: usize,
    /// The smooth vertices' weights over elements (original ids), SMOOTH's rows.
    vertex_offsets: Vec<u32>,
    vertex_elements: Vec<u32>,
    vertex_weights: Vec<f32>,
    /// This frame's smooth-vertex values.
    vertices: Vec<[f32; 4]>,
    /// Dilation: `ring_ends[r]` ends ring `r` in `dilated`; each dilated texel's filled
    /// neighbours are `neighbours[neighbour_ends[i - 1]..neighbour_ends[i]]`. Within a ring,
    /// texels are ordered by [`Bands`]: band 0's, band 1's, …, then the deferred ones.
    ring_ends: Vec<u32>,
    dilated: Vec<u32>,
    neighbour_ends: Vec<u32>,
    neighbours: Vec<u32>,
    /// How a fill splits over `threads` threads.
    bands: Bands,
    threads: usize,
}

/// The split of a fill over threads (after the smooth-vertex values, computed by the same
/// threads in equal shares: [`Lightmap::vertex_values`]). Band `b` takes runs
/// `runs[b]..runs[b + 1]` and texels
/// `texels[b]..texels[b + 1]` (from its first run's texel to the next band's; the first from
/// 0, the last to the end), writes them, and dilates the texels of its own range whose
/// neighbours, and theirs ring after ring, lie in its range too: in ring `r` (with `c`
/// bands), `parts[r * (c + 1) + b]..parts[r * (c + 1) + b + 1]` of `dilated`. The rest of
/// ring `r`, from `parts[r * (c + 1) + c]` to `ring_ends[r]`, is deferred: dilated by the
/// calling thread once the bands are done (texels near a band's edge: a few rows' worth). So
/// the samples and the rings take one spawn of the threads, and the texels are the same for
/// any number of threads: each dilated texel reads the same neighbours, already final, in the
/// same order.
#[derive(Debug, Clone, Default)]
struct Bands {
    runs: Vec<usize>,
    texels: Vec<usize>,
    parts: Vec<u32>,
}

impl Bands {
    fn count(&self) -> usize {
        self.runs.len() - 1
    }

    /// Where group `g` of ring `r` starts in `dilated`: band `g`'s texels, or with `g` the
    /// band count, the deferred ones.
    fn start(&self, r: usize, g: usize) -> usize {
        self.parts[r * (self.count() + 1) + g] as usize
    }
}

impl Lightmap {
    /// The lightmap of `file` over the atlas its section ATLAS names (size and padding), with
    /// `values` (None: smooth when the file has SMOOTH weights, else flat). An error when the
    /// file has no lightmap coordinates, or none with an atlas (files of format 1.5 and
    /// before: [`with_size`](Self::with_size) chooses one).
    pub fn new(file: &OperatorFile, values: Option<LightmapValues>) -> Result<Self, RuntimeError> {
        let atlas = file
            .display
            .lightmap
            .as_ref()
            .and_then(|l| l.atlas)
            .ok_or_else(|| {
                input(
                    "the operator file names no lightmap atlas (sections LIGHTMAP and ATLAS, \
                     format 1.6): re-bake it with this lrr",
                )
            })?;
        Self::with_size(
            file,
            atlas.width as usize,
            atlas.height as usize,
            atlas.padding as usize,
            values,
        )
    }

    /// The lightmap of `file`'s coordinates over a `width × height` atlas dilated `padding`
    /// rings. The bake's generated charts were packed for the size section ATLAS names; at
    /// another size they may touch or blur. An error when the file has no coordinates, the
    /// size is not 1 to 16384 texels a side, `padding` is over 64, or smooth values are asked
    /// of a file without SMOOTH.
    pub fn with_size(
        file: &OperatorFile,
        width: usize,
        height: usize,
        padding: usize,
        values: Option<LightmapValues>,
    ) -> Result<Self, RuntimeError> {
        let uv = file.display.lightmap.as_ref().ok_or_else(|| {
            input(
                "the operator file has no lightmap coordinates (section LIGHTMAP): re-bake it \
                 with this lrr",
            )
        })?;
        Self::with_coordinates(file, &uv.uv, width, height, padding, values)
    }

    /// The lightmap of coordinates `uv` of `file`'s display faces (`F * 8` values, as section
    /// LIGHTMAP: `u, v` per corner, four corners per face) over a `width × height` atlas
    /// dilated `padding` rings: another layout than the file's (charts packed again).
    pub fn with_coordinates(
        file: &OperatorFile,
        uv: &[f32],
        width: usize,
        height: usize,
        padding: usize,
        values: Option<LightmapValues>,
    ) -> Result<Self, RuntimeError> {
        let side = 1..=lrr_formats::MAX_ATLAS_SIDE as usize;
        if !side.contains(&width) || !side.contains(&height) {
            return Err(input(format!(
                "a lightmap of {width}×{height} texels: each side must be 1 to {}",
                lrr_formats::MAX_ATLAS_SIDE
            )));
        }
        if padding > lrr_formats::MAX_ATLAS_PADDING as usize {
            return Err(input(format!(
                "lightmap padding {padding}: at most {} texels",
                lrr_formats::MAX_ATLAS_PADDING
            )));
        }
        let values = match values {
            Some(v) => v,
            None if file.display.smooth.is_some() => LightmapValues::Smooth,
            None => LightmapValues::Flat,
        };
        let faces = file.faces();
        if uv.len() != 8 * faces.len() {
            return Err(input(format!(
                "lightmap: {} coordinates for {} display faces (8 each)",
                uv.len(),
                faces.len()
            )));
        }
        if let Some(i) = uv.iter().position(|x| !x.is_finite()) {
            return Err(input(format!(
                "lightmap: coordinate {} of display face {} is {}, not finite",
                i % 8,
                i / 8,
                uv[i]
            )));
        }
        let mut map = Self {
            width,
            height,
            padding,
            values,
            run_start: vec![0],
            run_texel: Vec::new(),
            run_face: Vec::new(),
            run_index: Vec::new(),
            point: Vec::new(),
            weight: Vec::new(),
            elements: 0,
            vertex_offsets: Vec::new(),
            vertex_elements: Vec::new(),
            vertex_weights: Vec::new(),
            vertices: Vec::new(),
            ring_ends: Vec::new(),
            dilated: Vec::new(),
            neighbour_ends: Vec::new(),
            neighbours: Vec::new(),
            bands: Bands::default(),
            threads: 1,
        };
        if values == LightmapValues::Smooth {
            // Checks SMOOTH's shape against the faces, so that no index below is out of range.
            let r = crate::Reconstruction::new(file)?;
            let s = file
                .display
                .smooth
                .as_ref()
                .expect("Reconstruction::new checked it");
            map.vertex_offsets = s.offsets.clone();
            map.vertex_elements = s
                .positions
                .iter()
                .map(|&p| file.order[p as usize])
                .collect();
            map.vertex_weights = s.weights.clone();
            map.vertices = vec![[0.0; 4]; r.vertex_count()];
            map.elements = map
                .vertex_elements
                .iter()
                .map(|&e| e as usize + 1)
                .max()
                .unwrap_or(0);
        }
        let hidden = hidden_elements(file);
        let mut raster = Raster::new(width, height);
        raster.samples(file, uv, &hidden);
        map.weigh(file, &raster.samples);
        map.rings(&mut raster.filled);
        map.split(1);
        Ok(map)
    }

    /// Uses `threads` threads in [`fill`](Self::fill) (0: all the machine has; default 1).
    pub fn set_threads(&mut self, threads: usize) {
        self.threads = match threads {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
            t => t,
        };
        self.split(self.threads);
    }

    /// Texels across.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Texels down.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Rings of dilation.
    pub fn padding(&self) -> usize {
        self.padding
    }

    /// How values inside elements are reconstructed.
    pub fn values(&self) -> LightmapValues {
        self.values
    }

    /// Number of samples (texels a face covers).
    pub fn sample_count(&self) -> usize {
        self.point.len()
    }

    /// Number of texels dilation fills.
    pub fn dilated_count(&self) -> usize {
        self.dilated.len()
    }

    /// The samples in increasing texel order.
    pub fn samples(&self) -> impl ExactSizeIterator<Item = LightmapSample> + '_ {
        let mut run = 0;
        (0..self.point.len()).map(move |i| {
            while self.run_start[run + 1] as usize <= i {
                run += 1;
            }
            LightmapSample {
                texel: (self.run_texel[run] + i as u32 - self.run_start[run]) as usize,
                face: self.run_face[run] as usize,
                point: self.point[i],
            }
        })
    }

    /// The lightmap as the GPU's fill reads it (`lightmap.wgsl` of `lrr-shaders`): per sample
    /// its run (and, smooth, its four weights), per run its texel base and
    /// sources, and every dilated texel expanded into the same sources (the mean of its
    /// neighbours is linear in them), so that one dispatch writes samples and rings. A texel
    /// of ring `d` has about `2d + 1` terms along a straight chart edge (the building, padding
    /// 2: 5.2 on average, 22 at most), so the ring tables grow as the padding squared.
    #[cfg(feature = "gpu")]
    pub(crate) fn gpu_table(&self) -> GpuTable {
        let smooth = self.values == LightmapValues::Smooth;
        let corners = if smooth { 4 } else { 1 };
        let mut table = GpuTable::default();
        let mut sample_run = Vec::with_capacity(self.point.len());
        for r in 0..self.run_texel.len() {
            let first = self.run_start[r];
            table.run_base.push(self.run_texel[r].wrapping_sub(first));
            let mut index = [0u32; 4];
            index[..corners].copy_from_slice(&self.run_index[corners * r..corners * (r + 1)]);
            table.run_index.extend_from_slice(&index);
            for _ in first..self.run_start[r + 1] {
                sample_run.push(r as u32);
            }
        }
        for (i, &r) in sample_run.iter().enumerate() {
            table.samples.push(r);
            if smooth {
                table.samples.extend(self.weight[i].map(f32::to_bits));
            }
        }
        // A texel's terms (source, weight): a sample's from its run, a dilated texel's from
        // `terms`, found through `slot` (sample i: i; dilated texel d: samples + d).
        let samples = self.point.len();
        let mut slot = vec![u32::MAX; self.width * self.height];
        for (i, s) in self.samples().enumerate() {
            slot[s.texel] = i as u32;
        }
        let mut terms: Vec<Vec<(u32, f64)>> = Vec::with_capacity(self.dilated.len());
        let sample_terms = |i: usize, out: &mut Vec<(u32, f64)>| {
            out.clear();
            let r = sample_run[i] as usize;
            if smooth {
                for k in 0..4 {
                    if self.weight[i][k] != 0.0 {
                        out.push((self.run_index[4 * r + k], f64::from(self.weight[i][k])));
                    }
                }
            } else {
                out.push((self.run_index[r], 1.0 / PI));
            }
        };
        let mut scratch = Vec::new();
        let mut begin = 0;
        for &end in &self.ring_ends {
            // In ring order: a ring's neighbours are samples or texels of earlier rings.
            for d in begin..end as usize {
                let around = self.around(d);
                let share = 1.0 / around.len() as f64;
                let mut sum: Vec<(u32, f64)> = Vec::new();
                for &t in around {
                    let s = slot[t as usize] as usize;
                    let from = if s < samples {
                        sample_terms(s, &mut scratch);
                        &scratch
                    } else {
                        &terms[s - samples]
                    };
                    for &(source, w) in from {
                        match sum.iter_mut().find(|(x, _)| *x == source) {
                            Some((_, acc)) => *acc += share * w,
                            None => sum.push((source, share * w)),
                        }
                    }
                }
                slot[self.dilated[d] as usize] = (samples + d) as u32;
                terms.push(sum);
            }
            begin = end as usize;
        }
        for (d, sum) in terms.iter().enumerate() {
            for &(source, w) in sum {
                table.ring_source.push(source);
                table.ring_weight.push((w as f32).to_bits());
            }
            table.rings.push(self.dilated[d]);
            table.rings.push(table.ring_source.len() as u32);
        }
        table
    }

    /// The smooth lightmap as `lightmap_tiles.wgsl` reads it: the texels written (samples and
    /// dilated texels) in blocks of [`TILE_BLOCK`] texels of the atlas, each block one tile
    /// unless its texels read over [`TILE_VERTICES`] smooth vertices together (then cut into
    /// several), each tile's vertices listed and its texels' sources given as indices into
    /// that list. A block keeps a tile on few faces: the building's charts are narrow, and
    /// tiles of 64 texels along a row read 12.6 times its smooth vertices in all, 16 × 8
    /// blocks 2.8 times (on an H200: 28 and 15 µs a fill, the passes 17–18 µs). `None` for a
    /// flat lightmap, or when one texel alone reads more than [`TILE_VERTICES`] vertices (a
    /// dilated texel deep in a wide padding): the fill then takes the smooth pass and
    /// `lightmap.wgsl`.
    #[cfg(feature = "gpu")]
    pub(crate) fn gpu_tiles(&self) -> Option<TileTable> {
        self.tiles_within(TILE_BLOCK, TILE_VERTICES)
    }

    /// [`gpu_tiles`](Self::gpu_tiles) with blocks of `block` texels (across, down; at most
    /// [`TILE_LANES`] in all) and tiles of at most `vertices` smooth vertices (the tests'
    /// smaller limits cut more tiles).
    #[cfg(feature = "gpu")]
    fn tiles_within(&self, block: (usize, usize), vertices: usize) -> Option<TileTable> {
        assert!(
            block.0 * block.1 <= TILE_LANES,
            "a block of more texels than lanes"
        );
        if self.values != LightmapValues::Smooth || self.width * self.height > 1 << 31 {
            return None;
        }
        let table = self.gpu_table();
        let samples = self.point.len();
        // Items (sample i: i; dilated texel d: samples + d) by block, then by texel.
        let texel_of = |i: usize| -> usize {
            if i < samples {
                let run = table.samples[5 * i] as usize;
                (i as u32).wrapping_add(table.run_base[run]) as usize
            } else {
                table.rings[2 * (i - samples)] as usize
            }
        };
        let across = self.width.div_ceil(block.0);
        let block_of = |texel: usize| {
            let (x, y) = (texel % self.width, texel / self.width);
            (y / block.1) * across + x / block.0
        };
        let mut order: Vec<(usize, usize, u32)> = (0..samples + self.dilated.len())
            .map(|i| {
                let texel = texel_of(i);
                (block_of(texel), texel, i as u32)
            })
            .collect();
        order.sort_unstable();
        let mut t = TileTable {
            entries: (self.vertex_elements.iter().zip(&self.vertex_weights))
                .flat_map(|(&e, w)| [e, w.to_bits()])
                .collect(),
            tiles: vec![0, 0],
            ..TileTable::default()
        };
        // Per smooth vertex its index in the open tile's list (u32::MAX: not in it).
        let mut local = vec![u32::MAX; self.vertices.len()];
        // The open tile's first item, first listed vertex and block.
        let mut open = (0, 0, order.first().map_or(0, |o| o.0));
        let mut sources = Vec::new();
        // Every tile's vertices, one tile after another.
        let mut list: Vec<u32> = Vec::new();
        let mut k = 0;
        while k < order.len() {
            let (at, texel, i) = order[k];
            let i = i as usize;
            // Item i's smooth vertices: a sample's corners of non-zero weight (`corners`), a
            // dilated texel's terms.
            sources.clear();
            let mut corners = [None; 4];
            let ring_terms = if i < samples {
                let run = table.samples[5 * i] as usize;
                for c in 0..4 {
                    if self.weight[i][c] != 0.0 {
                        let v = table.run_index[4 * run + c];
                        corners[c] = Some(v);
                        sources.push(v);
                    }
                }
                0..0
            } else {
                let j = i - samples;
                let start = if j == 0 {
                    0
                } else {
                    table.rings[2 * j - 1] as usize
                };
                let range = start..table.rings[2 * j + 1] as usize;
                sources.extend_from_slice(&table.ring_source[range.clone()]);
                range
            };
            let listed = list.len();
            if at == open.2 {
                for &v in &sources {
                    if local[v as usize] == u32::MAX {
                        local[v as usize] = (list.len() - open.1) as u32;
                        list.push(v);
                    }
                }
            }
            if at != open.2 || list.len() - open.1 > vertices {
                // Item k opens the next tile: what it listed is taken back.
                for v in list.drain(listed..) {
                    local[v as usize] = u32::MAX;
                }
                if k == open.0 {
                    return None; // alone over the limit
                }
                for &v in &list[open.1..] {
                    local[v as usize] = u32::MAX;
                }
                open = (k, list.len(), at);
                t.tiles.extend([k as u32, open.1 as u32]);
                continue;
            }
            if i < samples {
                let mut packed = 0;
                for (c, v) in corners.iter().enumerate() {
                    if let Some(v) = v {
                        packed |= local[*v as usize] << (8 * c);
                    }
                }
                t.items.extend([texel as u32, packed]);
                t.slots.extend(self.weight[i].map(f32::to_bits));
            } else {
                t.items.extend([texel as u32 | TILE_DILATED, 0]);
                let start = (t.terms.len() / 2) as u32;
                for r in ring_terms {
                    let v = table.ring_source[r] as usize;
                    t.terms.extend([local[v], table.ring_weight[r]]);
                }
                t.slots.extend([start, (t.terms.len() / 2) as u32, 0, 0]);
            }
            k += 1;
        }
        // The end of the last tile (an empty lightmap has none: its pair [0, 0] stays alone).
        if !order.is_empty() {
            t.tiles.extend([order.len() as u32, list.len() as u32]);
        }
        let rows = &self.vertex_offsets;
        t.tile_vertices = (list.iter())
            .flat_map(|&v| [rows[v as usize], rows[v as usize + 1]])
            .collect();
        Some(t)
    }

    /// Smooth vertices of the lightmap's file (0 for a flat lightmap).
    #[cfg(feature = "gpu")]
    pub(crate) fn smooth_vertex_count(&self) -> usize {
        self.vertices.len()
    }

    /// Bytes one [`fill`](Self::fill) must at least move: the sample table it reads (runs,
    /// weights), the dilation table, the smooth vertices' rows, and the texels it writes.
    /// What a roofline compares a fill's time with.
    pub fn fill_bytes(&self) -> usize {
        4 * (self.run_start.len() + self.run_texel.len() + self.run_index.len())
            + 16 * self.weight.len()
            + 4 * (self.dilated.len() + self.neighbour_ends.len() + self.neighbours.len())
            + 4 * (self.vertex_offsets.len()
                + self.vertex_elements.len()
                + self.vertex_weights.len())
            + 12 * self.width * self.height
    }

    /// Fills `out` (`width × height` texels, rows top to bottom) with the exitant radiance
    /// `B/π` of `radiosity`, the radiosity per element in original ids (what the evaluators
    /// write): [`fill_samples`](Self::fill_samples), then [`dilate`](Self::dilate).
    pub fn fill(
        &mut self,
        radiosity: &[[f32; 3]],
        out: &mut [[f32; 3]],
    ) -> Result<(), RuntimeError> {
        self.run(Some(radiosity), out, true)
    }

    /// Writes every texel of `out`: the samples' `B/π`, zero elsewhere (dilation not done).
    pub fn fill_samples(
        &mut self,
        radiosity: &[[f32; 3]],
        out: &mut [[f32; 3]],
    ) -> Result<(), RuntimeError> {
        self.run(Some(radiosity), out, false)
    }

    /// Dilates `out` (filled by [`fill_samples`](Self::fill_samples), perhaps with light added
    /// at the samples) `padding` rings deep.
    pub fn dilate(&mut self, out: &mut [[f32; 3]]) -> Result<(), RuntimeError> {
        self.run(None, out, true)
    }

    /// The samples' pass of `radiosity` and/or the dilation: the smooth-vertex values in one
    /// spawn of the threads, the bands in another, then the deferred ring texels.
    fn run(
        &mut self,
        radiosity: Option<&[[f32; 3]]>,
        out: &mut [[f32; 3]],
        dilate: bool,
    ) -> Result<(), RuntimeError> {
        self.check_out(out)?;
        if let Some(b) = radiosity
            && b.len() < self.elements
        {
            return Err(input(format!(
                "lightmap: {} element values, but element {} is sampled; pass the frame's \
                 radiosity of every element",
                b.len(),
                self.elements - 1
            )));
        }
        let count = self.bands.count();
        if let Some(radiosity) = radiosity
            && self.values == LightmapValues::Smooth
        {
            self.vertex_values(radiosity, count);
        }
        let this = &*self;
        let band = |b: usize, texels: &mut [[f32; 3]]| {
            this.band(b, radiosity, dilate, texels);
        };
        let band = &band;
        if count == 1 {
            // No scope: one thread allocates nothing.
            band(0, out);
        } else {
            let mut rest = &mut *out;
            let mut first = None;
            std::thread::scope(|s| {
                for b in 0..count {
                    let len = this.bands.texels[b + 1] - this.bands.texels[b];
                    let (mine, tail) = rest.split_at_mut(len);
                    rest = tail;
                    match b {
                        0 => first = Some(mine),
                        _ => {
                            s.spawn(move || band(b, mine));
                        }
                    }
                }
                band(0, first.take().expect("at least one band"));
            });
        }
        if dilate {
            for r in 0..self.ring_ends.len() {
                for i in self.bands.start(r, count)..self.ring_ends[r] as usize {
                    out[self.dilated[i] as usize] = self.ring_mean(i, out, 0);
                }
            }
        }
        Ok(())
    }

    /// Band `b`'s share of a fill into `texels` (its range of the atlas): with `radiosity`,
    /// its runs, zero between them; with `dilate`, its own dilated texels. Row by row: ring
    /// `r` of row `y` right after the samples of row `y + r` (the texels it reads are then
    /// final), while the rows it reads are still in cache.
    fn band(
        &self,
        b: usize,
        radiosity: Option<&[[f32; 3]]>,
        dilate: bool,
        texels: &mut [[f32; 3]],
    ) {
        let w = self.width;
        let (start, end) = (self.bands.texels[b], self.bands.texels[b + 1]);
        if start == end {
            return;
        }
        let (mut run, last) = (self.bands.runs[b], self.bands.runs[b + 1]);
        let mut next = start;
        let rings = if dilate { self.ring_ends.len() } else { 0 };
        let mut cursor = [0usize; MAX_RINGS];
        let mut stop = [0usize; MAX_RINGS];
        for r in 0..rings {
            cursor[r] = self.bands.start(r, b);
            stop[r] = self.bands.start(r, b + 1);
        }
        let (first_row, last_row) = (start / w, (end - 1) / w);
        for y in first_row..=last_row + rings {
            if let Some(radiosity) = radiosity
                && y <= last_row
            {
                let row_end = ((y + 1) * w).min(end);
                while run < last && (self.run_texel[run] as usize) < row_end {
                    let t = self.run_texel[run] as usize;
                    let samples = self.run_start[run] as usize..self.run_start[run + 1] as usize;
                    texels[next - start..t - start].as_flattened_mut().fill(0.0);
                    next = t + samples.len();
                    let mine = &mut texels[t - start..next - start];
                    self.run_values(run, samples, radiosity, mine);
                    run += 1;
                }
                texels[next - start..row_end - start]
                    .as_flattened_mut()
                    .fill(0.0);
                next = row_end;
            }
            // Ring r + 1 up to row y - r - 1.
            for r in 0..rings.min(y + 1) {
                let before = (y - r) * w;
                while cursor[r] < stop[r] && (self.dilated[cursor[r]] as usize) < before {
                    let t = self.dilated[cursor[r]] as usize;
                    texels[t - start] = self.ring_mean(cursor[r], texels, start);
                    cursor[r] += 1;
                }
            }
        }
    }

    /// The values of run `run`'s `samples` into `texels`. Smooth: `Σ w·x` over the corners in
    /// f64, as `Reconstruction::at`: within half an f32 ulp of the exact sum of the stored
    /// terms, so a frame scaled by s gives texels scaled by s (the group layers of `lrr
    /// export` rely on it).
    #[inline(always)]
    fn run_values(
        &self,
        run: usize,
        samples: std::ops::Range<usize>,
        radiosity: &[[f32; 3]],
        texels: &mut [[f32; 3]],
    ) {
        match self.values {
            LightmapValues::Smooth => {
                let c = &self.run_index[4 * run..4 * run + 4];
                let x = [
                    self.vertices[c[0] as usize],
                    self.vertices[c[1] as usize],
                    self.vertices[c[2] as usize],
                    self.vertices[c[3] as usize],
                ];
                let mut xd = [[0.0f64; 4]; 4];
                for k in 0..4 {
                    for c in 0..4 {
                        xd[k][c] = f64::from(x[k][c]);
                    }
                }
                let x = xd;
                for (texel, w) in texels.iter_mut().zip(&self.weight[samples]) {
                    let mut v = [0.0f64; 4];
                    for k in 0..4 {
                        let w = f64::from(w[k]);
                        for c in 0..4 {
                            v[c] += w * x[k][c];
                        }
                    }
                    *texel = [v[0] as f32, v[1] as f32, v[2] as f32];
                }
            }
            LightmapValues::Flat => {
                let e = radiosity[self.run_index[run] as usize];
                texels.fill(e.map(|x| x / PI_F32));
            }
        }
    }

    /// The mean of the filled neighbours of dilated texel `i`, read in `texels` (the atlas
    /// from texel `start` on).
    fn ring_mean(&self, i: usize, texels: &[[f32; 3]], start: usize) -> [f32; 3] {
        let around = self.around(i);
        let mut sum = [0.0f32; 3];
        for &j in around {
            let v = texels[j as usize - start];
            for c in 0..3 {
                sum[c] += v[c];
            }
        }
        let scale = 1.0 / around.len() as f32;
        sum.map(|x| x * scale)
    }

    /// The filled neighbours of dilated texel `i`.
    fn around(&self, i: usize) -> &[u32] {
        let from = match i {
            0 => 0,
            i => self.neighbour_ends[i - 1] as usize,
        };
        &self.neighbours[from..self.neighbour_ends[i] as usize]
    }

    fn check_out(&self, out: &[[f32; 3]]) -> Result<(), RuntimeError> {
        if out.len() != self.width * self.height {
            return Err(input(format!(
                "lightmap: {} texels given for a {}×{} atlas",
                out.len(),
                self.width,
                self.height
            )));
        }
        Ok(())
    }

    /// This frame's smooth-vertex values (`r, g, b, 0`) from the element values `b` (checked
    /// long enough), clamped at zero (a vertex on a surface's boundary extrapolates, with
    /// negative weights), as [`Reconstruction::vertex_values`](crate::Reconstruction::vertex_values);
    /// `threads` threads take equal shares.
    fn vertex_values(&mut self, b: &[[f32; 3]], threads: usize) {
        let rows = (
            &self.vertex_offsets[..],
            &self.vertex_elements[..],
            &self.vertex_weights[..],
        );
        let per = self.vertices.len().div_ceil(threads).max(1);
        let mut shares = self.vertices.chunks_mut(per).enumerate();
        let Some((_, first)) = shares.next() else {
            return;
        };
        if threads == 1 {
            vertex_rows(rows, 0, first, b);
            return;
        }
        std::thread::scope(|s| {
            for (k, share) in shares {
                s.spawn(move || vertex_rows(rows, k * per, share, b));
            }
            vertex_rows(rows, 0, first, b);
        });
    }

    /// The samples' reconstruction weights (times 1/π).
    fn weigh(&mut self, file: &OperatorFile, samples: &[Sample]) {
        let faces = file.faces();
        let g = faces.geometry;
        for (i, s) in samples.iter().enumerate() {
            let f = s.face as usize;
            let follows = i > 0
                && s.texel == samples[i - 1].texel + 1
                && s.face == samples[i - 1].face
                && !(s.texel as usize).is_multiple_of(self.width);
            if !follows {
                if i > 0 {
                    self.run_start.push(i as u32);
                }
                self.run_texel.push(s.texel);
                self.run_face.push(s.face);
                match self.values {
                    LightmapValues::Flat => {
                        let e = file.order[faces.element(f)];
                        self.elements = self.elements.max(e as usize + 1);
                        self.run_index.push(e);
                    }
                    LightmapValues::Smooth => {
                        let corners = &file.display.smooth.as_ref().expect("smooth").corners;
                        for k in 0..4 {
                            let used = k < usize::from(g.vertex_count[f]);
                            self.run_index
                                .push(if used { corners[4 * f + k] } else { 0 });
                        }
                    }
                }
            }
            self.point.push(s.point);
            if self.values == LightmapValues::Smooth {
                let count = usize::from(g.vertex_count[f]);
                let mut v = [[0.0f64; 3]; 4];
                for (i, vi) in v.iter_mut().enumerate().take(count) {
                    *vi = [0, 1, 2].map(|c| f64::from(g.vertices[12 * f + 3 * i + c]));
                }
                let normal = [0, 1, 2].map(|c| f64::from(g.normals[3 * f + c]));
                let w = mean_value_weights(&v[..count], normal, s.point.map(f64::from));
                self.weight
                    .push([0, 1, 2, 3].map(|k| if k < count { (w[k] / PI) as f32 } else { 0.0 }));
            }
        }
        self.run_start.push(samples.len() as u32);
    }

    /// Splits the fill over `threads` threads ([`Bands`]): bands of about equal sample counts
    /// (whole runs), and each ring's dilated texels reordered band by band, the deferred ones
    /// last.
    fn split(&mut self, threads: usize) {
        let (n, runs) = (self.point.len(), self.run_texel.len());
        let count = threads.max(1).min(runs.max(1));
        let chunk = n.div_ceil(count).max(1);
        // Band b's first run: the first whose samples start at b·chunk or later.
        let bands: Vec<usize> = (0..=count)
            .map(|b| match b {
                0 => 0,
                b if b == count => runs,
                b => self
                    .run_start
                    .partition_point(|&s| (s as usize) < b * chunk)
                    .min(runs),
            })
            .collect();
        let texels: Vec<usize> = (0..=count)
            .map(|b| match b {
                0 => 0,
                b if b == count || bands[b] >= runs => self.width * self.height,
                b => self.run_texel[bands[b]] as usize,
            })
            .collect();
        // Per texel: the band whose thread dilates it (its range's, until a ring takes it), or
        // `count` when deferred.
        let mut owner = vec![0u32; self.width * self.height];
        for (b, w) in texels.windows(2).enumerate() {
            owner[w[0]..w[1]].fill(b as u32);
        }
        let (mut dilated, mut ends, mut neighbours) = (vec![], vec![], vec![]);
        let mut parts = Vec::with_capacity(self.ring_ends.len() * (count + 1));
        let mut begin = 0;
        for &end in &self.ring_ends {
            let ring = begin..end as usize;
            let mut group = vec![0u32; ring.len()];
            for (i, g) in ring.clone().zip(&mut group) {
                // Not yet dilated, so still its range's band.
                let b = owner[self.dilated[i] as usize];
                let own = self.around(i).iter().all(|&j| owner[j as usize] == b);
                *g = if own { b } else { count as u32 };
            }
            for (i, &g) in ring.clone().zip(&group) {
                owner[self.dilated[i] as usize] = g;
            }
            // Each group in texel order, as the bands' row-by-row pass takes them (a ring is
            // in texel order when built, but no longer after a split into several bands).
            let mut order: Vec<usize> = ring.clone().collect();
            order.sort_unstable_by_key(|&i| self.dilated[i]);
            for g in 0..=count as u32 {
                parts.push(dilated.len() as u32);
                for &i in order.iter().filter(|&&i| group[i - ring.start] == g) {
                    dilated.push(self.dilated[i]);
                    neighbours.extend_from_slice(self.around(i));
                    ends.push(neighbours.len() as u32);
                }
            }
            begin = end as usize;
        }
        self.dilated = dilated;
        self.neighbour_ends = ends;
        self.neighbours = neighbours;
        self.bands = Bands {
            runs: bands,
            texels,
            parts,
        };
    }

    /// The dilation rings from the texels the samples fill.
    fn rings(&mut self, filled: &mut [bool]) {
        let (w, h) = (self.width, self.height);
        let mut ring = Vec::new();
        for _ in 0..self.padding {
            ring.clear();
            for y in 0..h {
                for x in 0..w {
                    if filled[y * w + x] {
                        continue;
                    }
                    let before = self.neighbours.len();
                    for (dx, dy) in NEIGHBOURS {
                        let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                        if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                            continue;
                        }
                        let j = ny as usize * w + nx as usize;
                        if filled[j] {
                            self.neighbours.push(j as u32);
                        }
                    }
                    if self.neighbours.len() > before {
                        ring.push((y * w + x) as u32);
                        self.dilated.push((y * w + x) as u32);
                        self.neighbour_ends.push(self.neighbours.len() as u32);
                    }
                }
            }
            if ring.is_empty() {
                break;
            }
            for &t in &ring {
                filled[t as usize] = true;
            }
            self.ring_ends.push(self.dilated.len() as u32);
        }
    }
}

/// The values of smooth vertices `first..first + out.len()` from SMOOTH's `rows` (offsets,
/// elements, weights) over the element values `b`, clamped at zero.
fn vertex_rows(
    (offsets, elements, weights): (&[u32], &[u32], &[f32]),
    first: usize,
    out: &mut [[f32; 4]],
    b: &[[f32; 3]],
) {
    for (v, value) in (first..).zip(out) {
        let mut sum = [0.0f64; 3];
        for j in offsets[v] as usize..offsets[v + 1] as usize {
            let e = b[elements[j] as usize];
            let w = f64::from(weights[j]);
            for c in 0..3 {
                sum[c] += w * f64::from(e[c]);
            }
        }
        *value = [
            sum[0].max(0.0) as f32,
            sum[1].max(0.0) as f32,
            sum[2].max(0.0) as f32,
            0.0,
        ];
    }
}

const PI: f64 = std::f64::consts::PI;
/// Rings a lightmap dilates at most.
const MAX_RINGS: usize = lrr_formats::MAX_ATLAS_PADDING as usize;
const PI_F32: f32 = std::f32::consts::PI;

const NEIGHBOURS: [(i64, i64); 8] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];

/// Per element, by file position: black in every frame, because it sees no patch (its row of
/// `F_k`, or of every `Y_c`, is zero) and emits nothing. Lightmaps leave such elements to
/// dilation and exports hide them.
pub fn hidden_elements(file: &OperatorFile) -> Vec<bool> {
    let (n, k) = (file.n as usize, file.k as usize);
    let (matrix, blocks) = match &file.operator {
        OperatorData::Factored { fk, .. } => (fk, 1),
        OperatorData::PlainYk { yk } => (yk, file.channels as usize),
    };
    (0..n)
        .map(|s| {
            let dark = file.emission[3 * s..3 * s + 3].iter().all(|&e| e == 0.0);
            let sees_nothing = (0..blocks).all(|c| {
                let row = (c * n + s) * k;
                (row..row + k).all(|i| matrix.get(i) == Some(0.0))
            });
            dark && sees_nothing
        })
        .collect()
}

/// A sample while building.
struct Sample {
    texel: u32,
    face: u32,
    point: [f32; 3],
}

/// Rasterisation of the display faces in atlas space.
struct Raster {
    width: usize,
    height: usize,
    filled: Vec<bool>,
    samples: Vec<Sample>,
}

impl Raster {
    fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            filled: vec![false; width * height],
            samples: Vec::new(),
        }
    }

    /// The samples of every face not `hidden`, then of faces too small to hold a texel
    /// centre; sorted by texel.
    fn samples(&mut self, file: &OperatorFile, uv: &[f32], hidden: &[bool]) {
        let faces = file.faces();
        let g = faces.geometry;
        let mut unfilled = Vec::new();
        for f in 0..faces.len() {
            if hidden[faces.element(f)] {
                continue;
            }
            let count = usize::from(g.vertex_count[f]);
            let pts: Vec<[f64; 3]> = (0..count)
                .map(|i| [0, 1, 2].map(|c| f64::from(g.vertices[12 * f + 3 * i + c])))
                .collect();
            let t: Vec<[f64; 2]> = (0..count)
                .map(|i| {
                    [
                        f64::from(uv[8 * f + 2 * i]) * self.width as f64,
                        f64::from(uv[8 * f + 2 * i + 1]) * self.height as f64,
                    ]
                })
                .collect();
            if !self.face(f, &t, &pts) {
                unfilled.push((f, t, pts));
            }
        }
        for (f, t, pts) in unfilled {
            let n = pts.len() as f64;
            let centroid = [0, 1, 2].map(|c| pts.iter().map(|p| p[c]).sum::<f64>() / n);
            let at = [0, 1].map(|c| t.iter().map(|p| p[c]).sum::<f64>() / n);
            let (x, y) = (at[0].floor(), at[1].floor());
            if x < 0.0 || y < 0.0 || x >= self.width as f64 || y >= self.height as f64 {
                continue;
            }
            let i = y as usize * self.width + x as usize;
            if !self.filled[i] {
                self.take(i, f, centroid);
            }
        }
        self.samples.sort_unstable_by_key(|s| s.texel);
    }

    fn take(&mut self, texel: usize, face: usize, point: [f64; 3]) {
        self.filled[texel] = true;
        self.samples.push(Sample {
            texel: texel as u32,
            face: face as u32,
            point: point.map(|x| x as f32),
        });
    }

    /// Texels whose centres lie in face `f`'s atlas polygon `t` that no earlier face took;
    /// false when it holds no texel centre.
    fn face(&mut self, f: usize, t: &[[f64; 2]], pts: &[[f64; 3]]) -> bool {
        let lo = [0, 1].map(|c| t.iter().map(|p| p[c]).fold(f64::INFINITY, f64::min));
        let hi = [0, 1].map(|c| t.iter().map(|p| p[c]).fold(f64::NEG_INFINITY, f64::max));
        let span = |lo: f64, hi: f64, n: usize| {
            let first = (lo - 0.5).ceil().max(0.0);
            let last = (hi - 0.5).floor().min(n as f64 - 1.0);
            (first as i64)..(last as i64 + 1)
        };
        let (xs, ys) = (
            span(lo[0], hi[0], self.width),
            span(lo[1], hi[1], self.height),
        );
        let mut any = false;
        for y in ys {
            for x in xs.clone() {
                let p = [x as f64 + 0.5, y as f64 + 0.5];
                if !inside(t, p) {
                    continue;
                }
                any = true;
                let i = y as usize * self.width + x as usize;
                if self.filled[i] {
                    continue;
                }
                if let Some(q) = lift(t, pts, p) {
                    self.take(i, f, q);
                }
            }
        }
        any
    }
}

fn perp_dot(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

fn sub2(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

/// Whether `p` lies in the convex polygon `t` (either orientation), within 1e-9 texels.
fn inside(t: &[[f64; 2]], p: [f64; 2]) -> bool {
    let side = |k: usize| {
        let (a, b) = (t[k], t[(k + 1) % t.len()]);
        let e = sub2(b, a);
        perp_dot(e, sub2(p, a)) / (e[0] * e[0] + e[1] * e[1]).sqrt().max(f64::MIN_POSITIVE)
    };
    let tolerance = 1e-9;
    (0..t.len()).all(|k| side(k) >= -tolerance) || (0..t.len()).all(|k| side(k) <= tolerance)
}

/// Barycentric coordinates of `p` in triangle `t`, None when it is degenerate.
fn barycentric(t: [[f64; 2]; 3], p: [f64; 2]) -> Option<[f64; 3]> {
    let (e1, e2) = (sub2(t[1], t[0]), sub2(t[2], t[0]));
    let d = perp_dot(e1, e2);
    let len2 = |e: [f64; 2]| e[0] * e[0] + e[1] * e[1];
    if d.abs() <= 1e-12 * len2(e1).max(len2(e2)) {
        return None;
    }
    let q = sub2(p, t[0]);
    let b1 = perp_dot(q, e2) / d;
    let b2 = perp_dot(e1, q) / d;
    Some([1.0 - b1 - b2, b1, b2])
}

/// The point of the face at atlas position `p`: the affine map of the face's first
/// non-degenerate corner triangle in the atlas onto the same corners in space.
fn lift(t: &[[f64; 2]], pts: &[[f64; 3]], p: [f64; 2]) -> Option<[f64; 3]> {
    (1..t.len() - 1).find_map(|i| {
        let w = barycentric([t[0], t[i], t[i + 1]], p)?;
        Some([0, 1, 2].map(|c| w[0] * pts[0][c] + w[1] * pts[i][c] + w[2] * pts[i + 1][c]))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testkit::faces::{EMISSION, ORDER, element_at, lightmapped};

    /// The strip of `testkit::faces` with lightmap coordinates `uv(x, y)`.
    fn strip(
        uv: impl Fn(f32, f32) -> [f32; 2],
        width: u32,
        height: u32,
        padding: u32,
    ) -> OperatorFile {
        let file = lightmapped(uv, width, height, padding);
        file.validate().unwrap();
        file
    }

    /// Radiosity per element in original ids: the emission (one patch, `F_k = 0`).
    fn radiosity() -> Vec<[f32; 3]> {
        let mut b = vec![[0.0; 3]; 2];
        for (s, &id) in ORDER.iter().enumerate() {
            b[id as usize] = EMISSION[s];
        }
        b
    }

    #[test]
    fn flat_texels_are_the_element_under_their_centre_over_pi() {
        // 16 × 7 texels over the strip [0, 2] × [0, 1]: no texel centre on a diagonal.
        let file = strip(|x, y| [x / 2.0, y], 16, 7, 1);
        let mut map = Lightmap::new(&file, Some(LightmapValues::Flat)).unwrap();
        assert_eq!((map.width(), map.height(), map.padding()), (16, 7, 1));
        assert_eq!(map.sample_count(), 16 * 7);
        assert_eq!(map.dilated_count(), 0, "the strip covers the atlas");
        let mut texels = vec![[f32::NAN; 3]; 16 * 7];
        map.fill(&radiosity(), &mut texels).unwrap();
        for (i, s) in map.samples().enumerate() {
            assert_eq!(s.texel, i, "samples in texel order");
            let (x, y) = ((i % 16) as f32 + 0.5, (i / 16) as f32 + 0.5);
            let (px, py) = (x / 8.0, y / 7.0);
            assert!((s.point[0] - px).abs() < 1e-6 && (s.point[1] - py).abs() < 1e-6);
            let e = element_at(px, py);
            assert_eq!(
                texels[i],
                EMISSION[e].map(|v| v / std::f32::consts::PI),
                "{s:?}"
            );
        }
    }

    #[test]
    fn smooth_texels_are_the_reconstruction_at_the_sample_over_pi() {
        let file = strip(|x, y| [x / 2.0, y], 16, 7, 1);
        let mut map = Lightmap::new(&file, None).unwrap();
        assert_eq!(map.values(), LightmapValues::Smooth);
        let b = radiosity();
        let mut texels = vec![[0.0; 3]; 16 * 7];
        map.fill(&b, &mut texels).unwrap();
        let r = crate::Reconstruction::new(&file).unwrap();
        let mut vertices = vec![[0.0; 3]; r.vertex_count()];
        r.vertex_values(&b, &mut vertices).unwrap();
        let mut varies = false;
        for s in map.samples() {
            let want = r.at(&vertices, s.face, s.point);
            for c in 0..3 {
                let want = want[c] / std::f32::consts::PI;
                assert!(
                    (texels[s.texel][c] - want).abs() <= 1e-6 * want.max(1e-6),
                    "{s:?}"
                );
            }
            varies |= texels[s.texel] != texels[0];
        }
        assert!(varies);
    }

    #[test]
    fn dilation_fills_padding_rings_with_the_mean_of_filled_neighbours() {
        // The strip over texels x 4..12, y 2..6 of a 16 × 8 atlas, dilated 2 rings.
        let file = strip(|x, y| [0.25 + x / 4.0, 0.25 + y / 2.0], 16, 8, 2);
        let mut map = Lightmap::new(&file, Some(LightmapValues::Flat)).unwrap();
        assert_eq!(map.sample_count(), 8 * 4);
        assert_eq!(map.dilated_count(), (10 * 6 - 8 * 4) + (12 * 8 - 10 * 6));
        let mut texels = vec![[f32::NAN; 3]; 16 * 8];
        map.fill(&radiosity(), &mut texels).unwrap();
        let at = |x: usize, y: usize| texels[y * 16 + x];
        // A corner of ring 1 has one filled neighbour, the chart's corner.
        assert_eq!(at(3, 1), at(4, 2));
        // Beside an edge: the mean of the three texels along it.
        let mean = |v: [[f32; 3]; 3]| {
            let mut m = [0.0f32; 3];
            for c in 0..3 {
                m[c] = (v[0][c] + v[1][c] + v[2][c]) / 3.0;
            }
            m
        };
        assert_eq!(at(6, 1), mean([at(5, 2), at(6, 2), at(7, 2)]));
        // Ring 2 takes ring 1's values; beyond it every texel is zero.
        assert_eq!(at(2, 0), at(3, 1));
        for y in 0..8 {
            for x in 0..16 {
                let ring = (4i64 - x as i64)
                    .max(x as i64 - 11)
                    .max(2 - y as i64)
                    .max(y as i64 - 5);
                if ring > 2 {
                    assert_eq!(at(x, y), [0.0; 3], "({x}, {y})");
                } else {
                    assert!(at(x, y).iter().sum::<f32>() > 0.0, "({x}, {y})");
                }
            }
        }
    }

    /// The GPU's table (`lightmap.wgsl`'s layout), evaluated here in f64, gives the CPU's
    /// fill: every sample and every ring texel (each expanded into sources), at any padding
    /// and thread count (a split reorders the ring texels), smooth and flat. Without an
    /// adapter: an index slip in the table shows here, not only on a GPU.
    #[cfg(feature = "gpu")]
    #[test]
    fn the_gpu_table_gives_the_cpu_fill() {
        let b = radiosity();
        for padding in [0, 1, 3] {
            let file = strip(|x, y| [0.1 + x / 2.5, 0.05 + y * 0.7], 97, 61, padding);
            for values in [LightmapValues::Smooth, LightmapValues::Flat] {
                for threads in [1, 3] {
                    let what = format!("padding {padding}, {values:?}, {threads} threads");
                    let mut map = Lightmap::new(&file, Some(values)).unwrap();
                    map.set_threads(threads);
                    let mut want = vec![[f32::NAN; 3]; 97 * 61];
                    map.fill(&b, &mut want).unwrap();
                    let sources: Vec<[f64; 3]> = match values {
                        LightmapValues::Smooth => (map.vertices.iter())
                            .map(|v| [0, 1, 2].map(|c| f64::from(v[c])))
                            .collect(),
                        LightmapValues::Flat => b.iter().map(|v| v.map(f64::from)).collect(),
                    };
                    let t = map.gpu_table();
                    let mut got = vec![None; 97 * 61];
                    let stride = if values == LightmapValues::Smooth {
                        5
                    } else {
                        1
                    };
                    for i in 0..map.sample_count() {
                        let run = t.samples[stride * i] as usize;
                        let texel = (i as u32).wrapping_add(t.run_base[run]) as usize;
                        let mut v = [0.0f64; 3];
                        for k in 0..stride.min(4) {
                            let w = match values {
                                LightmapValues::Smooth => {
                                    f64::from(f32::from_bits(t.samples[5 * i + 1 + k]))
                                }
                                LightmapValues::Flat => 1.0 / PI,
                            };
                            let x = sources[t.run_index[4 * run + k] as usize];
                            for c in 0..3 {
                                v[c] += w * x[c];
                            }
                        }
                        assert!(
                            got[texel].replace(v).is_none(),
                            "{what}: texel {texel} twice"
                        );
                    }
                    for j in 0..map.dilated_count() {
                        let start = if j == 0 {
                            0
                        } else {
                            t.rings[2 * j - 1] as usize
                        };
                        let mut v = [0.0f64; 3];
                        for k in start..t.rings[2 * j + 1] as usize {
                            let w = f64::from(f32::from_bits(t.ring_weight[k]));
                            let x = sources[t.ring_source[k] as usize];
                            for c in 0..3 {
                                v[c] += w * x[c];
                            }
                        }
                        let texel = t.rings[2 * j] as usize;
                        assert!(
                            got[texel].replace(v).is_none(),
                            "{what}: texel {texel} twice"
                        );
                    }
                    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                        match g {
                            None => assert_eq!(*w, [0.0; 3], "{what}: texel {i} left out"),
                            Some(g) => {
                                for c in 0..3 {
                                    let w = f64::from(w[c]);
                                    assert!(
                                        (g[c] - w).abs() <= 1e-6 * w.abs() + 1e-9,
                                        "{what}: texel {i}: table {g:?} against fill {w}"
                                    );
                                }
                            }
                        }
                    }
                    assert_eq!(
                        got.iter().filter(|g| g.is_some()).count(),
                        map.sample_count() + map.dilated_count(),
                        "{what}"
                    );
                    assert!(padding == 0 || map.dilated_count() > 0, "{what}");
                }
            }
        }
    }

    /// The tiles of `lightmap_tiles.wgsl` (`Lightmap::gpu_tiles`), evaluated here as the
    /// shader does (each tile's vertices from SMOOTH's rows, then its texels), give the CPU's
    /// fill: at paddings 0, 1 and 3, on the strip and on a dense grid (many vertices under a
    /// run of texels), with the shader's limits and with smaller ones that cut tiles at the
    /// vertex limit; each texel once, every written texel covered. A texel over the vertex
    /// limit on its own gives `None`.
    #[cfg(feature = "gpu")]
    #[test]
    fn the_gpu_tiles_give_the_cpu_fill() {
        let grid = crate::testkit::faces::lightmapped_grid(900, 9, 64, 48, 3, 7);
        let grid_b: Vec<[f32; 3]> = (0..900)
            .map(|e| {
                [
                    0.2 + (e % 7) as f32,
                    1.0 + (e % 5) as f32,
                    0.5 + (e % 3) as f32,
                ]
            })
            .collect();
        let mut cut = false;
        for padding in [0, 1, 3] {
            let strip = strip(|x, y| [0.1 + x / 2.5, 0.05 + y * 0.7], 97, 61, padding);
            let mut grid = grid.clone();
            let atlas = (grid.display.lightmap.as_mut()).and_then(|l| l.atlas.as_mut());
            atlas.expect("an atlas").padding = padding;
            for (name, file, b) in [
                ("strip", &strip, radiosity()),
                ("grid", &grid, grid_b.clone()),
            ] {
                let mut map = Lightmap::new(file, Some(LightmapValues::Smooth)).unwrap();
                let (w, h) = (map.width, map.height);
                let mut want = vec![[f32::NAN; 3]; w * h];
                map.fill(&b, &mut want).unwrap();
                for (block, limit) in [(TILE_BLOCK, TILE_VERTICES), ((64, 1), 12), ((7, 5), 5)] {
                    let what = format!("{name}, padding {padding}, tiles of {block:?}/{limit}");
                    let Some(t) = map.tiles_within(block, limit) else {
                        // Only a dilated texel reads more than 4 vertices.
                        assert!(limit < TILE_VERTICES && padding > 0, "{what}: no tiles");
                        continue;
                    };
                    let mut got = evaluate_tiles(&t, &b, w, block, limit);
                    got.resize(w * h, None);
                    let blocks: std::collections::HashSet<(usize, usize)> = (got.iter())
                        .enumerate()
                        .filter(|(_, g)| g.is_some())
                        .map(|(i, _)| (i % w / block.0, i / w / block.1))
                        .collect();
                    cut |= t.tiles.len() / 2 - 1 > blocks.len();
                    let mut written = 0;
                    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                        match g {
                            None => assert_eq!(*w, [0.0; 3], "{what}: texel {i} left out"),
                            Some(g) => {
                                written += 1;
                                for c in 0..3 {
                                    let w = f64::from(w[c]);
                                    assert!(
                                        (g[c] - w).abs() <= 1e-5 * w.abs() + 1e-9,
                                        "{what}: texel {i}: tiles {g:?} against fill {w}"
                                    );
                                }
                            }
                        }
                    }
                    assert_eq!(written, map.sample_count() + map.dilated_count(), "{what}");
                }
                assert!(map.tiles_within((8, 8), 3).is_none() || map.dilated_count() == 0);
            }
        }
        assert!(cut, "no tile was cut at the vertex limit");
    }

    /// `lightmap_tiles.wgsl`'s arithmetic on the host (f32 vertex sums as the shader's, f64
    /// texels) over an atlas `width` texels across: per texel its value, `None` where no item
    /// writes. Panics on a texel written twice, a tile over its limits or over two blocks, or
    /// an index out of its tile.
    #[cfg(feature = "gpu")]
    fn evaluate_tiles(
        t: &TileTable,
        b: &[[f32; 3]],
        width: usize,
        block: (usize, usize),
        limit: usize,
    ) -> Vec<Option<[f64; 3]>> {
        let mut got: Vec<Option<[f64; 3]>> = Vec::new();
        let f = f32::from_bits;
        for tile in 0..t.tiles.len() / 2 - 1 {
            let (i0, i1) = (t.tiles[2 * tile] as usize, t.tiles[2 * tile + 2] as usize);
            let (v0, v1) = (
                t.tiles[2 * tile + 1] as usize,
                t.tiles[2 * tile + 3] as usize,
            );
            assert!(
                i1 > i0 && i1 - i0 <= TILE_LANES && v1 - v0 <= limit,
                "tile {tile}"
            );
            let values: Vec<[f64; 3]> = (v0..v1)
                .map(|j| {
                    let row = &t.tile_vertices[2 * j..2 * j + 2];
                    let mut sum = [0.0f32; 3];
                    for e in row[0] as usize..row[1] as usize {
                        let x = b[t.entries[2 * e] as usize];
                        for c in 0..3 {
                            sum[c] += f(t.entries[2 * e + 1]) * x[c];
                        }
                    }
                    sum.map(|x| f64::from(x.max(0.0)))
                })
                .collect();
            let block_of = |texel: usize| (texel % width / block.0, texel / width / block.1);
            let first = block_of((t.items[2 * i0] & !TILE_DILATED) as usize);
            for i in i0..i1 {
                let (head, x) = (t.items[2 * i], t.items[2 * i + 1]);
                let texel = (head & !TILE_DILATED) as usize;
                assert_eq!(block_of(texel), first, "tile {tile} over two blocks");
                let mut v = [0.0f64; 3];
                let mut add = |local: u32, w: f32| {
                    assert!((local as usize) < v1 - v0, "tile {tile}: vertex {local}");
                    let value = values[local as usize];
                    for c in 0..3 {
                        v[c] += f64::from(w) * value[c];
                    }
                };
                let slot = &t.slots[4 * i..4 * i + 4];
                if head & TILE_DILATED == 0 {
                    for k in 0..4 {
                        // Unused corners index 0 with weight 0.
                        if slot[k] != 0 {
                            add((x >> (8 * k)) & 0xff, f(slot[k]));
                        }
                    }
                } else {
                    for k in slot[0] as usize..slot[1] as usize {
                        add(t.terms[2 * k], f(t.terms[2 * k + 1]));
                    }
                }
                if got.len() <= texel {
                    got.resize(texel + 1, None);
                }
                assert!(got[texel].replace(v).is_none(), "texel {texel} twice");
            }
        }
        got
    }

    #[test]
    fn threads_give_the_same_texels() {
        let file = strip(|x, y| [0.1 + x / 2.5, 0.05 + y * 0.7], 97, 61, 3);
        let b = radiosity();
        let mut one = Lightmap::new(&file, None).unwrap();
        let mut texels = vec![[0.0; 3]; 97 * 61];
        one.fill(&b, &mut texels).unwrap();
        for threads in [2, 3, 7, 64] {
            let mut many = one.clone();
            many.set_threads(threads);
            let mut got = vec![[f32::NAN; 3]; 97 * 61];
            many.fill(&b, &mut got).unwrap();
            assert_eq!(got, texels, "{threads} threads");
            // Split again, from a split into several bands, and back.
            for again in [3, 1, threads] {
                let mut resplit = many.clone();
                resplit.set_threads(again);
                let mut got = vec![[f32::NAN; 3]; 97 * 61];
                resplit.fill(&b, &mut got).unwrap();
                assert_eq!(got, texels, "{threads} threads, then {again}");
            }
            // The two halves give the same texels, as long as nothing is added between.
            let mut halves = vec![[f32::NAN; 3]; 97 * 61];
            many.fill_samples(&b, &mut halves).unwrap();
            many.dilate(&mut halves).unwrap();
            assert_eq!(halves, texels, "{threads} threads, in two halves");
            let bands = many.bands.count();
            let deferred: usize = (0..many.ring_ends.len())
                .map(|r| many.ring_ends[r] as usize - many.bands.start(r, bands))
                .sum();
            assert!(
                deferred > 0,
                "{threads} threads: rings cross the bands' edges"
            );
        }
        assert!(
            one.dilated_count() > 500,
            "{} dilated texels",
            one.dilated_count()
        );
        assert!(one.fill_bytes() >= 12 * 97 * 61 + 16 * one.sample_count());
    }

    #[test]
    fn bad_calls_are_errors_that_say_what_is_wrong() {
        let mut file = strip(|x, y| [x / 2.0, y], 16, 7, 1);
        let mut map = Lightmap::new(&file, None).unwrap();
        let e = map.fill(&radiosity(), &mut [[0.0; 3]; 5]).unwrap_err();
        assert!(
            e.to_string().contains("5 texels given for a 16×7 atlas"),
            "{e}"
        );
        let e = map
            .fill(&radiosity()[..1], &mut vec![[0.0; 3]; 16 * 7])
            .unwrap_err();
        assert!(e.to_string().contains("1 element values"), "{e}");
        let e = Lightmap::with_size(&file, 0, 4, 1, None).unwrap_err();
        assert!(e.to_string().contains("0×4 texels"), "{e}");
        let e = Lightmap::with_size(&file, 4, 4, 65, None).unwrap_err();
        assert!(e.to_string().contains("padding 65"), "{e}");
        let e = Lightmap::with_coordinates(&file, &[0.0; 7], 4, 4, 1, None).unwrap_err();
        assert!(
            e.to_string().contains("7 coordinates for 4 display faces"),
            "{e}"
        );
        file.display.lightmap.as_mut().unwrap().atlas = None;
        let e = Lightmap::new(&file, None).unwrap_err();
        assert!(e.to_string().contains("re-bake"), "{e}");
        assert!(Lightmap::with_size(&file, 8, 8, 1, None).is_ok());
        file.display.lightmap = None;
        let e = Lightmap::with_size(&file, 8, 8, 1, None).unwrap_err();
        assert!(e.to_string().contains("no lightmap coordinates"), "{e}");
        let mut file = strip(|x, y| [x / 2.0, y], 16, 7, 1);
        file.display.smooth = None;
        let e = Lightmap::new(&file, Some(LightmapValues::Smooth)).unwrap_err();
        assert!(e.to_string().contains("SMOOTH"), "{e}");
        assert_eq!(
            Lightmap::new(&file, None).unwrap().values(),
            LightmapValues::Flat
        );
    }
}
