//! `meshsmooth._core`: the compiled half of the Python package. It takes flat,
//! already checked arrays (the Python half, `meshsmooth/__init__.py`, turns
//! numpy and meshio input into them and names the bad argument); here they
//! become a `Mesh`, the library runs with the GIL released, and the results
//! come back as numpy arrays and dicts.

use meshsmooth::backend::gpu;
use meshsmooth::io::{self, Format};
use meshsmooth::mesh::data::{DataArray, ValueType, Values};
use meshsmooth::metric::smetric::MetricKind;
use meshsmooth::report::quality_report;
use meshsmooth::smoother::Event;
use meshsmooth::solve::{Record, StopReason};
use meshsmooth::{ElementKind, Error, Mesh, Smoother, metric_report};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::{PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::Path;

/// The library's error as the Python exception a caller expects: bad input
/// (mesh, options, file content) is a `ValueError`, a failing device a
/// `RuntimeError`, the operating system's refusal an `OSError`. The message is
/// the CLI's.
fn py_err(e: Error) -> PyErr {
    let msg = e.to_string();
    match e {
        Error::Io { .. } => PyOSError::new_err(msg),
        Error::Gpu(_) => PyRuntimeError::new_err(msg),
        _ => PyValueError::new_err(msg),
    }
}

fn parse<T: std::str::FromStr<Err = Error>>(s: &str) -> PyResult<T> {
    s.parse().map_err(py_err)
}

fn stop_name(s: StopReason) -> &'static str {
    match s {
        StopReason::Converged => "converged",
        StopReason::Stalled => "stalled",
        StopReason::MaxIterations => "max_iterations",
        StopReason::TimeLimit => "time_limit",
        StopReason::Cancelled => "cancelled",
        StopReason::TargetReached => "target_reached",
        StopReason::SmallStep => "small_step",
    }
}

/// A mesh from the flat arrays: points (n, 3), kind codes (indices into
/// `ElementKind::ALL`), CSR offsets and connectivity, optional fixed flags;
/// validated as every reader validates.
/// Point-data arrays (name -> (n,) or (n, k) float array) for the size and
/// metric targets.
fn add_point_fields(mesh: &mut Mesh, fields: Option<&Bound<'_, PyDict>>) -> PyResult<()> {
    let Some(fields) = fields else { return Ok(()) };
    for (name, value) in fields.iter() {
        let name: String = name.extract()?;
        let arr: numpy::PyReadonlyArrayDyn<'_, f64> = value.extract().map_err(|_| {
            PyValueError::new_err(format!(
                "fields[{name:?}] must be a float64 array of one value or row per point"
            ))
        })?;
        let a = arr.as_array();
        let shape = a.shape().to_vec();
        let components = match shape.as_slice() {
            [n] if *n == mesh.num_points() => 1,
            [n, k] if *n == mesh.num_points() && *k > 0 => *k,
            _ => {
                return Err(PyValueError::new_err(format!(
                    "fields[{name:?}] has shape {shape:?}; expected ({0},) or ({0}, k), one row per point",
                    mesh.num_points()
                )));
            }
        };
        let values: Vec<f64> = a.iter().copied().collect();
        mesh.data
            .point
            .push(DataArray::new(name, ValueType::F64, components, Values::Float(values)));
    }
    Ok(())
}

