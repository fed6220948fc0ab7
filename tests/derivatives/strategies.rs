//! The definiteness strategies against each other: `analytic` is `teran` computed another way,
//! `abs` moves every indefinite piece exactly twice as far as `teran`, `none` changes nothing but
//! counts what the others fix; and the scene names of strategies and models.

use super::*;

/// Strategies compared per model on deformed, near-inverted, inverted and flat F.
pub fn check_strategies(model: &Model, seed: u64) {
    let mut rng = rng(seed);
    let mut indefinite_seen = 0;
    for family in FAMILIES {
        for _ in 0..SAMPLES {
            let f = sample_f(&mut rng, family)
                + 0.5 * random_matrix(&mut rng) * (family == Family::Random) as u8 as f64;
            let tangent = |d| model.tangent(&f, d);
            let [adaptive, teran, analytic, abs, exact] = Definiteness::ALL.map(tangent);
            let matrix = |d| tangent_matrix(|x| model.tangent(&f, d).apply(x));
            let [m_adaptive, m_teran, m_analytic, m_abs, m_exact] = Definiteness::ALL.map(matrix);
            let norm = m_exact.norm().max(stress_scale(lame()));

            assert_eq!(exact.clamped_pieces(), 0);
            assert_eq!(exact.indefinite_pieces(), teran.clamped_pieces(), "at {f}");
            assert_eq!(teran.clamped_pieces(), abs.clamped_pieces(), "at {f}");
            assert_eq!(teran.clamped_pieces(), analytic.clamped_pieces(), "at {f}");
            // Per element, `adaptive` is `teran`: the solver holds the exact pieces beside it.
            assert_eq!(m_adaptive, m_teran, "at {f}");
            assert_eq!(adaptive.clamped_pieces(), teran.clamped_pieces(), "at {f}");
            for t in [&teran, &analytic, &abs, &exact, &adaptive] {
                assert_eq!(t.indefinite_pieces(), exact.indefinite_pieces(), "at {f}");
            }
            indefinite_seen += (exact.indefinite_pieces() > 0) as usize;

            let gap = (m_analytic - m_teran).norm();
            assert!(gap <= 1e-10 * norm, "analytic ≠ teran by {gap:e} at {f}");
            // |λ| − λ = 2(max(λ, 0) − λ) for every eigenvalue of every piece.
            let gap = ((m_abs - m_exact) - 2.0 * (m_teran - m_exact)).norm();
            assert!(
                gap <= 1e-9 * norm,
                "abs ≠ exact + 2(teran − exact) by {gap:e} at {f}"
            );
        }
    }
    // `none` really is different somewhere, except for linear elasticity, which is convex.
    if model.kind() == ModelKind::Linear {
        assert_eq!(indefinite_seen, 0);
    } else {
        assert!(indefinite_seen > 0, "{:?} never indefinite", model.kind());
    }
}

#[test]
fn definiteness_names_round_trip() {
    for d in Definiteness::ALL {
        assert_eq!(Definiteness::from_name(d.name()), Some(d));
        assert_eq!(d.to_string(), d.name());
        assert_eq!(d.is_psd(), d != Definiteness::Exact);
    }
    assert_eq!(Definiteness::default(), Definiteness::Adaptive);
    assert_eq!(Definiteness::TERAN, Definiteness::Projected);
    assert_eq!(Definiteness::NONE, Definiteness::Exact);
    let aliases = [
        ("projected", Definiteness::Projected),
        ("Clamp", Definiteness::Projected),
        ("exact", Definiteness::Exact),
        ("absolute", Definiteness::Abs),
    ];
    for (name, d) in aliases {
        assert_eq!(Definiteness::from_name(name), Some(d), "{name}");
    }
    assert_eq!(Definiteness::from_name("cholesky"), None);
}

#[test]
fn model_names_round_trip() {
    for kind in ModelKind::ALL {
        assert_eq!(ModelKind::from_name(kind.name()), Some(kind));
        assert_eq!(kind.to_string(), kind.name());
        assert_eq!(Model::new(kind, lame()).kind(), kind);
    }
    let aliases = [
        ("nh-clamped", ModelKind::NeoHookeanClamped),
        ("Neo_Hookean_Clamped", ModelKind::NeoHookeanClamped),
        ("snh", ModelKind::StableNeoHookean),
        ("Stable_Neo_Hookean", ModelKind::StableNeoHookean),
        ("stvk", ModelKind::StVenantKirchhoff),
        ("saint-venant-kirchhoff", ModelKind::StVenantKirchhoff),
        ("linear-elastic", ModelKind::Linear),
    ];
    for (name, kind) in aliases {
        assert_eq!(ModelKind::from_name(name), Some(kind), "{name}");
    }
    assert_eq!(ModelKind::from_name("ogden"), None);
}
