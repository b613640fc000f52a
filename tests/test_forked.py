"""Jobs in forked processes (``mbinspect.forked``) and the figures they draw."""

from __future__ import annotations

import os

import numpy as np
import pytest

from mbinspect.forked import forked, usable_cores
from mbinspect.reefs import extract_reefs
from mbinspect.report.reefs import reef_figures, write_reef_outputs

several_cores = pytest.mark.skipif(usable_cores() < 2, reason="one usable core: the jobs run here")


@several_cores
def test_jobs_run_in_other_processes_on_data_that_cannot_be_pickled():
    data = np.arange(1000.0)
    square = lambda v: v**2  # noqa: E731 - a lambda is never pickled: it must come by fork
    jobs = [lambda i=i: (os.getpid(), float(square(data[i::4]).sum())) for i in range(4)]
    with forked(jobs, workers=2) as results:
        done = results()
    assert [v for _, v in done] == [float((data[i::4] ** 2).sum()) for i in range(4)]
    assert os.getpid() not in {pid for pid, _ in done}


def test_a_failing_job_raises_where_its_results_are_asked_for():
    def broken() -> int:
        raise ValueError("bad job")

    with pytest.raises(ValueError, match="bad job"), forked([lambda: 1, broken], workers=2) as results:
        results()


def test_one_worker_runs_the_jobs_here_in_order():
    with forked([os.getpid, lambda: "b"], workers=1) as results:
        assert results() == [os.getpid(), "b"]


def test_figures_drawn_in_workers_are_those_drawn_here(tmp_path, reef_small):
    res = extract_reefs(reef_small.cloud)
    (tmp_path / "here").mkdir()
    here = reef_figures(res, reef_small.cloud.xyz, tmp_path / "here")
    written = write_reef_outputs(res, reef_small.cloud.xyz, tmp_path / "out")
    pngs = sorted(n for n in written if n.endswith(".png"))
    assert pngs and len(pngs) == len(here)
    for name in pngs:
        assert (tmp_path / "out" / name).read_bytes() == (tmp_path / "here" / name).read_bytes(), name
