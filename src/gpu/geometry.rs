//! The scene on the device: one space of `u32` words (mesh records, each grid mesh's top level,
//! coordinates, block boxes, block records and loose triangles, the scene's CWBVH over
//! instances with the exact child boxes the CPU traverses, instances; laid
//! out in [`super::layout`]) split into up to [`GEO_CHUNKS`] storage bindings, so that a scene
//! larger than one binding (128 MiB on lavapipe) still works. Word `i` is word
//! `i & (2^shift − 1)` of chunk `i >> shift`; see `kernels/bvh.wgsl`.

use crate::bvh::mesh::WideBoxes;
use crate::bvh::SceneBvh;
use crate::error::{Error, ErrorKind, Result};
use crate::grid::node::Box4;
use crate::grid::GridMesh;
use wgpu::util::DeviceExt;

use super::layout::{
    BLK_BOXES, BLK_DIMS, BLK_NORMAL, BLK_ROOT, BLK_TRI0, BLK_TRI_STRIDE, BLK_VERT, BLK_WORDS,
    BOX4_WORDS, GEO_CHUNKS, GRID_STACK_MAX, INSTANCE_WORDS, INST_MESH, INST_XFORM, MESH_BLOCK_OFF,
    MESH_LOOSE_OFF, MESH_NBLOCKS, MESH_ROOT, MESH_STRIP_OFF, MESH_TOP_OFF, MESH_WORDS,
    TRAVERSAL_STACK,
};
use super::GpuContext;

/// The words of a scene and where its parts start.
#[derive(Clone, Debug, Default)]
pub struct PackedScene {
    /// All words.
    pub words: Vec<u32>,
    /// 0: one mesh (record 0, world space); 1: instances under a top level.
    pub mode: u32,
    /// Word offset of the mesh records ([`MESH_WORDS`] words each, `MESH_*`).
    pub mesh_off: u32,
    /// Word offset of the top-level nodes.
    pub top_node_off: u32,
    /// Number of top-level nodes.
    pub top_node_count: u32,
    /// Word offset of the top-level leaf → instance table.
    pub top_index_off: u32,
    /// Word offset of the instance records.
    pub inst_off: u32,
    /// Word offset of the top-level nodes' exact child boxes.
    pub top_box_off: u32,
    /// The most stack entries any mesh's walk can hold ([`crate::grid::top::Top::stack`]):
    /// the kernels' `GRID_STACK`.
    pub grid_stack: u32,
}

fn offset(words: &[u32]) -> Result<u32> {
    u32::try_from(words.len()).map_err(|_| {
        Error::new(
            ErrorKind::Gpu,
            "scene too large for the GPU backend (more than 2^32 words)",
        )
    })
}

fn push_boxes(words: &mut Vec<u32>, boxes: &[WideBoxes]) {
    for b in boxes {
        for side in [&b.lo, &b.hi] {
            for axis in side {
                words.extend(axis.iter().map(|x| x.to_bits()));
            }
        }
    }
}

/// A `Box4`'s words: `lo[axis][child]`, then `hi`.
fn box4_words(b: &Box4) -> [u32; BOX4_WORDS] {
    std::array::from_fn(|i| {
        let side = if i < BOX4_WORDS / 2 { &b.lo } else { &b.hi };
        let j = i % (BOX4_WORDS / 2);
        side[j / 4][j % 4].to_bits()
    })
}

