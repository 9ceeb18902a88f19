import numpy as np
import pytest


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
