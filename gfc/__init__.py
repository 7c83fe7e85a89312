"""Generative Factor Chaining: composable diffusion skill models for bimanual planning."""

__version__ = "0.1.0"
