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


def test_diffraction_decision_applied_at_f22_2um_and_skipped_at_f1_4_24um():
    from spectral_cam.render.decisions import decide_diffraction
    from spectral_cam.spectra import parse_bands

    bands = parse_bands("400:700:10")

    def decide(f_number, pitch):
        return decide_diffraction(ThinLens(0.05, f_number, 3.0, 400 * pitch, 300 * pitch, 400, 300), bands, "auto")

    applied, record = decide(22, 2e-6)
    assert applied and record["choice"] == "airy_psf_per_band"
    skipped, record = decide(1.4, 24e-6)
    assert not skipped and record["choice"] == "skipped" and "0.03" in record["reason"]


def test_lens_decision_uses_the_depth_range():
    from spectral_cam.render.decisions import decide_lens_model

    lens = ThinLens(0.025, 1.4, 2.0, 480 * 6e-6, 320 * 6e-6, 480, 320)
    flat = np.full((4, 4), 2.0)
    assert decide_lens_model(lens, flat)[0] == "pinhole"
    deep = flat.copy()
    deep[0, 0] = 1.0  # CoC at 1 m = 2R·f·|z − z_f|/(z·(z_f − f)) ≈ 228 µm ≫ one pixel
    choice, record = decide_lens_model(lens, deep)
    assert choice == "thin" and record["max_coc_px"] == pytest.approx(
        (0.025 / 1.4) * 0.025 * 1.0 / (1.0 * 1.975) / 6e-6, rel=1e-6)


@pytest.mark.timeout(120)
def test_diffraction_blurs_the_render_and_conserves_energy(make_scene):
    from spectral_cam import render

    base = {"scene": {"preset": "slanted_edge"}, "lens": {"model": "pinhole", "f_number": 22.0},
            "sensor": {"width_px": 32, "height_px": 32, "pixel_pitch_um": 2.0}}
    on = render(make_scene(**base, render={"spp": 16, "diffraction": "on"}), with_depth=False)
    off = render(make_scene(**base, render={"spp": 16, "diffraction": "off"}), with_depth=False)
    assert on.data.sum() == pytest.approx(off.data.sum(), rel=0.02)  # reflected borders
    # the edge spreads: fewer pixels sit at the plateaus' extremes
    assert np.abs(np.diff(on.data[..., -1], axis=1)).max() < 0.6 * np.abs(np.diff(off.data[..., -1], axis=1)).max()


def test_diffraction_conserves_each_bands_total_even_for_a_point_source():
    lens = ThinLens(0.008, 2.8, 2.0, 64 * 6e-6, 64 * 6e-6, 64, 64)
    cube = np.zeros((64, 64, 2), np.float32)
    cube[32, 32] = 1.0  # a one-pixel source: the band-limited OTF rings below zero around it
    blurred = lens.apply_diffraction(cube, [550.0, 700.0])
    assert blurred.min() >= 0
    assert blurred.sum(axis=(0, 1)) == pytest.approx([1.0, 1.0], rel=1e-5)
    assert blurred[32, 32, 1] < blurred[32, 32, 0] < 1.0  # longer waves spread more
