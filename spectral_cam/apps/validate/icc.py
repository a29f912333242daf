"""Images tagged with an embedded ICC profile: a tool's output decoded to linear sRGB through the
profile it carries (``output = "icc"`` of a command pipeline).

Raw developers embed matrix/TRC ("matrix-shaper") profiles in what they write: darktable's linear
Rec. 709, RawTherapee's RTv4_sRGB, an sRGB IEC61966-2.1 profile. Such a profile says everything
needed: each channel's tone reproduction curve (``rTRC``/``gTRC``/``bTRC``: a ``curv`` table or
gamma, or a ``para`` parametric curve) takes the stored values to linear light, and the
colorants (``rXYZ``/``gXYZ``/``bXYZ``, the primaries' XYZ adapted to the D50 profile connection
space) take linear light to XYZ (D50). From there Bradford adaptation to D65 and sRGB's matrix give
linear sRGB. Profiles built on lookup tables (``A2B0``) are refused with a clear message.

References
----------
.. [1] ICC.1:2022 (profile version 4.4), §7.2 (header), §7.3 (tag table), §10.6 (curveType),
   §10.18 (parametricCurveType), §10.31 (XYZType), §F.3 (the three-component matrix-based
   input and display profiles: connection = [colorants]·TRC(device)).
.. [2] Lam (1985); CIE 160:2004 (the Bradford transform).
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from ...errors import ConfigError

__all__ = ["embedded_profile", "MatrixShaperProfile", "icc_to_linear_srgb"]

#: The profile connection space's white (ICC.1 §7.2.16: D50, Y = 1).
PCS_WHITE_XYZ = np.array([0.9642, 1.0, 0.8249])


def embedded_profile(path: str | Path) -> bytes | None:
    """The ICC profile embedded in a TIFF (tag 34675, InterColorProfile) or PNG (iCCP, read with
    Pillow), or None."""
    path = Path(path)
    if path.suffix.lower() in (".tif", ".tiff"):
        import tifffile

        with tifffile.TiffFile(path) as tif:
            tag = tif.pages[0].tags.get(34675)
            return bytes(tag.value) if tag is not None else None
    if path.suffix.lower() == ".png":
        from PIL import Image

        with Image.open(path) as image:
            return image.info.get("icc_profile")
    return None


def _s15(data: bytes, offset: int, count: int) -> np.ndarray:
    """``count`` s15Fixed16Number values at ``offset``."""
    return np.array(struct.unpack(f">{count}i", data[offset:offset + 4 * count]), dtype=np.float64) / 65536.0


class MatrixShaperProfile:
    """A matrix/TRC ICC profile: per-channel curves to linear light, colorants to XYZ (D50).

    Parameters
    ----------
    data : bytes
        The profile.

    Raises
    ------
    ConfigError
        For a profile that is not an RGB matrix/TRC one (what it lacks is named).
    """

    def __init__(self, data: bytes):
        if len(data) < 132 or data[36:40] != b"acsp":
            raise ConfigError("the embedded ICC profile is not a profile (no 'acsp' signature)")
        if data[16:20] != b"RGB ":
            raise ConfigError(f"the embedded ICC profile's colour space is {data[16:20].decode(errors='replace')!r}; "
                              "only RGB profiles are read")
        count = struct.unpack(">I", data[128:132])[0]
        self.tags = {}
        for k in range(count):
            signature, offset, size = struct.unpack(">4sII", data[132 + 12 * k:144 + 12 * k])
            self.tags[signature.decode("latin-1")] = data[offset:offset + size]
        missing = [t for t in ("rXYZ", "gXYZ", "bXYZ", "rTRC", "gTRC", "bTRC") if t not in self.tags]
        if missing:
            raise ConfigError(f"the embedded ICC profile is not a matrix/TRC profile (it lacks {', '.join(missing)}); "
                              "convert the output to sRGB or linear Rec. 709 and declare that instead")
        self.colorants = np.stack([_s15(self.tags[t], 8, 3) for t in ("rXYZ", "gXYZ", "bXYZ")], axis=1)
        self.description = self._description()

    def _description(self) -> str:
        tag = self.tags.get("desc", b"")
        if tag[:4] == b"desc":  # v2 textDescriptionType
            length = struct.unpack(">I", tag[8:12])[0]
            return tag[12:12 + length].rstrip(b"\0").decode("latin-1")
        if tag[:4] == b"mluc":  # v4 multiLocalizedUnicodeType: the first record
            size, offset = struct.unpack(">II", tag[20:28])
            return tag[offset:offset + size].decode("utf-16-be", errors="replace")
        return ""

    @staticmethod
    def _curve(tag: bytes, values: np.ndarray) -> np.ndarray:
        """A TRC applied to device values in [0, 1] (ICC.1 §10.6, §10.18)."""
        kind = tag[:4]
        if kind == b"curv":
            n = struct.unpack(">I", tag[8:12])[0]
            if n == 0:
                return values
            if n == 1:
                return np.sign(values) * np.abs(values) ** (struct.unpack(">H", tag[12:14])[0] / 256.0)
            table = np.array(struct.unpack(f">{n}H", tag[12:12 + 2 * n]), dtype=np.float64) / 65535.0
            return np.interp(values, np.linspace(0.0, 1.0, n), table)
        if kind == b"para":
            function = struct.unpack(">H", tag[8:10])[0]
            counts = {0: 1, 1: 3, 2: 4, 3: 5, 4: 7}
            if function not in counts:
                raise ConfigError(f"the embedded ICC profile has a parametric curve of type {function}; valid: 0-4")
            g, a, b, c, d, e, f = list(_s15(tag, 12, counts[function])) + [1.0, 0.0, 0.0, 0.0, 0.0, 0.0][
                counts[function] - 1:]
            x = np.clip(values, 0.0, None)
            if function == 0:
                return x ** g
            if function == 1:
                return np.where(x >= -b / a, (a * x + b) ** g, 0.0)
            if function == 2:
                return np.where(x >= -b / a, (a * x + b) ** g + c, c)
            if function == 3:
                return np.where(x >= d, (a * x + b) ** g, c * x)
            return np.where(x >= d, (a * x + b) ** g + e, c * x + f)
        raise ConfigError(f"the embedded ICC profile's TRC is a {kind.decode(errors='replace')!r}; valid: curv, para")

    def to_xyz_d50(self, device: np.ndarray) -> np.ndarray:
        """(..., 3) device values in [0, 1] → XYZ relative to the D50 PCS white (Y = 1)."""
        linear = np.stack([self._curve(self.tags[t], device[..., i]) for i, t in enumerate(("rTRC", "gTRC", "bTRC"))],
                          axis=-1)
        return linear @ self.colorants.T


def icc_to_linear_srgb(image: np.ndarray, profile: bytes) -> np.ndarray:
    """An image tagged with ``profile`` (values in [0, 1]) as linear sRGB (D65 white = 1).

    Through the profile to XYZ (D50 PCS), Bradford to D65, sRGB's matrix (IEC 61966-2-1).
    """
    from ...cie import bradford_adaptation, xyz_d65_white
    from ...colour_ground_truth import xyz_to_linear_srgb

    xyz = MatrixShaperProfile(profile).to_xyz_d50(np.asarray(image, dtype=np.float64))
    return xyz_to_linear_srgb(xyz @ bradford_adaptation(PCS_WHITE_XYZ, xyz_d65_white()).T)
