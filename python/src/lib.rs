//! `sism._sism`: the extension module under the `sism` Python package. Thin: every figure comes from
//! the `sism` library as the command line gets it; this file converts arguments and results. The
//! Python side (`python/sism/__init__.py`) turns pixel bytes into NumPy arrays, so the module needs
//! no NumPy at build time and one wheel (the stable ABI, Python 3.9+) serves every Python.
//!
//! The GIL is released during every render, comparison and study (`Python::detach`), so other
//! Python threads run meanwhile. Errors carry the library's message: `OSError` where a file could
//! not be read or written, `ValueError` for bad input (`sism::ErrorKind`).

use std::path::PathBuf;

use pyo3::exceptions::{PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList};

use sism::algorithms::{self as registry, Family};
use sism::frame::VisibilityImage;
use sism::machine::sweep::{self, SweepAxes};
use sism::render::{self as frames, RenderOptions};
use sism::{Error, ErrorKind, Scene};

/// The command line's allocator (its `src/main.rs` says why): line-aligned blocks with no reuse
/// within a counted frame, over mimalloc, so a frame counted here records what `sism` records.
#[global_allocator]
static GLOBAL: sism_simd::LineAlloc<mimalloc::MiMalloc> = sism_simd::LineAlloc(mimalloc::MiMalloc);

/// mimalloc's `mi_option_purge_delay` (mimalloc.h's `mi_option_e`).
const MI_OPTION_PURGE_DELAY: libmimalloc_sys::mi_option_t = 15;

/// The library's error as the matching Python exception.
fn py_err(e: Error) -> PyErr {
    let message = e.to_string();
    match e.kind() {
        ErrorKind::Io => PyOSError::new_err(message),
        ErrorKind::InvalidInput => PyValueError::new_err(message),
        ErrorKind::External => PyRuntimeError::new_err(message),
    }
}

fn value_err(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}

/// A loaded scene (`sism.load_scene`): its meshes, light and camera at the chosen image size.
#[pyclass(module = "sism._sism", name = "Scene", frozen)]
struct PyScene {
    scene: Scene,
}

#[pymethods]
impl PyScene {
    /// Image width, pixels.
    #[getter]
    fn width(&self) -> u32 {
        self.scene.camera.width
    }
    /// Image height, pixels.
    #[getter]
    fn height(&self) -> u32 {
        self.scene.camera.height
    }
    /// Triangles in all meshes.
    #[getter]
    fn triangles(&self) -> usize {
        self.scene.triangle_count()
    }
    /// The scene file it was loaded from.
    #[getter]
    fn path(&self) -> PathBuf {
        self.scene.source.clone()
    }
    /// Area light radius, world units (0 is a point light).
    #[getter]
    fn light_radius(&self) -> f32 {
        self.scene.light.radius
    }
    fn __repr__(&self) -> String {
        format!(
            "Scene('{}', {}x{}, {} triangles)",
            self.scene.source.display(),
            self.scene.camera.width,
            self.scene.camera.height,
            self.scene.triangle_count()
        )
    }
}

/// Every algorithm: name, family, one-line summary, whether `machine=` can time it, and its
/// parameters (key, default, range, description).
#[pyfunction]
fn algorithms(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let list = PyList::empty(py);
    for a in registry::REGISTRY.iter().filter(|a| a.family != Family::Test) {
        let d = PyDict::new(py);
        d.set_item("name", a.name)?;
        d.set_item("family", a.family.name())?;
        d.set_item("summary", a.summary)?;
        d.set_item("machine", a.kernels)?;
        let params = PyList::empty(py);
        for p in a.params {
            let pd = PyDict::new(py);
            pd.set_item("key", p.key)?;
            pd.set_item("default", p.default)?;
            pd.set_item("range", p.range())?;
            pd.set_item("description", p.description)?;
            params.append(pd)?;
        }
        d.set_item("params", params)?;
        list.append(d)?;
    }
    Ok(list)
}

/// Loads a scene file (TOML), optionally at another image size.
#[pyfunction]
#[pyo3(signature = (path, width=None, height=None))]
fn load_scene(py: Python<'_>, path: PathBuf, width: Option<u32>, height: Option<u32>) -> PyResult<PyScene> {
    let scene = py.detach(|| -> sism::Result<Scene> {
        let mut scene = Scene::load(&path)?;
        if let Some(w) = width {
            scene.camera.width = w;
        }
        if let Some(h) = height {
            scene.camera.height = h;
        }
        scene
            .camera
            .validate()
            .map_err(|(key, msg)| Error::invalid(format!("{}: {key} {msg}", path.display())))?;
        Ok(scene)
    });
    Ok(PyScene {
        scene: scene.map_err(py_err)?,
    })
}