fn build_mesh(
    points: &PyReadonlyArray2<f64>,
    kinds: &PyReadonlyArray1<u8>,
    offsets: &PyReadonlyArray1<i64>,
    conn: &PyReadonlyArray1<u32>,
    fixed: Option<&PyReadonlyArray1<bool>>,
) -> PyResult<Mesh> {
    let p = points.as_array();
    if p.ncols() != 3 {
        return Err(PyValueError::new_err("points must have 3 columns"));
    }
    let mut mesh = Mesh::new(p.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect());
    let kinds = kinds.as_array();
    let offsets = offsets.as_array();
    let conn = conn.as_array();
    if offsets.len() != kinds.len() + 1 {
        return Err(PyValueError::new_err("offsets must have one entry more than kinds"));
    }
    let conn: Vec<u32> = conn.iter().copied().collect();
    for (e, &k) in kinds.iter().enumerate() {
        let kind = *ElementKind::ALL
            .get(k as usize)
            .ok_or_else(|| PyValueError::new_err(format!("unknown element kind code {k}")))?;
        // a polyhedron needs its faces, which this array interface does not carry
        let Some(nv) = kind.num_vertices() else {
            return Err(PyValueError::new_err(format!(
                "element {e}: polyhedra are not supported through the Python array interface; use a .vtu or .vtk file"
            )));
        };
        let (a, b) = (offsets[e], offsets[e + 1]);
        if a < 0 || b < a || b as usize > conn.len() || (b - a) as usize != nv {
            return Err(PyValueError::new_err(format!("element {e}: bad offsets {a}..{b}")));
        }
        mesh.push_element(kind, &conn[a as usize..b as usize]);
    }
    if let Some(f) = fixed {
        mesh.fixed = f.as_array().iter().copied().collect();
    }
    mesh.validate().map_err(py_err)?;
    Ok(mesh)
}

fn points_array<'py>(py: Python<'py>, points: &[[f64; 3]]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = points.iter().flatten().copied().collect();
    flat.into_pyarray(py)
        .reshape([points.len(), 3])
        .expect("n * 3 values reshape to (n, 3)")
}

/// The quality report as a Python dict (through its JSON form, so the keys
/// are the CLI's `quality --json` keys).
fn report_dict<'py>(py: Python<'py>, mesh: &Mesh) -> PyResult<Bound<'py, PyAny>> {
    let json = serde_json::to_string(&quality_report(mesh, &mesh.points)).expect("report serialises");
    py.import("json")?.call_method1("loads", (json,))
}

/// The library's default settings as JSON (the Python keywords' defaults are tested against them).
#[pyfunction]
fn default_settings() -> String {
    serde_json::to_string(&Smoother::default()).expect("settings serialise")
}

