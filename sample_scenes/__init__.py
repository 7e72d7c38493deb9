"""Deterministic builders for every scene the demo, tests and benchmarks use (nothing is downloaded),
and the command line (``cli``) that builds them and runs the jobs on them."""
