//! Embree 4 as an independent cross-check and benchmark peer (cargo feature `embree`).
//!
//! - [`ffi`]: the hand-written C API subset, with the 4.4 struct layout asserted;
//! - this module: safe wrappers — [`Device`], [`Geometry`], [`SceneBuilder`] → [`Scene`]
//!   (every handle is released on drop, every call is checked with `rtcGetDeviceError`);
//! - [`subdiv`]: a [`crate::mesh::ControlMesh`] as `RTC_GEOMETRY_TYPE_SUBDIVISION`;
//! - [`crosscheck`]: limit-surface and triangle/BVH agreement reports;
//! - `crate::cli::embree`: the `crosscheck` and `bench` subcommands.
//!
//! The library is set up by `scripts/setup-embree.sh` and linked by `build.rs`.

pub mod bench;
pub mod crosscheck;
pub mod ffi;
pub mod rays;
pub mod subdiv;
pub mod triangles;

use crate::error::{Error, ErrorKind, Result};
use std::ffi::{c_char, c_void, CStr, CString};
use std::sync::atomic::{AtomicI64, Ordering};
use std::sync::{Arc, Mutex};

struct DeviceInner {
    raw: ffi::RTCDevice,
    /// Messages from the error callback, drained by [`Device::check`].
    errors: Box<Mutex<Vec<String>>>,
    /// Bytes Embree holds, from its memory monitor callback.
    memory: Box<AtomicI64>,
}

// SAFETY: an Embree device is thread-safe (all API calls on it may come from any thread);
// the error list is behind a mutex.
unsafe impl Send for DeviceInner {}
unsafe impl Sync for DeviceInner {}

impl Drop for DeviceInner {
    fn drop(&mut self) {
        // SAFETY: `raw` came from rtcNewDevice and this is its last owner.
        unsafe { ffi::rtcReleaseDevice(self.raw) }
    }
}

unsafe extern "C" fn on_memory(user: *mut c_void, bytes: isize, _post: bool) -> bool {
    if !user.is_null() {
        // SAFETY: `user` is the device's counter, alive as long as the device.
        let counter = unsafe { &*(user as *const AtomicI64) };
        counter.fetch_add(bytes as i64, Ordering::Relaxed);
    }
    true
}

unsafe extern "C" fn on_error(user: *mut c_void, code: u32, message: *const c_char) {
    if user.is_null() {
        return;
    }
    // SAFETY: `user` is the `Mutex<Vec<String>>` owned by the device, alive as long as it is.
    let sink = unsafe { &*(user as *const Mutex<Vec<String>>) };
    let text = if message.is_null() {
        String::new()
    } else {
        // SAFETY: Embree passes a NUL-terminated string valid for the call.
        unsafe { CStr::from_ptr(message) }
            .to_string_lossy()
            .into_owned()
    };
    if let Ok(mut v) = sink.lock() {
        v.push(format!("{} ({text})", error_name(code)));
    }
}

fn error_name(code: u32) -> &'static str {
    match code {
        ffi::RTC_ERROR_NONE => "no error",
        ffi::RTC_ERROR_UNKNOWN => "unknown error",
        ffi::RTC_ERROR_INVALID_ARGUMENT => "invalid argument",
        ffi::RTC_ERROR_INVALID_OPERATION => "invalid operation",
        ffi::RTC_ERROR_OUT_OF_MEMORY => "out of memory",
        ffi::RTC_ERROR_UNSUPPORTED_CPU => "unsupported CPU",
        ffi::RTC_ERROR_CANCELLED => "cancelled",
        _ => "error",
    }
}

/// An Embree device (`RTCDevice`): owns the library's thread pool and memory.
/// Cheap to clone (reference counted); geometries and scenes keep their device alive.
#[derive(Clone)]
pub struct Device {
    inner: Arc<DeviceInner>,
}

