"""The console entry point: what it sets before numpy is imported."""

import os
import subprocess
import sys

import pytest

PROBE = ("import os, sys\n"
         "from mbinspect.command import prepare\n"
         "prepare()\n"
         "import numpy._core.multiarray as m\n"
         "print(os.environ['NUMPY_MADVISE_HUGEPAGE'], int(m._get_madvise_hugepage()))\n")


@pytest.mark.parametrize(("given", "expected"), [(None, "0 0"), ("1", "1 1"), ("0", "0 0")])
def test_huge_pages_off_unless_the_user_asks(given, expected):
    env = {k: v for k, v in os.environ.items() if k != "NUMPY_MADVISE_HUGEPAGE"}
    if given is not None:
        env["NUMPY_MADVISE_HUGEPAGE"] = given
    out = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == expected.split()


def test_the_entry_point_imports_no_numpy_before_it_prepares():
    code = ("import sys\nimport mbinspect.command\nimport mbinspect.interrupt\n"
            "print('numpy' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


WORKERS = ("import os\n"
           "from mbinspect.survey.cluster import dask_client\n"
           "def probe():\n"
           "    import numpy._core.multiarray as m\n"
           "    return os.environ.get('NUMPY_MADVISE_HUGEPAGE'), int(m._get_madvise_hugepage())\n"
           "if __name__ == '__main__':\n"
           "    with dask_client(workers=1) as c:\n"
           "        seen = sorted(set(c.run(probe).values()))\n"
           "    print(seen, os.environ.get('NUMPY_MADVISE_HUGEPAGE'))\n")


@pytest.mark.skipif(sys.platform == "win32", reason="the workers' fork server is POSIX only")
def test_the_survey_workers_ask_for_small_pages_and_the_parent_is_left_as_it_was(tmp_path):
    script = tmp_path / "probe.py"
    script.write_text(WORKERS)
    env = {k: v for k, v in os.environ.items() if k != "NUMPY_MADVISE_HUGEPAGE"}
    out = subprocess.run([sys.executable, str(script)], env=env, capture_output=True, text=True, check=True,
                         timeout=120)
    assert out.stdout.split("\n")[0] == "[('0', 0)] None"
