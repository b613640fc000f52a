"""XTF (Triton's eXtended Triton Format) holding R2Sonic bathymetry: packet type 65, the
sonar's own 'BTH0' packet as QINSy records it.

The file opens with a 1024-byte header (more when it describes more than six channels)
giving the navigation's units and, per channel, the sensor's mounting angles. Every
packet then starts with 0xFACE, its type and its size (little-endian). A type-65 packet is
a 256-byte ping header (the ship's position, heading, roll, pitch and heave at the ping)
followed by the R2Sonic packet, big-endian, in sections: H0 (time, ping number, sound
speed, beam widths), R0 (two-way travel time per beam), A0 or A2 (beam angles from the
array's centreline), I1 (intensity, micropascals) and Q0 (detection flags, 4 bits a beam).

Raw ranges and angles, so each sounding is placed here: a straight ray at the sonar's
sound speed (no sound-speed profile: the outer beams keep a refraction smile), the beam
angle turned into the vertical by the ping's roll and the channel's mounting roll, the
ray's across-track and vertical parts turned by the heading plus the mounting yaw, heave
added. Measured on a real R2Sonic 2026 file (10.5 m), the seabed comes out flat and its
two sides symmetric to 4 cm with roll applied this way; the opposite sign or no mounting
roll tilt it by 1.8-3.5 %. The ping header's pitch is not applied: either sign roughens
that seabed (residual to a 0.25 m median surface, beams within 20 degrees of nadir: 1.50 cm
without, 1.97-2.04 cm with). The channel's lever arm is not applied (the ping's position is
the sensor's, as the header names it) and heights are relative to the transducer with
heave applied: no draft, no tide. A beam is valid when its flags say phase or magnitude
detection and it has a range.
"""

from __future__ import annotations

import struct
from collections import Counter

import numpy as np

from .common import Datagrams, Soundings, offsets_to_geographic

__all__ = ["read_xtf"]

_MAGIC = 0xFACE
_R2SONIC = 65
_FILE_FORMAT = 0x7B
_LATLON = 3
#: Offsets in the 256-byte ping header (little-endian): sensor y (lat), x (lon) as doubles;
#: pitch, roll, heading, heave as floats.
_PING_LAT, _PING_ATTITUDE = 160, 204
#: The H0 section's layout after its name and size.
_H0 = struct.Struct(">12s12sIIIfffffffffHhfffffffIHH")


def read_xtf(path: str) -> Soundings:
    """Read the soundings of an XTF file of R2Sonic bathymetry (packet type 65).

    Parameters
    ----------
    path : str
        The file (``.xtf``).

    Returns
    -------
    Soundings
        ``intensity`` is the beam's intensity (dB re 1 uPa), ``beam_angle`` the angle from
        the vertical (deg, + starboard) after roll, ``time`` the ping's time.

    Raises
    ------
    InputError
        Not an XTF file, a packet that does not start where the previous one ended or runs
        past the end of the file (naming its byte offset), navigation not in latitude and
        longitude, no R2Sonic bathymetry packet (naming the packet types the file holds),
        or a bathymetry packet without its header, ranges or angles.
    """
    with open(path, "rb") as fh:
        data = fh.read()
    dg = Datagrams(path, data)
    start, mount = _file_header(dg)
    packets, kinds = _walk(dg, start)
    if not packets:
        held = ", ".join(f"{k} ({n})" for k, n in sorted(kinds.items())) or "none"
        raise dg.fail(f"no R2Sonic bathymetry packet (type {_R2SONIC}); packet types held: {held}. "
                      "Other XTF bathymetry packets are not read here")
    pings = [_bth0(dg, off, size) for off, size in packets]
    return _assemble(path, pings, mount)


