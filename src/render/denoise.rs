//! `--denoise`: Intel Open Image Denoise's `RT` filter on the finished image, with the
//! albedo and normal feature buffers ([`crate::film::aov`]).
//!
//! Only with the cargo feature `denoise`, which loads `libOpenImageDenoise` at run time
//! (`libloading`): the library is not a Debian package and the default build does not
//! need it. Where it is: `RDR_OIDN_LIB` (the file), else the system loader's search
//! for `libOpenImageDenoise.so.2`. The PyPI wheel `pyoidn` ships it
//! (`pip install pyoidn`; `…/site-packages/pyoidn/oidn/lib/libOpenImageDenoise.so.2`).

use crate::math::Vec3;

/// How to get the library, for error messages.
pub const HOW_TO_GET: &str =
    "pip install pyoidn (in a venv) ships it; point RDR_OIDN_LIB at …/site-packages/pyoidn/oidn/lib/libOpenImageDenoise.so.2";

/// Whether this build can denoise at all (the `denoise` feature).
pub const AVAILABLE: bool = cfg!(feature = "denoise");

/// Denoises `color` (linear RGB, `width`×`height`, rows top-down) with the albedo and
/// normal images of the same layout.
#[cfg(feature = "denoise")]
pub fn denoise(width: u32, height: u32, color: &[Vec3], albedo: &[Vec3], normal: &[Vec3]) -> Result<Vec<Vec3>, String> {
    oidn::run(width, height, color, albedo, normal)
}

/// Fails (with how to fix it) when [`denoise`] cannot work here: checked before a
/// render, not after it.
#[cfg(feature = "denoise")]
pub fn check() -> Result<(), String> {
    oidn::library().map(drop)
}

#[cfg(not(feature = "denoise"))]
pub fn check() -> Result<(), String> {
    denoise(0, 0, &[], &[], &[]).map(drop)
}

#[cfg(not(feature = "denoise"))]
pub fn denoise(_width: u32, _height: u32, _color: &[Vec3], _albedo: &[Vec3], _normal: &[Vec3]) -> Result<Vec<Vec3>, String> {
    Err("this rdr was built without the `denoise` feature (cargo build --release --features denoise)".into())
}

#[cfg(feature = "denoise")]
mod oidn {
    use super::{Vec3, HOW_TO_GET};
    use libloading::{Library, Symbol};
    use std::ffi::{c_char, c_void, CStr, CString};

    type Handle = *mut c_void;
    const DEVICE_TYPE_CPU: i32 = 1;
    const FORMAT_FLOAT3: i32 = 3;
    const ERROR_NONE: i32 = 0;

    pub fn library() -> Result<Library, String> {
        let name = std::env::var_os("RDR_OIDN_LIB").unwrap_or_else(|| "libOpenImageDenoise.so.2".into());
        // SAFETY: loading runs the library's initialisers; libOpenImageDenoise's only
        // register its devices. The path is the user's choice (RDR_OIDN_LIB).
        unsafe { Library::new(&name) }.map_err(|e| {
            format!(
                "cannot load Intel Open Image Denoise ({}): {e}; {HOW_TO_GET}",
                name.to_string_lossy()
            )
        })
    }

    /// f32 triples of a Vec3 image, the layout OIDN's FLOAT3 images have.
    fn flat(img: &[Vec3]) -> Vec<f32> {
        img.iter().flat_map(|v| [v.x, v.y, v.z]).collect()
    }