/// Smooths (or, `untangle_only`, untangles) the mesh with the settings in
/// `settings` (a JSON object keyed as the Python keywords): the library's
/// `Smoother` checks them and runs the one sequence every front end runs.
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (points, kinds, offsets, conn, fixed, settings, callback=None, untangle_only=false, fields=None))]
fn smooth<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    kinds: PyReadonlyArray1<'py, u8>,
    offsets: PyReadonlyArray1<'py, i64>,
    conn: PyReadonlyArray1<'py, u32>,
    fixed: Option<PyReadonlyArray1<'py, bool>>,
    settings: &str,
    callback: Option<Py<PyAny>>,
    untangle_only: bool,
    fields: Option<Bound<'py, PyDict>>,
) -> PyResult<(Bound<'py, PyArray2<f64>>, Bound<'py, PyDict>)> {
    let smoother = Smoother::from_json(settings).map_err(py_err)?;
    let mut mesh = build_mesh(&points, &kinds, &offsets, &conn, fixed.as_ref())?;
    add_point_fields(&mut mesh, fields.as_ref())?;
    // the first exception raised by the callback or a signal handler (Ctrl-C)
    let mut raised: Option<PyErr> = None;
    let mut notes: Vec<String> = Vec::new();
    let mut target_note: Option<String> = None;
    let solved = py.detach(|| {
        let mut observer = |e: Event<'_>| -> bool {
            match e {
                Event::Start(start) => {
                    notes.extend(start.notes.iter().cloned());
                    target_note = start.targets.clone();
                    true
                }
                Event::Iteration(r) => Python::attach(|py| -> PyResult<bool> {
                    py.check_signals()?;
                    let Some(cb) = &callback else { return Ok(true) };
                    let d = PyDict::new(py);
                    d.set_item("iteration", r.iteration)?;
                    d.set_item("seconds", r.seconds)?;
                    d.set_item("objective", r.objective)?;
                    d.set_item("grad_norm", r.grad_norm)?;
                    // only an explicit False stops: a callback returning None goes on
                    Ok(!cb.bind(py).call1((d,))?.is(pyo3::types::PyBool::new(py, false)))
                })
                .unwrap_or_else(|e| {
                    raised = Some(e);
                    false
                }),
                _ => true,
            }
        };
        if untangle_only {
            smoother
                .untangle_observed(&mut mesh, &mut observer)
                .map(|r| (r.untangled, None))
        } else {
            smoother
                .smooth_observed(&mut mesh, &mut observer)
                .map(|r| (r.untangled, Some(r.info)))
        }
    });
    if let Some(e) = raised {
        return Err(e);
    }
    let (untangled, solved) = solved.map_err(py_err)?;
    let untangle_dict = match &untangled {
        None => None,
        Some(u) => {
            let d = PyDict::new(py);
            d.set_item("inverted_before", u.inverted_before)?;
            d.set_item("inverted_after", u.inverted_after)?;
            d.set_item("inverted_corners_before", u.inverted_corners_before)?;
            d.set_item("corners_before", u.corners_before)?;
            d.set_item("corners_after", u.corners_after)?;
            d.set_item("rounds", u.rounds)?;
            d.set_item("iterations", u.iterations)?;
            d.set_item("seconds", u.seconds)?;
            d.set_item("device", &u.device)?;
            Some(d)
        }
    };
    let Some(info) = solved else {
        // untangle only: what untangling did, and the quality of the result
        let d = PyDict::new(py);
        d.set_item("untangle", untangle_dict)?;
        d.set_item("notes", notes)?;
        d.set_item("quality", io::eta_field(&mesh).into_pyarray(py))?;
        d.set_item("report", report_dict(py, &mesh)?)?;
        return Ok((points_array(py, &mesh.points), d));
    };
    let d = PyDict::new(py);
    d.set_item("untangle", untangle_dict)?;
    d.set_item("targets", target_note)?;
    d.set_item("notes", notes)?;
    d.set_item("method", info.method.name())?;
    d.set_item("device", &info.device)?;
    d.set_item("iterations", info.iterations)?;
    d.set_item("stop", stop_name(info.stop))?;
    d.set_item("stop_reason", info.stop.to_string())?;
    d.set_item("objective", info.objective)?;
    d.set_item("grad_norm", info.grad_norm)?;
    d.set_item("seconds", info.seconds)?;
    d.set_item("setup_seconds", info.setup_seconds)?;
    d.set_item("optimise_seconds", info.optimise_seconds)?;
    d.set_item("reorder_seconds", info.reorder_seconds)?;
    d.set_item("reorderings", info.reorderings)?;
    d.set_item("memory_bytes", info.memory_bytes)?;
    d.set_item("colors", info.colors)?;
    d.set_item("cg_iterations", info.cg_iterations)?;
    d.set_item("negative_curvature_steps", info.negative_curvature_steps)?;
    d.set_item("start_sweeps", info.start_sweeps)?;
    d.set_item("line_search_trials", info.line_search_trials)?;
    let rec = &info.history.records;
    let history = PyDict::new(py);
    let column = |f: fn(&Record) -> f64| rec.iter().map(f).collect::<Vec<f64>>().into_pyarray(py);
    history.set_item(
        "iteration",
        rec.iter()
            .map(|r| r.iteration as i64)
            .collect::<Vec<_>>()
            .into_pyarray(py),
    )?;
    history.set_item("seconds", column(|r| r.seconds))?;
    history.set_item("objective", column(|r| r.objective))?;
    history.set_item("grad_norm", column(|r| r.grad_norm))?;
    d.set_item("history", history)?;
    d.set_item("quality", io::eta_field(&mesh).into_pyarray(py))?;
    d.set_item("report", report_dict(py, &mesh)?)?;
    Ok((points_array(py, &mesh.points), d))
}

/// The quality report of a mesh and the per-element values of `metric`
/// (NaN where an element is inverted).
#[pyfunction]
fn quality<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    kinds: PyReadonlyArray1<'py, u8>,
    offsets: PyReadonlyArray1<'py, i64>,
    conn: PyReadonlyArray1<'py, u32>,
    metric: &str,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyArray1<f64>>)> {
    let mesh = build_mesh(&points, &kinds, &offsets, &conn, None)?;
    let metric: MetricKind = parse(metric)?;
    let values = py
        .detach(|| metric_report::element_values(&mesh, &mesh.points, metric, None))
        .map_err(py_err)?;
    let values: Vec<f64> = values.into_iter().map(|v| v.unwrap_or(f64::NAN)).collect();
    Ok((report_dict(py, &mesh)?, values.into_pyarray(py)))
}

