//! `tetsim.Material`: a constitutive model evaluated on many deformation gradients at once.

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use tetsim::material::{Definiteness, Lame, Material as _, Model};
use tetsim::math::Mat3;
use tetsim::scene::units::Kind;

use crate::args::{self, Signature};
use crate::arrays;
use crate::errors::{Fields, argument};

/// A constitutive model: Ψ(F) (J/m³), P(F) = ∂Ψ/∂F (Pa) and ∂P/∂F on arrays of deformation
/// gradients F of shape (k, 3, 3).
///
/// Material(model, youngs_modulus=..., poisson_ratio=...) or Material(model, mu=..., lam=...):
/// the scene's [material] keys (lam is λ, `lambda` being a Python keyword) with the same
/// defaults (E = 1e5 Pa, ν = 0.3), checks and units (youngs_modulus="1.2 MPa"). Models: neo-hookean, neo-hookean-clamped,
/// corotated, stable-neo-hookean, st-venant-kirchhoff, mooney-rivlin, linear.
/// inversion_threshold (default 0.1): every model is its formula wherever every principal
/// stretch of F is at least this; below it the model's inversion extension acts. energy, stress
/// and tangent refuse an F holding NaN or inf, and an F whose result overflows.
#[pyclass(module = "tetsim", frozen)]
pub struct Material {
    model: Model,
    lame: Lame,
}