    pub fn run(width: u32, height: u32, color: &[Vec3], albedo: &[Vec3], normal: &[Vec3]) -> Result<Vec<Vec3>, String> {
        let n = width as usize * height as usize;
        if color.len() != n || albedo.len() != n || normal.len() != n {
            return Err(format!(
                "images of {} / {} / {} pixels for a {width}x{height} film",
                color.len(),
                albedo.len(),
                normal.len()
            ));
        }
        let lib = library()?;
        let (mut color, mut albedo, mut normal) = (flat(color), flat(albedo), flat(normal));
        let mut output = vec![0f32; 3 * n];
        // SAFETY: the symbols are looked up with the signatures of OIDN 2's C API
        // (oidn.h); a library of another major version would not be named
        // libOpenImageDenoise.so.2. Every image is a live Vec of exactly
        // width·height·3 f32s (checked above), shared with the filter only until
        // `oidnExecuteFilter` returns (the filter is released before they are dropped);
        // pixel and row strides 0 mean "packed", which they are. The C strings live to
        // the end of the block. Handles are checked for null before use and released once.
        unsafe {
            let sym = |name: &[u8]| -> Result<*mut c_void, String> {
                let s: Symbol<*mut c_void> = lib.get(name).map_err(|e| {
                    format!(
                        "{}: {e} (not Open Image Denoise 2?)",
                        String::from_utf8_lossy(&name[..name.len() - 1])
                    )
                })?;
                Ok(*s)
            };
            let new_device: extern "C" fn(i32) -> Handle = std::mem::transmute(sym(b"oidnNewDevice\0")?);
            let commit_device: extern "C" fn(Handle) = std::mem::transmute(sym(b"oidnCommitDevice\0")?);
            let device_error: extern "C" fn(Handle, *mut *const c_char) -> i32 = std::mem::transmute(sym(b"oidnGetDeviceError\0")?);
            let release_device: extern "C" fn(Handle) = std::mem::transmute(sym(b"oidnReleaseDevice\0")?);
            let new_filter: extern "C" fn(Handle, *const c_char) -> Handle = std::mem::transmute(sym(b"oidnNewFilter\0")?);
            let set_image: extern "C" fn(Handle, *const c_char, *mut c_void, i32, usize, usize, usize, usize, usize) =
                std::mem::transmute(sym(b"oidnSetSharedFilterImage\0")?);
            let set_bool: extern "C" fn(Handle, *const c_char, bool) = std::mem::transmute(sym(b"oidnSetFilterBool\0")?);
            let commit_filter: extern "C" fn(Handle) = std::mem::transmute(sym(b"oidnCommitFilter\0")?);
            let execute: extern "C" fn(Handle) = std::mem::transmute(sym(b"oidnExecuteFilter\0")?);
            let release_filter: extern "C" fn(Handle) = std::mem::transmute(sym(b"oidnReleaseFilter\0")?);

            let error_of = |device: Handle| -> Option<String> {
                let mut msg: *const c_char = std::ptr::null();
                let code = device_error(device, &mut msg);
                (code != ERROR_NONE).then(|| {
                    let text = if msg.is_null() {
                        String::new()
                    } else {
                        CStr::from_ptr(msg).to_string_lossy().into_owned()
                    };
                    format!("Open Image Denoise error {code}: {text}")
                })
            };
            let device = new_device(DEVICE_TYPE_CPU);
            if device.is_null() {
                return Err("Open Image Denoise: no CPU device".into());
            }
            commit_device(device);
            if let Some(e) = error_of(device) {
                release_device(device);
                return Err(e);
            }
            let rt = CString::new("RT").expect("no NUL");
            let filter = new_filter(device, rt.as_ptr());
            if filter.is_null() {
                let e = error_of(device).unwrap_or_else(|| "Open Image Denoise: no RT filter".into());
                release_device(device);
                return Err(e);
            }
            let (w, h) = (width as usize, height as usize);
            for (name, buf) in [
                ("color", color.as_mut_ptr()),
                ("albedo", albedo.as_mut_ptr()),
                ("normal", normal.as_mut_ptr()),
                ("output", output.as_mut_ptr()),
            ] {
                let name = CString::new(name).expect("no NUL");
                set_image(filter, name.as_ptr(), buf.cast(), FORMAT_FLOAT3, w, h, 0, 0, 0);
            }
            let hdr = CString::new("hdr").expect("no NUL");
            set_bool(filter, hdr.as_ptr(), true);
            commit_filter(filter);
            execute(filter);
            let failed = error_of(device);
            release_filter(filter);
            release_device(device);
            if let Some(e) = failed {
                return Err(e);
            }
        }
        Ok(output.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect())
    }
}
