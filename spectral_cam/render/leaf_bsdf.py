"""A leaf as Mitsuba sees it: a two-sided diffuse reflector *and transmitter* with spectral
reflectance ρ(λ) and transmittance τ(λ) (PROSPECT-D's, :mod:`spectral_cam.leaves`), optionally
under a rough dielectric cuticle that reflects a specular sheen, with traits that vary within a
leaf (veins, a paler base) and between leaves (age) and woody stems, written in Python (drjit)
because Mitsuba 3 has no diffuse transmitter (its ``principledthin`` ties transmission to the
reflection colour).

Without a cuticle (no ``eta``; the leaf of issue 24)::

    f(ωi, ωo) = ρ/π  (ωo on ωi's side),   τ/π  (on the other side)

With a cuticle (``eta`` = n, ``alpha`` = GGX roughness α)::

    f = f_spec + (1 − F(θi))·(1 − F(θo))/t̄ · {ρ/π | τ/π},
    f_spec = F(ωi·h)·D(h)·G(ωi, ωo)/(4|cos θi||cos θo|)   (ωo on ωi's side only)

F is the unpolarised Fresnel reflectance of a dielectric of index n in air (Born & Wolf §1.5),
D, G Trowbridge–Reitz (GGX) with Smith's masking (Walter et al. 2007), and
t̄ = 1 − 2∫F(θ)cos θ sin θ dθ the hemispherical (diffuse) transmissivity of the interface. Why
this split, and why it does not count the surface twice:

* PROSPECT (Jacquemoud & Baret 1990; Féret et al. 2017) is a plate model. Its reflectance is
  R = r_α + t_α·(…) and its transmittance T = t_α·(…), where r_α = 1 − t_α is the first
  interface's reflectance averaged over incidences within a 40° cone (``tav(40°, n)``, Stern 1964)
  and every other term carries the factor t_α of the light that got in. So the leaf's own
  surface reflection is already the r_α in R; the body (the light that entered) reflects
  ρ = (R − r_α)/t_α and transmits τ = T/t_α per unit of light that entered
  (:func:`spectral_cam.leaves.prospect_layers` computes these with PROSPECT's own n(λ)). Since
  R + T ≤ 1, ρ + τ ≤ 1.
* Here the surface term r_α is replaced by the rough-dielectric lobe, whose albedo is F(θi) at the
  incidence actually met (r_α is F's average over the 40° cone: 0.04 for n = 1.47, but
  F rises to 1 at grazing incidence: the sheen of leaves seen against the sun, Grant 1987,
  Vanderbilt & Grant 1985), and the body receives the rest, 1 − F(θi), instead of t_α. The light
  leaves the body through the interface again, diffusely: the factor (1 − F(θo))/t̄ integrates to
  one over the outgoing hemisphere, so the body's albedo is exactly (1 − F(θi))·ρ (or ·τ), the
  BSDF stays reciprocal, and at incidence near θ ≈ 30° (where 1 − F = t_α) the leaf reflects
  PROSPECT's R again.
* Energy: the lobe's albedo E_s(θ) ≤ F(θi) up to the masking losses of rough microfacets
  (measured: within 5 % of F up to 70° for α ≤ 0.1; tests/render/test_leaf_bsdf.py), the body
  (1 − F(θi))·(ρ + τ) ≤ 1 − F(θi): the whole albedo ≤ 1 at every angle.

Index and roughness: leaf cuticle wax has n ≈ 1.45–1.5 (Grant 1987; Vanderbilt & Grant 1985);
PROSPECT-D's tabulated n(λ) (prosail's ``nr``) falls from 1.51 at 400 nm to 1.44 at 720 nm and
the lobe uses its mean over the visible, n = 1.47 (:data:`spectral_cam.leaves.CUTICLE_INDEX`).
Surface roughness was fitted at σ ≈ 0.1–0.5 by species (Bousquet et al. 2005, laurel, beech,
hazel; Comar et al. 2014: wheat 0.18 along the veins and 0.46 across); each species draws its α
in that range (:mod:`spectral_cam.presets.plants`).

Within a leaf and between leaves: ``vein`` (a float texture, 0–1) blends the lamina's spectra
towards the veins' (pale, thick: :func:`spectral_cam.leaves.vein_traits`), then ``age`` (0–1,
usually a per-vertex ``mesh_attribute``) towards an old leaf's lamina (veins fade into it), and
``wood`` (0–1) towards an opaque Lambertian bark ``reflectance_wood`` without a cuticle: the
spectra are mixed linearly, as a pixel mixes the surfaces it sees (linear spectral mixing).

Sampling picks the lobe by its expected albedo (specular F(θi); reflection and transmission the
body's band means times 1 − F(θi); the bark's), then a GGX visible normal or a cosine-weighted
direction on that side; the sample's pdf is the whole mixture's and its weight f·|cos θo|/pdf,
so the estimate is unbiased and multiple importance sampling sees the same pdf as ``pdf``.

References
----------
.. [1] Jakob, W., et al. (2022). Mitsuba 3, "Custom plugins in Python" (``mi.BSDF``,
   ``mi.register_bsdf``); ``mi.MicrofacetDistribution``, ``mi.fresnel``.
.. [2] Pharr, Jakob & Humphreys (2023), PBRT 4th ed., §9.2 (diffuse BSDFs), §9.6 (Torrance–Sparrow
   with GGX), §13.1 (choosing a lobe by its albedo).
.. [3] Walter, B., Marschner, S. R., Li, H., & Torrance, K. E. (2007). Microfacet models for
   refraction through rough surfaces. EGSR, 195–206.
.. [4] Jacquemoud, S., & Baret, F. (1990). PROSPECT: A model of leaf optical properties spectra.
   Remote Sensing of Environment 34(2), 75–91; Féret et al. (2017) PROSPECT-D, RSE 193, 204–215.
.. [5] Grant, L. (1987). Diffuse and specular characteristics of leaf reflectance. Remote Sensing
   of Environment 22(2), 309–322; Vanderbilt, V. C., & Grant, L. (1985). Plant canopy specular
   reflectance model. IEEE TGRS 23(5), 722–730.
.. [6] Bousquet, L., Lachérade, S., Jacquemoud, S., & Moya, I. (2005). Leaf BRDF measurements and
   model for specular and diffuse components differentiation. Remote Sensing of Environment
   98(2–3), 201–211; Comar, A., et al. (2014). ACT: a leaf BRDF model taking into account the
   azimuthal anisotropy of monocotyledonous leaf surface. RSE 143, 112–121.
.. [7] Stern, F. (1964). Transmission of isotropic radiation across an interface between two
   dielectrics. Applied Optics 3(1), 111–113 (the cone-averaged t_α of PROSPECT).
"""

