"""Issue 37 #3: the leaf BSDF's cuticle (a rough dielectric specular lobe over the PROSPECT body),
its energy, and the mixing of veins, age and bark within one BSDF.

References: the unpolarised Fresnel reflectance of a dielectric (Born & Wolf §1.5) — a smooth-ish
GGX lobe (α ≤ 0.1, where Smith masking loses < 5 % up to 60°) reflects F(θ) of the light; PROSPECT's
plate model (R = r_α + t_α·(…), Jacquemoud & Baret 1990) for the body's split; Mitsuba's
``roughdielectric`` (Walter et al. 2007) for the reflection of a rougher lobe, which single
scattering keeps below F (Heitz, E., Hanika, J., d'Eon, E., & Dachsbacher, C. (2016). Multiple-
scattering microfacet BSDFs with the Smith model. ACM TOG 35(4)).
"""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.leaves import CUTICLE_INDEX, LeafTraits, prospect_d, prospect_layers
from spectral_cam.render.leaf_bsdf import PLUGIN, fresnel, hemispherical_transmissivity

pytestmark = pytest.mark.timeout(240)

SAMPLES = 1 << 18


@pytest.fixture(scope="module")
def mi():
    import mitsuba

    from spectral_cam.render.leaf_bsdf import register
    from spectral_cam.render.variants import choose_variant

    mitsuba.set_variant(choose_variant("auto"))
    register(mitsuba)
    return mitsuba


def _leaf(mi, rho, tau, **extra):
    def value(v):
        return {"type": "uniform", "value": float(v)}

    return mi.load_dict({"type": PLUGIN, "reflectance": value(rho), "transmittance": value(tau),
                         **{k: value(v) if isinstance(v, (int, float)) and k not in ("eta", "alpha") else v
                            for k, v in extra.items()}})


def _interaction(mi, theta_deg, back=False):
    si = mi.SurfaceInteraction3f()
    t = np.radians(theta_deg)
    si.wi = mi.Vector3f(float(np.sin(t)), 0.0, float(-np.cos(t) if back else np.cos(t)))
    si.wavelengths = mi.Spectrum(550.0)
    return si


def _albedo(mi, bsdf, theta_deg, back=False, seed=1):
    """(mean, standard error) of the sampled weights f·|cos θo|/pdf (the BSDF's own sampling,
    eval and pdf), the directional albedo at incidence θ."""
    rng = np.random.default_rng(seed)
    si = _interaction(mi, theta_deg, back)
    _, weight = bsdf.sample(mi.BSDFContext(), si, mi.Float(rng.random(SAMPLES)),
                            mi.Point2f(rng.random(SAMPLES), rng.random(SAMPLES)))
    w = np.asarray(weight[0], dtype=np.float64)
    return w.mean(), w.std() / np.sqrt(len(w))


def _uniform_estimates(mi, bsdf, theta_deg, seed=2):
    """∫ f·|cos θo| dωo and ∫ pdf dωo by uniform sampling of the sphere (independent of the
    BSDF's sampling)."""
    rng = np.random.default_rng(seed)
    si = _interaction(mi, theta_deg)
    d = mi.warp.square_to_uniform_sphere(mi.Point2f(rng.random(SAMPLES), rng.random(SAMPLES)))
    value, pdf = bsdf.eval_pdf(mi.BSDFContext(), si, d)
    return np.asarray(value[0]).mean() * 4 * np.pi, np.asarray(pdf).mean() * 4 * np.pi


@pytest.mark.parametrize("alpha", [0.05, 0.1])
def test_the_cuticle_lobe_reflects_the_fresnel_reflectance_of_its_index(mi, alpha):
    """The specular lobe alone (a body that reflects and transmits nothing) integrates over the
    hemisphere to F(θ) of n = 1.47 within 5 % at 0–60° (α = 0.05 also at 70°), on both faces.
    Measured (α = 0.05): 0.997, 1.003, 1.009, 0.999, 0.962 of F at 0, 30, 45, 60, 70°; (α = 0.1):
    0.992, 1.003, 1.011, 0.963 at 0–60° (masking and the tail below the horizon lose the rest)."""
    lobe = _leaf(mi, 0.0, 0.0, eta=CUTICLE_INDEX, alpha=alpha)
    angles = [0, 30, 45, 60] + ([70] if alpha <= 0.05 else [])
    for theta in angles:
        expected = fresnel(np.cos(np.radians(theta)), CUTICLE_INDEX)
        for back in (False, True):
            albedo, error = _albedo(mi, lobe, theta, back)
            assert error < 0.005 * expected
            assert albedo == pytest.approx(expected, rel=0.05), (theta, back, albedo / expected)


