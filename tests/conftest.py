"""Shared fixtures and helpers for the test suite."""

from __future__ import annotations

import os

import torch
from hypothesis import settings

# Tests are CPU-only and run two workers side by side on a 2-core machine: one thread each.
torch.set_num_threads(1)
os.environ.setdefault("OMP_NUM_THREADS", "1")

settings.register_profile("ci", deadline=None, max_examples=60)
settings.load_profile("ci")
