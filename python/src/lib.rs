//! `rdr._rdr`: the native half of the `rdr` Python package (the Python half, `rdr/`,
//! gives it Mitsuba's spelling). Scenes load and render through the library exactly
//! as `rdr render` does (`rdr::render::session`), so an image is bit for bit the CLI's.

use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray3, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyBytes, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use rdr::desc::xml::dict::DictValue;
use rdr::desc::SceneDesc;
use rdr::film::aov::AovSet;
use rdr::math::Vec3;
use rdr::render::params::ParamValue;
use rdr::render::session::{self, Caller, RenderOptions};
use rdr::render::{FilmState, RenderControl, RenderJob};
use rdr::{Loaded, Profile};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

pyo3::create_exception!(
    _rdr,
    Error,
    PyRuntimeError,
    "A scene, image or render option rdr refuses; the message is the command line's one line (file, key, line and column)."
);

/// What the command line would print after `error: `.
fn error(e: impl std::fmt::Display) -> PyErr {
    Error::new_err(rdr::limits::sanitize(&e.to_string()).replace('\n', " "))
}

/// An `anyhow` error with its causes, joined as the command line joins them.
fn chain(e: anyhow::Error) -> PyErr {
    let parts: Vec<String> = e.chain().map(|c| c.to_string()).collect();
    error(parts.join(": "))
}

/// A loaded scene: its description (what `traverse` edits), the built world and the job.
#[pyclass(module = "rdr._rdr", name = "Scene")]
struct Scene {
    desc: SceneDesc,
    loaded: Loaded,
    profile: Profile,
}

#[pymethods]
impl Scene {
    /// The warnings of loading it (the lines `rdr render` prints with `warning: `).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.loaded.scene.warnings.iter().map(|w| rdr::limits::sanitize(w)).collect()
    }

    /// (width, height) of the film.
    #[getter]
    fn size(&self) -> (u32, u32) {
        (self.loaded.job.film.width, self.loaded.job.film.height)
    }

    /// Samples per pixel the scene asks for.
    #[getter]
    fn spp(&self) -> u32 {
        self.loaded.job.spp
    }

    /// The integrator's name.
    #[getter]
    fn integrator(&self) -> &'static str {
        self.loaded.job.integrator.name()
    }

    fn __repr__(&self) -> String {
        let j = &self.loaded.job;
        format!(
            "Scene('{}', {}x{}, {} spp, {}, {} objects, {} lights)",
            self.desc.file.display(),
            j.film.width,
            j.film.height,
            j.spp,
            j.integrator.name(),
            self.loaded.scene.objects.len(),
            self.loaded.scene.lights.len()
        )
    }
}

fn build(desc: SceneDesc) -> PyResult<Scene> {
    let profile = Profile::Physical;
    let loaded = Loaded::build(&desc, profile).map_err(error)?;
    Ok(Scene { desc, loaded, profile })
}

/// `rdr render SCENE --override ... -D name=value` without the render.
#[pyfunction]
fn load_file(py: Python<'_>, path: PathBuf, overrides: Vec<String>, defines: Vec<(String, String)>) -> PyResult<Scene> {
    py.detach(|| build(SceneDesc::load_with_defines(&path, &overrides, &defines).map_err(error)?))
}

/// A scene in rdr's JSON, as text; `name` stands for it in messages, relative paths
/// resolve against `base_dir`.
#[pyfunction]
fn load_json(py: Python<'_>, text: &str, name: PathBuf, base_dir: PathBuf) -> PyResult<Scene> {
    let value = rdr::desc::json::parse_text(text, &name).map_err(error)?;
    py.detach(|| build(SceneDesc::from_value(&value, &name, &base_dir).map_err(error)?))
}

/// A Mitsuba scene dictionary.
#[pyfunction]
fn load_mitsuba_dict(py: Python<'_>, d: &Bound<'_, PyAny>, name: PathBuf, base_dir: PathBuf) -> PyResult<Scene> {
    let value = dict_value(d, "", &name)?;
    py.detach(|| build(rdr::desc::xml::dict::load(&value, &name, &base_dir).map_err(error)?))
}