fn image_bytes<'py>(py: Python<'py>, v: &VisibilityImage) -> Bound<'py, PyBytes> {
    let bytes: Vec<u8> = v.values.iter().flat_map(|x| x.to_le_bytes()).collect();
    PyBytes::new(py, &bytes)
}

fn stats_dict<'py>(py: Python<'py>, stats: &sism::stats::StatsReport) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for s in &stats.stats {
        d.set_item(&s.name, (s.value, s.unit.as_str()))?;
    }
    Ok(d)
}

fn facts_dict<'py>(py: Python<'py>, stats: &sism::stats::StatsReport) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (k, v) in &stats.facts {
        d.set_item(k, v)?;
    }
    Ok(d)
}

fn phase_dict<'py>(py: Python<'py>, p: &sism::machine::PhaseReport) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("phase", &p.phase)?;
    d.set_item("tasks", p.tasks)?;
    d.set_item("cycles", p.cycles)?;
    d.set_item("ms", p.ms)?;
    let stack = PyDict::new(py);
    for (name, cycles) in p.stack.parts() {
        stack.set_item(name, cycles)?;
    }
    d.set_item("stack", stack)?;
    d.set_item("lane_utilisation", p.lane_utilisation())?;
    d.set_item("l1_miss_rate", p.memory.l1_miss_rate())?;
    d.set_item("l2_miss_rate", p.memory.l2_miss_rate())?;
    Ok(d)
}

/// Parameters as `key=value` pairs: a dict's values may be str, int, float or bool.
fn param_pairs(params: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<(String, String)>> {
    let mut pairs = Vec::new();
    if let Some(d) = params {
        for (k, v) in d.iter() {
            let key: String = k
                .extract()
                .map_err(|_| value_err("params: keys are parameter names (str)"))?;
            let value = if let Ok(b) = v.extract::<bool>() {
                b.to_string()
            } else {
                v.str()?.to_string()
            };
            pairs.push((key, value));
        }
    }
    Ok(pairs)
}

fn find_algorithm(name: &str) -> PyResult<&'static registry::Algorithm> {
    registry::find(name)
        .filter(|a| a.family != Family::Test)
        .ok_or_else(|| {
            value_err(format!(
                "unknown algorithm `{name}`; known: {}",
                registry::REGISTRY
                    .iter()
                    .filter(|a| a.family != Family::Test)
                    .map(|a| a.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            ))
        })
}

/// Renders one frame. Returns a dict: `visibility` (little-endian f32 bytes, rows top to bottom),
/// `width`, `height`, `stats` (name → (value, unit)), `facts`, and with `machine` (a preset name
/// or a machine TOML file) `machine` (per-step and per-phase reports, the frame's).
#[pyfunction]
#[pyo3(signature = (scene, algo, params=None, machine=None, progress=false))]
fn render<'py>(
    py: Python<'py>,
    scene: &PyScene,
    algo: &str,
    params: Option<&Bound<'py, PyDict>>,
    machine: Option<PathBuf>,
    progress: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let algorithm = find_algorithm(algo)?;
    let resolved = algorithm
        .params(&param_pairs(params)?)
        .map_err(|e| py_err(e.into()))?;
    let out = PyDict::new(py);
    match machine {
        Some(m) => {
            registry::ensure_kernels(algorithm, "machine=").map_err(py_err)?;
            let name = m.to_string_lossy().into_owned();
            let config = py.detach(|| sism::host::resolve_machine(&name)).map_err(py_err)?;
            let r = py
                .detach(|| frames::render_on_machine(&scene.scene, algorithm, &resolved, &config, progress));
            let report = &r.report;
            let m = PyDict::new(py);
            m.set_item("name", &report.config.name)?;
            m.set_item("clock_ghz", report.config.clock_ghz)?;
            m.set_item("cores", report.config.cores)?;
            m.set_item("threads_per_core", report.config.threads_per_core)?;
            m.set_item("frame", phase_dict(py, &report.frame)?)?;
            let groups = PyList::empty(py);
            for g in &report.groups {
                groups.append(phase_dict(py, g)?)?;
            }
            m.set_item("phases", groups)?;
            let steps = PyList::empty(py);
            for s in &report.phases {
                steps.append(phase_dict(py, s)?)?;
            }
            m.set_item("steps", steps)?;
            out.set_item("machine", m)?;
            fill_render(py, &out, &r.result)?;
        }
        None => {
            let options = RenderOptions {
                progress,
                ..Default::default()
            };
            let r = py.detach(|| frames::render(&scene.scene, algorithm, &resolved, &options));
            out.set_item("machine", py.None())?;
            fill_render(py, &out, &r)?;
        }
    }
    out.set_item("algorithm", algorithm.name)?;
    out.set_item("params", resolved.describe())?;
    Ok(out)
}

