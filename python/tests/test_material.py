"""Material against the analytic formulas of SPEC §2 (and the models' docs), its tangent against
finite differences of its stress, and its parameters against the scene's conversions."""

import numpy as np
import pytest

import tetsim

E, NU = 1.0e6, 0.3
MU, LAM = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))


def random_f(k=50, seed=1, spread=0.3):
    """Deformation gradients near the identity, every stretch above 0.65: the formulas hold there
    (below the inversion threshold of 0.6 the models extend them, Irving et al. 2004)."""
    rng = np.random.default_rng(seed)
    f = np.eye(3) + spread * rng.uniform(-1, 1, size=(k, 3, 3))
    sigma = np.linalg.svd(f, compute_uv=False)
    f = f[(np.linalg.det(f) > 0) & (sigma.min(axis=1) > 0.65)]
    assert len(f) > k // 4
    return np.ascontiguousarray(f)


def polar_r(f):
    u, _, vt = np.linalg.svd(f)
    return u @ vt


def test_parameters_convert_like_the_scene():
    m = tetsim.Material("neo-hookean", youngs_modulus=E, poisson_ratio=NU)
    assert m.mu == pytest.approx(MU, rel=1e-15) and m.lam == pytest.approx(LAM, rel=1e-15)
    assert m.youngs_modulus == pytest.approx(E) and m.poisson_ratio == pytest.approx(NU)
    lame = tetsim.Material("corotated", mu=MU, lam=LAM)
    assert (lame.mu, lame.lam, lame.model) == (MU, LAM, "corotated")
    default = tetsim.Material()
    assert default.model == "neo-hookean"
    assert default.youngs_modulus == pytest.approx(1e5) and default.poisson_ratio == pytest.approx(0.3)


def test_neo_hookean_energy_and_stress_match_the_formula():
    f = random_f()
    m = tetsim.Material("neo-hookean", youngs_modulus=E, poisson_ratio=NU)
    j = np.linalg.det(f)
    psi = MU / 2 * (np.einsum("kij,kij->k", f, f) - 3) - MU * np.log(j) + LAM / 2 * np.log(j) ** 2
    f_inv_t = np.transpose(np.linalg.inv(f), (0, 2, 1))
    p = MU * (f - f_inv_t) + LAM * np.log(j)[:, None, None] * f_inv_t
    np.testing.assert_allclose(m.energy(f), psi, rtol=1e-10, atol=1e-9 * MU)
    np.testing.assert_allclose(m.stress(f), p, rtol=1e-10, atol=1e-9 * MU)
    assert m.energy(np.eye(3)[None]).tolist() == [0.0]


def test_corotated_energy_and_stress_match_the_formula():
    f = random_f(seed=2)
    m = tetsim.Material("corotated", mu=MU, lam=LAM)
    r = polar_r(f)
    tr = np.einsum("kji,kji->k", r, f) - 3  # tr(RᵀF − I)
    psi = MU * np.sum((f - r) ** 2, axis=(1, 2)) + LAM / 2 * tr**2
    p = 2 * MU * (f - r) + LAM * tr[:, None, None] * r
    np.testing.assert_allclose(m.energy(f), psi, rtol=1e-9, atol=1e-9 * MU)
    np.testing.assert_allclose(m.stress(f), p, rtol=1e-9, atol=1e-9 * MU)


def test_st_venant_kirchhoff_and_linear_match_their_formulas():
    f = random_f(seed=3)
    eye = np.eye(3)
    green = 0.5 * (np.transpose(f, (0, 2, 1)) @ f - eye)
    tr = np.trace(green, axis1=1, axis2=2)
    stvk = tetsim.Material("st-venant-kirchhoff", mu=MU, lam=LAM)
    psi = MU * np.sum(green**2, axis=(1, 2)) + LAM / 2 * tr**2
    np.testing.assert_allclose(stvk.energy(f), psi, rtol=1e-9, atol=1e-9 * MU)
    p = f @ (2 * MU * green + LAM * tr[:, None, None] * eye)
    np.testing.assert_allclose(stvk.stress(f), p, rtol=1e-9, atol=1e-9 * MU)
    linear = tetsim.Material("linear", mu=MU, lam=LAM)
    eps = 0.5 * (f + np.transpose(f, (0, 2, 1))) - eye
    tr = np.trace(eps, axis1=1, axis2=2)
    np.testing.assert_allclose(
        linear.energy(f), MU * np.sum(eps**2, axis=(1, 2)) + LAM / 2 * tr**2, rtol=1e-10
    )
    np.testing.assert_allclose(
        linear.stress(f), 2 * MU * eps + LAM * tr[:, None, None] * eye, rtol=1e-10, atol=1e-6
    )


@pytest.mark.parametrize(
    "model",
    ["neo-hookean", "corotated", "stable-neo-hookean", "st-venant-kirchhoff", "mooney-rivlin", "linear"],
)
def test_stress_is_the_derivative_of_energy_and_tangent_of_stress(model):
    f = random_f(k=12, seed=4)
    m = tetsim.Material(model, youngs_modulus=E, poisson_ratio=NU)
    h = 1e-6
    tangent = m.tangent(f)
    assert tangent.shape == (len(f), 9, 9) and tangent.dtype == np.float64
    for lm in range(9):
        d = np.zeros((3, 3))
        d[lm // 3, lm % 3] = h
        dpsi = (m.energy(f + d) - m.energy(f - d)) / (2 * h)
        np.testing.assert_allclose(dpsi, m.stress(f)[:, lm // 3, lm % 3], rtol=1e-5, atol=1e-3)
        dp = (m.stress(f + d) - m.stress(f - d)).reshape(len(f), 9) / (2 * h)
        np.testing.assert_allclose(dp, tangent[:, :, lm], rtol=1e-5, atol=1e-5 * MU)
    # Hyperelastic: the tangent is a Hessian, hence symmetric.
    np.testing.assert_allclose(tangent, np.transpose(tangent, (0, 2, 1)), atol=1e-6 * MU)


def test_projected_tangent_is_positive_semi_definite():
    rng = np.random.default_rng(5)
    f = np.ascontiguousarray(np.eye(3) + 1.5 * rng.uniform(-1, 1, size=(40, 3, 3)))  # some inverted
    m = tetsim.Material("neo-hookean", youngs_modulus=E, poisson_ratio=NU)
    assert np.linalg.eigvalsh(m.tangent(f, definiteness="none")).min() < 0
    for strategy in ("teran", "analytic", "abs"):
        eig = np.linalg.eigvalsh(m.tangent(f, definiteness=strategy))
        assert eig.min() >= -1e-8 * MU, strategy


def test_empty_batches_and_inverted_f_stay_finite():
    m = tetsim.Material("neo-hookean", youngs_modulus=E, poisson_ratio=NU)
    assert m.energy(np.zeros((0, 3, 3))).shape == (0,)
    assert m.tangent(np.zeros((0, 3, 3))).shape == (0, 9, 9)
    flat = np.ascontiguousarray(np.array([np.diag([1.0, 1.0, -0.5]), np.zeros((3, 3))]))
    assert np.isfinite(m.energy(flat)).all() and np.isfinite(m.stress(flat)).all()
