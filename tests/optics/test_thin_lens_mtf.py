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


# ----------------------------------------------------------------------------- diffraction OTF numerics
def _reference_diffraction(lens, data, wavelengths_nm, layout=None):
    """The float64 NumPy algorithm apply_diffraction replaced (issue 14 #4), on ``layout``
    ((rows, columns), (top, left)); None: its own, 3 Airy radii reflected on each side."""
    height, width = data.shape[:2]
    if layout is None:
        reach = 3.0 * 1.22 * max(wavelengths_nm) * 1e-9 * lens.working_f_number / lens.pixel_pitch_m
        pad = int(min(max(8, np.ceil(reach)), max(height, width)))
        layout = ((height + 2 * pad, width + 2 * pad), (pad, pad))
    (rows, columns), (top, left) = layout
    pads = ((top, rows - height - top), (left, columns - width - left))
    fy = np.fft.fftfreq(rows)[:, None]
    fx = np.fft.rfftfreq(columns)[None, :]
    radial = np.hypot(fx, fy) / lens.pixel_pitch_m
    out = np.empty(data.shape, dtype=np.float64)
    for band, wavelength in enumerate(wavelengths_nm):
        padded = np.pad(data[..., band].astype(np.float64), pads, mode="symmetric")
        otf = diffraction_mtf(radial, float(wavelength), lens.working_f_number)
        blurred = np.fft.irfft2(np.fft.rfft2(padded) * otf, s=(rows, columns))
        clipped = np.maximum(blurred[top:top + height, left:left + width], 0.0)
        out[..., band] = clipped * (data[..., band].sum(dtype=np.float64) / clipped.sum())
    return out


