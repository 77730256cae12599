//! `linlight._linlight`: the native part of the `linlight` Python package (maturin + PyO3).
//!
//! Thin wrappers over the workspace's crates: the line samplers (`linlight-sampling`), the image
//! format (`linlight-imagefile`), the image comparison of `linlight compare` and the renderer of
//! `linlight render`. The Python side (`python/linlight/__init__.py`) broadcasts arrays and
//! documents the API; every check that can refuse input is here or in the crates, and raises
//! `linlight.LinlightError` with the command line's message. Every entry point runs inside
//! `guarded`, so that a Rust panic becomes a `LinlightError` naming the call, never an unwinding
//! across the boundary.

use std::collections::BTreeMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

use glam::{Mat3, Vec3};
use linlight_brdf::ltc::GgxLtcTable;
use linlight_imagefile::{Image, Metadata};
use linlight_render::scene::Scene;
use linlight_render::shading::shading_frame;
use linlight_render::xml;
use linlight_render::{record_inputs, render as render_scene, Cylinders, LightSelection, Method};
use linlight_sampling::ltc::LtcLine;
use linlight_sampling::noise::Noise;
use linlight_sampling::{
    unit_normal, LineSampler, Prepared as PreparedTechnique, Segment, Technique,
};
use linlight_verify::image_stats::{compare as compare_images, CompareConfig};
use numpy::ndarray::{Array1, Array2, Array3, ArrayView2, ArrayView3};
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArray3, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3,
};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

create_exception!(
    _linlight,
    LinlightError,
    PyValueError,
    "Unusable input: the message is the one the `linlight` command prints (without its prefix)."
);

fn err(msg: impl std::fmt::Display) -> PyErr {
    LinlightError::new_err(msg.to_string())
}

/// Runs `f`, turning a panic into a `LinlightError` that names `what`.
fn guarded<T>(what: &str, f: impl FnOnce() -> Result<T, String>) -> PyResult<T> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => Err(err(e)),
        Err(payload) => {
            let msg = payload
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "unknown panic".into());
            Err(err(format!(
                "internal error in {what} (please report it): {msg}"
            )))
        }
    }
}

/// The name of LTC line sampling, the technique that is not a [`Technique`] (it needs a view
/// direction and a matrix A besides the light and the shading point).
const LTC: &str = "ltc";

fn technique(name: &str) -> Result<Technique, String> {
    if name == LTC {
        return Err(format!(
            "technique '{LTC}' needs a view direction and alpha or ltc_a (prepare(\"{LTC}\", \
             ..., view=..., alpha=...))"
        ));
    }
    Technique::from_name(name).ok_or_else(|| {
        let names: Vec<_> = Technique::ALL.iter().map(|t| t.name()).collect();
        format!(
            "unknown technique '{name}' (expected one of: {}, {LTC})",
            names.join(", ")
        )
    })
}

/// Rows of an (N, 3) array as vectors; `name` and the row index in the error of a non-finite
/// value.
fn vectors(name: &str, a: ArrayView2<'_, f32>, n: usize) -> Result<Vec<Vec3>, String> {
    if a.ncols() != 3 || a.nrows() != n {
        return Err(format!(
            "{name} has shape ({}, {}), expected ({n}, 3)",
            a.nrows(),
            a.ncols()
        ));
    }
    a.rows()
        .into_iter()
        .enumerate()
        .map(|(i, r)| {
            let v = Vec3::new(r[0], r[1], r[2]);
            if v.is_finite() {
                Ok(v)
            } else {
                Err(format!("{name}[{i}] = {v} is not finite"))
            }
        })
        .collect()
}

/// Directions (N, M, 3) and densities (N, M).
type Samples<'py> = (Bound<'py, PyArray3<f32>>, Bound<'py, PyArray2<f32>>);

/// One prepared sampler: a [`Technique`]'s or LTC line sampling's.
enum Sampler {
    Line(PreparedTechnique),
    Ltc(LtcLine),
}

impl Sampler {
    fn get(&self) -> &dyn LineSampler {
        match self {
            Sampler::Line(s) => s,
            Sampler::Ltc(s) => s,
        }
    }
}

