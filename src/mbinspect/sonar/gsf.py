"""GSF (Generic Sensor Format, 2.x and 3.x): swath bathymetry ping records.

Big-endian records: a size, an identifier (checksum flag, registry, type), the data. A
ping record (type 2) holds a ping header (time, position, heading, the tide and draft
correctors already added to its depths) and subrecords: arrays of per-beam values stored
as integers with a scale factor (value = stored / multiplier - offset) given by a scale
factors subrecord that holds until the next one. A beam is valid when the ping's flag
and its beam flag have bit 0 clear and it has a depth. The sounding lies ``across`` to
starboard and ``along`` ahead of the ping position, turned by the heading; a file without
across-track distances cannot place its soundings and is refused.
"""

from __future__ import annotations

import struct
import warnings

import numpy as np

from ..errors import InputWarning
from .common import Datagrams, Soundings, offsets_to_geographic

__all__ = ["read_gsf"]

_PING = 2
_HEADER = 1
#: array subrecord id -> (name, default bytes per value, signed)
_ARRAYS = {1: ("depth", 2, False), 2: ("across", 2, True), 3: ("along", 2, True), 5: ("beam_angle", 2, True),
           6: ("amp_cal", 1, True), 7: ("amp_rel", 1, False), 16: ("flags", 1, False),
           19: ("sigma_v", 2, False), 20: ("sigma_h", 2, False)}
_SCALE = 100
_UNSCALED = {"flags"}
_KINDS = {(1, True): "b", (1, False): "B", (2, True): ">i2", (2, False): ">u2", (4, True): ">i4",
          (4, False): ">u4"}


def read_gsf(path: str) -> Soundings:
    """Read the soundings of a GSF file.

    Parameters
    ----------
    path : str
        The file (``.gsf``, ``.mb121``).

    Returns
    -------
    Soundings
        ``intensity`` is the mean calibrated amplitude (dB) where the file has it, else the
        mean relative amplitude; ``sigma_v`` and ``sigma_h`` are the file's vertical and
        horizontal errors (m, at 95 %) halved to 1 sigma.

    Raises
    ------
    InputError
        A record past the end of the file (naming its byte offset), an array without scale
        factors, no ping record, or no across-track distances (the soundings cannot be placed).
    """
    with open(path, "rb") as fh:
        data = fh.read()
    dg = Datagrams(path, data)
    version = ""
    scales: dict[int, tuple[float, float, int]] = {}
    pings: list[tuple] = []
    overruns: list[tuple[int, int]] = []
    arrays: dict[str, list[tuple[np.ndarray, float, float]]] = {k[0]: [] for k in _ARRAYS.values()}
    off, n = 0, len(data)
    while off + 8 <= n:
        size, ident = struct.unpack_from(">II", data, off)
        start = off + 8 + (4 if ident & 0x80000000 else 0)
        kind = ident & 0x3FFFFF if (ident >> 22) & 0x3FF == 0 else -1
        if off + 8 + size > n:
            raise dg.fail(f"a GSF record of {size} bytes runs past the end of the file (truncated)", off)
        if kind == _HEADER:
            version = data[start:start + 12].split(b"\0")[0].decode("ascii", "replace")
        elif kind == _PING:
            pings.append(_ping(dg, start, off + 8 + size, off, version, scales, arrays, overruns))
        off += 8 + size
    if not version.startswith("GSF-v"):
        raise dg.fail("no GSF header record; expected a GSF file")
    if not pings:
        raise dg.fail("no swath bathymetry ping record; expected soundings")
    if overruns:
        subs = sorted({s for s, _ in overruns})
        most = max(k for _, k in overruns)
        warnings.warn(f"{path}: in {len(overruns)} of {len(pings)} pings a subrecord not read here "
                      f"({', '.join(map(str, subs))}) runs up to {most} byte{'s' * (most > 1)} past its "
                      "record; ignored, as libgsf does", InputWarning, stacklevel=4)
    return _assemble(path, version, pings, arrays)