fn fill_render<'py>(py: Python<'py>, out: &Bound<'py, PyDict>, r: &frames::RenderResult) -> PyResult<()> {
    out.set_item("visibility", image_bytes(py, &r.visibility))?;
    out.set_item("width", r.visibility.width)?;
    out.set_item("height", r.visibility.height)?;
    out.set_item("stats", stats_dict(py, &r.stats)?)?;
    out.set_item("facts", facts_dict(py, &r.stats)?)?;
    Ok(())
}

/// A visibility image from little-endian f32 bytes.
fn image_from(bytes: &[u8], width: u32, height: u32, which: &str) -> PyResult<VisibilityImage> {
    let n = width as u64 * height as u64;
    if width == 0 || height == 0 || bytes.len() as u64 != n * 4 {
        return Err(value_err(format!(
            "{which}: {} bytes for {width}x{height} float32 pixels (needs {})",
            bytes.len(),
            n * 4
        )));
    }
    Ok(VisibilityImage {
        width,
        height,
        values: bytes
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect(),
    })
}

/// Reads a visibility image (PFM or OpenEXR): `(bytes, width, height)`.
#[pyfunction]
fn read_visibility<'py>(py: Python<'py>, path: PathBuf) -> PyResult<(Bound<'py, PyBytes>, u32, u32)> {
    let v = py
        .detach(|| sism::output::read_visibility(&path))
        .map_err(|e| py_err(e.into()))?;
    Ok((image_bytes(py, &v), v.width, v.height))
}

/// The error report of `test` against `reference` (images as `(bytes, width, height)`), with
/// ꟻLIP between their shaded views when the shading is known: from `scene`, else from the two
/// `shaded.png` files given.
#[pyfunction]
#[pyo3(signature = (reference, test, scene=None, shaded_pngs=None))]
fn compare<'py>(
    py: Python<'py>,
    reference: (Vec<u8>, u32, u32),
    test: (Vec<u8>, u32, u32),
    scene: Option<&PyScene>,
    shaded_pngs: Option<(PathBuf, PathBuf)>,
) -> PyResult<Bound<'py, PyDict>> {
    let r = image_from(&reference.0, reference.1, reference.2, "reference")?;
    let t = image_from(&test.0, test.1, test.2, "test")?;
    let report = py.detach(|| -> sism::Result<sism::ErrorReport> {
        let mut report = sism::metrics::compare(&r, &t)?;
        report.flip = match (scene, &shaded_pngs) {
            (Some(s), _) => {
                let mut scene = s.scene.clone();
                scene.camera.width = r.width;
                scene.camera.height = r.height;
                scene.camera.validate().map_err(|(key, msg)| {
                    Error::invalid(format!("scene at the images' size: {key} {msg}"))
                })?;
                let (receivers, _) = sism::raster::eye::receivers(&scene);
                Some(sism::perceptual::flip_of_frame(&scene, &receivers, &r, &t)?.mean())
            }
            (None, Some((a, b))) => {
                let (ia, ib) = (sism::perceptual::read_png(a)?, sism::perceptual::read_png(b)?);
                Some(sism::perceptual::flip_ldr(&ia, &ib)?.mean())
            }
            (None, None) => None,
        };
        Ok(report)
    });
    let report = report.map_err(py_err)?;
    let d = PyDict::new(py);
    d.set_item("compared", report.compared)?;
    d.set_item("mae", report.mae)?;
    d.set_item("rmse", report.rmse)?;
    d.set_item("p99", report.p99)?;
    d.set_item("max", report.max)?;
    d.set_item("share_over_0_1", report.share_over_0_1)?;
    d.set_item("penumbra_pixels", report.penumbra_pixels)?;
    d.set_item("penumbra_mae", report.penumbra_mae)?;
    d.set_item("flip", report.flip)?;
    Ok(d)
}