from __future__ import annotations

import numpy as np

from ..leaves import LEAF_PLUGIN as PLUGIN

__all__ = ["PLUGIN", "register", "fresnel", "hemispherical_transmissivity"]



def fresnel(cos_theta, eta: float):
    """Unpolarised Fresnel reflectance of light meeting a dielectric of index ``eta`` from air
    at incidence cos θ (numpy; Born & Wolf §1.5)."""
    c = np.clip(np.asarray(cos_theta, dtype=float), 0.0, 1.0)
    s2 = 1.0 - c * c
    ct = np.sqrt(np.maximum(1.0 - s2 / eta ** 2, 0.0))
    rs = (c - eta * ct) / (c + eta * ct)
    rp = (eta * c - ct) / (eta * c + ct)
    return 0.5 * (rs * rs + rp * rp)


def hemispherical_transmissivity(eta: float) -> float:
    """t̄ = 1 − 2∫₀^{π/2} F(θ) cos θ sin θ dθ: the share of diffuse (Lambertian) light that
    crosses the interface from air (prosail's ``calctav(90, n)``)."""
    mu = (np.arange(20000) + 0.5) / 20000  # cos θ, midpoint rule on ∫ F(μ)·2μ dμ
    return float(1.0 - np.mean(fresnel(mu, eta) * 2.0 * mu))


