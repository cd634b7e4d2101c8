//! A small hand-written FFI to the part of Embree 4.4's C API that limitray uses.
//!
//! Written from Embree 4.4's documented API (`embree4/rtcore_*.h`); the `embreex` wheel that
//! `scripts/setup-embree.sh` unpacks carries the library but no headers. The crates
//! embree4-sys / embree4-rs are *not* used: they carry Embree 4.2 headers whose `RTCHit` lacks
//! `instPrimID[1]` (80-byte `RTCRayHit` instead of the 96 bytes of this 4.4 build, which has
//! `RTC_GEOMETRY_INSTANCE_ARRAY` on), so every hit would write 16 bytes past the struct.
//! Sizes and offsets are asserted at compile time below and again in `tests/embree.rs`, which
//! also checks that the library really writes `instPrimID[0]` and nothing beyond.
//!
//! C enums are passed as `u32` (they are `int`-sized in the C ABI and all values used are
//! non-negative).
#![allow(non_camel_case_types, non_snake_case, missing_docs)]

use std::ffi::{c_char, c_void};

/// Opaque device handle.
pub type RTCDevice = *mut c_void;
/// Opaque scene handle.
pub type RTCScene = *mut c_void;
/// Opaque geometry handle.
pub type RTCGeometry = *mut c_void;

/// `RTC_INVALID_GEOMETRY_ID`.
pub const RTC_INVALID_GEOMETRY_ID: u32 = u32::MAX;

// enum RTCError
pub const RTC_ERROR_NONE: u32 = 0;
pub const RTC_ERROR_UNKNOWN: u32 = 1;
pub const RTC_ERROR_INVALID_ARGUMENT: u32 = 2;
pub const RTC_ERROR_INVALID_OPERATION: u32 = 3;
pub const RTC_ERROR_OUT_OF_MEMORY: u32 = 4;
pub const RTC_ERROR_UNSUPPORTED_CPU: u32 = 5;
pub const RTC_ERROR_CANCELLED: u32 = 6;

// enum RTCDeviceProperty (subset)
pub const RTC_DEVICE_PROPERTY_VERSION: u32 = 0;
pub const RTC_DEVICE_PROPERTY_VERSION_MAJOR: u32 = 1;
pub const RTC_DEVICE_PROPERTY_VERSION_MINOR: u32 = 2;
pub const RTC_DEVICE_PROPERTY_VERSION_PATCH: u32 = 3;

// enum RTCGeometryType (subset)
pub const RTC_GEOMETRY_TYPE_TRIANGLE: u32 = 0;
pub const RTC_GEOMETRY_TYPE_QUAD: u32 = 1;
pub const RTC_GEOMETRY_TYPE_SUBDIVISION: u32 = 8;

// enum RTCBufferType
pub const RTC_BUFFER_TYPE_INDEX: u32 = 0;
pub const RTC_BUFFER_TYPE_VERTEX: u32 = 1;
pub const RTC_BUFFER_TYPE_VERTEX_ATTRIBUTE: u32 = 2;
pub const RTC_BUFFER_TYPE_FACE: u32 = 16;
pub const RTC_BUFFER_TYPE_LEVEL: u32 = 17;
pub const RTC_BUFFER_TYPE_EDGE_CREASE_INDEX: u32 = 18;
pub const RTC_BUFFER_TYPE_EDGE_CREASE_WEIGHT: u32 = 19;
pub const RTC_BUFFER_TYPE_VERTEX_CREASE_INDEX: u32 = 20;
pub const RTC_BUFFER_TYPE_VERTEX_CREASE_WEIGHT: u32 = 21;
pub const RTC_BUFFER_TYPE_HOLE: u32 = 22;

// enum RTCFormat (subset)
pub const RTC_FORMAT_UINT: u32 = 0x5001;
pub const RTC_FORMAT_UINT2: u32 = 0x5002;
pub const RTC_FORMAT_UINT3: u32 = 0x5003;
pub const RTC_FORMAT_UINT4: u32 = 0x5004;
pub const RTC_FORMAT_FLOAT: u32 = 0x9001;
pub const RTC_FORMAT_FLOAT2: u32 = 0x9002;
pub const RTC_FORMAT_FLOAT3: u32 = 0x9003;

// enum RTCSubdivisionMode
pub const RTC_SUBDIVISION_MODE_NO_BOUNDARY: u32 = 0;
pub const RTC_SUBDIVISION_MODE_SMOOTH_BOUNDARY: u32 = 1;
pub const RTC_SUBDIVISION_MODE_PIN_CORNERS: u32 = 2;
pub const RTC_SUBDIVISION_MODE_PIN_BOUNDARY: u32 = 3;
pub const RTC_SUBDIVISION_MODE_PIN_ALL: u32 = 4;