impl Device {
    /// A device with Embree's configuration string, e.g. `""` or `"threads=2"`.
    pub fn new(config: &str) -> Result<Device> {
        let c = CString::new(config).map_err(|_| {
            Error::new(
                ErrorKind::Usage,
                "Embree device configuration contains a NUL byte",
            )
        })?;
        // SAFETY: a valid C string; a null result is handled.
        let raw = unsafe { ffi::rtcNewDevice(c.as_ptr()) };
        if raw.is_null() {
            // SAFETY: rtcGetDeviceError(NULL) returns the error of the failed device creation.
            let code = unsafe { ffi::rtcGetDeviceError(std::ptr::null_mut()) };
            return Err(Error::new(
                ErrorKind::Usage,
                format!(
                    "Embree: cannot create a device with configuration {config:?}: {}",
                    error_name(code)
                ),
            ));
        }
        let errors: Box<Mutex<Vec<String>>> = Box::default();
        let user = &*errors as *const Mutex<Vec<String>> as *mut c_void;
        // SAFETY: the callback and its user pointer live as long as the device.
        unsafe { ffi::rtcSetDeviceErrorFunction(raw, Some(on_error), user) };
        let memory: Box<AtomicI64> = Box::default();
        let counter = &*memory as *const AtomicI64 as *mut c_void;
        // SAFETY: as above; the counter is only touched atomically.
        unsafe { ffi::rtcSetDeviceMemoryMonitorFunction(raw, Some(on_memory), counter) };
        Ok(Device {
            inner: Arc::new(DeviceInner {
                raw,
                errors,
                memory,
            }),
        })
    }

    /// A device whose build threads are limited to `threads` (0: Embree's default, all cores).
    pub fn with_threads(threads: usize) -> Result<Device> {
        if threads == 0 {
            Device::new("")
        } else {
            Device::new(&format!("threads={threads}"))
        }
    }

    /// Bytes Embree's allocations hold now (its memory monitor's running sum: scenes, BVHs,
    /// geometry buffers and grids).
    pub fn memory_bytes(&self) -> i64 {
        self.inner.memory.load(Ordering::Relaxed)
    }

    /// The raw handle (valid while this device lives).
    pub fn raw(&self) -> ffi::RTCDevice {
        self.inner.raw
    }

    /// Embree's version as `major * 10000 + minor * 100 + patch` (e.g. 40400).
    pub fn version(&self) -> u32 {
        // SAFETY: valid device, documented property.
        unsafe {
            ffi::rtcGetDeviceProperty(self.inner.raw, ffi::RTC_DEVICE_PROPERTY_VERSION) as u32
        }
    }

    /// Turns the device's pending error (if any) into a [`crate::Error`] naming `what`.
    pub fn check(&self, what: &str) -> Result<()> {
        // SAFETY: valid device.
        let code = unsafe { ffi::rtcGetDeviceError(self.inner.raw) };
        let mut messages = self
            .inner
            .errors
            .lock()
            .map(|mut v| std::mem::take(&mut *v))
            .unwrap_or_default();
        if code == ffi::RTC_ERROR_NONE && messages.is_empty() {
            return Ok(());
        }
        if messages.is_empty() {
            messages.push(error_name(code).to_string());
        }
        Err(Error::new(
            ErrorKind::Usage,
            format!("Embree: {what}: {}", messages.join("; ")),
        ))
    }
}

/// A geometry being set up (`RTCGeometry`); attach it to a [`SceneBuilder`].
pub struct Geometry {
    device: Device,
    raw: ffi::RTCGeometry,
    /// What the geometry's user-data pointer points at (a displacement's parameters), kept
    /// as long as the geometry: scenes hold their geometries.
    user: Option<Box<[f64; 2]>>,
}

impl Drop for Geometry {
    fn drop(&mut self) {
        // SAFETY: `raw` came from rtcNewGeometry; scenes it is attached to hold their own reference.
        unsafe { ffi::rtcReleaseGeometry(self.raw) }
    }
}

impl Geometry {
    /// A new geometry of an `RTC_GEOMETRY_TYPE_*` kind.
    pub fn new(device: &Device, kind: u32) -> Result<Geometry> {
        // SAFETY: valid device.
        let raw = unsafe { ffi::rtcNewGeometry(device.raw(), kind) };
        device.check("rtcNewGeometry")?;
        if raw.is_null() {
            return Err(Error::new(
                ErrorKind::Usage,
                "Embree: rtcNewGeometry returned null",
            ));
        }
        Ok(Geometry {
            device: device.clone(),
            raw,
            user: None,
        })
    }

