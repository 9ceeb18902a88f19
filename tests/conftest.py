import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

# The first-run compile notice goes to stderr whenever a kernel compiles; which test
# compiles what depends on the order, so the suite (and its subprocesses) runs quiet.
# tests/test_numba_cache.py turns it back on where it tests it.
os.environ["SDFPHYS_COMPILE_NOTICE"] = "0"


#: The compiling helper of a run on a cold cache (tests/prewarm.py), while it runs.
_prewarm: subprocess.Popen | None = None


def pytest_sessionstart(session):
    """On a cold numba cache and two cores or more, start tests/prewarm.py beside the run
    (its docstring says why); ``SDFPHYS_TEST_PREWARM=0`` turns it off."""
    global _prewarm
    from sdfphys import _warm

    if (os.environ.get("SDFPHYS_TEST_PREWARM", "1") == "0" or (os.cpu_count() or 1) < 2
            or not _warm._cold()):
        return
    # SDFPHYS_WARM=0: the helper forks no compiling child of its own (sdfphys._warm).
    _prewarm = subprocess.Popen([sys.executable, str(Path(__file__).with_name("prewarm.py"))],
                                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL, start_new_session=True,
                                env=dict(os.environ, SDFPHYS_WARM="0"))


def pytest_sessionfinish(session, exitstatus):
    """Stop the compiling helper if it still runs (a lock it held is taken over by the
    next process that needs its kernel: ``sdfphys._compile_lock``)."""
    if _prewarm is not None and _prewarm.poll() is None:
        _prewarm.terminate()
        try:
            _prewarm.wait(timeout=30)
        except subprocess.TimeoutExpired:         # inside a compile that ignores it
            _prewarm.kill()
            _prewarm.wait()


def pytest_addoption(parser):
    parser.addoption("--regen-golden", action="store_true", default=False,
                     help="rewrite tests/golden/*.npz from the current engine (on purpose: "
                          "a change of the physics; review and commit the new files)")


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture
def regen_golden(request) -> bool:
    """Whether ``--regen-golden`` was given."""
    return request.config.getoption("--regen-golden")