// enum RTCSceneFlags
pub const RTC_SCENE_FLAG_NONE: u32 = 0;
pub const RTC_SCENE_FLAG_DYNAMIC: u32 = 1 << 0;
pub const RTC_SCENE_FLAG_COMPACT: u32 = 1 << 1;
pub const RTC_SCENE_FLAG_ROBUST: u32 = 1 << 2;

// enum RTCBuildQuality
pub const RTC_BUILD_QUALITY_LOW: u32 = 0;
pub const RTC_BUILD_QUALITY_MEDIUM: u32 = 1;
pub const RTC_BUILD_QUALITY_HIGH: u32 = 2;

/// `struct RTCRay` (16-byte aligned, 48 bytes).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default)]
pub struct RTCRay {
    pub org_x: f32,
    pub org_y: f32,
    pub org_z: f32,
    pub tnear: f32,
    pub dir_x: f32,
    pub dir_y: f32,
    pub dir_z: f32,
    pub time: f32,
    pub tfar: f32,
    pub mask: u32,
    pub id: u32,
    pub flags: u32,
}

/// `struct RTCHit` of Embree 4.4 built with `RTC_MAX_INSTANCE_LEVEL_COUNT = 1` and
/// `RTC_GEOMETRY_INSTANCE_ARRAY` (16-byte aligned, 48 bytes: 36 used, 12 padding).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default)]
pub struct RTCHit {
    pub Ng_x: f32,
    pub Ng_y: f32,
    pub Ng_z: f32,
    pub u: f32,
    pub v: f32,
    pub primID: u32,
    pub geomID: u32,
    pub instID: [u32; 1],
    pub instPrimID: [u32; 1],
}

/// `struct RTCRayHit` (96 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct RTCRayHit {
    pub ray: RTCRay,
    pub hit: RTCHit,
}

/// `struct RTCBounds` (16-byte aligned, 32 bytes).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default)]
pub struct RTCBounds {
    pub lower_x: f32,
    pub lower_y: f32,
    pub lower_z: f32,
    pub align0: f32,
    pub upper_x: f32,
    pub upper_y: f32,
    pub upper_z: f32,
    pub align1: f32,
}

/// `struct RTCInterpolateArguments` (88 bytes on LP64).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct RTCInterpolateArguments {
    pub geometry: RTCGeometry,
    pub primID: u32,
    pub u: f32,
    pub v: f32,
    pub bufferType: u32,
    pub bufferSlot: u32,
    pub P: *mut f32,
    pub dPdu: *mut f32,
    pub dPdv: *mut f32,
    pub ddPdudu: *mut f32,
    pub ddPdvdv: *mut f32,
    pub ddPdudv: *mut f32,
    pub valueCount: u32,
}

/// `RTCMemoryMonitorFunction`: `bool (*)(void* userPtr, ssize_t bytes, bool post)`; return
/// `true` to let the allocation proceed.
pub type RTCMemoryMonitorFunction =
    Option<unsafe extern "C" fn(user: *mut c_void, bytes: isize, post: bool) -> bool>;

/// `RTCErrorFunction`: `void (*)(void* userPtr, enum RTCError code, const char* str)`.
pub type RTCErrorFunction =
    Option<unsafe extern "C" fn(user_ptr: *mut c_void, code: u32, message: *const c_char)>;

/// `struct RTCDisplacementFunctionNArguments`: `n` points of a subdivision face to displace in
/// place (`P` in, displaced `P` out), with their `(u, v)` and the limit surface's normal `Ng`
/// (not normalised).
#[repr(C)]
pub struct RTCDisplacementFunctionNArguments {
    /// The geometry's user data (`rtcSetGeometryUserData`).
    pub geometry_user_ptr: *mut c_void,
    /// The geometry.
    pub geometry: RTCGeometry,
    /// The face.
    pub prim_id: u32,
    /// Motion-blur time step.
    pub time_step: u32,
    /// `u` of each point.
    pub u: *const f32,
    /// `v` of each point.
    pub v: *const f32,
    /// Normal x of each point.
    pub ng_x: *const f32,
    /// Normal y of each point.
    pub ng_y: *const f32,
    /// Normal z of each point.
    pub ng_z: *const f32,
    /// Position x of each point (displaced in place).
    pub p_x: *mut f32,
    /// Position y of each point.
    pub p_y: *mut f32,
    /// Position z of each point.
    pub p_z: *mut f32,
    /// Number of points.
    pub n: u32,
}

