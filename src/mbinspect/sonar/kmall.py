"""Kongsberg KMALL: soundings of the #MRZ datagrams.

Each #MRZ datagram holds one swath: the ping's position (latitude and longitude of the
vessel reference point), and for every sounding its offset from that point in degrees of
latitude and longitude and its depth below it; the water line's height above the
reference point turns that depth into an elevation relative to the water level. Extra
detections (soundings in the water column) are kept, as the sonar marks them; detections
the sonar rejected are not ``valid``. Datagrams split into partitions are read when all
their partitions follow each other.
"""

from __future__ import annotations

import struct

import numpy as np

from .common import Datagrams, Soundings

__all__ = ["read_kmall"]

_HEADER = 20  # numBytesDgm, dgmType, version, systemID, echoSounderID, time_sec, time_nanosec
_SOUNDING_FIELDS = {  # name: (offset, dtype) in one sounding record
    "index": (0, "<u2"), "detection_type": (3, "u1"), "detection_method": (4, "u1"),
    "sigma_v": (20, "<f4"), "sigma_h": (24, "<f4"), "reflectivity": (48, "<f4"),
    "beam_angle": (72, "<f4"), "dlat": (88, "<f4"), "dlon": (92, "<f4"), "z": (96, "<f4"),
}


def _column(block: np.ndarray, name: str) -> np.ndarray:
    off, dt = _SOUNDING_FIELDS[name]
    size = np.dtype(dt).itemsize
    return np.ascontiguousarray(block[:, off:off + size]).view(dt).ravel()


def read_kmall(path: str) -> Soundings:
    """Read the soundings of a KMALL file.

    Parameters
    ----------
    path : str
        The file.

    Returns
    -------
    Soundings
        ``valid`` is False for detections the sonar rejected; ``sigma_v`` and ``sigma_h``
        are the sonar's own uncertainties (m); ``intensity`` is reflectivity1 (dB).

    Raises
    ------
    InputError
        A record that runs past the end of the file or is shorter than its header, naming
        the byte offset; a file with no #MRZ datagram.
    """
    with open(path, "rb") as fh:
        data = fh.read()
    dg = Datagrams(path, data)
    blocks: dict[int, list[np.ndarray]] = {}
    per_ping: list[tuple[int, ...]] = []
    off, n = 0, len(data)
    sonar = None
    pending: list[bytes] = []
    while off + _HEADER <= n:
        size, = struct.unpack_from("<I", data, off)
        kind = data[off + 4:off + 8]
        if size < _HEADER or off + size > n or kind[:1] != b"#":
            raise dg.fail(f"a record of {size} bytes of type {kind!r}; expected a KMALL datagram "
                          "(the file is truncated or corrupt)", off)
        if kind == b"#MRZ":
            body = data[off:off + size]
            parts, part = struct.unpack_from("<HH", body, _HEADER)
            if parts > 1:  # reassemble a partitioned datagram
                pending.append(body if part == 1 else body[_HEADER + 4:-4])
                if part < parts:
                    off += size
                    continue
                body = b"".join(pending)
                pending = []
            sonar = sonar or struct.unpack_from("<H", body, 10)[0]
            _one_swath(dg, body, off, blocks, per_ping)
        off += size
    if not per_ping:
        raise dg.fail("no #MRZ (depth) datagram in the file; expected KMALL soundings")
    return _assemble(path, blocks, per_ping, sonar)


def _one_swath(dg: Datagrams, body: bytes, off: int, blocks: dict[int, list[np.ndarray]],
               per_ping: list[tuple[int, ...]]) -> None:
    tsec, tns = struct.unpack_from("<II", body, 12)
    p = _HEADER + 4
    ncmn, ping = struct.unpack_from("<HH", body, p)
    p += ncmn
    ninfo, = struct.unpack_from("<H", body, p)
    ntx, nbtx = struct.unpack_from("<HH", body, p + 92)
    heading, = struct.unpack_from("<f", body, p + 96)
    z_water, = struct.unpack_from("<f", body, p + 108)
    lat, lon = struct.unpack_from("<dd", body, p + 124)
    p += ninfo + ntx * nbtx
    nrx_info, nmax, _nvalid, nbs = struct.unpack_from("<HHHH", body, p)
    nextra, nclass, nbclass = struct.unpack_from("<HHH", body, p + 26)
    p += nrx_info + nclass * nbclass
    count = nmax + nextra
    if nbs < 120 or p + count * nbs > len(body):
        raise dg.fail(f"#MRZ with {count} soundings of {nbs} bytes runs past its datagram", off)
    block = np.frombuffer(body, np.uint8, count * nbs, p).reshape(count, nbs)
    blocks.setdefault(nbs, []).append(block)
    per_ping.append((nbs, count, ping, tsec, tns, lat, lon, z_water, heading))


def _assemble(path: str, blocks: dict[int, list[np.ndarray]], per_ping: list[tuple[int, ...]],
              sonar: int | None) -> Soundings:
    # soundings grouped by record size, in file order within each size
    order = []
    for nbs in blocks:
        order += [k for k, rec in enumerate(per_ping) if rec[0] == nbs]
    stacked = {nbs: np.concatenate(b) for nbs, b in blocks.items()}
    cols = {name: np.concatenate([_column(stacked[nbs], name) for nbs in blocks])
            for name in _SOUNDING_FIELDS}
    counts = np.array([per_ping[k][1] for k in order])
    info = np.array([per_ping[k][2:] for k in order], dtype=np.float64)
    rep = np.repeat(np.arange(len(order)), counts)
    ping_no = np.unwrap(info[:, 0], period=65536).astype(np.int64)
    lat = info[rep, 3] + cols["dlat"]
    lon = info[rep, 4] + cols["dlon"]
    z = -(cols["z"].astype(np.float64) - info[rep, 5])
    fields = {
        "ping": ping_no[rep], "beam": cols["index"].astype(np.int32),
        "beam_angle": cols["beam_angle"].astype(np.float64),
        "intensity": cols["reflectivity"].astype(np.float64),
        "time": info[rep, 1] + info[rep, 2] * 1e-9,
        # 0 a normal detection, 1 an extra detection (a water-column target), 2 rejected
        "valid": cols["detection_type"] == 0,
        "extra_detection": cols["detection_type"] == 1,
        "sigma_v": cols["sigma_v"].astype(np.float64), "sigma_h": cols["sigma_h"].astype(np.float64),
    }
    meta = {"format": "kmall", "source": path, "sonar": f"EM{sonar}" if sonar else None,
            "level": "water level at the time of the ping (no tide)", "pings": len(order)}
    return Soundings(lat, lon, z, fields, meta)