    /// Sets Embree's displacement callback `f` with `params` as the geometry's user data
    /// (owned by the geometry, so valid for every scene build that uses it).
    pub fn set_displacement(
        &mut self,
        params: Box<[f64; 2]>,
        f: unsafe extern "C" fn(*const ffi::RTCDisplacementFunctionNArguments),
    ) {
        let user = self.user.insert(params);
        // SAFETY: valid geometry; the pointer stays valid while `self.user` holds the box.
        unsafe {
            ffi::rtcSetGeometryUserData(self.raw, user.as_mut_ptr() as *mut std::ffi::c_void);
            ffi::rtcSetGeometryDisplacementFunction(self.raw, Some(f));
        }
    }

    /// The raw handle (valid while this geometry or a scene holding it lives).
    pub fn raw(&self) -> ffi::RTCGeometry {
        self.raw
    }

    /// Allocates an Embree-owned buffer of `data.len() / components` items and copies `data`
    /// in. `T` is `u32` or `f32`; `components` is the number of `T` per item (the format says
    /// the same to Embree). Empty data sets nothing.
    pub fn set_buffer<T: Copy>(
        &mut self,
        kind: u32,
        slot: u32,
        format: u32,
        components: usize,
        data: &[T],
    ) -> Result<()> {
        if data.is_empty() {
            return Ok(());
        }
        if components == 0 || !data.len().is_multiple_of(components) {
            return Err(Error::new(
                ErrorKind::Usage,
                "Embree buffer length is not a multiple of the item size",
            ));
        }
        let stride = components * std::mem::size_of::<T>();
        let count = data.len() / components;
        // SAFETY: valid geometry; Embree returns `stride * count` writable bytes (plus padding).
        let ptr =
            unsafe { ffi::rtcSetNewGeometryBuffer(self.raw, kind, slot, format, stride, count) };
        self.device.check("rtcSetNewGeometryBuffer")?;
        if ptr.is_null() {
            return Err(Error::new(
                ErrorKind::Usage,
                "Embree: rtcSetNewGeometryBuffer returned null",
            ));
        }
        // SAFETY: the destination holds `data.len()` items of `T` (alignment: Embree aligns
        // buffers to at least 16 bytes) and does not overlap `data`.
        unsafe { std::ptr::copy_nonoverlapping(data.as_ptr(), ptr as *mut T, data.len()) };
        Ok(())
    }

    /// Commits the geometry (after all buffers and parameters are set).
    pub fn commit(&mut self) -> Result<()> {
        // SAFETY: valid geometry.
        unsafe { ffi::rtcCommitGeometry(self.raw) };
        self.device.check("rtcCommitGeometry")
    }
}

/// Scene flags and build quality.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SceneOptions {
    /// `RTC_SCENE_FLAG_ROBUST`: avoid optimisations that reduce arithmetic accuracy.
    pub robust: bool,
    /// `RTC_BUILD_QUALITY_HIGH` instead of Embree's default medium quality.
    pub high_quality: bool,
}

/// A scene being assembled.
pub struct SceneBuilder {
    device: Device,
    raw: ffi::RTCScene,
    geometries: Vec<Geometry>,
}

impl Drop for SceneBuilder {
    fn drop(&mut self) {
        if !self.raw.is_null() {
            // SAFETY: `raw` came from rtcNewScene and was not handed to a `Scene`.
            unsafe { ffi::rtcReleaseScene(self.raw) }
        }
    }
}