@pytest.mark.parametrize("alpha", [0.2, 0.35, 0.56])
def test_a_rough_cuticle_reflects_what_mitsubas_rough_dielectric_reflects(mi, alpha):
    """At the roughness the species draw (α 0.1–0.56, presets/plants.py), the lobe reflects what
    Mitsuba's own ``roughdielectric`` (GGX, the same α and index: an independent implementation
    of Walter et al. 2007) reflects, within 1 % at 0–70° and on both faces. That is below F(θ) as
    α grows (measured at α = 0.5: 0.71 of F at 0°, 0.47 at 60°): a single-scattering microfacet
    lobe loses what masking stops (Heitz et al. 2016), which is why the Fresnel check above is
    made where that loss is small (α ≤ 0.1)."""
    lobe = _leaf(mi, 0.0, 0.0, eta=CUTICLE_INDEX, alpha=alpha)
    reference = mi.load_dict({"type": "roughdielectric", "distribution": "ggx", "alpha": alpha,
                              "int_ior": CUTICLE_INDEX, "ext_ior": 1.0})
    reflection = mi.BSDFContext(mi.TransportMode.Radiance, mi.BSDFFlags.Reflection)
    rng = np.random.default_rng(5)
    for theta in (0, 30, 60, 70):
        si = _interaction(mi, theta)
        _, weight = reference.sample(reflection, si, mi.Float(rng.random(SAMPLES)),
                                     mi.Point2f(rng.random(SAMPLES), rng.random(SAMPLES)))
        expected = float(np.asarray(weight[0], dtype=np.float64).mean())
        assert expected < fresnel(np.cos(np.radians(theta)), CUTICLE_INDEX)
        for back in (False, True):
            albedo, error = _albedo(mi, lobe, theta, back)
            assert albedo == pytest.approx(expected, rel=0.01), (theta, back, albedo / expected)


def test_sampling_eval_and_pdf_agree(mi):
    """The sampled weights' mean equals the albedo integrated from ``eval`` by uniform sampling
    of the sphere, and the pdf integrates to at most one (what the GGX lobe sends below the
    horizon is lost), for a rough cuticle over a reflecting and transmitting body."""
    leaf = _leaf(mi, 0.45, 0.4, eta=CUTICLE_INDEX, alpha=0.35)
    for theta in (0, 40, 75):
        sampled, error = _albedo(mi, leaf, theta)
        integrated, pdf_mass = _uniform_estimates(mi, leaf, theta)
        assert integrated == pytest.approx(sampled, rel=0.01)
        assert 0.9 < pdf_mass < 1.005


@pytest.mark.parametrize("alpha", [0.1, 0.3, 0.5])
def test_a_cuticled_leaf_conserves_energy(mi, alpha):
    """Albedo ≤ 1 at every incidence for a body that absorbs only 1 % (ρ + τ = 0.99, more than
    any PROSPECT leaf keeps), and the body gets exactly 1 − F(θ) of the light: with no
    absorption at all the albedo is E_spec + 1 − F ≤ 1 + 10⁻³."""
    leaf = _leaf(mi, 0.6, 0.39, eta=CUTICLE_INDEX, alpha=alpha)
    lossless = _leaf(mi, 0.6, 0.4, eta=CUTICLE_INDEX, alpha=alpha)
    for theta in (0, 20, 40, 60, 75, 85):
        albedo, error = _albedo(mi, leaf, theta)
        assert albedo <= 1.0 + 3 * error, (theta, albedo)
        albedo, error = _albedo(mi, lossless, theta)
        assert albedo <= 1.001 + 3 * error, (theta, albedo)


def test_without_a_cuticle_the_leaf_is_lambertian(mi):
    """No ``eta``: the issue-24 leaf, albedo ρ + τ at every incidence."""
    leaf = _leaf(mi, 0.3, 0.5)
    for theta in (0, 60, 85):
        albedo, _ = _albedo(mi, leaf, theta)
        assert albedo == pytest.approx(0.8, rel=1e-3)


