import warnings

import numpy as np
import pytest

warnings.filterwarnings("ignore", module="colour")


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)