impl SceneBuilder {
    /// An empty scene on `device`.
    pub fn new(device: &Device, options: SceneOptions) -> Result<SceneBuilder> {
        // SAFETY: valid device.
        let raw = unsafe { ffi::rtcNewScene(device.raw()) };
        device.check("rtcNewScene")?;
        if raw.is_null() {
            return Err(Error::new(
                ErrorKind::Usage,
                "Embree: rtcNewScene returned null",
            ));
        }
        let flags = if options.robust {
            ffi::RTC_SCENE_FLAG_ROBUST
        } else {
            ffi::RTC_SCENE_FLAG_NONE
        };
        let quality = if options.high_quality {
            ffi::RTC_BUILD_QUALITY_HIGH
        } else {
            ffi::RTC_BUILD_QUALITY_MEDIUM
        };
        // SAFETY: valid scene.
        unsafe {
            ffi::rtcSetSceneFlags(raw, flags);
            ffi::rtcSetSceneBuildQuality(raw, quality);
        }
        device.check("scene flags")?;
        Ok(SceneBuilder {
            device: device.clone(),
            raw,
            geometries: Vec::new(),
        })
    }

    /// Attaches a committed geometry; returns its geometry id (0, 1, … in attach order).
    pub fn attach(&mut self, geometry: Geometry) -> Result<u32> {
        // SAFETY: valid scene and geometry of the same device.
        let id = unsafe { ffi::rtcAttachGeometry(self.raw, geometry.raw) };
        self.device.check("rtcAttachGeometry")?;
        if id as usize != self.geometries.len() {
            return Err(Error::new(
                ErrorKind::Usage,
                format!(
                    "Embree: unexpected geometry id {id} (expected {})",
                    self.geometries.len()
                ),
            ));
        }
        self.geometries.push(geometry);
        Ok(id)
    }

    /// Builds the acceleration structure (`rtcCommitScene`; may tessellate subdivision
    /// geometry lazily at first use, as Embree does) and returns the read-only scene.
    pub fn commit(mut self) -> Result<Scene> {
        // SAFETY: valid scene.
        unsafe { ffi::rtcCommitScene(self.raw) };
        self.device.check("rtcCommitScene")?;
        let raw = std::mem::replace(&mut self.raw, std::ptr::null_mut());
        Ok(Scene {
            device: self.device.clone(),
            raw,
            geometries: std::mem::take(&mut self.geometries),
        })
    }
}

/// A committed, read-only scene: intersection queries from any number of threads.
pub struct Scene {
    device: Device,
    raw: ffi::RTCScene,
    geometries: Vec<Geometry>,
}

// SAFETY: Embree documents rtcIntersect1 / rtcOccluded1 / rtcInterpolate on a committed scene
// as thread-safe; the wrapper exposes no mutation after commit.
unsafe impl Send for Scene {}
unsafe impl Sync for Scene {}

impl Drop for Scene {
    fn drop(&mut self) {
        // SAFETY: `raw` came from rtcNewScene; geometries are released after it (their Drop).
        unsafe { ffi::rtcReleaseScene(self.raw) }
    }
}

/// A hit as Embree reports it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmbreeHit {
    /// Distance along the ray (in units of the direction's length).
    pub t: f32,
    /// Geometry id.
    pub geom_id: u32,
    /// Primitive id: triangle index, or base face index for subdivision geometry.
    pub prim_id: u32,
    /// Hit `u` (triangle barycentric of vertex 1, or the face parameter for subdivision).
    pub u: f32,
    /// Hit `v` (triangle barycentric of vertex 2, or the face parameter for subdivision).
    pub v: f32,
    /// Unnormalised geometric normal.
    pub ng: [f32; 3],
}

/// Limit position and first derivatives from `rtcInterpolate`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interpolated {
    /// Position.
    pub p: [f32; 3],
    /// ∂P/∂u.
    pub du: [f32; 3],
    /// ∂P/∂v.
    pub dv: [f32; 3],
}

impl Scene {
    /// The device.
    pub fn device(&self) -> &Device {
        &self.device
    }

    /// The attached geometries, by geometry id.
    pub fn geometries(&self) -> &[Geometry] {
        &self.geometries
    }

    /// Scene bounds `[min, max]`.
    pub fn bounds(&self) -> [[f32; 3]; 2] {
        let mut b = ffi::RTCBounds::default();
        // SAFETY: valid committed scene, valid out pointer.
        unsafe { ffi::rtcGetSceneBounds(self.raw, &mut b) };
        [
            [b.lower_x, b.lower_y, b.lower_z],
            [b.upper_x, b.upper_y, b.upper_z],
        ]
    }

