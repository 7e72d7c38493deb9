"""Deterministic builders for every scene the demo, tests and benchmarks use (nothing is downloaded)."""