/// A Python value of a scene dictionary, in order (NumPy values through `tolist`).
fn dict_value(v: &Bound<'_, PyAny>, path: &str, name: &Path) -> PyResult<DictValue> {
    let at = |k: &str| if path.is_empty() { k.to_string() } else { format!("{path}.{k}") };
    if v.is_instance_of::<PyBool>() {
        return Ok(DictValue::Bool(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        return Ok(DictValue::Int(v.extract()?));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(DictValue::Float(v.extract()?));
    }
    if let Ok(s) = v.cast::<PyString>() {
        return Ok(DictValue::Str(s.extract()?));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut entries = Vec::with_capacity(d.len());
        for (k, x) in d.iter() {
            let k: String = k
                .extract()
                .map_err(|_| error(format!("{}: {}: keys must be strings", name.display(), at("?"))))?;
            let value = dict_value(&x, &at(&k), name)?;
            entries.push((k, value));
        }
        return Ok(DictValue::Dict(entries));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let items: Vec<Bound<'_, PyAny>> = v.try_iter()?.collect::<PyResult<_>>()?;
        return Ok(DictValue::List(
            items.iter().map(|x| dict_value(x, path, name)).collect::<PyResult<_>>()?,
        ));
    }
    if v.hasattr("tolist")? {
        return dict_value(&v.call_method0("tolist")?, path, name);
    }
    let ty = v.get_type().name()?.to_string();
    Err(error(format!(
        "{}: {}: a value of type {ty} (give numbers, strings, lists or dicts)",
        name.display(),
        if path.is_empty() { "(root)" } else { path }
    )))
}

/// The job of a render: the scene's, or with another integrator (rdr's JSON
/// `integrator` object, as text); then the options, checked as the CLI checks them.
fn job_of(scene: &Scene, integrator: Option<&str>, opts: &RenderOptions) -> PyResult<(RenderJob, Vec<String>)> {
    let mut warnings = Vec::new();
    let mut job = match integrator {
        None => scene.loaded.job.clone(),
        Some(text) => {
            let name = Path::new("integrator");
            let value: serde_json::Value = serde_json::from_str(text).map_err(|e| error(format!("integrator: {e}")))?;
            // the integrator object of a scene file also holds its point and delta lights
            for k in ["lights", "point_light_position", "point_light_flux"] {
                if value.get(k).is_some() {
                    return Err(error(format!(
                        "integrator: {k}: lights belong to the scene (give them when loading it)"
                    )));
                }
            }
            let (i, w) = rdr::desc::integrator_from_value(&value, name).map_err(error)?;
            warnings = w;
            let mut desc = scene.desc.clone();
            desc.integrator.integrator = i.integrator;
            if value.get("spp").is_some() {
                desc.integrator.spp = i.spp;
            }
            RenderJob::from_desc(&desc, scene.profile).map_err(error)?
        }
    };
    opts.apply(&mut job, scene.profile, Caller::Python).map_err(error)?;
    Ok((job, warnings))
}

/// `Vec<Vec3>` as its floats, x y z a pixel, without copying.
fn into_floats(v: Vec<Vec3>) -> Vec<f32> {
    const _: () = assert!(std::mem::size_of::<Vec3>() == 12 && std::mem::align_of::<Vec3>() == 4);
    let mut v = std::mem::ManuallyDrop::new(v);
    let (ptr, len, cap) = (v.as_mut_ptr(), v.len(), v.capacity());
    // SAFETY: glam's Vec3 is `#[repr(C)] { x, y, z: f32 }` (12 bytes, alignment 4,
    // asserted above): the buffer holds 3·len initialised f32s, and its allocation
    // (12·cap bytes, alignment 4) is exactly what a Vec<f32> of capacity 3·cap frees.
    // Covered by the Python tests: the array equals the CLI's EXR bit for bit.
    unsafe { Vec::from_raw_parts(ptr.cast::<f32>(), len * 3, cap * 3) }
}

/// A render for Python: the image (H, W, C), its channel names, whether it was
/// interrupted, the samples per pixel it holds, and warnings.
type Rendered<'py> = (Bound<'py, PyArray3<f32>>, Vec<String>, bool, u32, Vec<String>);

/// Renders (see [`Rendered`]).
#[pyfunction]
#[pyo3(signature = (scene, spp, seed, threads, integrator, time_limit, aovs, progress))]
#[allow(clippy::too_many_arguments)]
fn render<'py>(
    py: Python<'py>,
    scene: PyRef<'py, Scene>,
    spp: Option<u32>,
    seed: u32,
    threads: Option<usize>,
    integrator: Option<&str>,
    time_limit: Option<f64>,
    aovs: Vec<String>,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Rendered<'py>> {
    let aov = match aovs.is_empty() {
        true => AovSet::default(),
        false => AovSet::parse(&aovs.join(",")).map_err(|e| error(format!("aovs: {e}")))?,
    };
    let opts = RenderOptions {
        spp,
        seed,
        threads,
        time_limit,
        aov,
    };
    let (job, warnings) = job_of(&scene, integrator, &opts)?;
    let pool = session::thread_pool(threads, Caller::Python).map_err(error)?;
    let f = &job.film;
    let total = f.width as u64 * f.height as u64 * job.integrator.spp_done(job.spp, job.integrator.pass_count(job.spp)) as u64;
    let done = Arc::new(AtomicU64::new(0));
    let control = RenderControl {
        progress: progress.as_ref().map(|_| {
            let done = done.clone();
            Arc::new(move |n: u64| {
                done.fetch_add(n, Ordering::Relaxed);
            }) as Arc<dyn Fn(u64) + Send + Sync>
        }),
        ..RenderControl::default()
    };
    let world = &scene.loaded.scene;
    let progress = progress.map(Bound::unbind);
    // the render runs on its own pool while this thread, the GIL released, wakes every
    // 50 ms to let Python handle signals (Ctrl-C) and call the progress callback
    let (out, failure) = py.detach(|| {
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::scope(|s| {
            let worker = s.spawn(|| {
                let out = session::run(world, &job, &control, FilmState::default(), aov.any(), &pool);
                let _ = tx.send(());
                out
            });
            let mut failure: Option<PyErr> = None;
            loop {
                let finished = rx.recv_timeout(Duration::from_millis(50)).is_ok();
                if failure.is_none() {
                    let polled = Python::attach(|py| -> PyResult<()> {
                        py.check_signals()?;
                        if let Some(cb) = &progress {
                            cb.bind(py).call1((done.load(Ordering::Relaxed), total))?;
                        }
                        Ok(())
                    });
                    if let Err(e) = polled {
                        control.stop.stop();
                        failure = Some(e);
                    }
                }
                if finished {
                    break;
                }
            }
            (worker.join(), failure)
        })
    });
    let out = match out {
        Ok(out) => out,
        Err(_) => return Err(error("internal error (a bug in rdr, please report it): the render thread panicked")),
    };
    let interrupted = match failure {
        None => false,
        Some(e) if e.is_instance_of::<PyKeyboardInterrupt>(py) => true,
        Some(e) => return Err(e),
    };
    let (w, h) = (out.width as usize, out.height as usize);
    let mut names: Vec<String> = ["R", "G", "B"].map(String::from).to_vec();
    let data = match &out.aov {
        Some(sums) if aov.any() => {
            let layers = rdr::film::aov::channels(sums, aov);
            let values: Vec<&[f32]> = layers
                .iter()
                .filter_map(|l| match &l.data {
                    rdr::imageio::ChannelData::F32(v) => Some(v.as_slice()),
                    _ => None,
                })
                .collect();
            let c = 3 + values.len();
            let mut data = Vec::with_capacity(w * h * c);
            for (i, p) in out.pixels.iter().enumerate() {
                data.extend_from_slice(&p.to_array());
                data.extend(values.iter().map(|v| v[i]));
            }
            names.extend(layers.iter().map(|l| l.name.clone()));
            data
        }
        _ => into_floats(out.pixels),
    };
    let c = names.len();
    let array = Array3::from_shape_vec((h, w, c), data).map_err(error)?;
    let mut notes = warnings;
    if out.invalid_samples > 0 {
        notes.push(format!("{} sample(s) were NaN or infinite and were left out", out.invalid_samples));
    }
    Ok((array.into_pyarray(py), names, interrupted, out.spp_done, notes))
}