/// `RTCDisplacementFunctionN`: `void (*)(const struct RTCDisplacementFunctionNArguments*)`.
pub type RTCDisplacementFunctionN =
    Option<unsafe extern "C" fn(args: *const RTCDisplacementFunctionNArguments)>;

/// Opaque `struct RTCIntersectArguments` / `RTCOccludedArguments`; limitray always passes
/// null (Embree's defaults).
#[repr(C)]
pub struct RTCIntersectArguments {
    _private: [u8; 0],
}

/// See [`RTCIntersectArguments`].
#[repr(C)]
pub struct RTCOccludedArguments {
    _private: [u8; 0],
}

// Compile-time layout checks against the 4.4 ABI (repeated as tests in tests/embree.rs).
const _: () = {
    assert!(std::mem::size_of::<RTCRay>() == 48);
    assert!(std::mem::size_of::<RTCHit>() == 48);
    assert!(std::mem::size_of::<RTCRayHit>() == 96);
    assert!(std::mem::align_of::<RTCRayHit>() == 16);
    assert!(std::mem::offset_of!(RTCRayHit, hit) == 48);
    assert!(std::mem::offset_of!(RTCHit, primID) == 20);
    assert!(std::mem::offset_of!(RTCHit, instPrimID) == 32);
    assert!(std::mem::size_of::<RTCBounds>() == 32);
    assert!(std::mem::size_of::<RTCInterpolateArguments>() == 88);
    assert!(std::mem::offset_of!(RTCInterpolateArguments, P) == 32);
    assert!(std::mem::offset_of!(RTCInterpolateArguments, valueCount) == 80);
    assert!(std::mem::offset_of!(RTCDisplacementFunctionNArguments, u) == 24);
    assert!(std::mem::offset_of!(RTCDisplacementFunctionNArguments, n) == 88);
};

extern "C" {
    pub fn rtcNewDevice(config: *const c_char) -> RTCDevice;
    pub fn rtcReleaseDevice(device: RTCDevice);
    pub fn rtcGetDeviceError(device: RTCDevice) -> u32;
    pub fn rtcGetDeviceLastErrorMessage(device: RTCDevice) -> *const c_char;
    pub fn rtcGetDeviceProperty(device: RTCDevice, prop: u32) -> isize;
    pub fn rtcSetDeviceErrorFunction(device: RTCDevice, f: RTCErrorFunction, user: *mut c_void);
    pub fn rtcSetDeviceMemoryMonitorFunction(
        device: RTCDevice,
        f: RTCMemoryMonitorFunction,
        user: *mut c_void,
    );

    pub fn rtcNewScene(device: RTCDevice) -> RTCScene;
    pub fn rtcReleaseScene(scene: RTCScene);
    pub fn rtcSetSceneFlags(scene: RTCScene, flags: u32);
    pub fn rtcSetSceneBuildQuality(scene: RTCScene, quality: u32);
    pub fn rtcAttachGeometry(scene: RTCScene, geometry: RTCGeometry) -> u32;
    pub fn rtcCommitScene(scene: RTCScene);
    pub fn rtcGetSceneBounds(scene: RTCScene, bounds: *mut RTCBounds);

    pub fn rtcNewGeometry(device: RTCDevice, kind: u32) -> RTCGeometry;
    pub fn rtcReleaseGeometry(geometry: RTCGeometry);
    pub fn rtcCommitGeometry(geometry: RTCGeometry);
    pub fn rtcSetNewGeometryBuffer(
        geometry: RTCGeometry,
        kind: u32,
        slot: u32,
        format: u32,
        byte_stride: usize,
        item_count: usize,
    ) -> *mut c_void;
    pub fn rtcSetGeometryTessellationRate(geometry: RTCGeometry, rate: f32);
    pub fn rtcSetGeometrySubdivisionMode(geometry: RTCGeometry, topology: u32, mode: u32);
    pub fn rtcSetGeometryBuildQuality(geometry: RTCGeometry, quality: u32);
    pub fn rtcSetGeometryUserData(geometry: RTCGeometry, user: *mut c_void);
    pub fn rtcSetGeometryDisplacementFunction(
        geometry: RTCGeometry,
        displacement: RTCDisplacementFunctionN,
    );

    pub fn rtcIntersect1(scene: RTCScene, rayhit: *mut RTCRayHit, args: *mut RTCIntersectArguments);
    pub fn rtcOccluded1(scene: RTCScene, ray: *mut RTCRay, args: *mut RTCOccludedArguments);
    pub fn rtcInterpolate(args: *const RTCInterpolateArguments);
}
