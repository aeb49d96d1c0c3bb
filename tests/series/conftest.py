"""Fixtures of the series tests: the time steps on disk and the module's LocalCluster."""
from .helpers import client, steps  # noqa: F401 - fixtures