/// Prepared samplers of one technique for N (light, shading point) pairs.
#[pyclass(module = "linlight._linlight", frozen)]
struct Prepared {
    /// One of [`techniques`].
    technique: &'static str,
    /// `None` where the light contributes nothing at that point (no sample, pdf 0).
    samplers: Vec<Option<Sampler>>,
}

#[pymethods]
impl Prepared {
    /// The technique's name.
    #[getter]
    fn technique(&self) -> &'static str {
        self.technique
    }

    fn __len__(&self) -> usize {
        self.samplers.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "Prepared(technique='{}', n={}, valid={})",
            self.technique,
            self.samplers.len(),
            self.samplers.iter().filter(|s| s.is_some()).count()
        )
    }

    /// (N,) bool: where the light contributes at the point (the others sample nothing).
    fn valid<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        let v: Array1<bool> = self.samplers.iter().map(Option::is_some).collect();
        v.into_pyarray(py)
    }

    /// ξ of shape (N, M) in [0, 1) → directions (N, M, 3) and densities per radius (N, M);
    /// zero where the row is not valid.
    fn sample<'py>(
        &self,
        py: Python<'py>,
        xi: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<Samples<'py>> {
        let xi = xi.as_array();
        let (n, m) = xi.dim();
        if n != self.samplers.len() {
            return Err(err(format!(
                "xi has {n} rows but {} samplers were prepared",
                self.samplers.len()
            )));
        }
        if let Some(((i, j), x)) = xi.indexed_iter().find(|(_, &x)| !(0.0..1.0).contains(&x)) {
            return Err(err(format!("xi[{i}, {j}] = {x} is not in [0, 1)")));
        }
        let xi = xi.to_owned();
        let (dirs, pdfs) = py.detach(|| {
            guarded("Prepared.sample", || {
                let mut dirs = Array3::<f32>::zeros((n, m, 3));
                let mut pdfs = Array2::<f32>::zeros((n, m));
                for (i, s) in self.samplers.iter().enumerate() {
                    let Some(s) = s.as_ref().map(Sampler::get) else {
                        continue;
                    };
                    for j in 0..m {
                        let (d, p) = s.sample_with_pdf(xi[[i, j]]);
                        for c in 0..3 {
                            dirs[[i, j, c]] = d[c];
                        }
                        pdfs[[i, j]] = p;
                    }
                }
                Ok((dirs, pdfs))
            })
        })?;
        Ok((dirs.into_pyarray(py), pdfs.into_pyarray(py)))
    }

    /// Directions (N, M, 3) → densities per radius (N, M) (0 outside the support and where
    /// the row is not valid).
    fn pdf<'py>(
        &self,
        py: Python<'py>,
        directions: PyReadonlyArray3<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let (dirs, n, m) = self.directions(directions.as_array())?;
        let out = py.detach(|| {
            guarded("Prepared.pdf", || {
                Ok(self.per_direction(&dirs, n, m, |s, d| s.pdf(d)))
            })
        })?;
        Ok(out.into_pyarray(py))
    }

    /// Directions (N, M, 3) → the technique's inverse ξ(ω) (N, M); NaN where the technique has
    /// no inverse, the row is not valid or the direction is outside the support.
    fn inverse<'py>(
        &self,
        py: Python<'py>,
        directions: PyReadonlyArray3<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let (dirs, n, m) = self.directions(directions.as_array())?;
        let out = py.detach(|| {
            guarded("Prepared.inverse", || {
                let mut out = Array2::<f32>::from_elem((n, m), f32::NAN);
                for (i, s) in self.samplers.iter().enumerate() {
                    let Some(s) = s.as_ref().map(Sampler::get) else {
                        continue;
                    };
                    for j in 0..m {
                        if let Some(x) = s.inverse(dirs[i * m + j]) {
                            out[[i, j]] = x;
                        }
                    }
                }
                Ok(out)
            })
        })?;
        Ok(out.into_pyarray(py))
    }
}

