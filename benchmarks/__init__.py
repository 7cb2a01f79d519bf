"""Benchmark scripts (importable as ``benchmarks`` from the repository root, for their tests)."""