    /// Closest hit of the ray `origin + t dir`, `t` in `[tnear, tfar]`.
    pub fn intersect(
        &self,
        origin: [f32; 3],
        dir: [f32; 3],
        tnear: f32,
        tfar: f32,
    ) -> Option<EmbreeHit> {
        let mut rh = ffi::RTCRayHit {
            ray: ray(origin, dir, tnear, tfar),
            hit: ffi::RTCHit {
                geomID: ffi::RTC_INVALID_GEOMETRY_ID,
                instID: [ffi::RTC_INVALID_GEOMETRY_ID],
                instPrimID: [ffi::RTC_INVALID_GEOMETRY_ID],
                ..Default::default()
            },
        };
        // SAFETY: committed scene; `rh` is a 96-byte, 16-aligned RTCRayHit of the 4.4 ABI.
        unsafe { ffi::rtcIntersect1(self.raw, &mut rh, std::ptr::null_mut()) };
        if rh.hit.geomID == ffi::RTC_INVALID_GEOMETRY_ID {
            return None;
        }
        Some(EmbreeHit {
            t: rh.ray.tfar,
            geom_id: rh.hit.geomID,
            prim_id: rh.hit.primID,
            u: rh.hit.u,
            v: rh.hit.v,
            ng: [rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z],
        })
    }

    /// The raw ray/hit record after `rtcIntersect1` (for ABI tests).
    pub fn intersect_raw(&self, rayhit: &mut ffi::RTCRayHit) {
        // SAFETY: committed scene; `rayhit` has the 4.4 layout.
        unsafe { ffi::rtcIntersect1(self.raw, rayhit, std::ptr::null_mut()) };
    }

    /// Whether anything is hit with `t` in `[tnear, tfar]`.
    pub fn occluded(&self, origin: [f32; 3], dir: [f32; 3], tnear: f32, tfar: f32) -> bool {
        let mut r = ray(origin, dir, tnear, tfar);
        // SAFETY: committed scene; `r` is a 48-byte RTCRay.
        unsafe { ffi::rtcOccluded1(self.raw, &mut r, std::ptr::null_mut()) };
        // Embree sets tfar to -inf on an occluded ray.
        r.tfar == f32::NEG_INFINITY
    }

    /// `rtcInterpolate` of the vertex positions (slot 0) of geometry `geom_id` at primitive
    /// `prim_id`, `(u, v)` in Embree's parameterisation of that primitive.
    pub fn interpolate(&self, geom_id: u32, prim_id: u32, u: f32, v: f32) -> Result<Interpolated> {
        let g = self.geometries.get(geom_id as usize).ok_or_else(|| {
            Error::new(
                ErrorKind::Usage,
                format!("Embree: no geometry {geom_id} in the scene"),
            )
        })?;
        let mut out = Interpolated {
            p: [0.0; 3],
            du: [0.0; 3],
            dv: [0.0; 3],
        };
        let args = ffi::RTCInterpolateArguments {
            geometry: g.raw,
            primID: prim_id,
            u,
            v,
            bufferType: ffi::RTC_BUFFER_TYPE_VERTEX,
            bufferSlot: 0,
            P: out.p.as_mut_ptr(),
            dPdu: out.du.as_mut_ptr(),
            dPdv: out.dv.as_mut_ptr(),
            ddPdudu: std::ptr::null_mut(),
            ddPdvdv: std::ptr::null_mut(),
            ddPdudv: std::ptr::null_mut(),
            valueCount: 3,
        };
        // SAFETY: valid committed geometry; output arrays hold `valueCount` floats each.
        unsafe { ffi::rtcInterpolate(&args) };
        self.device.check("rtcInterpolate")?;
        Ok(out)
    }
}

fn ray(origin: [f32; 3], dir: [f32; 3], tnear: f32, tfar: f32) -> ffi::RTCRay {
    ffi::RTCRay {
        org_x: origin[0],
        org_y: origin[1],
        org_z: origin[2],
        tnear,
        dir_x: dir[0],
        dir_y: dir[1],
        dir_z: dir[2],
        time: 0.0,
        tfar,
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}
