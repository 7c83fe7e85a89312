"""Skill executors: one function per skill, each raising ``SkillFailure`` with a failure type."""