#[pymethods]
impl Material {
    #[new]
    #[pyo3(
        signature = (model=None, *extra, youngs_modulus=None, poisson_ratio=None, mu=None, lam=None, inversion_threshold=None, **unknown),
        text_signature = "(model='neo-hookean', *, youngs_modulus=None, poisson_ratio=None, mu=None, lam=None, inversion_threshold=None)"
    )]
    #[allow(clippy::too_many_arguments)]
    fn new(
        model: Option<&Bound<'_, PyAny>>,
        extra: &Bound<'_, PyTuple>,
        youngs_modulus: Option<&Bound<'_, PyAny>>,
        poisson_ratio: Option<&Bound<'_, PyAny>>,
        mu: Option<&Bound<'_, PyAny>>,
        lam: Option<&Bound<'_, PyAny>>,
        inversion_threshold: Option<&Bound<'_, PyAny>>,
        unknown: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        Signature {
            call: "Material",
            positional: &["model"],
            keyword: &[
                "youngs_modulus",
                "poisson_ratio",
                "mu",
                "lam",
                "inversion_threshold",
            ],
        }
        .check(extra, unknown)?;
        let model = match model {
            Some(m) if !m.is_none() => args::text(m, "model", "a model name, e.g. 'neo-hookean'")?,
            _ => "neo-hookean".to_string(),
        };
        // The scene's own validator checks the values, so a Material refuses exactly what a
        // [material] table would, with the same words; strings with a unit ("1 MPa") are read
        // as the scene reads them.
        let mut material = toml::Table::new();
        material.insert("model".into(), model.into());
        for (key, name, value, kind) in [
            (
                "youngs_modulus",
                "youngs_modulus",
                youngs_modulus,
                Kind::Pressure,
            ),
            ("poisson_ratio", "poisson_ratio", poisson_ratio, Kind::Ratio),
            ("mu", "mu", mu, Kind::Pressure),
            ("lambda", "lam", lam, Kind::Pressure),
            (
                "inversion_threshold",
                "inversion_threshold",
                inversion_threshold,
                Kind::Ratio,
            ),
        ] {
            if let Some(v) = args::optional_real(value, name, kind)? {
                material.insert(key.into(), v.into());
            }
        }
        let text = format!(
            "[mesh]\ngenerator = {{ box = {{ min = [0, 0, 0], max = [1, 1, 1], cells = [1, 1, 1] }} }}\n\n{}",
            toml::to_string(&toml::Table::from_iter([(
                "material".to_string(),
                toml::Value::Table(material)
            )]))
            .map_err(|e| argument("material", e))?
        );
        let scene = tetsim::Scene::parse(&text, "<Material>".as_ref(), ".".as_ref())
            .map_err(material_error)?;
        let (model, _) = tetsim::Scene::material_model(&scene.material).map_err(|m| {
            // The thresholds' messages start with their key.
            match m.split_once(' ') {
                Some(("inversion_threshold", _)) => argument("inversion_threshold", m),
                _ => argument("material", m),
            }
        })?;
        Ok(Material {
            lame: model.lame(),
            model,
        })
    }

    /// The model's scene name, e.g. 'neo-hookean'.
    #[getter]
    fn model(&self) -> &'static str {
        self.model.kind().name()
    }

    /// Lamé μ (shear modulus), Pa.
    #[getter]
    fn mu(&self) -> f64 {
        self.lame.mu
    }

    /// Lamé λ, Pa.
    #[getter]
    fn lam(&self) -> f64 {
        self.lame.lambda
    }

    /// Young's modulus E, Pa.
    #[getter]
    fn youngs_modulus(&self) -> f64 {
        self.lame.youngs_modulus()
    }

    /// Poisson ratio ν.
    #[getter]
    fn poisson_ratio(&self) -> f64 {
        self.lame.poisson_ratio()
    }

    /// The inversion threshold (a stretch), or None for a model without an extension.
    #[getter]
    fn inversion_threshold(&self) -> Option<f64> {
        self.model.inversion_threshold()
    }

    /// Energy density Ψ(F), J/m³: F (k, 3, 3) float64 → (k,) float64.
    #[allow(non_snake_case)]
    #[pyo3(signature = (F=None, *extra, **unknown), text_signature = "(F)")]
    fn energy<'py>(
        &self,
        py: Python<'py>,
        F: Option<&Bound<'py, PyAny>>,
        extra: &Bound<'py, PyTuple>,
        unknown: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let f = gradients("Material.energy", &[], F, extra, unknown)?;
        let model = &self.model;
        let psi: Vec<f64> = py.detach(|| f.iter().map(|f| model.energy_density(f)).collect());
        finite_results("energy", &psi, 1)?;
        let k = psi.len();
        arrays::from_reals(py, psi, &[k])
    }

    /// First Piola-Kirchhoff stress P(F) = ∂Ψ/∂F, Pa: F (k, 3, 3) → (k, 3, 3) float64.
    #[allow(non_snake_case)]
    #[pyo3(signature = (F=None, *extra, **unknown), text_signature = "(F)")]
    fn stress<'py>(
        &self,
        py: Python<'py>,
        F: Option<&Bound<'py, PyAny>>,
        extra: &Bound<'py, PyTuple>,
        unknown: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let f = gradients("Material.stress", &[], F, extra, unknown)?;
        let model = &self.model;
        let p: Vec<Mat3> = py.detach(|| f.iter().map(|f| model.stress(f)).collect());
        let flat: Vec<f64> = p.iter().flat_map(|m| m.iter().copied()).collect();
        finite_results("stress", &flat, 9)?;
        arrays::from_mat3s(py, &p)
    }

    /// The tangent ∂P/∂F, Pa: F (k, 3, 3) → (k, 9, 9) float64 with
    /// tangent[k, 3*i + j, 3*l + m] = ∂P_ij/∂F_lm, so that
    /// (tangent @ dF.reshape(k, 9, 1)).reshape(k, 3, 3) is the stress differential dP.
    ///
    /// definiteness: 'none' (default: the exact derivative), or 'teran', 'analytic', 'abs',
    /// 'adaptive' (the solver's positive semi-definite fixes, [solver] definiteness).
    #[allow(non_snake_case)]
    #[pyo3(
        signature = (F=None, definiteness=None, *extra, **unknown),
        text_signature = "(F, definiteness='none')"
    )]
    fn tangent<'py>(
        &self,
        py: Python<'py>,
        F: Option<&Bound<'py, PyAny>>,
        definiteness: Option<&Bound<'py, PyAny>>,
        extra: &Bound<'py, PyTuple>,
        unknown: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let f = gradients("Material.tangent", &["definiteness"], F, extra, unknown)?;
        let names: Vec<&str> = Definiteness::ALL.iter().map(|d| d.name()).collect();
        let name = match definiteness {
            Some(d) if !d.is_none() => {
                args::text(d, "definiteness", &format!("one of {}", names.join(", ")))?
            }
            _ => "none".to_string(),
        };
        let Some(strategy) = Definiteness::from_name(&name) else {
            return Err(argument(
                "definiteness",
                format!(
                    "unknown definiteness strategy \"{name}\", expected one of {}",
                    names.join(", ")
                ),
            ));
        };
        let model = &self.model;
        let flat: Vec<f64> = py.detach(|| {
            let mut out = vec![0.0; 81 * f.len()];
            for (f, block) in f.iter().zip(out.chunks_exact_mut(81)) {
                let tangent = model.tangent(f, strategy);
                for col in 0..9 {
                    let mut df = Mat3::zeros();
                    df[(col / 3, col % 3)] = 1.0;
                    let dp = tangent.apply(&df);
                    for row in 0..9 {
                        block[9 * row + col] = dp[(row / 3, row % 3)];
                    }
                }
            }
            out
        });
        finite_results("tangent", &flat, 81)?;
        let k = f.len();
        arrays::from_reals(py, flat, &[k, 9, 9])
    }

    fn __repr__(&self) -> String {
        format!(
            "Material({:?}, mu={}, lam={})",
            self.model.kind().name(),
            self.lame.mu,
            self.lame.lambda
        )
    }
}

