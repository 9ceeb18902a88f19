import os

import numpy as np
import pytest

# The first-run compile notice goes to stderr whenever a kernel compiles; which test
# compiles what depends on the order, so the suite (and its subprocesses) runs quiet.
# tests/test_numba_cache.py turns it back on where it tests it.
os.environ["SDFPHYS_COMPILE_NOTICE"] = "0"


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