def _test_cube(height, width, bands, seed=0):
    """Noise, a bright step and a few one-pixel sources: every frequency up to Nyquist."""
    rng = np.random.default_rng(seed)
    cube = rng.random((height, width, bands), dtype=np.float32)
    cube[height // 3:, width // 2:] *= 5.0
    cube[rng.integers(0, height, 4), rng.integers(0, width, 4)] = 40.0
    return cube


def _lens(height, width, f_number=16.0, pitch=4e-6):
    return ThinLens(0.05, f_number, 3.0, width * pitch, height * pitch, width, height)


@pytest.mark.parametrize("height, width, f_number, pitch", [
    (61, 97, 16.0, 4e-6),  # odd sizes; 11 px of reflection, padded to fast lengths
    (53, 40, 22.0, 2e-6),  # 29 px of reflection, 75 padded rows (odd: the mirrored OTF half)
    (9, 12, 8.0, 4e-6),    # reflection capped at the image's larger side, reflected twice
    (1, 1, 8.0, 4e-6),
])
def test_diffraction_matches_the_float64_reference_on_its_layout(height, width, f_number, pitch):
    from scipy.fft import next_fast_len

    lens = _lens(height, width, f_number, pitch)
    wavelengths = [400.0, 550.0, 620.0, 700.0]
    cube = _test_cube(height, width, len(wavelengths))
    layout = lens.diffraction_padding(height, width, wavelengths)
    (rows, columns), (top, left) = layout
    reach = 3.0 * 1.22 * 700e-9 * lens.working_f_number / pitch  # 3 Airy radii, px
    pad = min(max(8, np.ceil(reach)), max(height, width))
    assert rows == next_fast_len(rows) and columns == next_fast_len(columns, real=True)
    assert min(top, left, rows - height - top, columns - width - left) >= pad
    assert rows - height - 2 * top in (0, 1) and columns - width - 2 * left in (0, 1)  # extra split evenly

    blurred = lens.apply_diffraction(cube, wavelengths)
    reference = _reference_diffraction(lens, cube, wavelengths, layout)
    assert blurred.dtype == np.float32 and blurred.shape == cube.shape
    error = np.abs(blurred - reference).max() / reference.max()
    print(f"{height}x{width}: max |float32 − float64| / max = {error:.2e}")
    assert error < 1e-5
    assert blurred.sum(axis=(0, 1)) == pytest.approx(cube.sum(axis=(0, 1), dtype=np.float64), rel=1e-5)


def test_diffraction_layout_changes_only_the_border_against_the_legacy_padding():
    # The fast FFT sizes reflect a few more pixels than the 3 Airy radii the float64 code
    # did. ~5 % of the Airy PSF's light falls outside 3 Airy radii (1 − EE ≈ 2/(πx), x =
    # 3·3.83), and the periodic FFT wraps it in from the opposite border: on a soft slanted
    # edge at f/16, 4 µm (Airy radius 3.5 px at 700 nm) the legacy layout is 0.9 % of the
    # maximum off a wide reflection at the border column, the new one 0.6 %; they differ
    # by 0.3 %.
    height, width, wavelengths = 64, 90, [450.0, 700.0]
    lens = _lens(height, width)
    y, x = np.mgrid[:height, :width]
    edge = 1.0 / (1.0 + np.exp(-((x - 0.1 * y) - 40.0) / 1.5))  # a soft, slanted edge
    cube = np.repeat((0.2 + edge)[..., None], 2, axis=2).astype(np.float32)
    new = lens.apply_diffraction(cube, wavelengths)
    legacy = _reference_diffraction(lens, cube, wavelengths)
    wide = _reference_diffraction(lens, cube, wavelengths, ((height + 600, width + 600), (300, 300)))
    assert np.abs(new - legacy).max() / legacy.max() < 5e-3
    assert np.abs(new - wide).max() < np.abs(legacy - wide).max()


def test_reflection_index_is_numpy_pads_symmetric_mode_at_any_width():
    from spectral_cam.optics.thin_lens import _reflection_index

    for size in range(1, 7):
        for before in range(16):
            for after in (0, 1, 5, 15):
                samples = np.arange(size)
                expected = np.pad(samples, (before, after), mode="symmetric")
                assert np.array_equal(samples[_reflection_index(before, size, before + size + after)], expected)


def test_pocketfft_gives_the_same_bytes_for_any_number_of_workers():
    # scipy's pocketfft splits the 1-D transforms of an axis among threads, SIMD-batching
    # 4–8 lines at a time and the rest one by one: which lines a thread gets changes with
    # the count, the arithmetic per line must not.
    import scipy.fft as sfft

    rng = np.random.default_rng(3)
    for shape in [(37, 53), (211, 97), (250, 486)]:
        x = rng.random(shape, dtype=np.float32)
        spectrum = sfft.rfft2(x, workers=1)
        back = sfft.irfft2(spectrum, s=shape, workers=1)
        assert spectrum.dtype == np.complex64 and back.dtype == np.float32
        for workers in (2, 3, 5, 8):
            assert sfft.rfft2(x, workers=workers).tobytes() == spectrum.tobytes(), (shape, workers)
            assert sfft.irfft2(spectrum, s=shape, workers=workers).tobytes() == back.tobytes(), (shape, workers)


def test_diffraction_gives_the_same_bytes_for_any_workers_grouping_and_input_layout(monkeypatch):
    from spectral_cam.optics import thin_lens as optics

    height, width = 45, 70
    lens = _lens(height, width)
    wavelengths = list(np.linspace(400.0, 700.0, 7))
    cube = _test_cube(height, width, len(wavelengths), seed=1)
    expected = lens.apply_diffraction(cube, wavelengths, workers=1).tobytes()
    for workers in (2, 3, 5, 16):  # bands spread over threads
        assert lens.apply_diffraction(cube, wavelengths, workers=workers).tobytes() == expected, workers
    # one plane per group, one band in flight: the threads go to pocketfft instead
    monkeypatch.setattr(optics, "DIFFRACTION_GROUP_BYTES", 1)
    for workers in (1, 2, 3):
        assert lens.apply_diffraction(cube, wavelengths, workers=workers).tobytes() == expected, workers
    in_place = cube.copy()  # in place, a band group at a time: every group read before it is written
    assert lens.apply_diffraction(in_place, wavelengths, workers=2, out=in_place) is in_place
    assert in_place.tobytes() == expected
    monkeypatch.undo()
    in_place = cube.copy()
    lens.apply_diffraction(in_place, wavelengths, out=in_place)
    assert in_place.tobytes() == expected
    # any dtype and memory layout in; the same float32 values give the same bytes out
    as_float64 = cube.astype(np.float64)
    band_major = np.ascontiguousarray(cube.transpose(2, 0, 1)).transpose(1, 2, 0)
    for variant in (as_float64, band_major):
        assert lens.apply_diffraction(variant, wavelengths, workers=2).tobytes() == expected


def test_diffraction_refuses_a_wavelength_count_that_is_not_the_band_count():
    with pytest.raises(ValueError, match="3 wavelengths for 2 bands"):
        _lens(8, 8).apply_diffraction(np.ones((8, 8, 2), np.float32), [450.0, 550.0, 650.0])


def test_optics_imports_scipy_only_when_diffraction_runs():
    import subprocess
    import sys

    code = ("import sys; from spectral_cam.optics import ThinLens; "
            "lens = ThinLens(0.05, 8.0, 3.0, 6.4e-3, 4.8e-3, 640, 480); lens.describe(); lens.diffraction_cost(700.0); "
            "print('scipy' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=False)
    assert done.stdout.strip() == "False", done.stdout + done.stderr