def _bsdf_class(mi):
    """The leaf's ``mi.BSDF`` subclass for the active variant; its maths are the module's
    functions below, which take the instance (``leaf``) and the variant's ``mi`` and ``dr``."""
    import drjit as dr

    # Mitsuba requires this class inside a function: a Python BSDF must subclass the active
    # variant's mi.BSDF, which exists only once mi.set_variant has run and is another class in each
    # variant (register() makes and registers one per variant). Only the overrides Mitsuba calls
    # stay here; the maths are module-level functions.
    class Leaf(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            _init_leaf(mi, dr, self, props)

        def sample(self, ctx, si, sample1, sample2, active=True):
            return _sample(mi, dr, self, si, sample1, sample2, active)

        def eval(self, ctx, si, wo, active=True):
            return _eval_pdf(mi, dr, self, si, wo, active, want_pdf=False)[0]

        def pdf(self, ctx, si, wo, active=True):
            return _eval_pdf(mi, dr, self, si, wo, active)[1]

        def eval_pdf(self, ctx, si, wo, active=True):
            return _eval_pdf(mi, dr, self, si, wo, active)

        def eval_diffuse_reflectance(self, si, active=True):
            return _diffuse_reflectance(mi, dr, self, si, active)

        def traverse(self, callback):  # nothing to optimise: the leaf's spectra come from its traits
            pass

        def to_string(self):
            return _describe(self)

    return Leaf


# ----------------------------------------------------------------------------- the leaf's parameters
def _texture(props, name):
    return props.get_texture(name) if name in props else None


def _init_leaf(mi, dr, leaf, props) -> None:
    """Read the plugin's properties onto ``leaf``: its spectra and traits, the cuticle (``eta``,
    ``alpha``) and the lobes' flags."""
    leaf.reflectance = props.get_texture("reflectance")
    leaf.transmittance = props.get_texture("transmittance")
    leaf.vein = _texture(props, "vein")
    leaf.age = _texture(props, "age")
    leaf.wood = _texture(props, "wood")
    names = ["reflectance_vein", "transmittance_vein", "reflectance_old", "transmittance_old",
             "reflectance_wood"]
    leaf.spectra = {name: _texture(props, name) for name in names}
    if leaf.vein is not None and leaf.spectra["reflectance_vein"] is None:
        raise ValueError(f"{PLUGIN}: 'vein' needs reflectance_vein and transmittance_vein")
    if leaf.age is not None and leaf.spectra["reflectance_old"] is None:
        raise ValueError(f"{PLUGIN}: 'age' needs reflectance_old and transmittance_old")
    if leaf.wood is not None and leaf.spectra["reflectance_wood"] is None:
        raise ValueError(f"{PLUGIN}: 'wood' needs reflectance_wood")
    leaf.cuticle = "eta" in props
    leaf.eta = float(props.get("eta", 1.0))
    leaf.alpha = float(props.get("alpha", 0.3))
    leaf.t_diffuse = hemispherical_transmissivity(leaf.eta) if leaf.cuticle else 1.0
    # opaque (not literals): plants of other roughness compile to the same kernels
    leaf.eta_v = dr.opaque(mi.Float, leaf.eta)
    leaf.alpha_v = dr.opaque(mi.Float, leaf.alpha)
    leaf.inv_t_diffuse_v = dr.opaque(mi.Float, 1.0 / leaf.t_diffuse)
    both = mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide
    reflection = mi.BSDFFlags.DiffuseReflection | both
    transmission = mi.BSDFFlags.DiffuseTransmission | both
    glossy = mi.BSDFFlags.GlossyReflection | both
    leaf.m_components = [reflection, transmission] + ([glossy] if leaf.cuticle else [])
    leaf.m_flags = reflection | transmission | (glossy if leaf.cuticle else mi.BSDFFlags(0))


def _describe(leaf) -> str:
    cuticle = f", eta={leaf.eta:g}, alpha={leaf.alpha:g}" if leaf.cuticle else ""
    return f"{PLUGIN}[reflectance={leaf.reflectance}, transmittance={leaf.transmittance}{cuticle}]"


# ----------------------------------------------------------------------------- spectra at a point
def _mix(dr, leaf, si, active, young, vein_name, old_name):
    """A spectrum of the young lamina, blended towards the veins' by ``vein``, then towards an old
    leaf's by ``age``."""
    value = young.eval(si, active)
    if leaf.vein is not None:
        value = dr.lerp(value, leaf.spectra[vein_name].eval(si, active), leaf.vein.eval_1(si, active))
    if leaf.age is not None:
        value = dr.lerp(value, leaf.spectra[old_name].eval(si, active), leaf.age.eval_1(si, active))
    return value


def _spectra(mi, dr, leaf, si, active):
    """(ρ, τ, bark, w): the body's reflectance and transmittance here, the bark's
    reflectance and the bark's weight."""
    rho = _mix(dr, leaf, si, active, leaf.reflectance, "reflectance_vein", "reflectance_old")
    tau = _mix(dr, leaf, si, active, leaf.transmittance, "transmittance_vein", "transmittance_old")
    if leaf.wood is None:
        return rho, tau, None, mi.Float(0.0)
    return rho, tau, leaf.spectra["reflectance_wood"].eval(si, active), leaf.wood.eval_1(si, active)


def _fresnel(mi, dr, leaf, cos_theta):
    return mi.fresnel(dr.abs(cos_theta), leaf.eta_v)[0] if leaf.cuticle else mi.Float(0.0)


# ----------------------------------------------------------------------------- lobes
def _lobe_weights(mi, dr, leaf, si, rho, tau, bark, w):
    """Unnormalised probabilities of the specular, reflected and transmitted lobes."""
    body = 1.0 - w
    f_i = _fresnel(mi, dr, leaf, mi.Frame3f.cos_theta(si.wi))
    spec = body * f_i
    refl = body * (1.0 - f_i) * dr.mean(rho)
    if bark is not None:
        refl += w * dr.mean(bark)
    trans = body * (1.0 - f_i) * dr.mean(tau)
    return spec, refl, trans


def _probabilities(mi, dr, leaf, si, rho, tau, bark, w):
    spec, refl, trans = _lobe_weights(mi, dr, leaf, si, rho, tau, bark, w)
    total = spec + refl + trans
    ok = total > 0
    p_spec = dr.select(ok, spec / dr.maximum(total, 1e-12), 0.0)
    p_refl = dr.select(ok, refl / dr.maximum(total, 1e-12), 1.0)
    return p_spec, p_refl, 1.0 - p_spec - p_refl


def _distribution(mi, leaf):
    return mi.MicrofacetDistribution(mi.MicrofacetType.GGX, leaf.alpha_v, leaf.alpha_v, True)


def _local(mi, dr, si, wo):
    """ωi and ωo mirrored so that ωi lies above the surface (both faces alike)."""
    flip = dr.select(mi.Frame3f.cos_theta(si.wi) >= 0, 1.0, -1.0)
    wi = mi.Vector3f(si.wi.x, si.wi.y, si.wi.z * flip)
    return wi, mi.Vector3f(wo.x, wo.y, wo.z * flip)


def _spec_eval_pdf(mi, dr, leaf, si, wo, want_pdf=True):
    """The specular lobe's f·|cos θo| and its pdf (per solid angle) at ωo."""
    wi, wo = _local(mi, dr, si, wo)
    cos_i, cos_o = mi.Frame3f.cos_theta(wi), mi.Frame3f.cos_theta(wo)
    valid = (cos_i > 0) & (cos_o > 0)
    h = dr.normalize(wi + wo)
    distr = _distribution(mi, leaf)
    d = distr.eval(h)
    g = distr.G(wi, wo, h)
    dot_ih = dr.dot(wi, h)
    f = mi.fresnel(dr.maximum(dot_ih, 0.0), leaf.eta_v)[0]
    value = f * d * g / (4.0 * dr.maximum(cos_i, 1e-12))
    if not want_pdf:
        return dr.select(valid, value, 0.0), None
    pdf = distr.pdf(wi, h) / (4.0 * dr.maximum(dr.abs(dr.dot(wo, h)), 1e-12))
    return dr.select(valid, value, 0.0), dr.select(valid, pdf, 0.0)


def _body_factor(mi, dr, leaf, si, wo):
    """(1 − F(θi))·(1 − F(θo))/t̄ under a cuticle, 1 without."""
    if not leaf.cuticle:
        return mi.Float(1.0)
    f_i = _fresnel(mi, dr, leaf, mi.Frame3f.cos_theta(si.wi))
    f_o = _fresnel(mi, dr, leaf, mi.Frame3f.cos_theta(wo))
    return (1.0 - f_i) * (1.0 - f_o) * leaf.inv_t_diffuse_v


# ----------------------------------------------------------------------------- the BSDF's queries
def _eval_pdf(mi, dr, leaf, si, wo, active, want_pdf=True):
    """(f·|cos θo|, pdf) at ωo: the body's lobes, the bark's and the cuticle's (pdf None when not
    wanted)."""
    rho, tau, bark, w = _spectra(mi, dr, leaf, si, active)
    cos_o = mi.Frame3f.cos_theta(wo)
    same = mi.Frame3f.cos_theta(si.wi) * cos_o > 0
    lambert = dr.abs(cos_o) * dr.inv_pi
    body = _body_factor(mi, dr, leaf, si, wo) * (1.0 - w)
    value = dr.select(same, rho, tau) * body * lambert
    if bark is not None:
        value += dr.select(same, bark, 0.0) * w * lambert
    if leaf.cuticle:
        spec, spec_pdf = _spec_eval_pdf(mi, dr, leaf, si, wo, want_pdf)
        value += spec * (1.0 - w)
    if not want_pdf:  # eval alone: no lobe probabilities, no pdfs (fewer operations to compile)
        return value & active, None
    p_spec, p_refl, p_trans = _probabilities(mi, dr, leaf, si, rho, tau, bark, w)
    pdf = dr.select(same, p_refl, p_trans) * lambert
    if leaf.cuticle:
        pdf += p_spec * spec_pdf
    return value & active, dr.select(active, pdf, 0.0)


def _sample(mi, dr, leaf, si, sample1, sample2, active):
    """A lobe chosen by its expected albedo, then a GGX visible normal or a cosine-weighted
    direction on its side: the ``mi.BSDFSample3f`` and its weight f·|cos θo|/pdf."""
    rho, tau, bark, w = _spectra(mi, dr, leaf, si, active)
    p_spec, p_refl, p_trans = _probabilities(mi, dr, leaf, si, rho, tau, bark, w)
    choose_spec = sample1 < p_spec
    reflect = sample1 < p_spec + p_refl
    local = mi.warp.square_to_cosine_hemisphere(sample2)  # z >= 0
    side = dr.select(mi.Frame3f.cos_theta(si.wi) >= 0, 1.0, -1.0)
    wo = mi.Vector3f(local.x, local.y, dr.select(reflect, side, -side) * local.z)
    if leaf.cuticle:
        wi_local, _ = _local(mi, dr, si, wo)
        m, _ = _distribution(mi, leaf).sample(wi_local, sample2)
        spec_wo = mi.reflect(wi_local, m)
        # a microfacet normal that reflects below the horizon: the sample is lost (the pdf
        # counts the lobe on ωi's side only, so keeping it would bias the transmission)
        active = active & ~(choose_spec & (mi.Frame3f.cos_theta(spec_wo) <= 0))
        spec_wo = mi.Vector3f(spec_wo.x, spec_wo.y, spec_wo.z * side)
        wo = dr.select(choose_spec, spec_wo, wo)
    value, pdf = _eval_pdf(mi, dr, leaf, si, wo, active)
    bs = mi.BSDFSample3f()
    bs.wo = wo
    bs.pdf = pdf
    bs.eta = 1.0
    bs.sampled_type = dr.select(choose_spec, mi.UInt32(+mi.BSDFFlags.GlossyReflection),
                                dr.select(reflect, mi.UInt32(+mi.BSDFFlags.DiffuseReflection),
                                          mi.UInt32(+mi.BSDFFlags.DiffuseTransmission)))
    bs.sampled_component = dr.select(choose_spec, mi.UInt32(2),
                                     dr.select(reflect, mi.UInt32(0), mi.UInt32(1)))
    weight = value / dr.maximum(pdf, 1e-20)
    return bs, weight & (active & (pdf > 0))


def _diffuse_reflectance(mi, dr, leaf, si, active):
    """The body's reflectance at normal incidence ((1 − F(0))·ρ under a cuticle; the
    bark's where ``wood``): what an albedo label reads."""
    rho, tau, bark, w = _spectra(mi, dr, leaf, si, active)
    value = rho * (1.0 - _fresnel(mi, dr, leaf, mi.Float(1.0))) * (1.0 - w)
    if bark is not None:
        value += bark * w
    return value & active


def register(mi) -> None:
    """Register the leaf BSDF for the current variant (Python plugins are per variant), once."""
    from .plugins import register_once

    register_once(mi, "bsdf", PLUGIN, _bsdf_class)
