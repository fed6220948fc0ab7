//! `tetsim.Material`: a constitutive model evaluated on many deformation gradients at once.

use pyo3::prelude::*;
use tetsim::material::{Definiteness, Lame, Material as _, Model};
use tetsim::math::Mat3;

use crate::arrays;
use crate::errors::{Fields, argument};

/// A constitutive model: Ψ(F) (J/m³), P(F) = ∂Ψ/∂F (Pa) and ∂P/∂F on arrays of deformation
/// gradients F of shape (k, 3, 3).
///
/// Material(model, youngs_modulus=..., poisson_ratio=...) or Material(model, mu=..., lam=...):
/// the scene's [material] keys (lam is λ, `lambda` being a Python keyword) with the same
/// defaults (E = 1e5 Pa, ν = 0.3) and checks. Models: neo-hookean, neo-hookean-clamped,
/// corotated, stable-neo-hookean, st-venant-kirchhoff, mooney-rivlin, linear.
/// inversion_threshold (default 0.1): every model is its formula wherever every principal
/// stretch of F is at least this; below it the model's inversion extension acts.
#[pyclass(module = "tetsim", frozen)]
pub struct Material {
    model: Model,
    lame: Lame,
}

#[pymethods]
impl Material {
    #[new]
    #[pyo3(signature = (model="neo-hookean", *, youngs_modulus=None, poisson_ratio=None, mu=None, lam=None, inversion_threshold=None))]
    fn new(
        model: &str,
        youngs_modulus: Option<f64>,
        poisson_ratio: Option<f64>,
        mu: Option<f64>,
        lam: Option<f64>,
        inversion_threshold: Option<f64>,
    ) -> PyResult<Self> {
        // The scene's own validator checks the values, so a Material refuses exactly what a
        // [material] table would, with the same words.
        let mut material = toml::Table::new();
        material.insert("model".into(), model.into());
        for (key, value) in [
            ("youngs_modulus", youngs_modulus),
            ("poisson_ratio", poisson_ratio),
            ("mu", mu),
            ("lambda", lam),
            ("inversion_threshold", inversion_threshold),
        ] {
            if let Some(v) = value {
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
        let (model, _) =
            tetsim::Scene::material_model(&scene.material).map_err(|m| argument("material", m))?;
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
    fn energy<'py>(&self, py: Python<'py>, F: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let f = arrays::mat3s(F, "F")?;
        let model = &self.model;
        let psi: Vec<f64> = py.detach(|| f.iter().map(|f| model.energy_density(f)).collect());
        let k = psi.len();
        arrays::from_reals(py, psi, &[k])
    }

    /// First Piola-Kirchhoff stress P(F) = ∂Ψ/∂F, Pa: F (k, 3, 3) → (k, 3, 3) float64.
    #[allow(non_snake_case)]
    fn stress<'py>(&self, py: Python<'py>, F: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let f = arrays::mat3s(F, "F")?;
        let model = &self.model;
        let p: Vec<Mat3> = py.detach(|| f.iter().map(|f| model.stress(f)).collect());
        arrays::from_mat3s(py, &p)
    }

    /// The tangent ∂P/∂F, Pa: F (k, 3, 3) → (k, 9, 9) float64 with
    /// tangent[k, 3*i + j, 3*l + m] = ∂P_ij/∂F_lm, so that
    /// (tangent @ dF.reshape(k, 9, 1)).reshape(k, 3, 3) is the stress differential dP.
    ///
    /// definiteness: 'none' (default: the exact derivative), or 'teran', 'analytic', 'abs',
    /// 'adaptive' (the solver's positive semi-definite fixes, [solver] definiteness).
    #[allow(non_snake_case)]
    #[pyo3(signature = (F, definiteness="none"))]
    fn tangent<'py>(
        &self,
        py: Python<'py>,
        F: &Bound<'py, PyAny>,
        definiteness: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        let Some(strategy) = Definiteness::from_name(definiteness) else {
            let names: Vec<&str> = Definiteness::ALL.iter().map(|d| d.name()).collect();
            return Err(argument(
                "definiteness",
                format!(
                    "unknown definiteness strategy \"{definiteness}\", expected one of {}",
                    names.join(", ")
                ),
            ));
        };
        let f = arrays::mat3s(F, "F")?;
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
