"""The XTF reader (R2Sonic BTH0 packets as QINSy records them) against an independent decode
of a real R2Sonic 2026 line, and its refusals of damaged files."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pytest

from mbinspect.cli import main
from mbinspect.errors import InputError
from mbinspect.io import read
from mbinspect.sonar import read_sonar, to_cloud

DATA = Path(__file__).parent / "data"
LINE = DATA / "R2Testing_0009_first40.xtf"


def _packets(data: bytes) -> list[tuple[int, int, int]]:
    """(offset, type, size) of every packet after the 1024-byte header."""
    out, off = [], 1024
    while off < len(data):
        kind = data[off + 2]
        size, = struct.unpack_from("<I", data, off + 10)
        out.append((off, kind, size))
        off += size
    return out


def test_xtf_agrees_with_an_independent_decode():
    """tools/xtf_reference.py: pyxtf's framing, struct per beam, pyproj's geodesic."""
    ref = np.load(LINE.with_name(LINE.stem + ".reference.npz"))
    s = read_sonar(LINE, "xtf")
    assert len(s) == len(ref["xyz"]) == 40 * 256
    np.testing.assert_array_equal(s.fields["valid"], ref["valid"])
    np.testing.assert_array_equal(s.fields["ping"], ref["ping"])
    cloud = to_cloud(s, keep_rejected=True)
    assert cloud.meta["crs_name"] == "WGS 84 / UTM zone 10N"
    assert np.abs(cloud.xyz[:, 2] - ref["xyz"][:, 2]).max() < 1e-6
    assert np.hypot(*(cloud.xyz[:, :2] - ref["xyz"][:, :2]).T).max() < 1e-3
    np.testing.assert_allclose(s.fields["beam_angle"], ref["beam_angle"], atol=1e-9)
    np.testing.assert_allclose(s.fields["intensity"], ref["intensity"], atol=1e-9)
    np.testing.assert_allclose(s.fields["time"], ref["time"], atol=1e-6)
    assert s.meta["sonar"] == "R2Sonic 2026" and s.meta["pings"] == 40


def test_xtf_seabed_is_flat_and_level_across_the_swath():
    """Roll and the mounting roll applied with the right sign: the two sides of the swath
    agree (the raw refraction smile is symmetric) and the sand is flat to centimetres."""
    cloud = read(LINE)
    z, angle = cloud.xyz[:, 2], cloud.fields["beam_angle"]
    port = np.median(z[(angle > -45) & (angle < -25)])
    starboard = np.median(z[(angle > 25) & (angle < 45)])
    assert abs(port - starboard) < 0.06
    assert -10.9 < np.median(z[np.abs(angle) < 10]) < -10.5
    assert 30 < np.nanmedian(cloud.fields["intensity"]) < 70  # dB re 1 uPa, as the sonar scales it


def _edit(tmp_path: Path, name: str, change) -> Path:
    data = bytearray(LINE.read_bytes())
    change(data)
    path = tmp_path / name
    path.write_bytes(bytes(data))
    return path


def test_xtf_refusals_name_the_file_and_byte(tmp_path):
    data = LINE.read_bytes()
    packets = _packets(data)
    ping = next(off for off, kind, _ in packets if kind == 65)
    cut = tmp_path / "cut.xtf"
    cut.write_bytes(data[: int(len(data) * 0.6)])
    with pytest.raises(InputError, match=r"cut.xtf, byte \d+: a type-\d+ packet of \d+ bytes; expected one "
                                         "that fits the file"):
        read(cut)
    bad = _edit(tmp_path, "magic.xtf", lambda d: d.__setitem__(slice(ping, ping + 2), b"\0\0"))
    with pytest.raises(InputError, match=rf"magic.xtf, byte {ping}: packet starts with 0x0000; expected"):
        read(bad)
    metres = _edit(tmp_path, "metres.xtf", lambda d: d.__setitem__(slice(164, 166), b"\0\0"))
    with pytest.raises(InputError, match="navigation units 0 .* expected 3 .latitude and longitude."):
        read(metres)
    with pytest.raises(InputError, match=r"not an XTF file \(first byte 0x00"):
        read(_edit(tmp_path, "zero.xtf", lambda d: d.__setitem__(0, 0)))
    nav = tmp_path / "nav_only.xtf"
    nav.write_bytes(data[:1024] + b"".join(data[o:o + n] for o, k, n in packets if k != 65))
    with pytest.raises(InputError, match=r"no R2Sonic bathymetry packet \(type 65\); packet types held: "
                                         r"3 \(\d+\), 107 \(\d+\)"):
        read(nav)
    # the H0 section announcing more beams than the packet holds
    h0_points = ping + 256 + 12 + 4 + struct.calcsize(">12s12sIIIfffffffffHhfffffffIH")
    many = _edit(tmp_path, "many.xtf", lambda d: d.__setitem__(slice(h0_points, h0_points + 2), b"\x04\x00"))
    with pytest.raises(InputError, match=rf"many.xtf, byte {ping}: BTH0 section R0 of \d+ bytes is too short "
                                         "for the 1024 beams"):
        read(many)


def test_xtf_flags_and_the_command_line(tmp_path, capsys):
    data = LINE.read_bytes()
    ping = next(off for off, kind, _ in _packets(data) if kind == 65)
    body = ping + 256
    q = body + 12
    while data[q:q + 2] != b"Q0":
        q += struct.unpack_from(">H", data, q + 2)[0]
    # the first eight beams of the first ping: neither phase nor magnitude detection
    flagged = _edit(tmp_path, "flagged.xtf", lambda d: d.__setitem__(slice(q + 4, q + 8), b"\0\0\0\0"))
    assert len(read(flagged)) == 40 * 256 - 8
    assert len(read(flagged, keep_rejected=True)) == 40 * 256
    assert main(["info", str(LINE), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["n_points"] == 10240 and "xtf" in json.dumps(info)
    out = tmp_path / "reefs"
    assert main(["reefs", str(LINE), "--out", str(out), "--no-figures"]) == 0
    assert "0 reefs" in capsys.readouterr().out
    tiled = tmp_path / "tiled"
    assert main(["reefs", str(LINE), "--out", str(tiled), "--no-figures", "--tiled",
                 "--workers", "2"]) == 0
    assert "0 reefs" in capsys.readouterr().out
