"""Benchmarks behind ``agvnav bench``: each module has ``TITLE`` and ``run(quick, seed)``."""