impl Prepared {
    fn directions(&self, d: ArrayView3<'_, f32>) -> PyResult<(Vec<Vec3>, usize, usize)> {
        let (n, m, c) = d.dim();
        if n != self.samplers.len() || c != 3 {
            return Err(err(format!(
                "directions has shape ({n}, {m}, {c}), expected ({}, M, 3)",
                self.samplers.len()
            )));
        }
        let flat = d
            .to_shape((n * m, 3))
            .map_err(|e| err(format!("directions: {e}")))?;
        let dirs = vectors("directions (flattened)", flat.view(), n * m).map_err(err)?;
        Ok((dirs, n, m))
    }

    fn per_direction(
        &self,
        dirs: &[Vec3],
        n: usize,
        m: usize,
        f: impl Fn(&dyn LineSampler, Vec3) -> f32,
    ) -> Array2<f32> {
        let mut out = Array2::<f32>::zeros((n, m));
        for (i, s) in self.samplers.iter().enumerate() {
            let Some(s) = s.as_ref().map(Sampler::get) else {
                continue;
            };
            for j in 0..m {
                out[[i, j]] = f(s, dirs[i * m + j]);
            }
        }
        out
    }
}

/// The names of every technique `prepare` accepts (`ltc` through `prepare_ltc`).
#[pyfunction]
fn techniques() -> Vec<&'static str> {
    let mut v: Vec<&'static str> = Technique::ALL.iter().map(|t| t.name()).collect();
    v.push(LTC);
    v
}

/// The segments of N rows, refusing a zero-length one.
fn segments(b: &[Vec3], e: &[Vec3]) -> Result<Vec<Segment>, String> {
    b.iter()
        .zip(e)
        .enumerate()
        .map(|(i, (&b, &e))| {
            if b == e {
                Err(format!(
                    "light {i}: begin and end are the same point {b} (a segment needs two)"
                ))
            } else {
                Ok(Segment::new(b, e))
            }
        })
        .collect()
}

/// Prepares `technique` for N (light, shading point) pairs: `begin`, `end`, `x`, `n` of shape
/// (N, 3) float32 (broadcasting is done by the Python wrapper).
#[pyfunction]
fn prepare(
    py: Python<'_>,
    technique: &str,
    begin: PyReadonlyArray2<'_, f32>,
    end: PyReadonlyArray2<'_, f32>,
    x: PyReadonlyArray2<'_, f32>,
    n: PyReadonlyArray2<'_, f32>,
) -> PyResult<Prepared> {
    let t = self::technique(technique).map_err(err)?;
    let rows = begin.as_array().nrows();
    let b = vectors("begin", begin.as_array(), rows).map_err(err)?;
    let e = vectors("end", end.as_array(), rows).map_err(err)?;
    let x = vectors("x", x.as_array(), rows).map_err(err)?;
    let nn = vectors("n", n.as_array(), rows).map_err(err)?;
    let seg = segments(&b, &e).map_err(err)?;
    let samplers = py.detach(|| {
        guarded("prepare", || {
            Ok((0..rows)
                .map(|i| t.prepare(&seg[i], x[i], nn[i]).map(Sampler::Line))
                .collect())
        })
    })?;
    Ok(Prepared {
        technique: t.name(),
        samplers,
    })
}

/// Where LTC line sampling takes its matrix A (shading frame → cosine space) from.
enum LtcMatrices {
    /// GGX roughness per row: A from the fitted table at (α, cos θ_v), as the renderer looks it
    /// up.
    Ggx(Vec<f32>),
    /// A per row, given (rows of A in shading-frame coordinates).
    Given(Vec<Mat3>),
}