def _file_header(dg: Datagrams) -> tuple[int, tuple[float, float]]:
    """Where the packets start, and the bathymetry channel's mounting (roll, yaw) in degrees."""
    data = dg.data
    if len(data) < 1024 or data[0] != _FILE_FORMAT:
        first = f"0x{data[0]:02X}" if data else "nothing"
        raise dg.fail(f"not an XTF file (first byte {first}; expected 0x7B and a 1024-byte header)", 0)
    nav_units, sonar, bathy, snippet, forward, echo, interf = struct.unpack_from("<HHHBBHB", data, 164)
    if nav_units != _LATLON:
        raise dg.fail(f"navigation units {nav_units} (projected metres of a CRS the file does not name); "
                      "expected 3 (latitude and longitude)")
    channels = sonar + bathy + snippet + forward + echo + interf
    start = 1024 + 1024 * max(0, -(-(channels - 6) // 8))
    mount = (0.0, 0.0)
    for k in range(min(channels, 6)):
        base = 256 + 128 * k
        if data[base] == 3:  # the bathymetry channel
            yaw, _pitch, roll = struct.unpack_from("<fff", data, base + 60)
            mount = (float(roll), float(yaw))
            break
    return start, mount


def _walk(dg: Datagrams, off: int) -> tuple[list[tuple[int, int]], Counter[int]]:
    """The (offset, size) of every R2Sonic packet, and how many packets of each type."""
    data, n = dg.data, len(dg.data)
    packets: list[tuple[int, int]] = []
    kinds: Counter[int] = Counter()
    while off + 14 <= n:
        magic, kind = struct.unpack_from("<HB", data, off)
        size, = struct.unpack_from("<I", data, off + 10)
        if magic != _MAGIC:
            raise dg.fail(f"packet starts with 0x{magic:04X}; expected 0xFACE (corrupt, or the header's "
                          "channel count is wrong)", off)
        if size < 14 or off + size > n:
            raise dg.fail(f"a type-{kind} packet of {size} bytes; expected one that fits the file "
                          "(truncated or corrupt)", off)
        kinds[kind] += 1
        if kind == _R2SONIC:
            packets.append((off, size))
        off += size
    return packets, kinds


def _sections(dg: Datagrams, off: int, size: int) -> dict[bytes, tuple[int, int]]:
    """Where each section of the BTH0 packet in the type-65 packet at ``off`` starts, and its size."""
    data = dg.data
    body = off + 256
    if size < 256 + 12 or data[body:body + 4] != b"BTH0":
        raise dg.fail("type-65 packet without an R2Sonic 'BTH0' packet after its ping header", off)
    length, = struct.unpack_from(">I", data, body + 4)
    end = min(body + length, off + size)
    where: dict[bytes, tuple[int, int]] = {}
    q = body + 12
    while q + 4 <= end:
        name, sec = struct.unpack_from(">2sH", data, q)
        if sec < 4 or q + sec > end:
            raise dg.fail(f"BTH0 section {name!r} of {sec} bytes runs past its packet", off)
        where[name] = (q, sec)
        q += sec
    for need in (b"H0", b"R0"):
        if need not in where:
            raise dg.fail(f"BTH0 packet without its {need.decode()} section", off)
    if b"A0" not in where and b"A2" not in where:
        raise dg.fail("BTH0 packet without beam angles (an A0 or A2 section)", off)
    return where


def _bth0(dg: Datagrams, off: int, size: int) -> dict[str, np.ndarray | float]:
    """One ping: its header values and its per-beam range (m), angle (rad), intensity, valid."""
    data = dg.data
    secs = _sections(dg, off, size)
    at = {k: q for k, (q, _) in secs.items()}
    if secs[b"H0"][1] < 4 + _H0.size:
        raise dg.fail(f"BTH0 section H0 of {secs[b'H0'][1]} bytes; expected {4 + _H0.size}", off)
    h0 = _H0.unpack_from(data, at[b"H0"] + 4)
    seconds, nanos, ping, speed, n = h0[2], h0[3], h0[4], h0[6], h0[-1]

    def array(name: bytes, skip: int, kind: str, count: int) -> np.ndarray:
        if skip + np.dtype(kind).itemsize * count > secs[name][1]:
            raise dg.fail(f"BTH0 section {name.decode()} of {secs[name][1]} bytes is too short for "
                          f"the {n} beams its H0 section announces", off)
        return np.frombuffer(data, kind, count, at[name] + skip)

    scale, = struct.unpack_from(">f", data, at[b"R0"] + 4)
    with np.errstate(invalid="ignore", over="ignore"):
        ranges = array(b"R0", 8, ">u2", n) * (float(scale) * speed / 2.0)
    if b"A2" in at:
        first, step = struct.unpack_from(">ff", data, at[b"A2"] + 4)
        angles = first + np.cumsum(array(b"A2", 36, ">i2", n).astype(np.int64)) * float(step)
    else:
        first, last = struct.unpack_from(">ff", data, at[b"A0"] + 4)
        angles = np.linspace(first, last, n)
    intensity = np.full(n, np.nan)
    if b"I1" in at:
        scale_i, = struct.unpack_from(">f", data, at[b"I1"] + 4)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            upa = array(b"I1", 8, ">u2", n) * float(scale_i)
            intensity = np.where(upa > 0, 20.0 * np.log10(upa), np.nan)
    detected = np.ones(n, bool)
    if b"Q0" in at:
        words = array(b"Q0", 4, ">u4", (n + 7) // 8)
        nibbles = (words[:, None] >> np.arange(28, -1, -4, dtype=np.uint32)) & 0xF
        detected = (nibbles.ravel()[:n] & 0xC) != 0  # phase or magnitude detection
    lat, lon = struct.unpack_from("<dd", data, off + _PING_LAT)
    _pitch, roll, heading, heave = struct.unpack_from("<ffff", data, off + _PING_ATTITUDE)
    valid = detected & (ranges > 0) & np.isfinite(angles)
    return {"range": ranges, "angle": angles, "intensity": intensity, "valid": valid,
            "time": seconds + nanos * 1e-9, "ping": ping, "lat": lat, "lon": lon, "roll": roll,
            "heading": heading, "heave": heave, "n": n,
            "model": h0[0].split(b"\0")[0].decode("ascii", "replace")}


def _assemble(path: str, pings: list[dict], mount: tuple[float, float]) -> Soundings:
    counts = np.array([p["n"] for p in pings])
    rep = np.repeat(np.arange(len(pings)), counts)

    def per_ping(key: str) -> np.ndarray:
        return np.array([p[key] for p in pings], dtype=np.float64)[rep]

    def per_beam(key: str) -> np.ndarray:
        return np.concatenate([p[key] for p in pings])

    ranges = per_beam("range")
    vertical = per_beam("angle") - np.radians(per_ping("roll") + mount[0])
    across, down = ranges * np.sin(vertical), ranges * np.cos(vertical)
    heading = per_ping("heading") + mount[1]
    lat, lon = offsets_to_geographic(per_ping("lat"), per_ping("lon"), heading, np.zeros_like(across), across)
    fields = {
        "ping": per_ping("ping").astype(np.int64), "beam": np.concatenate([np.arange(k) for k in counts]),
        "beam_angle": np.degrees(vertical), "intensity": per_beam("intensity"), "time": per_ping("time"),
        "valid": per_beam("valid").astype(bool),
    }
    meta = {"format": "xtf", "source": path, "sonar": f"R2Sonic {pings[0]['model']}".strip(),
            "level": "the transducer, heave applied (no draft, no tide); straight rays at the sonar's "
                     "sound speed (no sound-speed profile)", "pings": len(pings)}
    return Soundings(lat, ((lon + 180.0) % 360.0) - 180.0, -down + per_ping("heave"), fields, meta)
