//! Parts: loaded from a mesh file, or built from vertex and face arrays (numpy, trimesh).

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use numpy::ndarray::ArrayView2;
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use moldgate::mesh::{self, LoadedMesh, Units};
use moldgate::report::Input;

use crate::{detached, guarded, LoadError, OptionsError, PyErrBox};

/// A part ready to study: a welded triangle mesh in millimetres, with what loading found.
///
/// Build one with `moldgate.load(path)`, `moldgate.Part(vertices, faces)` or
/// `moldgate.Part.from_trimesh(mesh)`.
#[pyclass(frozen, module = "moldgate")]
pub struct Part {
    pub(crate) mesh: Arc<LoadedMesh>,
    /// Where it came from (the report's `input`).
    pub(crate) input: Input,
    /// Seconds to read or build it.
    pub(crate) load_s: f64,
    /// For a part built from arrays, the part's vertex of each given vertex (-1 when no
    /// triangle uses it): [`moldgate::mesh::vertex_map`].
    pub(crate) vertex_map: Option<Arc<Vec<i64>>>,
}

/// Parses a unit name, refusing an unknown one with the library's message.
pub(crate) fn units(name: &str) -> PyResult<Units> {
    name.parse()
        .map_err(|e: String| OptionsError::new_err(format!("units: {e}")))
}

/// [`units`] of any Python object: anything but a string is refused with the same
/// message as the Python layer's (`units must be one of mm, cm, m, in; got None`), not
/// with a `TypeError` from the argument's conversion.
pub(crate) fn units_of(obj: &Bound<'_, PyAny>) -> PyResult<Units> {
    match obj.extract::<String>() {
        Ok(name) => units(&name),
        Err(_) => Err(OptionsError::new_err(format!(
            "units must be one of mm, cm, m, in; got {}",
            obj.repr()?
        ))),
    }
}

/// A `units` argument: a unit name, read by [`units_of`], so that `units=None` or a number
/// is an `OptionsError` like an unknown name, not a `TypeError` from the conversion.
pub(crate) struct UnitsArg(pub(crate) Units);

impl<'a, 'py> FromPyObject<'a, 'py> for UnitsArg {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<UnitsArg> {
        units_of(&obj).map(UnitsArg)
    }
}

/// Reads a mesh file by its extension (`.obj`, `.ply`, any case; STL otherwise), as the
/// command line does: only a regular file (a FIFO would hang the call).
pub(crate) fn read_file(path: &Path, units: Units) -> Result<(LoadedMesh, u64), String> {
    moldgate::files::read_mesh_file(path, units)
        .map_err(|e| format!("{}: {e}", moldgate::files::shown(&path)))
}

/// Reads a mesh file (STL, OBJ or PLY by its extension; STL for any other) in `units`.
fn load_part(py: Python<'_>, path: PathBuf, units: Units) -> PyResult<Part> {
    let t = Instant::now();
    let (mesh, bytes) = detached(py, || read_file(&path, units).map_err(PyErrBox::Load))?;
    Ok(Part {
        mesh: Arc::new(mesh),
        input: Input {
            path: Some(moldgate::files::shown(&path)),
            sample: None,
            bytes,
        },
        load_s: t.elapsed().as_secs_f64(),
        vertex_map: None,
    })
}

/// load(path, units="mm")
/// --
///
/// Reads a mesh file (STL, OBJ or PLY by its extension, STL for any other) in `units`.
#[pyfunction]
#[pyo3(signature = (path, units = "mm"))]
pub fn load(py: Python<'_>, path: PathBuf, units: &str) -> PyResult<Part> {
    let units = self::units(units)?;
    load_part(py, path, units)
}

/// check_units(units)
/// --
///
/// Raises `OptionsError` unless `units` is `mm`, `cm`, `m` or `in`.
#[pyfunction]
pub fn check_units(units: &str) -> PyResult<()> {
    self::units(units).map(|_| ())
}

/// sample(name)
/// --
///
/// A built-in sample part by name (`cover`, `plate`, ...: the command line's
/// `--sample`), in mm.
#[pyfunction]
pub fn sample(name: &str) -> PyResult<Part> {
    let Some(mesh) = moldgate::samples::sample(name) else {
        return Err(LoadError::new_err(format!(
            "unknown sample '{name}' (known: {})",
            moldgate::samples::SAMPLES
                .iter()
                .map(|s| s.name)
                .collect::<Vec<_>>()
                .join(", ")
        )));
    };
    Ok(Part {
        mesh: Arc::new(mesh::from_generated(mesh)),
        input: Input {
            path: None,
            sample: Some(name.to_string()),
            bytes: 0,
        },
        load_s: 0.0,
        vertex_map: None,
    })
}