fn push_mesh(words: &mut Vec<u32>, rec: usize, m: &GridMesh) -> Result<()> {
    if m.top.stack > GRID_STACK_MAX as usize {
        return Err(Error::new(
            ErrorKind::Gpu,
            format!(
                "a mesh's top level ({} nodes deep) can need {} stack entries; the GPU walk \
                 holds at most {GRID_STACK_MAX}",
                m.top.depth, m.top.stack
            ),
        ));
    }
    let top_off = offset(words)?;
    for n in &m.top.nodes {
        push_boxes(words, std::slice::from_ref(&n.boxes));
        words.extend_from_slice(&n.child);
    }
    let coord_off = offset(words)?;
    words.extend(m.coords.iter().map(|x| x.to_bits()));
    let box_off = offset(words)?;
    for b in &m.boxes {
        words.extend_from_slice(&box4_words(b));
    }
    let block_off = offset(words)?;
    for b in &m.blocks {
        let mut r = [0u32; BLK_WORDS];
        r[BLK_ROOT..BLK_ROOT + BOX4_WORDS].copy_from_slice(&box4_words(&b.root));
        r[BLK_VERT] = coord_off + b.vert;
        r[BLK_BOXES] = box_off + (BOX4_WORDS as u32) * b.boxes;
        r[BLK_DIMS] = b.cols as u32 | (b.rows as u32) << 8;
        r[BLK_TRI0] = b.tri0;
        r[BLK_TRI_STRIDE] = b.tri_stride;
        r[BLK_NORMAL] = b.normal();
        words.extend_from_slice(&r);
    }
    let loose_off = offset(words)?;
    for l in &m.loose {
        for p in &l.p {
            words.extend(p.iter().map(|x| x.to_bits()));
        }
        words.push(l.id);
    }
    let strip_off = offset(words)?;
    for st in &m.strips {
        words.extend_from_slice(st);
    }
    offset(words)?;
    words[rec + MESH_STRIP_OFF] = strip_off;
    words[rec + MESH_TOP_OFF] = top_off;
    words[rec + MESH_ROOT] = m.top.root;
    words[rec + MESH_BLOCK_OFF] = block_off;
    words[rec + MESH_NBLOCKS] = m.blocks.len() as u32;
    words[rec + MESH_LOOSE_OFF] = loose_off;
    Ok(())
}

impl PackedScene {
    /// One mesh, traced in its own space (as [`GridMesh::intersect`]).
    pub fn from_mesh(m: &GridMesh) -> Result<PackedScene> {
        let mut words = vec![0u32; MESH_WORDS];
        push_mesh(&mut words, 0, m)?;
        Ok(PackedScene {
            words,
            mode: 0,
            grid_stack: m.top.stack as u32,
            ..Default::default()
        })
    }

    /// Instances of meshes (as [`SceneBvh::intersect`]).
    pub fn from_scene(s: &SceneBvh) -> Result<PackedScene> {
        let mut words = vec![0u32; MESH_WORDS * s.meshes.len().max(1)];
        for (i, m) in s.meshes.iter().enumerate() {
            push_mesh(&mut words, MESH_WORDS * i, m)?;
        }
        if s.top_boxes.len() != s.top.nodes.len() {
            return Err(Error::new(
                ErrorKind::Gpu,
                "scene top level has no exact child boxes for every node",
            ));
        }
        // The CWBVH walk holds at most one entry per level.
        if s.top_depth >= TRAVERSAL_STACK as usize {
            return Err(Error::new(
                ErrorKind::Gpu,
                format!(
                    "the scene's top level over instances is {} nodes deep; the GPU walk holds \
                     {TRAVERSAL_STACK}",
                    s.top_depth
                ),
            ));
        }
        let top_node_off = offset(&words)?;
        words.extend_from_slice(bytemuck::cast_slice(&s.top.nodes));
        let top_box_off = offset(&words)?;
        push_boxes(&mut words, &s.top_boxes);
        let top_index_off = offset(&words)?;
        words.extend_from_slice(&s.top_index);
        let inst_off = offset(&words)?;
        for inst in &s.instances {
            let m = inst.world_to_object;
            let mut rec = [0u32; INSTANCE_WORDS];
            rec[INST_MESH] = inst.mesh;
            let cols = [
                m.matrix3.x_axis,
                m.matrix3.y_axis,
                m.matrix3.z_axis,
                m.translation,
            ];
            for (i, c) in cols.iter().enumerate() {
                let at = INST_XFORM + 3 * i;
                rec[at..at + 3].copy_from_slice(&[c.x.to_bits(), c.y.to_bits(), c.z.to_bits()]);
            }
            words.extend_from_slice(&rec);
        }
        offset(&words)?;
        Ok(PackedScene {
            words,
            mode: 1,
            mesh_off: 0,
            top_node_off,
            top_node_count: s.top.nodes.len() as u32,
            top_index_off,
            inst_off,
            top_box_off,
            grid_stack: s
                .meshes
                .iter()
                .map(|m| m.top.stack as u32)
                .max()
                .unwrap_or(1),
        })
    }

