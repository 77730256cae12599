"""Mitsuba 3 oracle harness for linlight: reference renders, K-preserving radius overrides,
R -> 0 sweeps. Run as `scripts/harness ...` (python -m harness inside the project venv)."""

MITSUBA_VERSION = "3.9.1"
