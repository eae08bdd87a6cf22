//! The operator on the GPU: every buffer a frame reads, uploaded once, sized as the passes'
//! bounds-check-free indexing assumes (see the WGSL files' headers).

use lrr_formats::{OperatorData, OperatorFile, StoredMatrix};
use lrr_shaders::Params;
use wgpu::util::DeviceExt;

use super::common::{GpuError, Pod, bytes_of};
use super::device::Gpu;

/// A chunk of whole rows of the stored matrix: its own buffer and its own uniform.
pub(super) struct Chunk {
    pub buffer: wgpu::Buffer,
    pub params: wgpu::Buffer,
    pub rows: u32,
}

/// The light groups' tables (see `light_groups.wgsl`).
pub(super) struct Groups {
    pub count: usize,
    pub positions: u32,
    pub group_x: wgpu::Buffer,
    pub position: wgpu::Buffer,
    pub starts: wgpu::Buffer,
    pub members: wgpu::Buffer,
    pub member_emission: wgpu::Buffer,
    /// `3n` f32, zero except at the lit elements, which `group_emission` overwrites.
    pub emission: wgpu::Buffer,
}

/// Every buffer of one operator.
pub(super) struct OperatorBuffers {
    pub n: u32,
    pub k: u32,
    pub kp: u32,
    pub factored: bool,
    /// Plain RGB: three blocks of rows, each serving one channel.
    pub per_block: bool,
    pub params: wgpu::Buffer,
    pub index: wgpu::Buffer,
    pub weights: wgpu::Buffer,
    pub order: wgpu::Buffer,
    /// File order (factored); a 16-byte placeholder for the plain layout.
    pub reflectance: wgpu::Buffer,
    /// One `k × KP` core per channel (the grey core three times); placeholders when plain.
    pub cores: [wgpu::Buffer; 3],
    pub chunks: Vec<Chunk>,
    pub x: wgpu::Buffer,
    pub z: wgpu::Buffer,
    pub groups: Groups,
    pub radiosity: wgpu::Buffer,
    /// Where `read` stores (never, in practice).
    pub sink: wgpu::Buffer,
    /// Bytes of the stored matrix on the GPU, padding included.
    pub matrix_bytes: u64,
}

const STORAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE;

/// A storage buffer holding `values` (at least 16 bytes: wgpu binds no empty buffer).
pub(super) fn storage<T: Pod>(
    gpu: &Gpu,
    label: &str,
    values: &[T],
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    let bytes = bytes_of(values);
    let mut padded;
    let contents = if bytes.len() >= 16 {
        bytes
    } else {
        padded = bytes.to_vec();
        padded.resize(16, 0);
        &padded
    };
    gpu.device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage: usage | STORAGE,
        })
}

/// A zeroed storage buffer of `floats` f32.
pub(super) fn zeros(
    gpu: &Gpu,
    label: &str,
    floats: usize,
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: (4 * floats).max(16) as u64,
        usage: usage | STORAGE,
        mapped_at_creation: false,
    })
}

fn uniform(gpu: &Gpu, params: &Params) -> wgpu::Buffer {
    gpu.device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("params"),
            contents: &params.to_bytes(),
            usage: wgpu::BufferUsages::UNIFORM,
        })
}

