"""Kongsberg .all (and MB-System's .mb56): XYZ88 'X' and old 'D' depths, 'P' positions.

Either byte order (old systems wrote big-endian). A depth datagram gives, per beam, the
depth below the transmit transducer and the across- and along-track distances from the
position sensor's reference point; the transducer's depth below the water line (in the
datagram) turns the depth into an elevation relative to the water level at the time of
the ping. The ping's position is interpolated in time between the position datagrams of
the active position system; the beam offsets are turned by the heading. Beams that the
sonar marks invalid (XYZ88 detection info bit 7; 'D' beams absent or of zero depth) are not
``valid``.
"""

from __future__ import annotations

import datetime as dt
import struct
import warnings

import numpy as np

from ..errors import InputWarning
from .common import Datagrams, Soundings, offsets_to_geographic

__all__ = ["read_all"]

_STX = 0x02


def _byte_order(dg: Datagrams) -> str:
    data = dg.data
    for order in ("<", ">"):
        if len(data) >= 8:
            size, = struct.unpack_from(order + "I", data, 0)
            if data[4] == _STX and 16 <= size <= len(data) - 4:
                return order
    raise dg.fail("not a Kongsberg .all datagram (no start byte 0x02 after a length); expected "
                  ".all or .mb56 data", 0)


