"""Every reader, given a damaged real file (bytes flipped, cut short, a chunk repeated, a
length field made huge, a region zeroed), reads it or refuses it with one of our errors:
never another exception, never a hang, never a runaway allocation (a LAZ chunk table of
garbage made lazrs ask for 48 GB and abort the process)."""

from __future__ import annotations

import resource
import signal
import warnings
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mbinspect.errors import MBInspectError
from mbinspect.io import read

DATA = Path(__file__).parent / "data"
FILES = [DATA / "Belgica_0077.all", DATA / "pdal_mbf_em300raw.mb56",
         DATA / "ets_kmall_OS03_-4033476991022010987.kmall", DATA / "gsf_EX1502L2_0175.gsf",
         DATA / "GSF3_09_test_file.gsf", DATA / "R2Testing_0009_first40.xtf",
         DATA / "outside" / "gsfpy_0059_EX1811_EM302_2pings.gsf", DATA / "outside" / "laspy_simple.las",
         DATA / "outside" / "laspy_simple.laz", DATA / "outside" / "laspy_1_4_w_evlr.las",
         DATA / "outside" / "pdal_ply_simple_binary.ply", DATA / "outside" / "pdal_ply_simple_text.ply"]


@st.composite
def damaged(draw: st.DrawFn, data: bytes) -> bytes:
    out = bytearray(data)
    kind = draw(st.sampled_from(["flip", "cut", "repeat", "huge", "zero"]))
    at = draw(st.integers(0, len(out) - 5))
    if kind == "flip":
        for i in draw(st.lists(st.integers(0, len(out) - 1), min_size=1, max_size=20)):
            out[i] = draw(st.integers(0, 255))
    elif kind == "cut":
        out = out[:max(1, at)]
    elif kind == "repeat":
        end = min(len(out), at + draw(st.integers(1, 5000)))
        out = out[:end] + out[at:end] + out[end:]
    elif kind == "huge":
        value = draw(st.integers(2**31, 2**32 - 1))
        out[at:at + 4] = value.to_bytes(4, draw(st.sampled_from(["little", "big"])))
    else:
        n = min(len(out) - at, draw(st.integers(1, 2000)))
        out[at:at + n] = bytes(n)
    return bytes(out)


class _Hang(Exception):
    pass


def _alarm(signum, frame):
    raise _Hang()


@pytest.mark.parametrize("source", FILES, ids=lambda p: p.name)
def test_damaged_files_are_read_or_refused_in_one_of_our_errors(source, tmp_path_factory):
    folder = tmp_path_factory.mktemp("fuzz")
    original = source.read_bytes()

    @settings(max_examples=60, deadline=None, derandomize=True,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
    @given(damaged(original))
    def check(data: bytes) -> None:
        path = folder / f"damaged{source.suffix}"
        path.write_bytes(data)
        previous = signal.signal(signal.SIGALRM, _alarm)
        signal.alarm(30)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                read(path, z_up=True) if source.suffix == ".ply" else read(path)
        except MBInspectError as exc:
            assert str(exc).startswith(str(path)) and "\n" not in str(exc)
        except _Hang:
            pytest.fail(f"{source.name}: a damaged copy took more than 30 s")
        finally:
            signal.alarm(0)
            signal.signal(signal.SIGALRM, previous)

    check()
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    assert peak < 3e9, f"peak memory {peak / 1e9:.1f} GB"
