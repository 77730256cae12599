#!/usr/bin/env python3
"""A negative control for `linlight samplers --external`: psa_numpy.py with one Halley step
instead of two. Its samples miss the target C* by up to ~1e-2 in ξ while its densities are
still the exact (n·ω)/Ω⊥_R of the directions it returns and its inverse is the exact CDF: only
the distribution of the samples is wrong. The suite must reject it (exit 1).
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from psa_numpy import serve  # noqa: E402

if __name__ == "__main__":
    serve(steps=1, name="psa-numpy-one-halley")