/// Prepares LTC line sampling for N rows: `begin`, `end`, `x`, `n`, `view` of shape (N, 3)
/// float32 and either `alpha` (N,) or `ltc_a` (N, 3, 3) (broadcasting is done by the Python
/// wrapper). The shading frame is the renderer's: x̂ = normalize(v − (n·v)n), ŷ = n × x̂, n (n
/// normalised); a row whose view is not above the surface (n·v ≤ 0) is not valid.
#[pyfunction]
#[pyo3(signature = (begin, end, x, n, view, alpha = None, ltc_a = None))]
#[allow(clippy::too_many_arguments)]
fn prepare_ltc(
    py: Python<'_>,
    begin: PyReadonlyArray2<'_, f32>,
    end: PyReadonlyArray2<'_, f32>,
    x: PyReadonlyArray2<'_, f32>,
    n: PyReadonlyArray2<'_, f32>,
    view: PyReadonlyArray2<'_, f32>,
    alpha: Option<PyReadonlyArray1<'_, f32>>,
    ltc_a: Option<PyReadonlyArray3<'_, f32>>,
) -> PyResult<Prepared> {
    let rows = begin.as_array().nrows();
    let b = vectors("begin", begin.as_array(), rows).map_err(err)?;
    let e = vectors("end", end.as_array(), rows).map_err(err)?;
    let x = vectors("x", x.as_array(), rows).map_err(err)?;
    let nn = vectors("n", n.as_array(), rows).map_err(err)?;
    let v = vectors("view", view.as_array(), rows).map_err(err)?;
    let seg = segments(&b, &e).map_err(err)?;
    let matrices =
        match (alpha, ltc_a) {
            (Some(alpha), None) => {
                let alpha = alpha.as_array();
                if alpha.len() != rows {
                    return Err(err(format!(
                        "alpha has shape ({},), expected ({rows},)",
                        alpha.len()
                    )));
                }
                if let Some((i, a)) = alpha
                    .iter()
                    .enumerate()
                    .find(|(_, a)| !(a.is_finite() && **a > 0.0))
                {
                    return Err(err(format!(
                        "alpha[{i}] = {a} is not a GGX roughness (finite and > 0)"
                    )));
                }
                LtcMatrices::Ggx(alpha.to_vec())
            }
            (None, Some(a)) => {
                let a = a.as_array();
                if a.dim() != (rows, 3, 3) {
                    let (r, p, q) = a.dim();
                    return Err(err(format!(
                        "ltc_a has shape ({r}, {p}, {q}), expected ({rows}, 3, 3)"
                    )));
                }
                let mut out = Vec::with_capacity(rows);
                for (i, m) in a.outer_iter().enumerate() {
                    let r = |k: usize| [m[[k, 0]], m[[k, 1]], m[[k, 2]]];
                    // Rows in, as the external protocol's `ltc_a`; glam's matrices are columns.
                    let a = Mat3::from_cols_array_2d(&[r(0), r(1), r(2)]).transpose();
                    if !a.is_finite() {
                        return Err(err(format!("ltc_a[{i}] = {a} is not finite")));
                    }
                    out.push(a);
                }
                LtcMatrices::Given(out)
            }
            (Some(_), Some(_)) => {
                return Err(err(
                    "ltc takes alpha (A from the fitted GGX table) or ltc_a (A given), not both",
                ))
            }
            (None, None) => return Err(err(
                "ltc needs alpha (GGX roughness: A from the fitted table) or ltc_a (the matrix A)",
            )),
        };
    let samplers = py.detach(|| {
        guarded("prepare", || {
            Ok((0..rows)
                .map(|i| {
                    let (n, v_unit) = (unit_normal(nn[i])?, unit_normal(v[i])?);
                    // Unit and finite: the dot product is a number.
                    let cos_theta_v = n.dot(v_unit);
                    if cos_theta_v <= 0.0 {
                        return None;
                    }
                    // The frame depends on the view's direction only: taken from the view as
                    // given, it is the frame of the external protocol's configurations (and of
                    // the renderer, whose views are unit vectors) to the last bit.
                    let (frame, _) = shading_frame(n, v[i]);
                    let a = match &matrices {
                        LtcMatrices::Ggx(alpha) => {
                            GgxLtcTable::ggx().lookup(alpha[i], cos_theta_v).0
                        }
                        LtcMatrices::Given(a) => a[i],
                    };
                    LtcLine::prepare(&seg[i], x[i], frame, a).map(Sampler::Ltc)
                })
                .collect())
        })
    })?;
    Ok(Prepared {
        technique: LTC,
        samplers,
    })
}