    /// Bytes of the words.
    pub fn bytes(&self) -> u64 {
        self.words.len() as u64 * 4
    }
}

fn size(bytes: u64) -> String {
    if bytes >= 1 << 20 {
        format!("{:.1} MiB", bytes as f64 / (1u64 << 20) as f64)
    } else {
        format!("{:.1} KiB", bytes as f64 / 1024.0)
    }
}

/// The geometry words in device buffers.
pub struct GpuGeometry {
    /// The chunk buffers; unused ones are small placeholders.
    pub chunks: Vec<wgpu::Buffer>,
    /// Chunks actually used.
    pub used_chunks: usize,
    /// log2 of the words per chunk.
    pub chunk_shift: u32,
}

impl GpuGeometry {
    /// Uploads `packed`, in chunks of the largest power-of-two number of words one storage
    /// binding holds on this adapter, or of at most `max_chunk_words` words when given (tests
    /// use a small value to exercise the split).
    pub fn upload(
        ctx: &GpuContext,
        packed: &PackedScene,
        max_chunk_words: Option<u64>,
    ) -> Result<GpuGeometry> {
        let binding = ctx
            .limits
            .max_storage_buffer_binding_size
            .min(ctx.limits.max_buffer_size);
        let mut limit = (binding / 4).min(1 << 30);
        if let Some(m) = max_chunk_words {
            limit = limit.min(m.max(4));
        }
        let chunk_shift = 63 - limit.leading_zeros();
        let chunk = 1usize << chunk_shift;
        let words = &packed.words;
        let used_chunks = words.len().div_ceil(chunk).max(1);
        if used_chunks > GEO_CHUNKS {
            return Err(Error::new(
                ErrorKind::Gpu,
                format!(
                    "scene needs {} of GPU geometry, more than {GEO_CHUNKS} storage bindings of {} on {}",
                    size(packed.bytes()),
                    size(chunk as u64 * 4),
                    ctx.describe()
                ),
            ));
        }
        let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let mut chunks = Vec::with_capacity(GEO_CHUNKS);
        for c in 0..GEO_CHUNKS {
            let lo = (c * chunk).min(words.len());
            let hi = ((c + 1) * chunk).min(words.len());
            let mut data: Vec<u32> = words[lo..hi].to_vec();
            if data.len() < 4 {
                data.resize(4, 0);
            }
            chunks.push(
                ctx.device
                    .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some("limitray geometry"),
                        contents: bytemuck::cast_slice(&data),
                        usage: wgpu::BufferUsages::STORAGE,
                    }),
            );
        }
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::new(
                ErrorKind::Gpu,
                format!("uploading {} of geometry: {e}", size(packed.bytes())),
            ));
        }
        Ok(GpuGeometry {
            chunks,
            used_chunks,
            chunk_shift,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A mesh whose top level can need more stack than the kernel holds is refused with an
    /// error that says so; one that needs exactly the kernel's stack is packed.
    #[test]
    fn a_top_level_beyond_the_kernel_stack_is_refused() {
        let mut m = GridMesh::default();
        m.top.root = crate::grid::top::EMPTY;
        m.top.stack = GRID_STACK_MAX as usize;
        assert_eq!(
            PackedScene::from_mesh(&m).unwrap().grid_stack,
            GRID_STACK_MAX
        );
        m.top.stack += 1;
        let e = PackedScene::from_mesh(&m).unwrap_err();
        assert!(e.to_string().contains("stack entries"), "{e}");
    }
}
