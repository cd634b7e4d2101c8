//! The one definition of every word layout the host and the kernels share: the geometry space
//! (grid mesh records, their top-level nodes, blocks and loose triangles, the instances' CWBVH
//! nodes and exact child boxes, instances), the ray and hit records
//! of the trace kernel, the render block of the path tracer (header, materials, lights,
//! distributions, environment, transforms), the pixel accumulators, the kind and status codes,
//! and the uniform block [`Params`].
//!
//! The host's packing code indexes with these constants, and [`prelude`] writes them as WGSL
//! `const` declarations (and `struct Params`) that [`module_source`] puts in front of every
//! kernel when its pipeline is created. The kernels (`kernels/*.wgsl`) therefore hold no layout
//! number of their own; a test checks that every upper-case name they use is either declared
//! by the prelude or by themselves, and that every module validates (with naga, no device).
//!
//! The prelude is generated at run time rather than by a build script: a build script cannot
//! see the crate's constants (it would need a second copy, or an `include!`d file that is
//! neither Rust module nor kernel), while formatting a few hundred bytes when a pipeline is
//! compiled costs nothing next to the compilation itself.
//!
//! Offsets are in 32-bit words; `*_WORDS` are record sizes. A field of three words holds an
//! `x, y, z` triple.

use obvhs::cwbvh::node::CwBvhNode;

