"""Skill signatures: what each skill reads, writes and acts with."""
