"""Write spectral_cam/data/colour_science/tables.npz: the colour-science datasets the render path
reads, so that a render, an exposure and a develop never import colour-science (0.5–1 s and
~77 MB of pandas and scipy.interpolate on every run; docs/design.md, "Fixed cost").

Every array is colour-science's own, unchanged;
tests/test_cie.py checks the shipped tables and the formulas of :mod:`spectral_cam.cie` against
the installed colour-science. Run it again after upgrading colour-science:

    python tools/make_colour_tables.py

colour-science is BSD-3-Clause (Colour Developers); the datasets' own sources are listed in
spectral_cam/data/colour_science/README.md.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parents[1] / "spectral_cam" / "data" / "colour_science" / "tables.npz"
CMFS = "CIE 1931 2 Degree Standard Observer"


def _add_set(arrays: dict, key: str, sds) -> None:
    """Spectra of a set: names, then one wavelength grid and a (spectra, wavelengths) table where
    they share a grid, else wavelengths and values per index."""
    sds = list(sds)
    arrays[f"{key}__names"] = np.array([str(sd.name) for sd in sds])
    grids = [np.asarray(sd.wavelengths, dtype=np.float64) for sd in sds]
    if all(len(g) == len(grids[0]) and np.array_equal(g, grids[0]) for g in grids):
        arrays[f"{key}__wavelengths"] = grids[0]
        arrays[f"{key}__values"] = np.stack([np.asarray(sd.values, dtype=np.float64) for sd in sds])
        return
    for index, sd in enumerate(sds):
        arrays[f"{key}__{index}__wavelengths"] = np.asarray(sd.wavelengths, dtype=np.float64)
        arrays[f"{key}__{index}__values"] = np.asarray(sd.values, dtype=np.float64)


def _named(mapping) -> list:
    out = []
    for name, sd in mapping.items():
        sd = sd.copy()
        sd.name = name
        out.append(sd)
    return out


def main() -> None:
    import colour
    from colour.colorimetry import SDS_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES
    from colour.quality import cfi2017
    from colour.temperature.robertson1968 import DATA_ISOTEMPERATURE_LINES_ROBERTSON1968

    arrays: dict[str, np.ndarray] = {"colour_version": np.array(colour.__version__)}
    # light sources first: an illuminant of the same name wins (as spectral_cam.spectra resolves names)
    _add_set(arrays, "light_sources", _named(colour.SDS_LIGHT_SOURCES))
    _add_set(arrays, "illuminants", _named(colour.SDS_ILLUMINANTS))
    ccs = colour.CCS_ILLUMINANTS[CMFS]
    arrays["illuminant_xy__names"] = np.array(list(ccs.keys()))
    arrays["illuminant_xy__values"] = np.array([np.asarray(ccs[k], dtype=np.float64) for k in ccs])
    cmfs = colour.MSDS_CMFS[CMFS]
    arrays["cmfs_1931__wavelengths"] = np.asarray(cmfs.wavelengths, dtype=np.float64)
    arrays["cmfs_1931__values"] = np.asarray(cmfs.values, dtype=np.float64)
    basis = [SDS_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES[k] for k in ("S0", "S1", "S2")]  # 300–830 nm, 5 nm
    arrays["daylight_basis__wavelengths"] = np.asarray(basis[0].wavelengths, dtype=np.float64)
    arrays["daylight_basis__values"] = np.stack([np.asarray(b.values, dtype=np.float64) for b in basis], axis=1)
    arrays["robertson1968"] = np.asarray(DATA_ISOTEMPERATURE_LINES_ROBERTSON1968, dtype=np.float64)
    _add_set(arrays, "colorchecker", _named(colour.SDS_COLOURCHECKERS["BabelColor Average"]))
    _add_set(arrays, "rawtoaces", colour.characterisation.read_training_data_rawtoaces_v1().to_sds())
    _add_set(arrays, "cie2017", cfi2017.load_TCS_CIE2017(cfi2017.SPECTRAL_SHAPE_CIE2017).to_sds())
    _add_set(arrays, "cri", _named(colour.quality.SDS_TCS["CIE 1995"]))
    _add_set(arrays, "cqs", _named(colour.quality.SDS_VS["NIST CQS 9.0"]))
    for key in ("Nikon 5100 (NPL)", "Sigma SDMerill (NPL)"):
        msds = colour.MSDS_CAMERA_SENSITIVITIES[key]
        slug = key.split(" (")[0].lower().replace(" ", "_")
        arrays[f"camera__{slug}__wavelengths"] = np.asarray(msds.wavelengths, dtype=np.float64)
        arrays[f"camera__{slug}__values"] = np.asarray(msds.values, dtype=np.float64)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(OUT, **arrays)
    print(f"wrote {OUT} ({OUT.stat().st_size / 1e3:.0f} kB, {len(arrays)} arrays, colour-science {colour.__version__})")


if __name__ == "__main__":
    main()