/// An image of the project's format: mean and variance of the mean per pixel (H, W, 3) and its
/// header.
#[pyclass(module = "linlight._linlight", name = "Image", frozen)]
struct PyImage {
    image: Image,
}

fn planes(img_w: usize, img_h: usize, v: &[[f32; 3]]) -> Array3<f32> {
    Array3::from_shape_fn((img_h, img_w, 3), |(y, x, c)| v[y * img_w + x][c])
}

fn pixels(name: &str, a: ArrayView3<'_, f32>) -> Result<(usize, usize, Vec<[f32; 3]>), String> {
    let (h, w, c) = a.dim();
    if c != 3 || h == 0 || w == 0 {
        return Err(format!(
            "{name} has shape ({h}, {w}, {c}), expected (H, W, 3)"
        ));
    }
    let v = a
        .outer_iter()
        .flat_map(|row| {
            row.outer_iter()
                .map(|p| [p[0], p[1], p[2]])
                .collect::<Vec<_>>()
        })
        .collect();
    Ok((w, h, v))
}

fn metadata(header: BTreeMap<String, String>) -> Result<Metadata, String> {
    let mut meta = Metadata::default();
    for (k, v) in header {
        let bad = |what: &str| format!("header['{k}'] = '{v}' is not {what}");
        match k.as_str() {
            "dof" => meta.dof = v.parse().map_err(|_| bad("a number"))?,
            "spp" => meta.spp = v.parse().map_err(|_| bad("a whole number ≥ 0"))?,
            "passes" => meta.passes = v.parse().map_err(|_| bad("a whole number ≥ 0"))?,
            "renderer" => meta.renderer = v,
            "scene_sha256" => meta.scene_sha256 = v,
            _ => {
                meta.extra.insert(k, v);
            }
        }
    }
    Ok(meta)
}

#[pymethods]
impl PyImage {
    /// Image(mean, var, header): `mean` and `var` (H, W, 3) float32; `header` maps names to
    /// strings (`dof`, `spp`, `passes` are parsed as numbers). Checked as every image file is:
    /// finite means, finite non-negative variances, finite non-negative dof.
    #[new]
    #[pyo3(signature = (mean, var, header))]
    fn new(
        mean: PyReadonlyArray3<'_, f32>,
        var: PyReadonlyArray3<'_, f32>,
        header: BTreeMap<String, String>,
    ) -> PyResult<Self> {
        let (w, h, m) = pixels("mean", mean.as_array()).map_err(err)?;
        let (wv, hv, v) = pixels("var", var.as_array()).map_err(err)?;
        if (w, h) != (wv, hv) {
            return Err(err(format!("mean is {w}×{h} but var is {wv}×{hv} pixels")));
        }
        let mut image = Image::new(w, h);
        image.mean = m;
        image.var = v;
        image.meta = metadata(header).map_err(err)?;
        image.validate().map_err(err)?;
        Ok(PyImage { image })
    }

    /// Reads an EXR of the project's format (the checks of `linlight info`).
    #[staticmethod]
    fn read(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let image = py.detach(|| {
            guarded("Image.read", || {
                Image::read(&path).map_err(|e| e.to_string())
            })
        })?;
        Ok(PyImage { image })
    }

    /// Writes the image as EXR (the bytes `linlight` writes for the same pixels and header).
    fn write(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        py.detach(|| {
            guarded("Image.write", || {
                self.image.write(&path).map_err(|e| e.to_string())
            })
        })
    }

    #[getter]
    fn width(&self) -> usize {
        self.image.width
    }

    #[getter]
    fn height(&self) -> usize {
        self.image.height
    }

    /// Pixel means, (H, W, 3) float32, row 0 at the top.
    #[getter]
    fn mean<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f32>> {
        planes(self.image.width, self.image.height, &self.image.mean).into_pyarray(py)
    }

    /// Variance of each pixel mean, (H, W, 3) float32.
    #[getter]
    fn var<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f32>> {
        planes(self.image.width, self.image.height, &self.image.var).into_pyarray(py)
    }