/// `obj` as a C-contiguous (n, 3) float64 array: no copy when it is one already.
fn vertex_array<'py>(obj: &Bound<'py, PyAny>) -> PyResult<PyReadonlyArray2<'py, f64>> {
    let py = obj.py();
    let np = py.import("numpy")?;
    let a = np
        .call_method1("asarray", (obj,))
        .map_err(|e| LoadError::new_err(format!("vertices: cannot be read as an array: {e}")))?;
    let shape: Vec<usize> = a.getattr("shape")?.extract()?;
    if shape.len() != 2 || shape[1] != 3 {
        return Err(LoadError::new_err(format!(
            "vertices must be an (n, 3) array, got shape {shape:?}"
        )));
    }
    let kind: String = a.getattr("dtype")?.getattr("kind")?.extract()?;
    if !matches!(kind.as_str(), "f" | "i" | "u" | "O") {
        let dtype = a.getattr("dtype")?.str()?.to_string();
        return Err(LoadError::new_err(format!(
            "vertices must be numbers, got an array of {dtype}"
        )));
    }
    fits_in_memory("vertices", &a, shape[0], 24, 32)?;
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", np.getattr("float64")?)?;
    let a = np
        .call_method("ascontiguousarray", (a,), Some(&kwargs))
        .map_err(|e| LoadError::new_err(format!("vertices: cannot be made numbers: {e}")))?;
    Ok(a.cast_into::<PyArray2<f64>>()?.readonly())
}

/// `obj` as a C-contiguous (m, 3) int64 array: no copy when it is one already. Any integer
/// dtype is accepted; unsigned values beyond int64 are refused.
fn face_array<'py>(obj: &Bound<'py, PyAny>) -> PyResult<PyReadonlyArray2<'py, i64>> {
    let py = obj.py();
    let np = py.import("numpy")?;
    let a = np
        .call_method1("asarray", (obj,))
        .map_err(|e| LoadError::new_err(format!("faces: cannot be read as an array: {e}")))?;
    let shape: Vec<usize> = a.getattr("shape")?.extract()?;
    if shape.len() != 2 || shape[1] != 3 {
        return Err(LoadError::new_err(format!(
            "faces must be an (m, 3) array of vertex indices (triangles), got shape {shape:?}"
        )));
    }
    let dtype = a.getattr("dtype")?;
    let kind: String = dtype.getattr("kind")?.extract()?;
    if !matches!(kind.as_str(), "i" | "u") {
        return Err(LoadError::new_err(format!(
            "faces must be an integer array, got {}",
            dtype.str()?
        )));
    }
    if kind == "u" && shape[0] > 0 {
        let max: u64 = a.call_method0("max")?.call_method0("item")?.extract()?;
        if max > i64::MAX as u64 {
            // Named like every other index out of range, by its triangle (the first holding
            // it: numpy's argmax over the flat array).
            let flat: usize = a.call_method0("argmax")?.extract()?;
            return Err(LoadError::new_err(format!(
                "triangle {} uses vertex {max}, beyond any vertex of an array",
                flat / 3
            )));
        }
    }
    fits_in_memory("faces", &a, shape[0], 24, 64)?;
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", np.getattr("int64")?)?;
    // A copy that cannot be made (numpy's MemoryError) is named as the vertices' is.
    let a = np
        .call_method("ascontiguousarray", (a,), Some(&kwargs))
        .map_err(|e| LoadError::new_err(format!("faces: cannot be made indices: {e}")))?;
    Ok(a.cast_into::<PyArray2<i64>>()?.readonly())
}