/// The deformation gradients F of `call` ((k, 3, 3) float64, every entry finite), after its
/// signature's check (`keyword`: the parameters after F).
fn gradients(
    call: &str,
    keyword: &[&str],
    f: Option<&Bound<'_, PyAny>>,
    extra: &Bound<'_, PyTuple>,
    unknown: Option<&Bound<'_, PyDict>>,
) -> PyResult<Vec<Mat3>> {
    let positional: Vec<&str> = std::iter::once("F")
        .chain(keyword.iter().copied())
        .collect();
    Signature {
        call,
        positional: &positional,
        keyword: &[],
    }
    .check(extra, unknown)?;
    let f = args::required(
        f,
        "F",
        call,
        "deformation gradients, a (k, 3, 3) float64 array",
    )?;
    let f = arrays::mat3s(f, "F")?;
    if let Some(k) = f.iter().position(|m| !m.iter().all(|c| c.is_finite())) {
        return Err(argument(
            "F",
            format!(
                "F[{k}] is not finite ({}): a deformation gradient holds finite numbers",
                matrix_text(&f[k])
            ),
        ));
    }
    Ok(f)
}

fn matrix_text(m: &Mat3) -> String {
    let row = |i: usize| format!("[{}, {}, {}]", m[(i, 0)], m[(i, 1)], m[(i, 2)]);
    format!("[{}, {}, {}]", row(0), row(1), row(2))
}

/// Refuse a result that overflowed (`per` values for each F): an F so large that its energy,
/// stress or tangent is beyond double precision, rather than an inf or NaN handed back.
fn finite_results(what: &str, values: &[f64], per: usize) -> PyResult<()> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(i) => Err(argument(
            "F",
            format!(
                "F[{}]: its {what} overflows double precision (the entries of F are too large)",
                i / per
            ),
        )),
    }
}

/// A [material] error as the keyword argument it is about (`poisson_ratio`, `lam`).
fn material_error(error: tetsim::Error) -> PyErr {
    let (key, message) = match &error {
        tetsim::Error::Scene { key, message, .. } => (key.clone(), message.clone()),
        other => (other.key().map(str::to_string), other.to_string()),
    };
    let rename = |k: &str| {
        let k = k.strip_prefix("material.").unwrap_or(k);
        if k == "lambda" {
            "lam".to_string()
        } else {
            k.to_string()
        }
    };
    let key = key.map(|k| rename(&k));
    let message = match message.split_once(": ") {
        Some((k, rest)) if k.starts_with("material") => {
            format!("{}: {rest}", rename(k))
        }
        _ => message,
    };
    Fields {
        message,
        key,
        ..Default::default()
    }
    .raise()
}