/// Counts one frame of `algo` once and re-times it on every machine of the sweep (cores × threads
/// × L2 around `machine`); one row per point and step, phase or frame.
#[pyfunction]
#[pyo3(signature = (scene, machine, algo="sism", cores=None, threads=None, l2_kb=None, params=None, progress=false))]
#[allow(clippy::too_many_arguments)]
fn study<'py>(
    py: Python<'py>,
    scene: &PyScene,
    machine: PathBuf,
    algo: &str,
    cores: Option<Vec<u32>>,
    threads: Option<Vec<u32>>,
    l2_kb: Option<Vec<u32>>,
    params: Option<&Bound<'py, PyDict>>,
    progress: bool,
) -> PyResult<Bound<'py, PyList>> {
    let algorithm = find_algorithm(algo)?;
    registry::ensure_kernels(algorithm, "machine=").map_err(py_err)?;
    let resolved = algorithm
        .params(&param_pairs(params)?)
        .map_err(|e| py_err(e.into()))?;
    let name = machine.to_string_lossy().into_owned();
    let base = py.detach(|| sism::host::resolve_machine(&name)).map_err(py_err)?;
    let axes = SweepAxes {
        cores: cores.unwrap_or_default(),
        threads: threads.unwrap_or_default(),
        l2_kb: l2_kb.unwrap_or_default(),
        ..Default::default()
    };
    let configs = sweep::configurations(&base, &axes).map_err(value_err)?;
    let points = py.detach(|| {
        let frame = frames::render(
            &scene.scene,
            algorithm,
            &resolved,
            &RenderOptions {
                exec: sism::exec::Exec::Counting,
                progress,
            },
        );
        let records = sism::machine::canonical(&frame.records);
        drop(frame);
        let bar = sism::progress::bar(configs.len() as u64, "simulating", progress);
        let points = sism::study::run_local(&records, &configs, &[], || bar.inc(1));
        bar.finish_and_clear();
        points
    });
    let rows = PyList::empty(py);
    for p in &points {
        let speedup = sism::study::speedup(&points, p);
        let levels = std::iter::once(("frame", &p.frame))
            .chain(p.groups.iter().map(|g| ("phase", g)))
            .chain(p.steps.iter().map(|s| ("step", s)));
        for (level, row) in levels {
            let d = PyDict::new(py);
            d.set_item("point", p.index)?;
            d.set_item("machine", &p.name)?;
            d.set_item("cores", p.cores)?;
            d.set_item("threads", p.threads)?;
            d.set_item("l2_kb", p.l2_kb)?;
            d.set_item("clock_ghz", p.clock_ghz)?;
            d.set_item("level", level)?;
            d.set_item("phase", &row.phase)?;
            d.set_item("tasks", row.tasks)?;
            d.set_item("cycles", row.cycles)?;
            d.set_item("ms", row.ms)?;
            for (part, cycles) in row.stack.parts() {
                d.set_item(part, cycles)?;
            }
            d.set_item("lane_utilisation", row.lane_utilisation)?;
            d.set_item("l1_miss_rate", row.l1_miss_rate)?;
            d.set_item("l2_miss_rate", row.l2_miss_rate)?;
            d.set_item("bytes_dram", row.bytes_dram)?;
            d.set_item("frame_speedup", speedup)?;
            rows.append(d)?;
        }
    }
    Ok(rows)
}

/// The SIMD backend the kernels run on (`avx512` or `portable`).
#[pyfunction]
fn simd_backend() -> &'static str {
    sism_simd::selected_backend().name()
}

#[pymodule]
fn _sism(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // Freed pages kept, never purged, as the command line does: a frame's buffers are faulted in
    // once, not in every phase.
    // SAFETY: sets an option of the allocator; mimalloc reads options atomically.
    unsafe { libmimalloc_sys::mi_option_set(MI_OPTION_PURGE_DELAY, -1) };
    m.add_class::<PyScene>()?;
    m.add_function(wrap_pyfunction!(algorithms, m)?)?;
    m.add_function(wrap_pyfunction!(load_scene, m)?)?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(read_visibility, m)?)?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_function(wrap_pyfunction!(study, m)?)?;
    m.add_function(wrap_pyfunction!(simd_backend, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
