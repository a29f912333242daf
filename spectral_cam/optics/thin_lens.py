"""Thin-lens optics: aperture, image distance, field of view, defocus, diffraction, vignetting.

All lengths in metres unless the name says otherwise (``focal_length_mm``), angles in
degrees where named ``_deg``.

References
----------
.. [1] Hecht, E. (2017). Optics, 5th ed., §5.2 (thin lens), §10.2.5 (Airy pattern).
.. [2] Ray, S. F. (2002). Applied Photographic Optics, 3rd ed., ch. 10 (depth of field,
   circle of confusion), ch. 17 (cos⁴ law).
.. [3] Pharr, M., Jakob, W., & Humphreys, G. (2023). Physically Based Rendering, 4th ed.,
   §5.2.3 (thin-lens camera model).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from .scene import LensSection, SensorSection

__all__ = [
    "ThinLens",
    "diffraction_mtf",
    "defocus_mtf",
    "defocus_otf",
    "pixel_mtf",
    "airy_kernel",
    "MTF_TOLERANCE",
    "DIFFRACTION_GROUP_BYTES",
]

#: An optical effect is modelled only when it costs more than this much MTF at Nyquist.
MTF_TOLERANCE = 0.03


def diffraction_mtf(frequency_cyc_per_m, wavelength_nm, working_f_number):
    """Diffraction-limited MTF of an aberration-free circular pupil (incoherent light).

    MTF(s) = (2/π)·(arccos s − s·√(1 − s²)), s = ν/ν_c, cut-off ν_c = 1/(λ·N_w)
    [Goodman, Introduction to Fourier Optics, 3rd ed., §6.3.2].

    Parameters
    ----------
    frequency_cyc_per_m
        Spatial frequency on the sensor, cycles per metre.
    wavelength_nm
        Wavelength, nm.
    working_f_number
        N_w = N·(1 + m).
    """
    cutoff = 1.0 / (np.asarray(wavelength_nm, dtype=float) * 1e-9 * working_f_number)
    s = np.clip(np.abs(np.asarray(frequency_cyc_per_m, dtype=float)) / cutoff, 0.0, 1.0)
    return (2.0 / np.pi) * (np.arccos(s) - s * np.sqrt(1.0 - s * s))


def defocus_otf(frequency_cyc_per_m, coc_diameter_m):
    """Geometric-optics OTF of a uniform blur disc of diameter c, signed: 2·J₁(πcν)/(πcν)
    (it turns negative past the first zero at cν ≈ 1.22: contrast reversal). Any length
    unit works if ν is in cycles per that unit (e.g. pixels and cycles per pixel).

    References
    ----------
    .. [1] Goodman, J. W. (2005). Introduction to Fourier Optics, 3rd ed., §2.1 (the
       Fourier transform of a circle function, jinc).
    .. [2] Smith, W. J. (2008). Modern Optical Engineering, 4th ed., §11.10.
    """
    from scipy.special import j1

    x = np.pi * np.asarray(coc_diameter_m, dtype=float) * np.abs(np.asarray(frequency_cyc_per_m, dtype=float))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(x < 1e-9, 1.0, 2.0 * j1(x) / np.where(x < 1e-9, 1.0, x))


def defocus_mtf(frequency_cyc_per_m, coc_diameter_m):
    """Geometric-optics MTF of a uniform blur disc of diameter c: |2·J₁(πcν)/(πcν)|, the
    modulus of :func:`defocus_otf` [Smith, Modern Optical Engineering, 4th ed., §11.10]."""
    return np.abs(defocus_otf(frequency_cyc_per_m, coc_diameter_m))


def pixel_mtf(frequency_cyc_per_m, pixel_pitch_m):
    """MTF of a square pixel aperture of 100 % fill factor: |sinc(ν·p)|."""
    return np.abs(np.sinc(np.asarray(frequency_cyc_per_m, dtype=float) * pixel_pitch_m))


def airy_kernel(wavelength_nm: float, working_f_number: float, pixel_pitch_m: float,
                *, energy: float = 0.995, supersample: int = 9, max_radius_px: int = 64) -> np.ndarray:
    """The Airy PSF integrated over square pixels, normalised to sum 1.

    I(r) ∝ [2·J₁(x)/x]², x = π·r/(λ·N_w) [Born & Wolf, Principles of Optics, §8.5.2]. The
    kernel radius grows until it holds ``energy`` of the PSF (from the encircled energy
    1 − J₀²(x) − J₁²(x)), capped at ``max_radius_px``; each pixel is integrated on a
    ``supersample``² grid.
    """
    from scipy.special import j0, j1

    scale = np.pi / (wavelength_nm * 1e-9 * working_f_number)  # x per metre of radius
    radii = np.linspace(1e-12, (max_radius_px + 1) * pixel_pitch_m, 20000)
    encircled = 1.0 - j0(radii * scale) ** 2 - j1(radii * scale) ** 2
    reach = radii[min(np.searchsorted(encircled, energy), len(radii) - 1)]
    half = int(min(max_radius_px, np.ceil(reach / pixel_pitch_m)))
    offsets = (np.arange(supersample) + 0.5) / supersample - 0.5
    centres = np.arange(-half, half + 1)
    fine = (centres[:, None] + offsets[None, :]).ravel() * pixel_pitch_m
    x = np.hypot(fine[:, None], fine[None, :]) * scale
    with np.errstate(invalid="ignore", divide="ignore"):
        psf = np.where(x < 1e-9, 1.0, (2.0 * j1(x) / np.where(x < 1e-9, 1.0, x)) ** 2)
    n = len(centres)
    kernel = psf.reshape(n, supersample, n, supersample).sum(axis=(1, 3))
    return (kernel / kernel.sum()).astype(np.float32)


#: Bytes of padded float32 bands :meth:`ThinLens.apply_diffraction` holds at once (or a
#: quarter of the output cube, if more): each group costs one pass over the interleaved cube.
DIFFRACTION_GROUP_BYTES = 256 << 20
_STRIP_ROWS = 16  # rows per gather/scatter step: the interleaved rows stay in cache


def _usable_cpus() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def _reflection_index(before: int, size: int, total: int) -> np.ndarray:
    """Source index of each of ``total`` positions when ``size`` samples start at ``before``
    and the rest mirror them about their edges, edge sample repeated (``numpy.pad``'s
    "symmetric", any width: the pattern repeats every 2·size)."""
    offset = np.mod(np.arange(total) - before, 2 * size)
    return np.where(offset < size, offset, 2 * size - 1 - offset)


def _diffraction_otf32(radial_cyc_per_px: np.ndarray, scale: float) -> np.ndarray:
    """:func:`diffraction_mtf` in float32 on a grid of radial frequencies in cycles per
    pixel; ``scale`` = λ·N_w/p turns them into s = ν/ν_c."""
    s = radial_cyc_per_px * np.float32(scale)
    np.minimum(s, np.float32(1.0), out=s)  # radial >= 0
    root = s * s
    np.subtract(np.float32(1.0), root, out=root)
    np.sqrt(root, out=root)
    root *= s
    np.arccos(s, out=s)
    s -= root
    s *= np.float32(2.0 / np.pi)
    return s


@dataclass(frozen=True)
class ThinLens:
    """A thin lens of focal length ``focal_length_m`` at f-number ``f_number``, focused at
    ``focus_distance_m`` (object distance along the optical axis), imaging onto a sensor
    ``sensor_width_m`` × ``sensor_height_m`` of ``width_px`` × ``height_px`` pixels."""

    focal_length_m: float
    f_number: float
    focus_distance_m: float
    sensor_width_m: float
    sensor_height_m: float
    width_px: int
    height_px: int
    #: The lens of the configured frame when this one images a larger area (a crop margin,
    #: a supersampled depth probe): scene presets lay objects out against it, so the frame
    #: shows the same scene whatever is rendered around it. None: this lens is the frame.
    frame_lens: "ThinLens | None" = field(default=None, compare=False, repr=False)

    @classmethod
    def from_config(cls, lens: LensSection, sensor: SensorSection) -> "ThinLens":
        return cls(
            focal_length_m=lens.focal_length_mm * 1e-3,
            f_number=lens.f_number,
            focus_distance_m=lens.focus_distance_m,
            sensor_width_m=sensor.width_m,
            sensor_height_m=sensor.height_m,
            width_px=sensor.width_px,
            height_px=sensor.height_px,
        )

    # ------------------------------------------------------------------ frame and capture area
    @property
    def layout_lens(self) -> "ThinLens":
        """The lens of the configured frame (this one unless it images a larger area)."""
        return self.frame_lens if self.frame_lens is not None else self

    def widened(self, margin_px: int) -> "ThinLens":
        """The same optics on a sensor ``margin_px`` pixels (same pitch) larger on every side:
        the frame's pixels see exactly the rays they saw before, and a ring of real pixels
        surrounds them (a DNG's crop margin, a defocus margin).

        Parameters
        ----------
        margin_px
            Whole pixels added on each side, >= 0.
        """
        if not (isinstance(margin_px, int) and margin_px >= 0):
            raise ValueError(f"margin_px {margin_px!r} must be a whole number of pixels >= 0")
        if margin_px == 0:
            return self
        pitch = self.pixel_pitch_m
        return replace(self, width_px=self.width_px + 2 * margin_px, height_px=self.height_px + 2 * margin_px,
                       sensor_width_m=self.sensor_width_m + 2 * margin_px * pitch,
                       sensor_height_m=self.sensor_height_m + 2 * margin_px * pitch, frame_lens=self.layout_lens)

    def supersampled(self, factor: int) -> "ThinLens":
        """The same sensor area sampled ``factor``× finer along each axis (scene layout kept)."""
        return replace(self, width_px=self.width_px * factor, height_px=self.height_px * factor,
                       frame_lens=self.layout_lens)

    @property
    def frame_window(self) -> tuple[int, int, int, int]:
        """(top, left, height, width) of the configured frame in this lens's pixels."""
        frame = self.layout_lens
        scale = frame.pixel_pitch_m / self.pixel_pitch_m
        height, width = round(frame.height_px * scale), round(frame.width_px * scale)
        return (self.height_px - height) // 2, (self.width_px - width) // 2, height, width

    # ------------------------------------------------------------------ first-order optics
    @property
    def aperture_radius_m(self) -> float:
        """Entrance-pupil radius R = f / (2N) (m)."""
        return self.focal_length_m / (2.0 * self.f_number)

    @property
    def image_distance_m(self) -> float:
        """Lens-to-sensor distance v = f·z_f / (z_f − f) (Gaussian lens equation) (m)."""
        f, z = self.focal_length_m, self.focus_distance_m
        return f * z / (z - f)

    @property
    def magnification(self) -> float:
        """Magnification m = f / (z_f − f) at the focus distance (> 0, unsigned)."""
        return self.focal_length_m / (self.focus_distance_m - self.focal_length_m)

    @property
    def working_f_number(self) -> float:
        """Working f-number N_w = N·(1 + m) = N·v/f."""
        return self.f_number * (1.0 + self.magnification)

    @property
    def pixel_pitch_m(self) -> float:
        return self.sensor_width_m / self.width_px

    @property
    def fov_x_deg(self) -> float:
        """Horizontal field of view 2·atan(s_w / 2v), from the image distance (not f)."""
        return math.degrees(2.0 * math.atan(self.sensor_width_m / (2.0 * self.image_distance_m)))

    @property
    def fov_y_deg(self) -> float:
        return math.degrees(2.0 * math.atan(self.sensor_height_m / (2.0 * self.image_distance_m)))

    @property
    def fov_diagonal_deg(self) -> float:
        """Diagonal field of view 2·atan(d / 2v), d the sensor's diagonal."""
        diagonal = math.hypot(self.sensor_width_m, self.sensor_height_m)
        return math.degrees(2.0 * math.atan(diagonal / (2.0 * self.image_distance_m)))

    # ------------------------------------------------------------------ defocus
    def coc_diameter_m(self, depth_m):
        """Circle-of-confusion diameter on the sensor for a point at depth z (m).

        c = A·f·|z − z_f| / (z·(z_f − f)), A = 2R [2, ch. 10].
        """
        z = np.asarray(depth_m, dtype=float)
        f, zf = self.focal_length_m, self.focus_distance_m
        with np.errstate(invalid="ignore"):
            relative = np.where(np.isinf(z), 1.0, np.abs(z - zf) / z)  # |z − z_f|/z → 1 at infinity
        return 2.0 * self.aperture_radius_m * f * relative / (zf - f)

    def coc_diameter_px(self, depth_m):
        return self.coc_diameter_m(depth_m) / self.pixel_pitch_m

    def hyperfocal_distance_m(self, coc_m: float) -> float:
        """H = f²/(N·c) + f for an acceptable circle of confusion c (m)."""
        f = self.focal_length_m
        return f * f / (self.f_number * coc_m) + f

    def depth_of_field_m(self, coc_m: float) -> tuple[float, float]:
        """Near and far limits of acceptable sharpness for a CoC ``coc_m`` (far may be inf)."""
        hyper = self.hyperfocal_distance_m(coc_m)
        z, f = self.focus_distance_m, self.focal_length_m
        near = z * (hyper - f) / (hyper + z - 2 * f)
        far = math.inf if z >= hyper else z * (hyper - f) / (hyper - z)
        return near, far

    # ------------------------------------------------------------------ diffraction
    def airy_diameter_m(self, wavelength_nm):
        """Diameter of the Airy disc's first dark ring, 2.44·λ·N_w (m) [1, §10.2.5]."""
        return 2.44 * np.asarray(wavelength_nm, dtype=float) * 1e-9 * self.working_f_number

    # ------------------------------------------------------------------ image geometry
    def pixel_angles_cos(self) -> np.ndarray:
        """cos θ of each pixel centre's chief ray with the optical axis, shape (H, W)."""
        pitch = self.pixel_pitch_m
        x = (np.arange(self.width_px) + 0.5 - self.width_px / 2) * pitch
        y = (np.arange(self.height_px) + 0.5 - self.height_px / 2) * pitch
        r2 = x[None, :] ** 2 + y[:, None] ** 2
        return self.image_distance_m / np.sqrt(r2 + self.image_distance_m ** 2)

    def project(self, x_m, y_m, z_m):
        """Pixel coordinates (column, row; continuous, 0 at the top-left corner) of a point
        in camera space (camera at the origin looking along +z, +y up).

        Mitsuba's ``look_at`` puts camera-space +x on the image's left, hence the minus sign.
        """
        scale = self.image_distance_m / (np.asarray(z_m, dtype=float) * self.pixel_pitch_m)
        column = self.width_px / 2 - np.asarray(x_m) * scale
        row = self.height_px / 2 - np.asarray(y_m) * scale
        return column, row

    def unproject(self, column, row, z_m):
        """Camera-space (x, y) at depth z of pixel coordinates (inverse of :meth:`project`)."""
        scale = np.asarray(z_m, dtype=float) * self.pixel_pitch_m / self.image_distance_m
        return (self.width_px / 2 - np.asarray(column)) * scale, (self.height_px / 2 - np.asarray(row)) * scale

    @property
    def nyquist_cyc_per_m(self) -> float:
        """Sensor Nyquist frequency 1/(2p), cycles per metre."""
        return 0.5 / self.pixel_pitch_m

    def diffraction_cost(self, wavelength_nm: float) -> float:
        """MTF lost to diffraction at the sensor's Nyquist frequency, 1 − MTF_diff(ν_N)."""
        return float(1.0 - diffraction_mtf(self.nyquist_cyc_per_m, wavelength_nm, self.working_f_number))

    def defocus_cost(self, near_m: float, far_m: float) -> float:
        """Largest MTF loss at Nyquist from defocus over the depth range [near, far] (m)."""
        coc = max(float(self.coc_diameter_m(z)) for z in (near_m, far_m))  # |z − z_f|/z peaks at an end of the range
        return float(1.0 - defocus_mtf(self.nyquist_cyc_per_m, coc))

    def diffraction_padding(self, height: int, width: int, wavelengths_nm) -> tuple[tuple[int, int], tuple[int, int]]:
        """The FFT layout :meth:`apply_diffraction` uses for an ``height`` × ``width`` image.

        At least 3 Airy radii of the longest band (8 px at the least, the image's larger side
        at the most) are reflected on every side, then the padded size grows to the next fast
        FFT length (:func:`scipy.fft.next_fast_len`; the last axis is the real-input one), the
        extra reflected pixels split between the two sides.

        Returns
        -------
        ((int, int), (int, int))
            The padded (rows, columns) and the image's (top, left) offset in them.
        """
        from scipy.fft import next_fast_len

        reach = 3.0 * 1.22 * float(np.max(wavelengths_nm)) * 1e-9 * self.working_f_number / self.pixel_pitch_m
        pad = int(min(max(8, np.ceil(reach)), max(height, width)))
        rows, columns = next_fast_len(height + 2 * pad), next_fast_len(width + 2 * pad, real=True)
        return (rows, columns), (pad + (rows - height - 2 * pad) // 2, pad + (columns - width - 2 * pad) // 2)

    def apply_diffraction(self, data: np.ndarray, wavelengths_nm, *, workers: int | None = None,
                          out: np.ndarray | None = None) -> np.ndarray:
        """Blur each band of an (H, W, B) radiance cube by its diffraction OTF.

        The render's pixel values already integrate radiance over each pixel (box filter),
        so the PSF must not be pixel-integrated a second time: the cube's spectrum is
        multiplied by the diffraction-limited OTF (real and non-negative for an
        aberration-free circular pupil) at each 2-D frequency up to Nyquist. Edges are
        reflected before the FFT (:meth:`diffraction_padding`). The band-limited OTF rings
        slightly below zero next to point-like features; those values are clipped and each
        band rescaled to its total before the blur (OTF(0) = 1: diffraction moves light, it
        does not make any).

        Numerics: float32 real FFTs (scipy's pocketfft) on fast padded sizes, within ~1e-6
        of the maximum of a float64 computation on the same layout. Bands are gathered from
        the interleaved cube a group at a time (one pass over the cube per group, not per
        band) into a preallocated float32 buffer, blurred one band per thread (threads left
        over go to each FFT) and written into the float32 output. Every band takes the same
        arithmetic path whatever the thread count, so ``workers`` never changes the bytes
        (tests/optics/test_thin_lens_mtf.py checks it, pocketfft's own ``workers`` included).

        Parameters
        ----------
        data
            (H, W, B) radiance, any real dtype.
        wavelengths_nm
            The B band centres, nm.
        workers
            Threads; None: every usable CPU.
        out
            Where to write the result: a float32 (H, W, B) array, ``data`` itself included
            (each group of bands is read whole before it is written back, so blurring in
            place gives the same bytes and saves a cube: 5.6 GB at 45 MP, 31 bands).

        Returns
        -------
        numpy.ndarray
            (H, W, B) float32 (``out`` when given).

        References
        ----------
        .. [1] Goodman, Introduction to Fourier Optics, 3rd ed., §6.3 (incoherent imaging
           as multiplication by the OTF).
        """
        from concurrent.futures import ThreadPoolExecutor

        from scipy import fft as sfft

        height, width, n_bands = data.shape
        wavelengths = [float(w) for w in np.asarray(wavelengths_nm, dtype=float).ravel()]
        if len(wavelengths) != n_bands:
            raise ValueError(f"{len(wavelengths)} wavelengths for {n_bands} bands")
        if out is None:
            out = np.empty((height, width, n_bands), dtype=np.float32)
        elif out.shape != data.shape or out.dtype != np.float32:
            raise ValueError(f"out must be a float32 array of shape {data.shape}; got {out.dtype} {out.shape}")
        if out.size == 0:
            return out
        (rows, columns), (top, left) = self.diffraction_padding(height, width, wavelengths)
        workers = _usable_cpus() if workers is None else max(1, int(workers))
        # memory: a group of padded bands, and ~3 padded bands of FFT temporaries per band
        # in flight, each held to DIFFRACTION_GROUP_BYTES or a quarter of the output cube
        budget = max(DIFFRACTION_GROUP_BYTES, out.nbytes // 4)
        plane_bytes = rows * columns * 4
        group = int(np.clip(budget // plane_bytes, 1, n_bands))
        group = -(-n_bands // -(-n_bands // group))  # the same number of groups, evened out
        lanes = int(np.clip(budget // (3 * plane_bytes), 1, min(workers, group)))  # bands in flight
        fft_workers = max(1, workers // lanes)  # pocketfft gives the same bytes for any count
        planes = np.empty((group, rows, columns), dtype=np.float32)
        half = rows // 2 + 1  # the OTF is even in f_y: rows 0..rows/2, the rest mirrored
        radial = np.hypot((np.arange(half) / rows).astype(np.float32)[:, None],
                          np.fft.rfftfreq(columns).astype(np.float32)[None, :])  # cycles per pixel
        reflect_rows = top + _reflection_index(top, height, rows)  # padded row each padded row copies
        reflect_columns = left + _reflection_index(left, width, columns)
        strips = [(r, min(r + _STRIP_ROWS, height)) for r in range(0, height, _STRIP_ROWS)]
        strip_sets = [strips[i::workers] for i in range(min(workers, len(strips)))]

        def blur(slot: int, wavelength_nm: float) -> None:
            plane = planes[slot]
            plane[:top] = plane[reflect_rows[:top]]
            plane[top + height:] = plane[reflect_rows[top + height:]]
            plane[:, :left] = plane[:, reflect_columns[:left]]
            plane[:, left + width:] = plane[:, reflect_columns[left + width:]]
            window = plane[top:top + height, left:left + width]
            total_before = float(window.sum(dtype=np.float64))
            spectrum = sfft.rfft2(plane, workers=fft_workers)
            otf = _diffraction_otf32(radial, wavelength_nm * 1e-9 * self.working_f_number / self.pixel_pitch_m)
            spectrum[:half] *= otf
            spectrum[half:] *= otf[rows - half:0:-1]  # row r holds f_y = −(rows − r)/rows
            del otf
            blurred = sfft.irfft2(spectrum, s=(rows, columns), workers=fft_workers, overwrite_x=True)
            del spectrum
            inner = blurred[top:top + height, left:left + width]
            np.maximum(inner, 0.0, out=inner)
            total_after = float(inner.sum(dtype=np.float64))
            if total_after > 0:
                np.multiply(inner, np.float32(total_before / total_after), out=window)
            else:
                window[...] = inner

        def blur_lane(first: int, slots) -> None:
            for slot in slots:
                blur(slot, wavelengths[first + slot])

        def gather(first: int, count: int, strip_set) -> None:
            for r0, r1 in strip_set:  # a few rows at a time: the interleaved read stays in cache
                block = np.ascontiguousarray(data[r0:r1, :, first:first + count])
                planes[:count, top + r0:top + r1, left:left + width] = block.transpose(2, 0, 1)

        def scatter(first: int, count: int, strip_set) -> None:
            for r0, r1 in strip_set:
                out[r0:r1, :, first:first + count] = \
                    planes[:count, top + r0:top + r1, left:left + width].transpose(1, 2, 0)

        pool = ThreadPoolExecutor(max_workers=workers) if workers > 1 else None

        def each(func, calls) -> None:
            if pool is None or len(calls) == 1:
                for args in calls:
                    func(*args)
            else:
                list(pool.map(lambda args: func(*args), calls))  # list(): re-raise a thread's error

        try:
            for first in range(0, n_bands, group):
                count = min(group, n_bands - first)
                each(gather, [(first, count, strip_set) for strip_set in strip_sets])
                each(blur_lane, [(first, range(lane, count, lanes)) for lane in range(min(lanes, count))])
                each(scatter, [(first, count, strip_set) for strip_set in strip_sets])
        finally:
            if pool is not None:
                pool.shutdown()
        return out

    def describe(self) -> dict:
        """Derived quantities for meta.json."""
        return {
            "aperture_radius_m": self.aperture_radius_m,
            "image_distance_m": self.image_distance_m,
            "magnification": self.magnification,
            "working_f_number": self.working_f_number,
            "fov_x_deg": self.fov_x_deg,
            "fov_y_deg": self.fov_y_deg,
            "sensor_width_m": self.sensor_width_m,
            "sensor_height_m": self.sensor_height_m,
        }