/// Refuses, before any copy, an array of `rows` rows whose copy (`copy_bytes` a row, when
/// it is not already C-contiguous of 8-byte items) and the part's own memory for it
/// (`part_bytes` a row, at least) would not fit in the memory the system has available:
/// an array that numpy only pretends to hold (`broadcast_to`) would else be copied until
/// the system kills the process.
fn fits_in_memory(
    what: &str,
    a: &Bound<'_, PyAny>,
    rows: usize,
    copy_bytes: u64,
    part_bytes: u64,
) -> PyResult<()> {
    let Some(available) = memory_available() else {
        return Ok(());
    };
    let flags = a.getattr("flags")?;
    let contiguous: bool = flags.getattr("c_contiguous")?.extract()?;
    let itemsize: u64 = a.getattr("itemsize")?.extract()?;
    let copy = if contiguous && itemsize == 8 {
        0
    } else {
        copy_bytes
    };
    let need = rows as u64 * (copy + part_bytes);
    if need > available {
        let gb = |b: u64| b as f64 / 1e9;
        return Err(LoadError::new_err(format!(
            "{what}: {rows} rows need about {:.1} GB to build the part, more than the {:.1} GB of memory available",
            gb(need),
            gb(available)
        )));
    }
    Ok(())
}

/// The memory the system can give without swapping, bytes (`MemAvailable` of
/// /proc/meminfo); `None` where it cannot be read.
fn memory_available() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Rows of three from a C-contiguous (n, 3) array.
fn rows<'a, T: numpy::Element>(a: &'a PyReadonlyArray2<'_, T>) -> PyResult<&'a [[T; 3]]> {
    let flat = a.as_slice()?;
    // SAFETY: `[T; 3]` has the size of three `T` and the alignment of `T`, and the array
    // is C-contiguous with three columns, so its data is `len / 3` such rows.
    Ok(unsafe { std::slice::from_raw_parts(flat.as_ptr().cast::<[T; 3]>(), flat.len() / 3) })
}

/// Builds a part from arrays: the GIL is released while they are read and welded, so they
/// must not be changed by another thread meanwhile (as for numpy's own operations).
pub(crate) fn part_from_arrays(
    vertices: &Bound<'_, PyAny>,
    faces: &Bound<'_, PyAny>,
    units: Units,
) -> PyResult<Part> {
    let py = vertices.py();
    let t = Instant::now();
    let v = vertex_array(vertices)?;
    let f = face_array(faces)?;
    let (vr, fr) = (rows(&v)?, rows(&f)?);
    let (mesh, map) = detached(py, || {
        let mesh = mesh::from_arrays(vr, fr, units).map_err(|e| PyErrBox::Load(e.to_string()))?;
        let map = mesh::vertex_map(vr, &mesh.mesh, units);
        Ok((mesh, map))
    })?;
    Ok(Part {
        mesh: Arc::new(mesh),
        input: Input {
            path: None,
            sample: None,
            bytes: 0,
        },
        load_s: t.elapsed().as_secs_f64(),
        vertex_map: Some(Arc::new(map)),
    })
}

/// Any object with `.vertices` and `.faces` (a `trimesh.Trimesh`) as a part.
pub(crate) fn part_from_object(obj: &Bound<'_, PyAny>, units: Units) -> PyResult<Part> {
    let (Ok(v), Ok(f)) = (obj.getattr("vertices"), obj.getattr("faces")) else {
        return Err(LoadError::new_err(format!(
            "cannot study a {}: give a path, a moldgate.Part, or an object with .vertices and .faces (a trimesh.Trimesh)",
            obj.get_type().name()?
        )));
    };
    part_from_arrays(&v, &f, units)
}

/// A read-only numpy view of `rows` that keeps `owner` alive (no copy).
fn view<'py, T: numpy::Element>(
    owner: Bound<'py, PyAny>,
    flat: &[T],
) -> PyResult<Bound<'py, PyArray2<T>>> {
    let n = flat.len() / 3;
    let v = ArrayView2::from_shape((n, 3), flat).expect("three values a row");
    // SAFETY: the data is owned by the part behind `owner` (an `Arc` never changed after
    // construction), which the array keeps alive; the array is made read-only below.
    let a = unsafe { PyArray2::borrow_from_array(&v, owner) };
    let kwargs = PyDict::new(a.py());
    kwargs.set_item("write", false)?;
    a.call_method("setflags", (), Some(&kwargs))?;
    Ok(a)
}

#[pymethods]
impl Part {
    /// Part(vertices, faces, units="mm")
    /// --
    ///
    /// A part from an (n, 3) array of vertex positions (any numbers, read as float64) and
    /// an (m, 3) array of triangles as vertex indices (any integer dtype), in `units`.
    /// Corners are welded by exact position like a file's facets.
    #[new]
    #[pyo3(signature = (vertices, faces, units = UnitsArg(Units::Mm)))]
    fn new(
        vertices: &Bound<'_, PyAny>,
        faces: &Bound<'_, PyAny>,
        units: UnitsArg,
    ) -> PyResult<Part> {
        guarded(|| part_from_arrays(vertices, faces, units.0))
    }

