"""Diffraction, defocus and pixel MTFs, and the Airy kernel, against each other's
independent derivations: the PSF route (Bessel-function Airy pattern, integrated over pixels,
Fourier transformed) must reproduce the pupil-autocorrelation formula times the pixel sinc."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.optics import ThinLens, airy_kernel, defocus_mtf, diffraction_mtf, pixel_mtf


@pytest.mark.parametrize("wavelength_nm, f_number, pitch_m", [(450, 8.0, 2e-6), (700, 4.0, 4e-6), (550, 16.0, 3e-6)])
def test_airy_kernel_spectrum_matches_diffraction_mtf_times_pixel_sinc(wavelength_nm, f_number, pitch_m):
    kernel = airy_kernel(wavelength_nm, f_number, pitch_m, energy=0.999, max_radius_px=200).astype(np.float64)
    row = kernel.sum(axis=0)  # line-spread function along x
    size = 4096
    spectrum = np.abs(np.fft.rfft(row, n=size))
    freqs = np.fft.rfftfreq(size, d=pitch_m)
    keep = freqs <= 0.5 / pitch_m

    def transfer(nu):  # continuous OTF: pupil autocorrelation × signed pixel sinc
        return diffraction_mtf(nu, wavelength_nm, f_number) * np.sinc(nu * pitch_m)

    # a kernel sampled at the pixel pitch carries the aliases of the continuous OTF
    expected = np.abs(sum(transfer(freqs[keep] + k / pitch_m) for k in range(-4, 5)))
    assert np.max(np.abs(spectrum[keep] - expected)) < 0.005
    assert np.allclose(pixel_mtf(freqs[keep], pitch_m), np.abs(np.sinc(freqs[keep] * pitch_m)))


def test_diffraction_mtf_limits():
    cutoff = 1.0 / (550e-9 * 4.0)
    assert diffraction_mtf(0.0, 550, 4.0) == pytest.approx(1.0)
    assert diffraction_mtf(cutoff, 550, 4.0) == pytest.approx(0.0, abs=1e-12)
    # slope at the origin is −4/(π ν_c) (Goodman §6.3.2)
    small = 1e-4 * cutoff
    assert (1 - diffraction_mtf(small, 550, 4.0)) / 1e-4 == pytest.approx(4 / np.pi, rel=1e-3)


def test_defocus_mtf_first_zero():
    # 2·J1(x)/x first vanishes at x = 3.8317 (first zero of J1)
    coc = 20e-6
    assert defocus_mtf(3.8317 / (np.pi * coc), coc) == pytest.approx(0.0, abs=1e-4)
    assert defocus_mtf(0.0, coc) == 1.0


def test_model_decisions_for_diffraction_follow_the_nyquist_cost():
    def lens(f_number, pitch):
        return ThinLens(0.05, f_number, 3.0, 400 * pitch, 300 * pitch, 400, 300)

    assert lens(22, 2e-6).diffraction_cost(700) > 0.03  # applied
    assert lens(1.4, 24e-6).diffraction_cost(700) < 0.03  # skipped