/// An (H, W, 3) float32 array's pixels.
fn pixels(image: &PyReadonlyArray3<'_, f32>) -> PyResult<(u32, u32, Vec<Vec3>)> {
    let shape = image.shape();
    if shape[2] != 3 {
        return Err(error(format!(
            "an image of {} channels (give the colour: image[..., :3])",
            shape[2]
        )));
    }
    let a = image.as_array();
    let px = a.rows().into_iter().map(|r| Vec3::new(r[0], r[1], r[2])).collect();
    Ok((shape[1] as u32, shape[0] as u32, px))
}

/// Writes an (H, W, 3) image as `rdr render -o PATH` would: .exr float32 RGB, .png 8-bit sRGB.
#[pyfunction]
fn write(path: PathBuf, image: PyReadonlyArray3<'_, f32>) -> PyResult<()> {
    let (w, h, px) = pixels(&image)?;
    rdr::imageio::check_output_path(&path).map_err(chain)?;
    let bytes = rdr::imageio::encode_image(&path, w, h, &px, rdr::imageio::ExrPixels::Float).map_err(chain)?;
    rdr::imageio::write_atomically(&path, &bytes).map_err(chain)
}

/// Reads an image as linear RGB float32 (H, W, 3): EXR as stored, PNG and JPEG
/// from sRGB.
#[pyfunction]
fn read<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let exr = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    let img = py
        .detach(|| match exr {
            true => rdr::imageio::read_exr(&path),
            false => rdr::imageio::read_texture_image(&path),
        })
        .map_err(chain)?;
    let array = Array3::from_shape_vec((img.height, img.width, 3), into_floats(img.pixels)).map_err(error)?;
    Ok(array.into_pyarray(py))
}