impl OperatorBuffers {
    pub fn new(gpu: &Gpu, file: &OperatorFile) -> Result<Self, GpuError> {
        let (n, k) = (file.n, file.k);
        let kp = lrr_shaders::padded_k(k);
        let factored = matches!(file.operator, OperatorData::Factored { .. });
        let blocks = if factored { 1 } else { file.channels };
        let (n64, k64, kp64) = (u64::from(n), u64::from(k), u64::from(kp));
        let lit: u64 = file.lights.iter().map(|g| g.positions.len() as u64).sum();
        check_fits(
            &[
                ("core (k × k per channel)", 4 * k64 * kp64),
                ("index", 4 * (k64 + 1)),
                ("weights", 4 * n64),
                ("order", 4 * n64),
                ("emission", 12 * n64),
                ("radiosity", 12 * n64),
                ("light-group sums", 12 * kp64 * file.lights.len() as u64),
                ("light-group emission", 12 * lit),
            ],
            gpu.max_binding_bytes(),
            &gpu.info.name,
        )?;
        let groups = groups(gpu, file, kp as usize);
        let params = Params {
            n,
            k,
            row_count: n,
            groups: groups.count as u32,
            positions: groups.positions,
            ..Params::default()
        };
        let cores = match &file.operator {
            OperatorData::Factored { cores, .. } => padded_cores(cores, file.channels, k, kp)
                .map(|c| storage(gpu, "core", &c, wgpu::BufferUsages::COPY_DST)),
            OperatorData::PlainYk { .. } => {
                [0; 3].map(|_| zeros(gpu, "core", 0, wgpu::BufferUsages::empty()))
            }
        };
        let reflectance = if factored { &file.reflectance[..] } else { &[] };
        let (chunks, matrix_bytes) = chunks(gpu, file.operator.matrix(), &params, blocks * n, kp)?;
        Ok(OperatorBuffers {
            n,
            k,
            kp,
            factored,
            per_block: blocks == 3,
            params: uniform(gpu, &params),
            index: storage(gpu, "index", &file.index, wgpu::BufferUsages::empty()),
            weights: storage(gpu, "weights", &file.weights, wgpu::BufferUsages::empty()),
            order: storage(gpu, "order", &file.order, wgpu::BufferUsages::empty()),
            reflectance: storage(
                gpu,
                "reflectance",
                reflectance,
                wgpu::BufferUsages::COPY_DST,
            ),
            cores,
            chunks,
            // COPY_DST: the hybrid frame uploads Z (X for the plain layout) computed on the CPU.
            x: zeros(gpu, "x", 3 * kp as usize, wgpu::BufferUsages::COPY_DST),
            z: zeros(gpu, "z", 3 * kp as usize, wgpu::BufferUsages::COPY_DST),
            groups,
            radiosity: zeros(
                gpu,
                "radiosity",
                3 * n as usize,
                wgpu::BufferUsages::COPY_SRC,
            ),
            sink: zeros(gpu, "sink", 4, wgpu::BufferUsages::empty()),
            matrix_bytes,
        })
    }

    /// Replaces the cores and reflectance after an albedo edit (factored only).
    pub fn set_albedo(&self, gpu: &Gpu, cores: &[f64], channels: u32, reflectance: &[f32]) {
        let padded = padded_cores(cores, channels, self.k, self.kp);
        for (buffer, core) in self.cores.iter().zip(&padded) {
            gpu.queue.write_buffer(buffer, 0, bytes_of(core));
        }
        gpu.queue
            .write_buffer(&self.reflectance, 0, bytes_of(reflectance));
    }
}

/// Refuses an operator whose buffers, other than the stored matrix (which is split into chunks
/// of rows), do not fit one storage binding of `limit` bytes: wgpu would abort the process.
fn check_fits(buffers: &[(&str, u64)], limit: u64, adapter: &str) -> Result<(), GpuError> {
    match buffers.iter().find(|(_, bytes)| *bytes > limit) {
        None => Ok(()),
        Some((name, bytes)) => Err(GpuError::Device(format!(
            "GPU: the {name} buffer needs {bytes} bytes, over the {limit}-byte limit of one \
             storage binding on {adapter}; only the stored matrix is split into chunks: \
             evaluate this operator on the CPU"
        ))),
    }
}

/// The three channels' cores as `k` rows of `kp` f32 (the grey core three times).
fn padded_cores(cores: &[f64], channels: u32, k: u32, kp: u32) -> [Vec<f32>; 3] {
    let (k, kp) = (k as usize, kp as usize);
    std::array::from_fn(|c| {
        let core = if channels == 1 { 0 } else { c };
        let m = &cores[core * k * k..(core + 1) * k * k];
        let mut out = vec![0.0f32; k * kp];
        for (row, src) in out.chunks_exact_mut(kp).zip(m.chunks_exact(k)) {
            for (o, &v) in row.iter_mut().zip(src) {
                *o = v as f32;
            }
        }
        out
    })
}

/// The stored matrix (`rows` rows of `k` entries) as chunks of whole rows of `kp` entries, each
/// no larger than the device allows. Returns the chunks and their total bytes.
fn chunks(
    gpu: &Gpu,
    m: &StoredMatrix,
    base: &Params,
    rows: u32,
    kp: u32,
) -> Result<(Vec<Chunk>, u64), GpuError> {
    let size = m.precision().size() as u64;
    let row_bytes = u64::from(kp) * size;
    let limit = gpu.max_chunk_bytes();
    let per_chunk = (limit / row_bytes).min(u64::from(u32::MAX)) as u32;
    if per_chunk == 0 {
        return Err(GpuError::Device(format!(
            "GPU: one row of the stored matrix ({row_bytes} bytes, k = {}) exceeds the \
             {limit}-byte limit of a storage binding on {}",
            base.k, gpu.info.name
        )));
    }
    let mut out = Vec::new();
    let mut first = 0;
    while first < rows {
        let count = per_chunk.min(rows - first);
        let buffer = upload_rows(
            gpu,
            m,
            base.k as usize,
            kp as usize,
            first as usize,
            count as usize,
        );
        let params = Params {
            first_row: first,
            row_count: count,
            ..*base
        };
        out.push(Chunk {
            buffer,
            params: uniform(gpu, &params),
            rows: count,
        });
        first += count;
    }
    Ok((out, u64::from(rows) * row_bytes))
}