    /// The heavy-tail share per pixel (H, W, 3), or None when the file has none.
    #[getter]
    fn tail<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray3<f32>>> {
        let t = self.image.tail.as_ref()?;
        Some(planes(self.image.width, self.image.height, t).into_pyarray(py))
    }

    /// Header: `dof` (float), `spp`, `passes` (int), `renderer`, `scene_sha256` and every other
    /// attribute (str).
    #[getter]
    fn header<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let m = &self.image.meta;
        d.set_item("dof", m.dof)?;
        d.set_item("spp", m.spp)?;
        d.set_item("passes", m.passes)?;
        d.set_item("renderer", &m.renderer)?;
        d.set_item("scene_sha256", &m.scene_sha256)?;
        for (k, v) in &m.extra {
            d.set_item(k, v)?;
        }
        Ok(d)
    }

    fn __repr__(&self) -> String {
        format!(
            "Image({}x{}, spp={}, passes={}, dof={}, renderer='{}')",
            self.image.width,
            self.image.height,
            self.image.meta.spp,
            self.image.meta.passes,
            self.image.meta.dof,
            self.image.meta.renderer
        )
    }
}

/// The comparison of `linlight compare A B`: its JSON report (the text `--json` writes) and the
/// per-pixel z map (H, W, 3).
#[pyfunction]
#[pyo3(signature = (a, b, alpha = 0.01, tolerance = 0.005, tile = 16, allow_different_scenes = false))]
fn compare<'py>(
    py: Python<'py>,
    a: &PyImage,
    b: &PyImage,
    alpha: f64,
    tolerance: f64,
    tile: usize,
    allow_different_scenes: bool,
) -> PyResult<(String, Bound<'py, PyArray3<f32>>)> {
    let cfg = CompareConfig {
        alpha,
        tolerance,
        tile,
        allow_different_scenes,
        ..CompareConfig::default()
    };
    let (a, b) = (&a.image, &b.image);
    let (text, z) = py.detach(|| {
        guarded("compare", || {
            let cmp = compare_images(a, b, &cfg).map_err(|e| e.to_string())?;
            let value = linlight::compare_report::report_json(&cmp, a, b)?;
            let text = serde_json::to_string_pretty(&value)
                .map_err(|e| format!("cannot serialise the report: {e}"))?;
            Ok((text, planes(a.width, a.height, &cmp.maps.z)))
        })
    })?;
    Ok((text, z.into_pyarray(py)))
}

/// `linlight render`'s options, checked as the command checks them.
struct RenderRequest {
    scene: PathBuf,
    overrides: Vec<(String, String)>,
    spp: Option<u32>,
    passes: u32,
    seed: Option<u64>,
    method: Method,
    noise: Noise,
    light_samples: Option<u32>,
    lights: LightSelection,
    cylinders: Cylinders,
    threads: Option<usize>,
}

/// The keyword arguments of `render` as given (checked by `RenderRequest::parse`).
struct RenderArgs<'a> {
    scene: PathBuf,
    defines: Vec<(String, String)>,
    spp: Option<u32>,
    passes: u32,
    seed: Option<u64>,
    technique: &'a str,
    noise: &'a str,
    mis: Option<&'a str>,
    light_samples: Option<u32>,
    lights: &'a str,
    cylinders: &'a str,
    cylinder_technique: &'a str,
    cylinder_mis: &'a str,
    threads: Option<usize>,
}

