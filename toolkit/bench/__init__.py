"""Benchmark runners and result writers (they combine planners, localisers and robots)."""