/// Rows `first .. first + count` of `m` (`k` entries each) in a new buffer, padded to `kp`
/// entries, written through a mapping in blocks of about 1 MiB (no whole-chunk host copy).
fn upload_rows(
    gpu: &Gpu,
    m: &StoredMatrix,
    k: usize,
    kp: usize,
    first: usize,
    count: usize,
) -> wgpu::Buffer {
    let size = m.precision().size();
    let row_bytes = kp * size;
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("stored matrix chunk"),
        size: (count * row_bytes) as u64,
        usage: STORAGE,
        mapped_at_creation: true,
    });
    {
        let mut view = (buffer.slice(..).get_mapped_range_mut())
            .expect("a buffer mapped at creation has a mapped range");
        let block = (1 << 20) / row_bytes + 1;
        let mut staging = vec![0u8; block * row_bytes];
        let mut r = 0;
        while r < count {
            let rows = block.min(count - r);
            let out = &mut staging[..rows * row_bytes];
            for (i, dst) in out.chunks_exact_mut(row_bytes).enumerate() {
                let start = (first + r + i) * k;
                let src = match m {
                    StoredMatrix::F32(v) => bytes_of(&v[start..start + k]),
                    StoredMatrix::F16(v) => bytes_of(&v[start..start + k]),
                };
                dst[..src.len()].copy_from_slice(src);
            }
            let at = r * row_bytes;
            view.slice(at..at + out.len()).copy_from_slice(out);
            r += rows;
        }
    }
    buffer.unmap();
    buffer
}

/// The light groups' tables: `x_g` as planes of `kp`, and the lit positions in CSR form.
fn groups(gpu: &Gpu, file: &OperatorFile, kp: usize) -> Groups {
    let g = file.lights.len();
    let mut group_x = vec![0.0f32; g * 3 * kp];
    let mut entries: Vec<(u32, u32, [f32; 3])> = Vec::new();
    for (gi, group) in file.lights.iter().enumerate() {
        for (p, x) in group.x.chunks_exact(3).enumerate() {
            for c in 0..3 {
                group_x[gi * 3 * kp + c * kp + p] = x[c] as f32;
            }
        }
        for (&s, e) in group.positions.iter().zip(group.emission.chunks_exact(3)) {
            entries.push((s, gi as u32, [e[0], e[1], e[2]]));
        }
    }
    entries.sort_by_key(|&(s, g, _)| (s, g));
    let mut position: Vec<u32> = Vec::new();
    let mut starts: Vec<u32> = Vec::new();
    for (m, &(s, _, _)) in entries.iter().enumerate() {
        if position.last() != Some(&s) {
            position.push(s);
            starts.push(m as u32);
        }
    }
    starts.push(entries.len() as u32);
    let members: Vec<u32> = entries.iter().map(|e| e.1).collect();
    let emission: Vec<f32> = entries.iter().flat_map(|e| e.2).collect();
    let none = wgpu::BufferUsages::empty();
    Groups {
        count: g,
        positions: position.len() as u32,
        group_x: storage(gpu, "group x", &group_x, none),
        position: storage(gpu, "group positions", &position, none),
        starts: storage(gpu, "group starts", &starts, none),
        members: storage(gpu, "group members", &members, none),
        member_emission: storage(gpu, "group emission", &emission, none),
        // Copied into an upload slot when the direct pass adds to a group frame's emission.
        emission: zeros(
            gpu,
            "emission of the groups",
            3 * file.n as usize,
            wgpu::BufferUsages::COPY_SRC,
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buffers_over_the_binding_limit_are_refused_by_name() {
        let fits = [("core (k × k per channel)", 100), ("radiosity", 128)];
        assert_eq!(check_fits(&fits, 128, "gpu"), Ok(()));
        let over = [("core (k × k per channel)", 100), ("radiosity", 129)];
        let e = check_fits(&over, 128, "llvmpipe").unwrap_err().to_string();
        assert!(e.contains("radiosity buffer needs 129 bytes"), "{e}");
        assert!(
            e.contains("128-byte limit") && e.contains("llvmpipe"),
            "{e}"
        );
        assert!(e.contains("on the CPU"), "{e}");
    }
}