def _seconds(date: np.ndarray, ms: np.ndarray) -> np.ndarray:
    """Seconds since 1970 from Kongsberg's YYYYMMDD date and milliseconds since midnight."""
    epoch = dt.date(1970, 1, 1)
    days = np.array([(dt.date(int(d) // 10000, int(d) // 100 % 100, int(d) % 100) - epoch).days
                     if d > 19000000 else 0 for d in date], dtype=np.float64)
    return days * 86400.0 + ms / 1000.0


def read_all(path: str) -> Soundings:
    """Read the soundings of a Kongsberg .all file.

    Parameters
    ----------
    path : str
        The file (``.all``, ``.mb56``).

    Returns
    -------
    Soundings
        ``intensity`` is the beam's reflectivity (dB), ``beam_angle`` the angle from the
        vertical toward the sounding (deg, + starboard).

    Raises
    ------
    InputError
        A datagram running past the end of the file (naming its byte offset), no depth
        datagram, or no position datagram to place the pings.
    """
    with open(path, "rb") as fh:
        data = fh.read()
    dg = Datagrams(path, data)
    order = _byte_order(dg)
    pos: list[tuple[float, float, float, float, int]] = []
    pings: list[tuple] = []
    beams: list[dict[str, np.ndarray]] = []
    model = None
    corrupt = 0
    off, n = 0, len(data)
    while off + 4 <= n:
        size, = struct.unpack_from(order + "I", data, off)
        if size < 16 or off + 4 + size > n or data[off + 4] != _STX:
            raise dg.fail(f"a datagram of {size} bytes; expected one that fits the file (truncated "
                          "or corrupt)", off)
        kind = data[off + 5]
        if kind in (0x58, 0x44, 0x50) and not _checksum_holds(data, off, size, order):
            corrupt += 1  # a datagram whose bytes changed since the sonar wrote it: left out
        elif kind in (0x58, 0x44, 0x50):  # X, D, P
            model, date, ms, counter, serial = struct.unpack_from(order + "HIIHH", data, off + 6)
            body = off + 20
            if kind == 0x50:
                lat, lon = struct.unpack_from(order + "ii", data, body)
                descriptor = data[body + 16]
                pos.append((date, ms, lat / 2e7, lon / 1e7, descriptor))
            elif kind == 0x58:
                pings.append(_xyz88(dg, order, off, size, date, ms, counter, beams))
            else:
                pings.append(_depth_d(dg, order, off, size, date, ms, counter, model, beams))
        off += 4 + size
    if corrupt:
        warnings.warn(f"{path}: {corrupt} depth or position datagrams fail their checksum (their bytes "
                      "changed since the sonar wrote them) and were left out", InputWarning, stacklevel=4)
    if not pings:
        raise dg.fail("no depth datagram (XYZ88 'X' or 'D'); expected soundings (navigation or "
                      "other records only)")
    if not pos:
        raise dg.fail("no position datagram 'P': the pings cannot be placed")
    return _assemble(path, order, pings, beams, pos, model)


def _xyz88(dg: Datagrams, order: str, off: int, size: int, date: int, ms: int, counter: int,
           beams: list[dict[str, np.ndarray]]) -> tuple:
    body = off + 20
    heading, _ss, tx_depth, nbeams, _nvalid, _fs = struct.unpack_from(order + "HHfHHf", dg.data, body)
    start = body + 20
    if start + 20 * nbeams > off + 4 + size:
        raise dg.fail(f"XYZ88 datagram with {nbeams} beams runs past its end", off)
    rec = np.dtype([("z", order + "f4"), ("y", order + "f4"), ("x", order + "f4"), ("win", order + "u2"),
                    ("qf", "u1"), ("iba", "i1"), ("info", "u1"), ("clean", "i1"), ("bs", order + "i2")])
    b = np.frombuffer(dg.data, rec, nbeams, start)
    beams.append({"z": b["z"].astype(np.float64), "y": b["y"].astype(np.float64),
                  "x": b["x"].astype(np.float64), "bs": b["bs"] * 0.1, "valid": (b["info"] & 0x80) == 0,
                  "beam": np.arange(nbeams)})
    return (date, ms, counter, heading / 100.0, float(tx_depth), nbeams)


def _depth_d(dg: Datagrams, order: str, off: int, size: int, date: int, ms: int, counter: int,
             model: int, beams: list[dict[str, np.ndarray]]) -> tuple:
    body = off + 20
    heading, _ss, tx_cm, _max, nvalid, zres, xyres, _rate = struct.unpack_from(order + "HHHBBBBH", dg.data,
                                                                               body)
    start = body + 12
    if start + 16 * nvalid + 1 > off + 4 + size:
        raise dg.fail(f"depth datagram 'D' with {nvalid} beams runs past its end", off)
    unsigned = model in (120, 300, 1002, 2000, 3000, 3002)
    rec = np.dtype([("z", order + ("u2" if unsigned else "i2")), ("y", order + "i2"), ("x", order + "i2"),
                    ("dep", order + "i2"), ("az", order + "u2"), ("range", order + "u2"), ("qf", "u1"),
                    ("win", "u1"), ("bs", "i1"), ("num", "u1")])
    b = np.frombuffer(dg.data, rec, nvalid, start)
    multiplier = struct.unpack_from("b", dg.data, start + 16 * nvalid)[0]
    tx_depth = (tx_cm + 65536 * multiplier) / 100.0
    z = b["z"] * (zres / 100.0)
    beams.append({"z": z.astype(np.float64), "y": b["y"] * (xyres / 100.0), "x": b["x"] * (xyres / 100.0),
                  "bs": b["bs"] * 0.5, "valid": z != 0, "beam": b["num"].astype(np.int64) - 1})
    return (date, ms, counter, heading / 100.0, tx_depth, nvalid)


def _checksum_holds(data: bytes, off: int, size: int, order: str) -> bool:
    """Whether a datagram's checksum (the sum of its bytes between STX and ETX) holds; one
    without an ETX where it belongs holds nothing to check."""
    end = off + 4 + size
    if data[end - 3] != 0x03:
        return True
    stored, = struct.unpack_from(order + "H", data, end - 2)
    body = np.frombuffer(data, np.uint8, end - 3 - (off + 5), off + 5)
    return (int(body.sum(dtype=np.uint64)) & 0xFFFF) == stored


def _assemble(path: str, order: str, pings: list[tuple], beams: list[dict[str, np.ndarray]],
              pos: list[tuple[float, float, float, float, int]], model: int | None) -> Soundings:
    p = np.array(pos, dtype=np.float64)
    active = (p[:, 4].astype(np.int64) & 0x80) != 0
    if active.any():
        p = p[active]
    # positions in time order, one per instant (a file may repeat or interleave them)
    pt, first = np.unique(_seconds(p[:, 0], p[:, 1]), return_index=True)
    plat, plon = p[first, 2], p[first, 3]
    info = np.array([q[:5] for q in pings], dtype=np.float64)
    counts = np.array([q[5] for q in pings])
    t = _seconds(info[:, 0], info[:, 1])
    outside = np.maximum(pt[0] - t, t - pt[-1])
    if (outside > 1.0).any():  # np.interp holds the end fixes: say how far that reaches
        warnings.warn(f"{path}: {int((outside > 1.0).sum())} of {len(t)} pings lie up to "
                      f"{float(outside.max()):.1f} s outside the navigation's time span; they are placed at "
                      "its first or last fix, off by as far as the ship sailed meanwhile", InputWarning,
                      stacklevel=4)
    lat_p = np.interp(t, pt, plat)
    lon_p = np.interp(t, pt, np.unwrap(plon, period=360.0))
    b = {k: np.concatenate([q[k] for q in beams]) for k in beams[0]}
    rep = np.repeat(np.arange(len(pings)), counts)
    lat, lon = offsets_to_geographic(lat_p[rep], lon_p[rep], info[rep, 3], b["x"].astype(np.float64),
                                     b["y"].astype(np.float64))
    z = -(b["z"] + info[rep, 4])
    ping_no = np.unwrap(info[:, 2], period=65536).astype(np.int64)
    fields = {
        "ping": ping_no[rep], "beam": b["beam"].astype(np.int32),
        "beam_angle": np.degrees(np.arctan2(b["y"], b["z"])).astype(np.float64),
        "intensity": b["bs"].astype(np.float64), "time": t[rep], "valid": b["valid"].astype(bool),
    }
    meta = {"format": "all", "source": path, "sonar": f"EM{model}" if model else None,
            "byte_order": "little-endian" if order == "<" else "big-endian",
            "level": "water level at the time of the ping (no tide)", "pings": len(pings)}
    return Soundings(lat, ((lon + 180.0) % 360.0) - 180.0, z, fields, meta)