/// `rdr compare`'s relative MSE of `image` against `reference`.
#[pyfunction]
fn compare(image: PyReadonlyArray3<'_, f32>, reference: PyReadonlyArray3<'_, f32>) -> PyResult<f64> {
    let (w, h, x) = pixels(&image)?;
    let (wr, hr, r) = pixels(&reference)?;
    if (w, h) != (wr, hr) {
        return Err(error(format!("the image is {w}x{h} but the reference is {wr}x{hr}")));
    }
    let img = |px| rdr::metrics::Image::new(w as usize, h as usize, px);
    Ok(rdr::metrics::rel_mse(&img(x), &img(r), None).0)
}

/// The image as PNG bytes (8-bit sRGB, as `rdr render -o x.png` writes).
#[pyfunction]
fn png_bytes<'py>(py: Python<'py>, image: PyReadonlyArray3<'_, f32>) -> PyResult<Bound<'py, PyBytes>> {
    let (w, h, px) = pixels(&image)?;
    let bytes = rdr::imageio::encode_png(w, h, &px).map_err(chain)?;
    Ok(PyBytes::new(py, &bytes))
}

/// The editable parameters of a scene (`rdr.traverse`), as Python values.
#[pyfunction]
fn params<'py>(py: Python<'py>, scene: PyRef<'py, Scene>) -> PyResult<Vec<(String, Bound<'py, PyAny>)>> {
    rdr::render::params::list(&scene.desc)
        .into_iter()
        .map(|(k, v)| {
            // an f32 as the shortest decimal that reads back to it (0.12, not 0.11999999731779099)
            let short = |x: f32| x.to_string().parse::<f64>().unwrap_or(x as f64);
            let value = match v {
                ParamValue::Int(n) => n.into_pyobject(py)?.into_any(),
                ParamValue::Float(x) => short(x).into_pyobject(py)?.into_any(),
                ParamValue::Vec3(c) => PyList::new(py, c.to_array().map(short))?.into_any(),
                ParamValue::Size(w, h) => PyList::new(py, [w, h])?.into_any(),
            };
            Ok((k, value))
        })
        .collect()
}

/// The message of `rdr.Error` for a key that cannot change.
#[pyfunction]
fn not_editable(key: &str) -> String {
    rdr::render::params::not_editable(key)
}

/// Applies edits made through `rdr.traverse` (all or none).
#[pyfunction]
fn update(mut scene: PyRefMut<'_, Scene>, changes: Vec<(String, Bound<'_, PyAny>)>) -> PyResult<()> {
    let current = rdr::render::params::list(&scene.desc);
    let mut typed = Vec::with_capacity(changes.len());
    for (key, value) in changes {
        let Some((_, was)) = current.iter().find(|(k, _)| *k == key) else {
            return Err(error(rdr::render::params::not_editable(&key)));
        };
        let wrong = |what: &str| error(format!("{key}: expected {what}"));
        let v = match was {
            ParamValue::Int(_) => ParamValue::Int(value.extract().map_err(|_| wrong("a whole number of at least 1"))?),
            ParamValue::Float(_) => ParamValue::Float(value.extract().map_err(|_| wrong("a number"))?),
            ParamValue::Vec3(_) => {
                let v: Vec<f32> = value.extract().map_err(|_| wrong("three numbers"))?;
                match v[..] {
                    [x, y, z] => ParamValue::Vec3(Vec3::new(x, y, z)),
                    _ => return Err(wrong("three numbers")),
                }
            }
            ParamValue::Size(..) => {
                let v: Vec<u32> = value.extract().map_err(|_| wrong("a width and a height"))?;
                match v[..] {
                    [w, h] => ParamValue::Size(w, h),
                    _ => return Err(wrong("a width and a height")),
                }
            }
        };
        typed.push((key, v));
    }
    let Scene { desc, loaded, profile } = &mut *scene;
    rdr::render::params::update(desc, loaded, *profile, &typed).map_err(error)
}

#[pymodule]
fn _rdr(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("Error", m.py().get_type::<Error>())?;
    m.add_class::<Scene>()?;
    m.add_function(wrap_pyfunction!(load_file, m)?)?;
    m.add_function(wrap_pyfunction!(load_json, m)?)?;
    m.add_function(wrap_pyfunction!(load_mitsuba_dict, m)?)?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(write, m)?)?;
    m.add_function(wrap_pyfunction!(read, m)?)?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_function(wrap_pyfunction!(png_bytes, m)?)?;
    m.add_function(wrap_pyfunction!(params, m)?)?;
    m.add_function(wrap_pyfunction!(update, m)?)?;
    m.add_function(wrap_pyfunction!(not_editable, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
