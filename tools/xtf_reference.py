"""An independent decode of an XTF file of R2Sonic bathymetry, to cross-check mbinspect's reader.

Independent of ``mbinspect.sonar.xtf`` in every step it can be: pyxtf (PyPI) frames the
file and parses its header and channel table; each BTH0 section is parsed value by value
with ``struct``; the soundings are placed on the ellipsoid by pyproj's geodesic (``Geod.fwd``
from the ping position along the heading plus 90 degrees) and projected with pyproj. The
geometry is the one the reader's docstring states (roll and mounting roll applied to the
beam angle, mounting yaw to the heading, heave added; no pitch, no lever arm), so the two
must agree to the rounding of the file's floats.

Run in an environment with pyxtf (``pip install pyxtf==1.5.0 pyproj numpy``)::

    python tools/xtf_reference.py FILE.xtf OUT.reference.npz

The arrays are those of the other ``*.reference.npz`` in ``tests/data``: ``xyz`` (UTM of the
file's zone), ``intensity``, ``beam_angle``, ``ping``, ``valid``, ``lat``, ``lon``, ``sx``,
``sy``, ``line``, and also ``range`` (m) and ``time``.
"""

from __future__ import annotations

import math
import struct
import sys

import numpy as np
import pyxtf
from pyproj import Geod, Transformer


def _sections(body: bytes) -> dict[str, bytes]:
    assert body[:4] == b"BTH0", body[:4]
    length = struct.unpack(">I", body[4:8])[0]
    out, q = {}, 12
    while q < length:
        name = body[q:q + 2].decode()
        size = struct.unpack(">H", body[q + 2:q + 4])[0]
        out[name] = body[q:q + size]
        q += size
    return out


def _ping(packet: bytes) -> list[dict]:
    """Every beam of one type-65 packet (``packet`` from its first byte)."""
    lat, lon = struct.unpack("<dd", packet[160:176])
    _pitch, roll, heading, heave = struct.unpack("<ffff", packet[204:220])
    s = _sections(packet[256:])
    h0 = s["H0"]
    t_s, t_ns, ping = struct.unpack(">III", h0[28:40])
    speed = struct.unpack(">f", h0[44:48])[0]
    n = struct.unpack(">H", h0[-2:])[0]
    r_scale = struct.unpack(">f", s["R0"][4:8])[0]
    a_first, a_scale = struct.unpack(">ff", s["A2"][4:12])
    i_scale = struct.unpack(">f", s["I1"][4:8])[0]
    beams, angle_sum = [], 0
    for k in range(n):
        raw_r = struct.unpack(">H", s["R0"][8 + 2 * k:10 + 2 * k])[0]
        angle_sum += struct.unpack(">h", s["A2"][36 + 2 * k:38 + 2 * k])[0]
        raw_i = struct.unpack(">H", s["I1"][8 + 2 * k:10 + 2 * k])[0]
        word = struct.unpack(">I", s["Q0"][4 + 4 * (k // 8):8 + 4 * (k // 8)])[0]
        flags = (word >> (28 - 4 * (k % 8))) & 0xF
        beams.append({"range": raw_r * r_scale * speed / 2, "angle": a_first + angle_sum * a_scale,
                      "upa": raw_i * i_scale, "valid": bool(flags & 0xC) and raw_r > 0,
                      "lat": lat, "lon": lon, "roll": roll, "heading": heading, "heave": heave,
                      "ping": ping, "time": t_s + t_ns * 1e-9})
    return beams


def decode(path: str) -> dict[str, np.ndarray]:
    header, packets = pyxtf.xtf_read(path, types=[pyxtf.XTFHeaderType.qinsy_r2sonic_bathy])
    bathy = [c for c in header.ChanInfo if c.TypeOfChannel == 3][0]
    beams: list[dict] = []
    # pyxtf keeps the packet's bytes after its 14-byte start; put the start back
    for p in packets[pyxtf.XTFHeaderType.qinsy_r2sonic_bathy]:
        beams.extend(_ping(bytes(p)[:14] + p.data))
    geod = Geod(ellps="WGS84")
    vertical = [b["angle"] - math.radians(b["roll"] + bathy.OffsetRoll) for b in beams]
    across = [b["range"] * math.sin(v) for b, v in zip(beams, vertical, strict=True)]
    azimuth = [b["heading"] + bathy.OffsetYaw + 90.0 for b in beams]
    lon, lat, _ = geod.fwd([b["lon"] for b in beams], [b["lat"] for b in beams], azimuth, across)
    zone = int((np.median([b["lon"] for b in beams]) + 180) // 6) + 1
    epsg = (32600 if np.median(lat) >= 0 else 32700) + zone
    to_utm = Transformer.from_crs("EPSG:4326", f"EPSG:{epsg}", always_xy=True)
    x, y = to_utm.transform(lon, lat)
    sx, sy = to_utm.transform([b["lon"] for b in beams], [b["lat"] for b in beams])
    z = [-b["range"] * math.cos(v) + b["heave"] for b, v in zip(beams, vertical, strict=True)]
    return {"xyz": np.column_stack([x, y, z]),
            "intensity": np.array([20 * math.log10(b["upa"]) if b["upa"] > 0 else np.nan for b in beams]),
            "beam_angle": np.degrees(vertical), "ping": np.array([b["ping"] for b in beams]),
            "valid": np.array([b["valid"] for b in beams]), "lat": np.asarray(lat), "lon": np.asarray(lon),
            "sx": np.asarray(sx), "sy": np.asarray(sy), "line": np.zeros(len(beams), np.int32),
            "range": np.array([b["range"] for b in beams]), "time": np.array([b["time"] for b in beams]),
            "epsg": np.array(epsg)}


if __name__ == "__main__":
    out = decode(sys.argv[1])
    np.savez_compressed(sys.argv[2], **out)
    print(f"{sys.argv[1]}: {len(out['xyz']):,} soundings, {int(out['valid'].sum()):,} valid, "
          f"{len(np.unique(out['ping']))} pings, EPSG:{int(out['epsg'])}")
