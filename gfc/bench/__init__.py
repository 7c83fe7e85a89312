"""Benchmarks: each prints a table and writes it (with the command that produced it) under docs/."""
