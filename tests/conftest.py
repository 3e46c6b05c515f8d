"""Shared fixtures: models are built once per session (building one takes ~50 ms)."""

import pytest

from coexist.effects import Gent, IdealDielectric, NeoHookean
from coexist.model import MembraneModel


@pytest.fixture(scope="session")
def neo_hookean():
    return MembraneModel(NeoHookean(), IdealDielectric())


@pytest.fixture(scope="session")
def gent97():
    return MembraneModel(Gent(97.0), IdealDielectric())
