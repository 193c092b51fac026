"""dampfit's phyphox experiment ``dampfit-decay.phyphox``: shipped in the package, written on request.

The file (``dampfit/data/dampfit-decay.phyphox``, package data of the wheel) is XML in the
phyphox file format (format 1.14: ``rateStrategy``): the acceleration sensor without g
(``<sensor type="linear_acceleration" rate="0" rateStrategy="request">``: as fast as the phone
delivers, samples passed on as they come, none duplicated or dropped by resampling) writing
the time, x, y and z buffers (``<container size="0">``: unbounded, so a whole decay is kept),
one graph of them, and an export set "Raw Data" whose columns — ``Time (s)``, ``Linear
Acceleration x (m/s^2)``, … — are those of phyphox's own accelerometer export, which
:func:`dampfit.io.readers.read` reads as ``phyphox-csv``. ``dampfit record`` finds these
buffers through ``/config`` (:mod:`dampfit.record.phyphox`), not by their names.

Format facts from the phyphox-docs repository (github.com/phyphox/phyphox-docs):
``docs/file-format/index.md`` and ``input.md``, and the element specifications
``spec/root.yml`` (container ``size``: default 1, 0 = unbounded; export ``set``/``data``) and
``spec/views.yml`` (graph ``labelX``/``unitX``/``partialUpdate``, several x/y inputs).

**QR code** (optional, ``pip install 'dampfit[qr]'`` = segno): phyphox adds an experiment
from a QR code that carries the file itself (its "offline" QR format, documented on the
phyphox-docs page on transferring experiments and in its ``tools/generate_qr.py``): the
payload is the file STORED in a headerless zip entry (the file's bytes followed by a data
descriptor ``PK\\x07\\x08``, CRC-32, size, size), cut into chunks; each code is the 13-byte
header ``phyphox`` + CRC-32 of the whole payload (big-endian) + chunk index + chunk count,
then its chunk, encoded as one byte-mode segment (iOS accepts nothing else).
:func:`qr_payloads` builds them; :func:`write_experiment` draws them with segno as SVG files.
"""

from __future__ import annotations

import io
import os
import struct
import zlib
from importlib import resources
from pathlib import Path

from dampfit.files.atomic import atomic_write, check_output_file

#: File name of the shipped experiment.
EXPERIMENT = "dampfit-decay.phyphox"
#: Largest chunk [bytes] per QR code (what phyphox's own editor uses: dense codes stay
#: scannable off a screen).
QR_CHUNK = 1500
_MAGIC = b"phyphox"


def experiment_bytes() -> bytes:
    """The shipped experiment file, byte for byte."""
    return resources.files("dampfit").joinpath("data", EXPERIMENT).read_bytes()


def qr_payloads(data: bytes, chunk: int = QR_CHUNK) -> list[bytes]:
    """The byte string of each QR code that carries ``data`` as a phyphox experiment (see the
    module docstring); one code when the file fits into ``chunk`` bytes."""
    crc = zlib.crc32(data) & 0xFFFFFFFF
    payload = data + b"PK\x07\x08" + struct.pack("<III", crc, len(data), len(data))
    whole = zlib.crc32(payload) & 0xFFFFFFFF
    parts = [payload[i:i + chunk] for i in range(0, len(payload), chunk)]
    if len(parts) > 255:
        raise ValueError("the experiment is too large for phyphox's QR codes")
    return [_MAGIC + struct.pack(">I", whole) + bytes([i, len(parts)]) + part
            for i, part in enumerate(parts)]


def _qr_paths(path: Path, n: int) -> list[Path]:
    stem = path.with_suffix("").name if path.suffix == ".phyphox" else path.name
    if n == 1:
        return [path.with_name(f"{stem}.qr.svg")]
    return [path.with_name(f"{stem}.qr-{i + 1}-of-{n}.svg") for i in range(n)]


#: Largest existing file [bytes] ``--force`` looks into to see whether dampfit wrote it.
_OURS_MAX = 4 * 2**20


def _ours(path: Path, kind: str) -> bool:
    """Whether the existing ``path`` is a file dampfit's ``--experiment`` writes: a phyphox
    experiment whose category is ``dampfit`` (this version's or an older one), or a QR code
    SVG (``kind`` "svg"). A link is never ours (``--force`` would replace the link only, but
    nobody asked dampfit to write one)."""
    import xml.etree.ElementTree as ET

    from dampfit.errors import InputError
    from dampfit.io.bounded import read_regular

    try:
        data = read_regular(path, _OURS_MAX, missing=FileNotFoundError(), what="a file")
    except (OSError, InputError):
        return False
    if kind == "svg":
        head = data[:400].lstrip()
        return (head.startswith(b"<?xml") or head.startswith(b"<svg")) and b"<svg" in head
    try:
        root = ET.fromstring(data)
    except (ET.ParseError, ValueError):
        return False
    return root.tag == "phyphox" and (root.findtext("category") or "").strip() == "dampfit"


def _check(path: Path, force: bool, kind: str) -> Path:
    """:func:`check_output_file`, and with ``force`` only a file dampfit wrote is replaced."""
    from dampfit.errors import InputError

    path = check_output_file(path, force, option="--experiment")
    if force and os.path.lexists(path) and not _ours(path, kind):
        raise InputError(f"refusing to replace {path} with --force: it is not a file dampfit's "
                         "--experiment wrote (a phyphox experiment of category 'dampfit' or "
                         "its QR code); remove it yourself or choose another name")
    return path


def write_experiment(path: str | os.PathLike, force: bool = False) -> tuple[Path, list[Path], str]:
    """Write the experiment to ``path`` (refused if it exists, unless ``force`` and dampfit
    wrote it: :func:`_ours`) and, when segno is installed, its QR code(s) beside it as
    ``NAME.qr.svg``; atomic writes. Returns (the file, the QR files, a line on the QR code:
    where it is, or how to get one)."""
    path = _check(Path(path), force, "phyphox")
    data = experiment_bytes()
    payloads = qr_payloads(data)
    qr_paths = _qr_paths(path, len(payloads))
    try:
        import segno
    except ImportError:
        segno = None
    if segno is not None:
        for p in qr_paths:
            _check(p, force, "svg")

    def write_bytes(content: bytes):
        def write(tmp: str) -> None:
            with open(tmp, "wb") as fh:
                fh.write(content)
        return write

    atomic_write(path, write_bytes(data), suffix=".phyphox")
    if segno is None:
        return path, [], ("no QR code: segno is not installed (pip install 'dampfit[qr]' "
                          "draws one beside the file)")
    for payload, p in zip(payloads, qr_paths):
        buf = io.BytesIO()
        segno.make(payload, mode="byte", error="l", micro=False).save(
            buf, kind="svg", scale=4, border=4, dark="#000000", light="#ffffff")
        atomic_write(p, write_bytes(buf.getvalue()), suffix=".svg")
    which = qr_paths[0].name if len(qr_paths) == 1 else f"{len(qr_paths)} codes {qr_paths[0].name}…"
    return path, qr_paths, (f"QR code: {which} (in phyphox tap + → 'Add experiment from QR code' "
                            "and scan it from the screen)")