def test_the_body_split_keeps_prospects_reflectance():
    """ρ = (R − r_α)/t_α and τ = T/t_α with PROSPECT's n(λ): at the incidence where 1 − F(θ) = t_α
    (≈ 31°) a cuticle of that index reflects F + (1 − F)·ρ = PROSPECT-D's R and transmits T, and
    ρ + τ ≤ 1; the diffuse exit factor (1 − F(θo))/t̄ integrates to one. (The lobe itself uses
    one index, 1.47, PROSPECT's n averaged over 400–720 nm: F(0) 0.036 against 0.033–0.042.)"""
    import prosail
    from prosail.prospect_d import calctav

    wl = np.arange(400.0, 801.0, 10.0)
    nr = prosail.spectral_lib.prospectd.nr[(wl - 400).astype(int)]
    assert np.mean(prosail.spectral_lib.prospectd.nr[:321]) == pytest.approx(CUTICLE_INDEX, abs=0.005)
    t_alpha = calctav(40.0, nr)
    mu = np.linspace(0.5, 1.0, 20001)[:, None]
    at = mu[np.argmin(np.abs(1 - fresnel(mu, nr[None, :]) - t_alpha[None, :]), axis=0), 0]
    f = fresnel(at, nr)
    for traits in (LeafTraits(), LeafTraits(cab=15.0, car=5.0, brown=0.2), LeafTraits(n=2.2, cab=2.0, brown=1.5)):
        rho, tau = prospect_layers(traits, wl)
        r, t = prospect_d(traits, wl)
        assert np.all(rho + tau <= 1.0 + 1e-12) and np.all(rho >= 0)
        np.testing.assert_allclose(f + (1 - f) * rho, r, rtol=1e-3)
        np.testing.assert_allclose((1 - f) * tau, t, rtol=1e-3)
    mu = (np.arange(100000) + 0.5) / 100000
    exit_mass = np.mean((1 - fresnel(mu, CUTICLE_INDEX)) * 2 * mu) / hemispherical_transmissivity(CUTICLE_INDEX)
    assert exit_mass == pytest.approx(1.0, abs=1e-6)


def test_veins_age_and_bark_mix_the_spectra_linearly(mi):
    """With weights v (veins), a (age) and w (bark), the body reflects
    (1 − w)·lerp(lerp(ρ, ρ_vein, v), ρ_old, a) + w·ρ_bark: checked through the albedo (no
    cuticle) at v = 0.25, a = 0.5, w = 0 and w = 1."""
    extra = {"reflectance_vein": 0.5, "transmittance_vein": 0.2, "reflectance_old": 0.1, "transmittance_old": 0.1,
             "reflectance_wood": 0.25, "vein": 0.25, "age": 0.5}
    young = (0.75 * 0.2 + 0.25 * 0.5, 0.75 * 0.4 + 0.25 * 0.2)
    expected = 0.5 * (young[0] + 0.1) + 0.5 * (young[1] + 0.1)
    albedo, _ = _albedo(mi, _leaf(mi, 0.2, 0.4, wood=0.0, **extra), 30)
    assert albedo == pytest.approx(expected, rel=2e-3)
    albedo, _ = _albedo(mi, _leaf(mi, 0.2, 0.4, wood=1.0, **extra), 30)
    assert albedo == pytest.approx(0.25, rel=2e-3)
    with pytest.raises(Exception, match="vein"):
        _leaf(mi, 0.2, 0.4, vein=0.5)


def test_the_diffuse_reflectance_is_the_bodys_at_normal_incidence(mi):
    """What an albedo label reads: (1 − F(0))·ρ under a cuticle, ρ without one, the bark's on wood."""
    si = _interaction(mi, 0)
    f0 = fresnel(1.0, CUTICLE_INDEX)
    value = _leaf(mi, 0.4, 0.3, eta=CUTICLE_INDEX, alpha=0.3).eval_diffuse_reflectance(si)
    assert np.asarray(value[0])[0] == pytest.approx(0.4 * (1 - f0), rel=1e-5)
    assert np.asarray(_leaf(mi, 0.4, 0.3).eval_diffuse_reflectance(si)[0])[0] == pytest.approx(0.4, rel=1e-6)
    wood = _leaf(mi, 0.4, 0.3, reflectance_wood=0.2, wood=1.0).eval_diffuse_reflectance(si)
    assert np.asarray(wood[0])[0] == pytest.approx(0.2, rel=1e-6)