type FlatMesh<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<u8>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<u32>>,
    Option<Bound<'py, PyArray1<bool>>>,
);

/// A mesh file through the library's readers: points, kind codes, offsets,
/// connectivity, fixed flags (None when the file marks none).
#[pyfunction]
fn read<'py>(py: Python<'py>, path: std::path::PathBuf) -> PyResult<FlatMesh<'py>> {
    let mesh = py.detach(|| io::read(&path)).map_err(py_err)?;
    if let Some(e) = mesh.kinds.iter().position(|&k| k == ElementKind::Polyhedron) {
        return Err(PyValueError::new_err(format!(
            "{}: element {e} is a polyhedron; the Python array interface cannot carry polyhedron faces",
            path.display()
        )));
    }
    let kinds: Vec<u8> = mesh
        .kinds
        .iter()
        .map(|k| ElementKind::ALL.iter().position(|a| a == k).expect("a known kind") as u8)
        .collect();
    let offsets: Vec<i64> = mesh.offsets.iter().map(|&o| o as i64).collect();
    let fixed = (!mesh.fixed.is_empty()).then(|| mesh.fixed.clone().into_pyarray(py));
    Ok((
        points_array(py, &mesh.points),
        kinds.into_pyarray(py),
        offsets.into_pyarray(py),
        mesh.conn.clone().into_pyarray(py),
        fixed,
    ))
}

/// Writes a mesh through the library's writers (with its per-element
/// `inverse_mean_ratio`); the format follows the extension unless named.
#[pyfunction]
#[pyo3(signature = (path, points, kinds, offsets, conn, format=None))]
fn write<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    points: PyReadonlyArray2<'py, f64>,
    kinds: PyReadonlyArray1<'py, u8>,
    offsets: PyReadonlyArray1<'py, i64>,
    conn: PyReadonlyArray1<'py, u32>,
    format: Option<&str>,
) -> PyResult<()> {
    let mesh = build_mesh(&points, &kinds, &offsets, &conn, None)?;
    let format = match format {
        Some(name) => Format::from_name(name).ok_or_else(|| {
            let names: Vec<&str> = Format::ALL.iter().map(|f| f.name()).collect();
            PyValueError::new_err(format!("unknown format {name:?}; one of {}", names.join(", ")))
        })?,
        None => Format::from_path(&path).map_err(py_err)?,
    };
    py.detach(|| io::write_mesh(Path::new(&path), &mesh, format))
        .map_err(py_err)
}

/// The GPU adapters wgpu finds, best first, as `meshsmooth devices` lists them.
#[pyfunction]
fn devices(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let adapters = py.detach(gpu::list_adapters);
    let out = PyList::empty(py);
    for a in adapters {
        let d = PyDict::new(py);
        d.set_item("name", a.name)?;
        d.set_item("backend", a.backend)?;
        d.set_item("device_type", a.device_type)?;
        d.set_item("driver", a.driver)?;
        d.set_item("driver_info", a.driver_info)?;
        d.set_item("f64", a.f64)?;
        d.set_item("compute", a.compute)?;
        out.append(d)?;
    }
    Ok(out)
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let names: Vec<&str> = ElementKind::ALL.iter().map(|k| k.name()).collect();
    m.add("KIND_NAMES", names)?;
    m.add("VERSION", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(smooth, m)?)?;
    m.add_function(wrap_pyfunction!(default_settings, m)?)?;
    m.add_function(wrap_pyfunction!(quality, m)?)?;
    m.add_function(wrap_pyfunction!(read, m)?)?;
    m.add_function(wrap_pyfunction!(write, m)?)?;
    m.add_function(wrap_pyfunction!(devices, m)?)?;
    Ok(())
}