def _ping(dg: Datagrams, start: int, end: int, off: int, version: str,
          scales: dict[int, tuple[float, float, int]],
          arrays: dict[str, list[tuple[np.ndarray, float, float]]],
          overruns: list[tuple[int, int]]) -> tuple:
    data = dg.data
    sec, nsec, lon, lat, nbeams, _centre, ping_flags, _res, tide, draft, heading = struct.unpack_from(
        ">iiiiHHHhhiH", data, start)
    p = start + (56 if version >= "GSF-v03.01" else 42)
    got: dict[str, tuple[np.ndarray, float, float]] = {}
    while p + 4 <= end:
        word, = struct.unpack_from(">I", data, p)
        sub, size = word >> 24, word & 0xFFFFFF
        body = p + 4
        if body + size > end:
            if sub == _SCALE or sub in _ARRAYS:
                raise dg.fail(f"ping subrecord {sub} of {size} bytes runs past its record", off)
            # a subrecord not read here (NOAA's EM302 files write their intensity series one
            # byte long, as libgsf and gsfu tolerate): its ping kept, the overrun counted
            overruns.append((sub, body + size - end))
            break
        if sub == _SCALE:
            count, = struct.unpack_from(">i", data, body)
            for k in range(count):
                w, mult, offset = struct.unpack_from(">Iii", data, body + 4 + 12 * k)
                scales[w >> 24] = (float(mult), float(offset), (w >> 20) & 0xF)
        elif sub in _ARRAYS and nbeams:
            name, default, signed = _ARRAYS[sub]
            width = size // nbeams if size // nbeams in (1, 2, 4) else default
            raw = np.frombuffer(data, _KINDS[width, signed], nbeams, body)
            mult, offset = 1.0, 0.0
            if name not in _UNSCALED:
                if sub not in scales or scales[sub][0] == 0:
                    raise dg.fail(f"ping array subrecord {sub} ({name}) without a scale factor", off)
                mult, offset = scales[sub][:2]
            got[name] = (raw, mult, offset)
        p = body + size
    for name, parts in arrays.items():
        parts.append(got[name] if name in got else (np.full(nbeams, np.nan), 1.0, 0.0))
    return (sec + nsec * 1e-9, lat * 1e-7, lon * 1e-7, heading / 100.0, ping_flags, nbeams,
            "across" in got, "depth" in got)


def _scaled(parts: list[tuple[np.ndarray, float, float]], counts: np.ndarray) -> np.ndarray:
    """One array of a file: every ping's stored values, scaled by that ping's factors."""
    if not parts:
        return np.zeros(0)
    raw = np.concatenate([q[0] for q in parts]).astype(np.float64)
    mult = np.repeat([q[1] for q in parts], counts)
    offset = np.repeat([q[2] for q in parts], counts)
    return raw / mult - offset


def _assemble(path: str, version: str, pings: list[tuple],
              arrays: dict[str, list[tuple[np.ndarray, float, float]]]) -> Soundings:
    info = np.array([q[:6] for q in pings], dtype=np.float64)
    counts = info[:, 5].astype(np.int64)
    if not any(q[6] for q in pings):
        raise Datagrams(path, b"").fail("the pings have no across-track distances: the soundings "
                                        "cannot be placed (not georeferenceable)")
    a = {k: _scaled(v, counts) for k, v in arrays.items()}
    rep = np.repeat(np.arange(len(pings)), counts)
    along = np.nan_to_num(a["along"], nan=0.0)
    lat, lon = offsets_to_geographic(info[rep, 1], info[rep, 2], info[rep, 3], along, a["across"])
    flags = np.nan_to_num(a["flags"], nan=0.0).astype(np.int64)
    ping_ok = (info[rep, 4].astype(np.int64) & 1) == 0
    valid = ping_ok & ((flags & 1) == 0) & np.isfinite(a["depth"]) & np.isfinite(a["across"])
    beam = np.concatenate([np.arange(c) for c in counts]) if len(counts) else np.zeros(0, np.int64)
    intensity = a["amp_cal"] if np.isfinite(a["amp_cal"]).any() else a["amp_rel"]
    fields = {
        "ping": rep.astype(np.int64), "beam": beam.astype(np.int32), "beam_angle": a["beam_angle"],
        "intensity": intensity, "time": info[rep, 0], "valid": valid,
        "sigma_v": a["sigma_v"] / 2.0, "sigma_h": a["sigma_h"] / 2.0,
    }
    meta = {"format": "gsf", "source": path, "version": version, "sonar": None,
            "level": "the level of the file's depths (its tide and draft correctors applied)",
            "pings": len(pings)}
    return Soundings(lat, ((lon + 180.0) % 360.0) - 180.0, -a["depth"], fields, meta)