impl RenderRequest {
    /// The checks of `linlight render`'s command line, in its order and with its messages.
    fn parse(a: RenderArgs<'_>) -> Result<Self, String> {
        let RenderArgs {
            scene,
            defines,
            spp,
            passes,
            seed,
            technique,
            noise,
            mis,
            light_samples,
            lights,
            cylinders,
            cylinder_technique,
            cylinder_mis,
            threads,
        } = a;
        let method = match (mis, Method::from_technique_name(technique)?) {
        (None, m) => m,
        (Some(h), Method::Mis(_)) => Method::Mis(h.parse()?),
        (Some(_), m) => {
            return Err(format!(
                "--mis chooses the heuristic of --technique mis; it does not apply to --technique {}",
                m.technique_name()
            ))
        }
    };
        let noise: Noise = noise.parse()?;
        let lights: LightSelection = lights.parse().map_err(|e| format!("--lights: {e}"))?;
        let cylinders =
            linlight::outputs::cylinders(cylinders, cylinder_technique, cylinder_mis, |name| {
                format!("--{name}")
            })?;
        if light_samples == Some(0) {
            return Err("--light-samples must be at least 1".into());
        }
        if spp == Some(0) || passes == 0 {
            return Err("--spp and --passes must be at least 1".into());
        }
        if let Some((k, _)) = defines.iter().find(|(k, _)| k.is_empty()) {
            return Err(format!("-D expects NAME=VALUE, got '{k}'"));
        }
        if !scene.is_file() {
            return Err(format!("cannot read scene file {}", scene.display()));
        }
        Ok(RenderRequest {
            scene,
            overrides: defines,
            spp,
            passes,
            seed,
            method,
            noise,
            light_samples,
            lights,
            cylinders,
            threads,
        })
    }
}

/// Loads, checks and renders; returns the image (header as `linlight render` writes it) and the
/// warnings the command prints.
fn render_image(req: &RenderRequest) -> Result<(Image, Vec<String>), String> {
    let scene: Scene = xml::load_scene(&req.scene, &req.overrides).map_err(|e| e.to_string())?;
    let (opts, warnings) = linlight::outputs::render_options(
        &scene,
        linlight::outputs::RenderChoices {
            spp: req.spp,
            passes: req.passes,
            seed: req.seed,
            method: req.method,
            light_samples: req.light_samples,
            lights: req.lights,
            noise: req.noise,
            cylinders: req.cylinders,
        },
        |name| name.replace('-', "_"),
        true,
    );
    linlight::outputs::check_radiance(&scene)?;
    let pool = linlight::outputs::thread_pool(req.threads)?;
    let mut image = pool
        .install(|| render_scene(&scene, &opts, &|_, _| {}))
        .map_err(|e| e.to_string())?;
    record_inputs(&mut image.meta, &req.scene, &req.overrides);
    if let Some(effects) = linlight::outputs::finite_radius_effect(&scene, opts.cylinders) {
        image
            .meta
            .extra
            .insert("finite_radius_effect".into(), effects);
    }
    Ok((image, warnings))
}

/// Renders a scene as `linlight render` does: the image and the warnings the command prints.
#[pyfunction]
#[pyo3(signature = (scene, defines, spp = None, passes = 1, seed = None, technique = "mis",
    noise = "white", mis = None, light_samples = None, lights = "every", cylinders = "exact",
    cylinder_technique = "projected", cylinder_mis = "balance", threads = None))]
#[allow(clippy::too_many_arguments)]
fn render(
    py: Python<'_>,
    scene: PathBuf,
    defines: Vec<(String, String)>,
    spp: Option<u32>,
    passes: u32,
    seed: Option<u64>,
    technique: &str,
    noise: &str,
    mis: Option<&str>,
    light_samples: Option<u32>,
    lights: &str,
    cylinders: &str,
    cylinder_technique: &str,
    cylinder_mis: &str,
    threads: Option<usize>,
) -> PyResult<(PyImage, Vec<String>)> {
    let req = RenderRequest::parse(RenderArgs {
        scene,
        defines,
        spp,
        passes,
        seed,
        technique,
        noise,
        mis,
        light_samples,
        lights,
        cylinders,
        cylinder_technique,
        cylinder_mis,
        threads,
    })
    .map_err(err)?;
    let (image, warnings) = py.detach(|| guarded("render", || render_image(&req)))?;
    Ok((PyImage { image }, warnings))
}

#[pymodule]
fn _linlight(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("LinlightError", m.py().get_type::<LinlightError>())?;
    m.add_class::<Prepared>()?;
    m.add_class::<PyImage>()?;
    m.add_function(wrap_pyfunction!(techniques, m)?)?;
    m.add_function(wrap_pyfunction!(prepare, m)?)?;
    m.add_function(wrap_pyfunction!(prepare_ltc, m)?)?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    Ok(())
}
