"""Skill datasets: collection in simulation (coming) and the on-disk format."""
