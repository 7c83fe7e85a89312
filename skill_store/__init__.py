"""Versioned, atomic, integrity-checked skill checkpoints (safetensors + manifest)."""
