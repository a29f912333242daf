"""A leaf as Mitsuba sees it: a two-sided Lambertian reflector *and transmitter* with spectral
reflectance R(λ) and transmittance T(λ) (PROSPECT-D's, :mod:`spectral_cam.leaves`), written in
Python (drjit) because Mitsuba 3 has no diffuse transmitter (its ``principledthin`` ties
transmission to the reflection colour).

    f(ωi, ωo) = R/π  (ωo on ωi's side),   T/π  (on the other side)

Sampling chooses reflection with probability p = R̄/(R̄ + T̄) (band means at the path's
wavelengths), then a cosine-weighted direction on that side; the weight is R/p or T/(1 − p), so
the estimate is unbiased for any p. Both faces are alike (PROSPECT's leaf is symmetric).

References
----------
.. [1] Jakob, W., et al. (2022). Mitsuba 3, "Custom plugins in Python" (``mi.BSDF``,
   ``mi.register_bsdf``).
.. [2] Pharr, Jakob & Humphreys (2023), PBRT 4th ed., §9.2 (diffuse BSDFs), §13.1 (choosing a
   lobe by its albedo); Jacquemoud & Baret (1990) (the leaf as a Lambertian reflector and
   transmitter).
"""

from __future__ import annotations

from ..leaves import LEAF_PLUGIN as PLUGIN

__all__ = ["PLUGIN", "register"]

_REGISTERED: set[str] = set()


def _bsdf_class(mi):
    import drjit as dr

    class Leaf(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            self.reflectance = props.get_texture("reflectance")
            self.transmittance = props.get_texture("transmittance")
            both = mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide
            reflection = mi.BSDFFlags.DiffuseReflection | both
            transmission = mi.BSDFFlags.DiffuseTransmission | both
            self.m_components = [reflection, transmission]
            self.m_flags = reflection | transmission

        def _reflect_probability(self, si, active):
            r = dr.mean(self.reflectance.eval(si, active))
            t = dr.mean(self.transmittance.eval(si, active))
            return dr.select(r + t > 0, r / dr.maximum(r + t, 1e-12), 1.0)

        def sample(self, ctx, si, sample1, sample2, active=True):
            p = self._reflect_probability(si, active)
            reflect = sample1 < p
            local = mi.warp.square_to_cosine_hemisphere(sample2)  # z >= 0
            side = dr.select(mi.Frame3f.cos_theta(si.wi) >= 0, 1.0, -1.0)
            wo = mi.Vector3f(local.x, local.y, dr.select(reflect, side, -side) * local.z)
            bs = mi.BSDFSample3f()
            bs.wo = wo
            bs.pdf = dr.select(reflect, p, 1.0 - p) * mi.warp.square_to_cosine_hemisphere_pdf(local)
            bs.eta = 1.0
            bs.sampled_type = dr.select(reflect, mi.UInt32(+mi.BSDFFlags.DiffuseReflection),
                                        mi.UInt32(+mi.BSDFFlags.DiffuseTransmission))
            bs.sampled_component = dr.select(reflect, mi.UInt32(0), mi.UInt32(1))
            weight = dr.select(reflect, self.reflectance.eval(si, active) / dr.maximum(p, 1e-12),
                               self.transmittance.eval(si, active) / dr.maximum(1.0 - p, 1e-12))
            return bs, weight & (active & (bs.pdf > 0))

        def eval(self, ctx, si, wo, active=True):
            cos_o = mi.Frame3f.cos_theta(wo)
            same = mi.Frame3f.cos_theta(si.wi) * cos_o > 0
            value = dr.select(same, self.reflectance.eval(si, active), self.transmittance.eval(si, active))
            return (value * dr.inv_pi * dr.abs(cos_o)) & active

        def pdf(self, ctx, si, wo, active=True):
            cos_o = mi.Frame3f.cos_theta(wo)
            p = self._reflect_probability(si, active)
            same = mi.Frame3f.cos_theta(si.wi) * cos_o > 0
            return dr.select(same, p, 1.0 - p) * dr.abs(cos_o) * dr.inv_pi

        def eval_pdf(self, ctx, si, wo, active=True):
            return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

        def traverse(self, callback):  # nothing to optimise: the leaf's spectra come from its traits
            pass

        def to_string(self):
            return f"{PLUGIN}[reflectance={self.reflectance}, transmittance={self.transmittance}]"

    return Leaf


def register(mi) -> None:
    """Register the leaf BSDF for the current variant (Python plugins are per variant), once."""
    if mi.variant() in _REGISTERED:
        return
    cls = _bsdf_class(mi)
    mi.register_bsdf(PLUGIN, lambda props: cls(props))
    _REGISTERED.add(mi.variant())

