"""Material against the analytic formulas of SPEC §2 (and the models' docs), its tangent against
finite differences of its stress, and its parameters against the scene's conversions."""

import numpy as np
import pytest

import tetsim

E, NU = 1.0e6, 0.3
MU, LAM = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))


def random_f(k=50, seed=1, spread=0.3):
    """Deformation gradients near the identity, every stretch above 0.65 (see
    test_neo_hookean_is_its_formula_down_to_the_threshold for stretches down to 0.1)."""
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


def stretched_f(k, seed, lowest=0.1, highest=3.0, min_det=0.2):
    """F = U diag(σ) Vᵀ with random rotations and every stretch σ in [lowest, highest], det F ≥
    min_det: deep compression along one or two axes, within the formula's range."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < k:
        s = np.exp(rng.uniform(np.log(lowest), np.log(highest), size=3))
        if s.prod() < min_det:
            continue
        u, _ = np.linalg.qr(rng.standard_normal((3, 3)))
        v, _ = np.linalg.qr(rng.standard_normal((3, 3)))
        u *= np.sign(np.linalg.det(u))
        v *= np.sign(np.linalg.det(v))
        out.append(u @ np.diag(s) @ v.T)
    # Stretches right at the threshold too.
    out[0] = np.diag([lowest, 2.0, 2.5])
    out[1] = np.diag([lowest * 1.0000001, lowest * 2.1, 1 / lowest])
    return np.ascontiguousarray(out)


def relative(a, b):
    """Largest difference relative to each sample's largest entry of the reference."""
    a, b = np.asarray(a), np.asarray(b)
    axes = tuple(range(1, b.ndim))
    scale = np.abs(b).max(axis=axes) if axes else np.abs(b)
    diff = np.abs(a - b).max(axis=axes) if axes else np.abs(a - b)
    return (diff / scale).max()


def test_neo_hookean_is_its_formula_down_to_the_threshold():
    # SPEC §2 and §3: Ψ, P and ∂P/∂F are the Neo-Hookean formulas wherever every principal
    # stretch is at least the inversion threshold (0.1), to 1e-12 relative.
    m = tetsim.Material("neo-hookean", youngs_modulus=E, poisson_ratio=NU)
    assert m.inversion_threshold == 0.1
    f = stretched_f(200, seed=11)
    j = np.linalg.det(f)
    log_j = np.log(j)
    c = np.einsum("kij,kij->k", f, f)
    psi = MU / 2 * (c - 3) - MU * log_j + LAM / 2 * log_j**2
    f_inv = np.linalg.inv(f)
    f_inv_t = np.transpose(f_inv, (0, 2, 1))
    p = MU * (f - f_inv_t) + LAM * log_j[:, None, None] * f_inv_t
    # dP = μ dF + (μ − λ log J) F⁻ᵀ dFᵀ F⁻ᵀ + λ tr(F⁻¹ dF) F⁻ᵀ, one column per entry of dF.
    tangent = np.zeros((len(f), 9, 9))
    for lm in range(9):
        d = np.zeros((3, 3))
        d[lm // 3, lm % 3] = 1.0
        dp = (
            MU * d
            + (MU - LAM * log_j)[:, None, None] * (f_inv_t @ d.T @ f_inv_t)
            + LAM * np.einsum("kij,ji->k", f_inv, d)[:, None, None] * f_inv_t
        )
        tangent[:, :, lm] = dp.reshape(len(f), 9)
    assert relative(m.energy(f) + MU, psi + MU) < 1e-12  # Ψ ≥ 0: relative to Ψ + μ
    assert relative(m.stress(f), p) < 1e-12
    assert relative(m.tangent(f, definiteness="none"), tangent) < 1e-12
    # The same for a threshold set lower, down to its own value.
    low = tetsim.Material("neo-hookean", youngs_modulus=E, poisson_ratio=NU, inversion_threshold=0.05)
    f = stretched_f(50, seed=12, lowest=0.05, min_det=0.05)
    j = np.linalg.det(f)
    f_inv_t = np.transpose(np.linalg.inv(f), (0, 2, 1))
    p = MU * (f - f_inv_t) + LAM * np.log(j)[:, None, None] * f_inv_t
    assert relative(low.stress(f), p) < 1e-12


def test_crushed_neo_hookean_resists_more_and_more():
    # Below the threshold the extension keeps the compressive stress growing: never crushed
    # flat by a load of the order of E.
    m = tetsim.Material("neo-hookean", youngs_modulus=E, poisson_ratio=NU)
    s = np.linspace(0.3, -1.0, 131)
    f = np.ascontiguousarray([np.diag([1.05, 1.05, x]) for x in s])
    p33 = m.stress(f)[:, 2, 2]
    assert (np.diff(p33) < 0).all()
    assert p33[s <= 0.0].max() < -40 * E


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
