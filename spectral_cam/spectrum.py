"""A tabulated spectrum that needs no colour-science (:class:`Spectrum`), and its conversion to
colour-science's objects for analyses that use them (:func:`as_colour`).

References
----------
.. [1] Mansencal, T., et al. (2024). Colour 0.4.x, ``SpectralDistribution`` and
   ``MultiSpectralDistributions`` (the attributes this type shares).
"""

from __future__ import annotations

import numpy as np

__all__ = ["Spectrum", "as_colour", "interpolate"]


def interpolate(wavelengths, values, points, *, outside: float | None = None) -> np.ndarray:
    """Tabulated ``values`` (one column per channel) linearly interpolated at ``points`` (nm);
    outside the table the end values are held (``outside=None``) or replaced by ``outside``.
    Linear interpolation keeps spiky spectra (FL11) non-negative."""
    points = np.asarray(points, dtype=np.float64)
    domain, values = np.asarray(wavelengths, dtype=np.float64), np.asarray(values, dtype=np.float64)
    if values.ndim == 1:
        return np.interp(points, domain, values, left=outside, right=outside)
    return np.stack([np.interp(points, domain, column, left=outside, right=outside) for column in values.T],
                    axis=-1)


class Spectrum:
    """A tabulated spectrum: increasing ``wavelengths`` (nm) and ``values`` there, one column
    per channel for several (``labels``), e.g. a camera's r, g, b.

    The attributes colour-science's ``SpectralDistribution`` and
    ``MultiSpectralDistributions`` share (``wavelengths``, ``values``, ``name``, ``labels``,
    ``copy``), so :func:`sample` and this package take either; :meth:`to_colour` gives the
    colour-science object for its functions.

    Examples
    --------
    >>> ramp = Spectrum([400.0, 700.0], [0.1, 0.9], "ramp")
    >>> float(ramp[550.0])
    0.5
    """

    __slots__ = ("wavelengths", "values", "name", "labels")

    def __init__(self, wavelengths, values, name: str = "", labels: tuple[str, ...] | None = None):
        self.wavelengths = np.asarray(wavelengths, dtype=np.float64)
        self.values = np.asarray(values, dtype=np.float64)
        self.name = str(name)
        self.labels = None if labels is None else tuple(labels)
        if self.values.shape[:1] != self.wavelengths.shape:
            raise ValueError(f"spectrum {name!r}: {self.wavelengths.shape[0]} wavelengths but values of shape "
                             f"{self.values.shape}")

    def __getitem__(self, wavelength_nm):
        """Values at wavelengths (nm), linearly interpolated, the end values held outside (as
        :func:`spectral_cam.spectra.sample`; colour-science's ``sd[λ]`` interpolates with its
        own interpolator)."""
        return interpolate(self.wavelengths, self.values, wavelength_nm)

    def copy(self) -> "Spectrum":
        return Spectrum(self.wavelengths.copy(), self.values.copy(), self.name, self.labels)

    def __repr__(self) -> str:
        return (f"Spectrum({self.name!r}, {self.wavelengths[0]:g}–{self.wavelengths[-1]:g} nm, "
                f"{len(self.wavelengths)} samples{'' if self.labels is None else ', ' + '/'.join(self.labels)})")

    def to_colour(self):
        """The colour-science ``SpectralDistribution`` (one channel) or
        ``MultiSpectralDistributions`` (several) of the same table."""
        import colour

        if self.values.ndim == 1:
            return colour.SpectralDistribution(dict(zip(self.wavelengths, self.values)), name=self.name)
        return colour.MultiSpectralDistributions(dict(zip(self.wavelengths, self.values)),
                                                 labels=self.labels, name=self.name)


def as_colour(spectrum):
    """colour-science's object for a :class:`Spectrum` (another object passes through)."""
    return spectrum.to_colour() if isinstance(spectrum, Spectrum) else spectrum