    /// Part.from_trimesh(mesh, units="mm")
    /// --
    ///
    /// A part from any object with `.vertices` and `.faces` (a `trimesh.Trimesh`): its
    /// arrays are read in place, without a copy.
    #[staticmethod]
    #[pyo3(signature = (mesh, units = UnitsArg(Units::Mm)))]
    fn from_trimesh(mesh: &Bound<'_, PyAny>, units: UnitsArg) -> PyResult<Part> {
        guarded(|| part_from_object(mesh, units.0))
    }

    /// A part tessellated from a STEP or IGES file (`moldgate.load`): its report names the
    /// file.
    #[staticmethod]
    fn _tessellated(
        vertices: &Bound<'_, PyAny>,
        faces: &Bound<'_, PyAny>,
        path: String,
        bytes: u64,
        load_s: f64,
    ) -> PyResult<Part> {
        guarded(|| {
            let mut p = part_from_arrays(vertices, faces, Units::Mm)?;
            // The arrays are gmsh's, not the caller's.
            p.vertex_map = None;
            p.input = Input {
                path: Some(path),
                sample: None,
                bytes,
            };
            p.load_s += load_s;
            Ok(p)
        })
    }

    /// For a part built from arrays (`Part(vertices, faces)`, a trimesh), the number of the
    /// part's vertex at each given vertex's position, an int64 array as long as the given
    /// vertices; -1 where no triangle uses the vertex. Welding numbers the part's vertices
    /// by first use and merges repeated positions, so a per-vertex field of a study reads
    /// on the given mesh as `field[vertex_map]` (where `vertex_map >= 0`). None for a part
    /// read from a file.
    #[getter]
    fn vertex_map<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<i64>>> {
        self.vertex_map
            .as_ref()
            .map(|m| PyArray1::from_slice(py, m))
    }

    /// Welded vertex positions in mm, a read-only (n, 3) float64 view (no copy).
    #[getter]
    fn vertices<'py>(slf: Bound<'py, Self>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let flat: &[f64] = {
            let v = &slf.get().mesh.mesh.vertices;
            // SAFETY: `DVec3` is `#[repr(C)]` of three f64, so a vertex list is 3 n f64.
            unsafe { std::slice::from_raw_parts(v.as_ptr().cast::<f64>(), 3 * v.len()) }
        };
        view(slf.into_any(), flat)
    }

    /// Triangles as vertex indices, a read-only (m, 3) uint32 view (no copy).
    #[getter]
    fn faces<'py>(slf: Bound<'py, Self>) -> PyResult<Bound<'py, PyArray2<u32>>> {
        let flat: &[u32] = slf.get().mesh.mesh.triangles.as_flattened();
        // The slice borrows from the part, which the view keeps alive.
        let flat: &[u32] = unsafe { std::slice::from_raw_parts(flat.as_ptr(), flat.len()) };
        view(slf.into_any(), flat)
    }

    /// What loading found: format, unit, counts (facets, vertices, triangles, open and
    /// non-manifold edges, bodies), area and bounds, as a dict.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        crate::study::json_to_py(
            py,
            &serde_json::to_string(&self.mesh.stats).unwrap_or_default(),
        )
    }

    /// Problems that do not stop the work (open edges, several bodies, a size that suggests
    /// another unit), one sentence each, naming this package's keywords.
    #[getter]
    fn warnings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let words = self
            .mesh
            .warnings
            .iter()
            .map(|w| moldgate::study::keyword_words(w, "True"));
        PyList::new(py, words)
    }

    /// The file it was read from, or None.
    #[getter]
    fn path(&self) -> Option<String> {
        self.input.path.clone()
    }

    /// The welded mesh as the bytes of a binary STL file, in mm.
    fn to_stl<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyBytes>> {
        let mut out = Vec::new();
        self.mesh
            .mesh
            .write_stl(&mut out)
            .map_err(|e| crate::InternalError::new_err(e.to_string()))?;
        Ok(pyo3::types::PyBytes::new(py, &out))
    }

    fn __repr__(&self) -> String {
        let s = &self.mesh.stats;
        format!(
            "<moldgate.Part {} triangles, {} vertices{}>",
            s.triangles,
            s.vertices,
            self.input
                .path
                .as_deref()
                .map(|p| format!(" from {p}"))
                .unwrap_or_default()
        )
    }
}
