#!/usr/bin/env python3
"""A negative control for `linlight samplers --external`: ltc_numpy.py with its densities
divided by κ (the tube's width change under A). Its samples and inverse are right, its densities
are not the densities of its samples where κ ≠ 1: a renderer dividing by them is biased. The
suite must reject it (exit 1).
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import ltc_numpy  # noqa: E402


class WithoutKappa(ltc_numpy.LtcLine):
    def __init__(self, config):
        super().__init__(config)
        self.scale /= self.kappa


if __name__ == "__main__":
    ltc_numpy.LtcLine = WithoutKappa
    ltc_numpy.serve(name="ltc-numpy-without-kappa")