/// Declares `pub const` items and the table [`CONSTANTS`] the prelude is written from.
macro_rules! shared_consts {
    ($( $(#[doc = $doc:literal])+ $name:ident: $ty:ident = $value:expr; )*) => {
        $( $(#[doc = $doc])+ pub const $name: $ty = $value; )*
        /// Every shared integer constant: name and value, in declaration order.
        pub const CONSTANTS: &[(&str, u64)] = &[$((stringify!($name), $name as u64)),*];
    };
}

shared_consts! {
    // ---- Dispatch.
    /// Invocations per workgroup of every kernel.
    WORKGROUP: u32 = 64;
    /// Storage bindings the geometry words may be split into (bindings 1 to 8).
    GEO_CHUNKS: usize = 8;
    /// Entries of the stack of the walk over instances (one per level of their CWBVH): the host
    /// refuses a scene whose top level is deeper, and a ray whose traversal would still need
    /// more reports [`STATUS_OVERFLOW`] (the host turns that into an error) rather than
    /// skipping subtrees.
    TRAVERSAL_STACK: u32 = 32;

    /// The most entries the stack of a mesh's grid top level ([`crate::grid::top`]) may have.
    /// Kernels are compiled for each scene with `GRID_STACK` (declared by [`module_source`])
    /// set to the most any of its meshes' walks can hold ([`crate::grid::top::Top::stack`],
    /// the exact worst case over all rays, computed from the tree); the host refuses a mesh
    /// that needs more than this, never a silently truncated walk.
    GRID_STACK_MAX: u32 = 512;

    // ---- Mesh record (one per mesh, at `Params::mesh_off`): a grid mesh
    // ([`crate::grid::GridMesh`]).
    /// Words per mesh record.
    MESH_WORDS: usize = 8;
    /// Mesh record: word offset of the top-level nodes (`TOP_WORDS` each).
    MESH_TOP_OFF: usize = 0;
    /// Mesh record: the top level's root reference (`TOP_LEAF` set: a primitive; `TOP_EMPTY`:
    /// an empty mesh).
    MESH_ROOT: usize = 1;
    /// Mesh record: word offset of the block records (`BLK_WORDS` each).
    MESH_BLOCK_OFF: usize = 2;
    /// Mesh record: number of blocks (primitives below it are blocks, the rest strips of loose
    /// triangles).
    MESH_NBLOCKS: usize = 3;
    /// Mesh record: word offset of the loose triangles (`LOOSE_WORDS` each).
    MESH_LOOSE_OFF: usize = 4;
    /// Mesh record: word offset of the strips (`STRIP_WORDS` each: first loose triangle,
    /// count), the top level's primitives from `MESH_NBLOCKS` on.
    MESH_STRIP_OFF: usize = 5;
    /// Words per strip.
    STRIP_WORDS: usize = 2;

    // ---- Four boxes (`Box4`): lo[axis][child], then hi[axis][child].
    /// Words of a `Box4`.
    BOX4_WORDS: usize = 24;
    /// Offset of the upper corners in a `Box4`.
    BOX4_HI: usize = 12;

    // ---- Grid top-level node (`Node8`): a `Box8` (the layout of `WideBoxes`, `BOX_WORDS`
    // words), then eight child references.
    /// Children per top-level node.
    TOP_WIDTH: u32 = crate::grid::top::WIDTH as u32;
    /// Words per top-level node.
    TOP_WORDS: usize = 56;
    /// Node: first child reference (after the boxes).
    TOP_CHILD: usize = 48;
    /// A child reference to a primitive (block or loose triangle).
    TOP_LEAF: u32 = crate::grid::top::LEAF;
    /// An absent child.
    TOP_EMPTY: u32 = crate::grid::top::EMPTY;

    // ---- Grid block record.
    /// Words per block record.
    BLK_WORDS: usize = 32;
    /// Block: its root `Box4` (words 0..24).
    BLK_ROOT: usize = 0;
    /// Block: word offset of its coordinates (row by row: the row's x, then y, then z).
    BLK_VERT: usize = 24;
    /// Block: word offset of its four quadrant `Box4`s (blocks of more than 4×4 quads).
    BLK_BOXES: usize = 25;
    /// Block: quads across (low byte) and up (second byte).
    BLK_DIMS: usize = 26;
    /// Block: the diced-mesh id of its first triangle.
    BLK_TRI0: usize = 27;
    /// Block: id step from one quad row to the next.
    BLK_TRI_STRIDE: usize = 28;
    /// Block: index of its first vertex's normal (render block, `MX_NORMALS`).
    BLK_NORMAL: usize = 29;
    /// Quads per block side (`BLOCK`).
    GRID_BLOCK: u32 = crate::grid::block::BLOCK as u32;
    /// A hit location on a loose triangle (`Hit::leaf`, [`crate::grid::LEAF_LOOSE`]).
    LEAF_LOOSE: u32 = crate::grid::LEAF_LOOSE;

    // ---- Loose triangle record.
    /// Words per loose triangle: three corners, then its diced-mesh id.
    LOOSE_WORDS: usize = 10;
    /// Loose triangle: its id.
    LOOSE_ID: usize = 9;

    // ---- CWBVH node of the scene's top level over instances (obvhs's 80-byte `CwBvhNode`,
    // uploaded as it is).
    /// Words per node.
    NODE_WORDS: usize = 20;
    /// Node word whose top byte is `imask` (which children are inner nodes).
    NODE_IMASK: usize = 3;
    /// Node word `child_base_idx`.
    NODE_CHILD_BASE: usize = 4;
    /// Node word `primitive_base_idx`.
    NODE_PRIM_BASE: usize = 5;
    /// First of the two node words of `child_meta` (children 0–3, then 4–7).
    NODE_META: usize = 6;
    /// Children per node.
    NODE_CHILDREN: usize = 8;

    // ---- Exact child boxes of a node (`WideBoxes`): lo[axis][child], then hi[axis][child].
    /// Words per node of exact child boxes.
    BOX_WORDS: usize = 48;
    /// Offset of the upper corners (`hi`) in a box record.
    BOX_HI: usize = 24;

    // ---- Triangles and instances.
    /// Words per triangle of three corners (mesh lights).
    TRI_WORDS: usize = 9;
    /// Words per instance record.
    INSTANCE_WORDS: usize = 16;
    /// Instance record: the mesh.
    INST_MESH: usize = 0;
    /// Instance record: world-to-object x, y, z axes and translation (12 words, glam's
    /// `Affine3A` columns).
    INST_XFORM: usize = 4;

    // ---- Rays in and hits out (trace kernel), primary hits (path kernels).
    /// Words per ray: origin, tmin, direction, tmax.
    RAY_WORDS: usize = 8;
    /// Ray: tmin.
    RAY_TMIN: usize = 3;
    /// Ray: direction.
    RAY_DIR: usize = 4;
    /// Ray: tmax.
    RAY_TMAX: usize = 7;
    /// Words per hit record (trace results and primary hits of the renderer).
    HIT_WORDS: usize = 8;
    /// Hit: status (`STATUS_*`).
    HIT_STATUS: usize = 0;
    /// Hit: instance.
    HIT_INSTANCE: usize = 1;
    /// Hit: the triangle's location in its mesh ([`crate::bvh::Hit::leaf`]).
    HIT_LEAF: usize = 2;
    /// Hit: t (f32 bits).
    HIT_T: usize = 3;
    /// Hit: barycentric weight of corner 1 (f32 bits).
    HIT_B1: usize = 4;
    /// Hit: barycentric weight of corner 2 (f32 bits).
    HIT_B2: usize = 5;
    /// Hit: traversal loop iterations (trace kernel only).
    HIT_ITERS: usize = 6;
    /// Status: no hit.
    STATUS_MISS: u32 = 0;
    /// Status: a mesh hit.
    STATUS_HIT: u32 = 1;
    /// Status: the iteration bound or the traversal stack was exceeded.
    STATUS_OVERFLOW: u32 = 2;
    /// Status (primary hits only): a quad light is in front of any mesh.
    STATUS_QUAD_LIGHT: u32 = 3;

    // ---- Pixel accumulators (f32) of the path kernel.
    /// Floats per pixel accumulator.
    ACC_WORDS: usize = 12;
    /// Accumulator: sum of rgb.
    ACC_RGB: usize = 0;
    /// Accumulator: sum of alpha.
    ACC_ALPHA: usize = 3;
    /// Accumulator: sum of first-hit normals.
    ACC_NORMAL: usize = 4;
    /// Accumulator: sum of first-hit albedos.
    ACC_ALBEDO: usize = 7;
    /// Accumulator: 1 when a path exceeded the traversal bound.
    ACC_OVERFLOW: usize = 10;

    // ---- Render block header (at `Params::user1`); offsets are absolute words.
    /// Words of the render block header.
    HEADER_WORDS: usize = 40;
    /// Header: image width.
    H_WIDTH: usize = 0;
    /// Header: image height.
    H_HEIGHT: usize = 1;
    /// Header: samples per pixel.
    H_SPP: usize = 2;
    /// Header: maximum path depth.
    H_MAX_DEPTH: usize = 3;
    /// Header: RNG seed.
    H_SEED: usize = 4;
    /// Header: offset of the materials (`MAT_WORDS` each).
    H_MAT: usize = 5;
    /// Header: offset of the material index of each instance.
    H_INST_MAT: usize = 6;
    /// Header: number of quad lights.
    H_NQUADS: usize = 7;
    /// Header: offset of the quad lights (`QUAD_WORDS` each).
    H_QUADS: usize = 8;
    /// Header: number of mesh lights.
    H_NMESHL: usize = 9;
    /// Header: offset of the mesh lights (`MESHL_WORDS` each).
    H_MESHL: usize = 10;
    /// Header: offset of the mesh light of each instance (`NONE` if not emissive).
    H_INST_LIGHT: usize = 11;
    /// Header: environment kind (`ENV_*`).
    H_ENV_KIND: usize = 12;
    /// Header: offset of the environment record (rgb, or an `ENV_MAP_WORDS` record).
    H_ENV: usize = 13;
    /// Header: offset of the light-selection distribution.
    H_SELECT: usize = 14;
    /// Header: offset of the instance transforms (`XF_WORDS` each).
    H_INST_XF: usize = 15;
    /// Header: offset of the per-mesh records (`MESH_EXTRA_WORDS` each).
    H_MESH_EXTRA: usize = 16;
    /// Header: the camera (`CAM_*`, 15 words), in the header itself.
    H_CAMERA: usize = 20;
    /// Camera: position.
    CAM_POSITION: usize = 0;
    /// Camera: forward.
    CAM_FORWARD: usize = 3;
    /// Camera: right.
    CAM_RIGHT: usize = 6;
    /// Camera: up.
    CAM_UP: usize = 9;
    /// Camera: tan(fov / 2).
    CAM_TAN_HALF_FOV: usize = 12;
    /// Camera: aperture radius.
    CAM_APERTURE: usize = 13;
    /// Camera: focus distance.
    CAM_FOCUS_DISTANCE: usize = 14;
    /// Camera: words.
    CAM_WORDS: usize = 15;
    /// "No such record" (an instance without a mesh light).
    NONE: u32 = u32::MAX;

    // ---- Materials.
    /// Words per material.
    MAT_WORDS: usize = 12;
    /// Material: kind (`M_*`).
    MAT_KIND: usize = 0;
    /// Material: albedo, eta, f0 or radiance (rgb), or the IOR (one word).
    MAT_COLOR: usize = 1;
    /// Material: conductor k (rgb).
    MAT_K: usize = 4;
    /// Material: GGX α.
    MAT_ALPHA: usize = 7;
    /// Material: offset of its albedo map's texture record (`TEX_*`), or `NONE`.
    MAT_ALBEDO_MAP: usize = 8;
    /// Material: offset of its roughness map's texture record, or `NONE`.
    MAT_ROUGHNESS_MAP: usize = 9;
    /// Material: offset of its emission map's texture record, or `NONE`.
    MAT_EMISSION_MAP: usize = 10;
    /// Kind: diffuse.
    M_DIFFUSE: u32 = 0;
    /// Kind: conductor with a complex IOR.
    M_CONDUCTOR: u32 = 1;
    /// Kind: conductor with Schlick's Fresnel.
    M_SCHLICK: u32 = 2;
    /// Kind: dielectric.
    M_DIELECTRIC: u32 = 3;
    /// Kind: emissive.
    M_EMISSIVE: u32 = 4;

    // ---- Textures (`src/gpu/texture.rs`): a head, then one level record per pyramid level.
    /// Texture: kind (`TEX_NOISE` or `TEX_IMAGE`).
    TEX_KIND: usize = 0;
    /// Texture: noise frequency (`f32`).
    TEX_FREQUENCY: usize = 1;
    /// Texture: number of pyramid levels (images).
    TEX_LEVELS: usize = 2;
    /// Texture: first level record (`LVL_WORDS` each, level 0 first).
    TEX_LEVEL0: usize = 3;
    /// Kind: procedural noise of the object-space point.
    TEX_NOISE: u32 = 0;
    /// Kind: a mip pyramid of linear RGB `f32` texels.
    TEX_IMAGE: u32 = 1;
    /// Words per level record.
    LVL_WORDS: usize = 3;
    /// Level: width in texels.
    LVL_WIDTH: usize = 0;
    /// Level: height in texels.
    LVL_HEIGHT: usize = 1;
    /// Level: offset of its texels (rgb, row by row from the top).
    LVL_TEXELS: usize = 2;

    // ---- Lights.
    /// Words per quad light.
    QUAD_WORDS: usize = 16;
    /// Quad: corner.
    QUAD_CORNER: usize = 0;
    /// Quad: first edge.
    QUAD_EDGE1: usize = 3;
    /// Quad: second edge.
    QUAD_EDGE2: usize = 6;
    /// Quad: normal.
    QUAD_NORMAL: usize = 9;
    /// Quad: area.
    QUAD_AREA: usize = 12;
    /// Quad: radiance.
    QUAD_RADIANCE: usize = 13;
    /// Words per mesh light.
    MESHL_WORDS: usize = 8;
    /// Mesh light: instance.
    MESHL_INSTANCE: usize = 0;
    /// Mesh light: area.
    MESHL_AREA: usize = 1;
    /// Mesh light: radiance.
    MESHL_RADIANCE: usize = 2;
    /// Mesh light: triangle count.
    MESHL_TRI_COUNT: usize = 5;
    /// Mesh light: offset of its world-space triangles (`TRI_WORDS` each).
    MESHL_TRIS: usize = 6;
    /// Mesh light: offset of its area distribution.
    MESHL_DIST: usize = 7;

    // ---- Distributions: 1D is n, total, cdf[n + 1], pmf[n]; 2D is width, height, rows
    // (offset), then one column distribution offset per row.
    /// 1D: number of cells.
    DIST_N: usize = 0;
    /// 1D: total.
    DIST_TOTAL: usize = 1;
    /// 1D: first cdf entry (the pmf follows the n + 1 cdf entries).
    DIST_CDF: usize = 2;
    /// 2D: width.
    DIST2_WIDTH: usize = 0;
    /// 2D: height.
    DIST2_HEIGHT: usize = 1;
    /// 2D: offset of the row distribution.
    DIST2_ROWS: usize = 2;
    /// 2D: first column distribution offset.
    DIST2_COLS: usize = 3;

    // ---- Environment.
    /// Environment kind: none.
    ENV_NONE: u32 = 0;
    /// Environment kind: constant radiance (rgb at `H_ENV`).
    ENV_CONSTANT: u32 = 1;
    /// Environment kind: a lat-long map (`ENV_MAP_WORDS` record at `H_ENV`).
    ENV_MAP: u32 = 2;
    /// Words of an environment map record.
    ENV_MAP_WORDS: usize = 5;
    /// Map: width.
    ENV_WIDTH: usize = 0;
    /// Map: height.
    ENV_HEIGHT: usize = 1;
    /// Map: rotation about y (radians).
    ENV_ROTATE: usize = 2;
    /// Map: offset of the texels (rgb, row by row).
    ENV_TEXELS: usize = 3;
    /// Map: offset of the 2D distribution.
    ENV_DIST: usize = 4;

    // ---- Instance transforms and per-mesh records of the render block.
    /// Words per instance transform.
    XF_WORDS: usize = 24;
    /// Transform: object-to-world x, y, z axes (9 words).
    XF_MATRIX: usize = 0;
    /// Transform: object-to-world translation.
    XF_TRANSLATION: usize = 9;
    /// Transform: the normal matrix's x, y, z axes (9 words).
    XF_NORMAL: usize = 12;
    /// Words per per-mesh record.
    MESH_EXTRA_WORDS: usize = 4;
    /// Per-mesh record: offset of the unit normals of its blocks' vertices (3 words each, in
    /// the order of the grid mesh's octahedral normals, decoded).
    MX_NORMALS: usize = 0;
    /// Per-mesh record: offset of the corner normals of its loose triangles (`TRI_WORDS`
    /// each).
    MX_LOOSE_NORMALS: usize = 1;
    /// Per-mesh record: offset of the texture coordinates of its blocks' vertices (2 words
    /// each, in the normals' order), or `NONE` when no map reads them.
    MX_ST: usize = 2;
    /// Per-mesh record: offset of the corner texture coordinates of its loose triangles (6
    /// words each), or `NONE`.
    MX_LOOSE_ST: usize = 3;

    // ---- Sample dimensions of the counter-based RNG (the CPU renderer's).
    /// Pixel jitter in x.
    D_PIXEL_X: u32 = crate::render::rng::dims::PIXEL_X;
    /// Pixel jitter in y.
    D_PIXEL_Y: u32 = crate::render::rng::dims::PIXEL_Y;
    /// Lens u.
    D_LENS_U: u32 = crate::render::rng::dims::LENS_U;
    /// Lens v.
    D_LENS_V: u32 = crate::render::rng::dims::LENS_V;
    /// First per-bounce dimension.
    D_BOUNCE_BASE: u32 = crate::render::rng::dims::BOUNCE_BASE;
    /// Dimensions per bounce.
    D_PER_BOUNCE: u32 = crate::render::rng::dims::PER_BOUNCE;
    /// Per bounce: light selection.
    D_LIGHT_SELECT: u32 = crate::render::rng::dims::LIGHT_SELECT;
    /// Per bounce: light sample u.
    D_LIGHT_U: u32 = crate::render::rng::dims::LIGHT_U;
    /// Per bounce: light sample v.
    D_LIGHT_V: u32 = crate::render::rng::dims::LIGHT_V;
    /// Per bounce: BSDF lobe.
    D_BSDF_LOBE: u32 = crate::render::rng::dims::BSDF_LOBE;
    /// Per bounce: BSDF u.
    D_BSDF_U: u32 = crate::render::rng::dims::BSDF_U;
    /// Per bounce: BSDF v.
    D_BSDF_V: u32 = crate::render::rng::dims::BSDF_V;
    /// Per bounce: Russian roulette.
    D_RR: u32 = crate::render::rng::dims::RR;
    /// First bounce that plays Russian roulette.
    RR_START: u32 = crate::render::integrator::RR_START;
}

/// Shared `f32` constants: name and value.
pub const F32_CONSTANTS: &[(&str, f32)] = &[
    ("PI", std::f32::consts::PI),
    ("DELTA_ALPHA", crate::render::material::DELTA_ALPHA),
    ("BOUNCE_SPREAD", crate::render::texturing::BOUNCE_SPREAD),
];

// The node words the kernels read are where obvhs keeps those fields.
const _: () = {
    use std::mem::{offset_of, size_of};
    assert!(size_of::<CwBvhNode>() == NODE_WORDS * 4);
    assert!(offset_of!(CwBvhNode, imask) == NODE_IMASK * 4 + 3);
    assert!(offset_of!(CwBvhNode, child_base_idx) == NODE_CHILD_BASE * 4);
    assert!(offset_of!(CwBvhNode, primitive_base_idx) == NODE_PRIM_BASE * 4);
    assert!(offset_of!(CwBvhNode, child_meta) == NODE_META * 4);
    assert!(size_of::<crate::bvh::mesh::WideBoxes>() == BOX_WORDS * 4);
    assert!(BOX_HI == 3 * NODE_CHILDREN);
    assert!(size_of::<crate::grid::node::Box4>() == BOX4_WORDS * 4);
    assert!(offset_of!(crate::grid::node::Box4, hi) == BOX4_HI * 4);
    assert!(offset_of!(crate::bvh::mesh::WideBoxes, hi) == BOX_HI * 4);
    assert!(TOP_CHILD == BOX_WORDS);
    assert!(size_of::<crate::grid::top::Node8>() == TOP_WORDS * 4);
    assert!(offset_of!(crate::grid::top::Node8, child) == TOP_CHILD * 4);
    assert!(BLK_NORMAL < BLK_WORDS && LOOSE_ID < LOOSE_WORDS);
    assert!(CAM_WORDS <= HEADER_WORDS - H_CAMERA);
    assert!(H_MESH_EXTRA < H_CAMERA);
    assert!(ACC_OVERFLOW < ACC_WORDS && HIT_ITERS < HIT_WORDS && RAY_TMAX < RAY_WORDS);
    assert!(QUAD_RADIANCE + 3 <= QUAD_WORDS && MESHL_DIST < MESHL_WORDS);
    assert!(
        MAT_EMISSION_MAP < MAT_WORDS
            && MX_LOOSE_ST < MESH_EXTRA_WORDS
            && XF_NORMAL + 9 <= XF_WORDS
            && ENV_DIST < ENV_MAP_WORDS
    );
};

/// Declares the `#[repr(C)]` uniform block and its WGSL twin, field for field.
macro_rules! uniform_block {
    ($(#[doc = $sdoc:literal])+ $name:ident { $( $(#[doc = $doc:literal])+ $field:ident: $ty:ident, )* }) => {
        $(#[doc = $sdoc])+
        #[repr(C)]
        #[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
        pub struct $name {
            $( $(#[doc = $doc])+ pub $field: $ty, )*
        }
        /// The WGSL declaration of the uniform block.
        pub const PARAMS_WGSL: &str = concat!(
            "struct ", stringify!($name), " {\n",
            $( "    ", stringify!($field), ": ", stringify!($ty), ",\n", )*
            "}\n"
        );
    };
}

uniform_block! {
    /// The uniform block of every geometry kernel (binding 0, `P` in `kernels/bvh.wgsl`).
    Params {
        /// log2 of the words per geometry chunk.
        chunk_shift: u32,
        /// 0: one mesh (record 0, world space); 1: instances under a top level.
        mode: u32,
        /// Word offset of the mesh records.
        mesh_off: u32,
        /// Word offset of the top-level nodes.
        top_node_off: u32,
        /// Number of top-level nodes.
        top_node_count: u32,
        /// Word offset of the top-level leaf → instance table.
        top_index_off: u32,
        /// Word offset of the instance records.
        inst_off: u32,
        /// Word offset of the top-level nodes' exact child boxes.
        top_box_off: u32,
        /// Rays (or work items) in this dispatch.
        ray_count: u32,
        /// Traversal loop iterations allowed per ray (all levels together).
        max_iter: u32,
        /// `1 + 2γ(3)` of the box test, as the CPU computes it.
        box_scale: f32,
        /// Kernel-specific.
        user0: u32,
        /// Kernel-specific.
        user1: u32,
        /// Kernel-specific.
        user2: u32,
        /// Kernel-specific.
        user3: u32,
        /// Must be 0: the kernels' opaque zero (`nf` in `kernels/bvh.wgsl`).
        user4: u32,
    }
}

/// The WGSL type of a shared integer constant (`u32` in every kernel).
fn wgsl_u32(name: &str, value: u64) -> String {
    assert!(value <= u32::MAX as u64, "{name} does not fit a u32");
    format!("const {name}: u32 = {value}u;\n")
}

/// The WGSL declarations of every shared constant, of the scene's `GRID_STACK` (entries of a
/// mesh walk's stack, 1 to [`GRID_STACK_MAX`]) and of `struct Params`.
pub fn prelude(grid_stack: u32) -> String {
    let mut s = String::from("// Generated from src/gpu/layout.rs: the host's layouts.\n");
    for &(name, value) in CONSTANTS {
        s.push_str(&wgsl_u32(name, value));
    }
    s.push_str(&wgsl_u32(
        "GRID_STACK",
        grid_stack.clamp(1, GRID_STACK_MAX) as u64,
    ));
    for &(name, value) in F32_CONSTANTS {
        // `{:?}` is the shortest decimal that reads back as the same f32; the `f` suffix makes
        // the literal an f32 (rounded once, from the decimal).
        s.push_str(&format!("const {name}: f32 = {value:?}f;\n"));
    }
    s.push_str(PARAMS_WGSL);
    s
}

/// A kernel module: the prelude (for a scene whose mesh walks need `grid_stack` entries),
/// then `parts` in order.
pub fn module_source(parts: &[&str], grid_stack: u32) -> String {
    let mut s = prelude(grid_stack);
    for p in parts {
        s.push('\n');
        s.push_str(p);
    }
    s
}

/// The kernel files.
pub mod kernels {
    /// The exact edge function.
    pub const EXACT: &str = include_str!("../../kernels/exact.wgsl");
    /// Ray queries on the geometry space.
    pub const BVH: &str = include_str!("../../kernels/bvh.wgsl");
    /// Closest hits of a batch of rays.
    pub const TRACE: &str = include_str!("../../kernels/trace.wgsl");
    /// Sampling, RNG and environment of the path tracer.
    pub const SAMPLING: &str = include_str!("../../kernels/sampling.wgsl");
    /// Materials of the path tracer.
    pub const MATERIAL: &str = include_str!("../../kernels/material.wgsl");
    /// The path tracer.
    pub const PATH: &str = include_str!("../../kernels/path.wgsl");
    /// Test kernel of the exact edge function.
    pub const EXACT_TEST: &str = include_str!("../../kernels/exact_test.wgsl");

    /// The closest-hit module's parts, in order.
    pub const TRACE_MODULE: &[&str] = &[EXACT, BVH, TRACE];
    /// Texture maps of the path tracer.
    pub const TEXTURE: &str = include_str!("../../kernels/texture.wgsl");
    /// The path tracer's parts, in order.
    pub const PATH_MODULE: &[&str] = &[EXACT, BVH, SAMPLING, TEXTURE, MATERIAL, PATH];
    /// The edge-function test module's parts, in order.
    pub const EXACT_TEST_MODULE: &[&str] = &[EXACT, EXACT_TEST];

    /// Every module the backend compiles, by name.
    pub const MODULES: &[(&str, &[&str])] = &[
        ("trace", TRACE_MODULE),
        ("path", PATH_MODULE),
        ("exact_test", EXACT_TEST_MODULE),
    ];
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    /// Identifiers of `src`, comments removed.
    fn identifiers(src: &str) -> Vec<String> {
        let mut out = Vec::new();
        for line in src.lines() {
            let code = line.split("//").next().unwrap_or("");
            let mut cur = String::new();
            for ch in code.chars().chain(std::iter::once(' ')) {
                if ch.is_ascii_alphanumeric() || ch == '_' {
                    cur.push(ch);
                } else if !cur.is_empty() {
                    out.push(std::mem::take(&mut cur));
                }
            }
        }
        out
    }

    /// Upper-case names (constants by the kernels' convention), digits-first tokens excluded.
    fn is_const_name(s: &str) -> bool {
        s.len() > 1
            && s.starts_with(|c: char| c.is_ascii_uppercase())
            && s.chars()
                .all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_')
    }

    /// Names a kernel declares itself (`const`, `override`, `struct`).
    fn declared(src: &str) -> BTreeSet<String> {
        let ids = identifiers(src);
        ids.windows(2)
            .filter(|w| matches!(w[0].as_str(), "const" | "override" | "struct"))
            .map(|w| w[1].clone())
            .collect()
    }

    #[test]
    fn the_prelude_defines_every_constant_the_kernels_use() {
        let prelude = prelude(GRID_STACK_MAX);
        let shared = declared(&prelude);
        for (module, parts) in kernels::MODULES {
            let own: BTreeSet<String> = parts.iter().flat_map(|p| declared(p)).collect();
            for name in &own {
                assert!(
                    !shared.contains(name),
                    "module {module} declares {name}, which the prelude declares"
                );
            }
            for p in *parts {
                for id in identifiers(p) {
                    if is_const_name(&id) {
                        assert!(
                            shared.contains(&id) || own.contains(&id),
                            "module {module} uses {id}, which neither the prelude nor the \
                             module declares"
                        );
                    }
                }
            }
        }
        // Every shared constant is declared exactly once.
        let names: Vec<&str> = CONSTANTS
            .iter()
            .map(|c| c.0)
            .chain(F32_CONSTANTS.iter().map(|c| c.0))
            .collect();
        let unique: BTreeSet<&str> = names.iter().copied().collect();
        assert_eq!(
            unique.len(),
            names.len(),
            "a shared constant is declared twice"
        );
    }

    #[test]
    fn kernels_write_no_record_sizes_by_hand() {
        // The record sizes that used to be spelled out in the kernels (20u, 48u, 16u, 12u…)
        // must come from the prelude; a bare `N * index` product with one of them is a second
        // copy of a layout.
        for (module, parts) in kernels::MODULES {
            for p in *parts {
                for (i, line) in p.lines().enumerate() {
                    let code = line.split("//").next().unwrap_or("");
                    for size in [
                        NODE_WORDS,
                        BOX_WORDS,
                        INSTANCE_WORDS,
                        MAT_WORDS,
                        XF_WORDS,
                        TRI_WORDS,
                        MESH_WORDS,
                    ] {
                        let bare = format!("{size}u *");
                        assert!(
                            !code.contains(&bare),
                            "module {module}, line {}: `{bare}` (use the layout constant): {line}",
                            i + 1
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn every_module_validates() {
        for (module, parts) in kernels::MODULES {
            let src = module_source(parts, GRID_STACK_MAX);
            let parsed = naga::front::wgsl::parse_str(&src)
                .unwrap_or_else(|e| panic!("module {module}: {}", e.emit_to_string(&src)));
            naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::default(),
            )
            .validate(&parsed)
            .unwrap_or_else(|e| panic!("module {module}: {}", e.emit_to_string(&src)));
        }
    }

    #[test]
    fn the_prelude_writes_each_value_once_and_exactly() {
        let p = prelude(GRID_STACK_MAX);
        assert!(p.contains("const NODE_WORDS: u32 = 20u;\n"));
        assert!(p.contains("const NONE: u32 = 4294967295u;\n"));
        assert!(p.contains("const DELTA_ALPHA: f32 = 0.001f;\n"));
        for &(name, value) in F32_CONSTANTS {
            let line = p
                .lines()
                .find(|l| l.starts_with(&format!("const {name}: f32 = ")))
                .unwrap();
            let lit = line
                .trim_start_matches(&format!("const {name}: f32 = "))
                .trim_end_matches("f;");
            assert_eq!(lit.parse::<f32>().unwrap().to_bits(), value.to_bits());
        }
        assert!(PARAMS_WGSL.contains("    box_scale: f32,\n"));
        assert_eq!(std::mem::size_of::<Params>(), 16 * 4);
    }
}
