"""The committed BSDF golden data (references/bsdf) is what Mitsuba computes now: a fresh
evaluation of every set must be identical bit for bit (same Mitsuba version and variant, same
deterministic directions). The Rust side compares against the committed data in
crates/render/tests/bsdf_mitsuba.rs; scripts/test-live-oracle also runs that test against a fresh
evaluation."""

import unittest

import numpy as np

from harness import bsdf_golden


class Generator(unittest.TestCase):
    def test_directions_are_unit_and_deterministic(self):
        a = bsdf_golden.pairs(7, 200, 0.1, "mixed")
        b = bsdf_golden.pairs(7, 200, 0.1, "mixed")
        self.assertEqual(a.tobytes(), b.tobytes())
        norms = np.linalg.norm(a.astype(np.float64), axis=2)
        self.assertTrue((np.abs(norms - 1.0) < 1e-6).all())
        self.assertTrue((a[:, 0, 2] < 0).any() and (a[:, 0, 2] > 0).any())

    def test_first_numbers_are_pinned(self):
        # The Rust test reimplements the generator; these pin it (SplitMix64 from seed 0).
        rng = bsdf_golden.SplitMix64(0)
        self.assertEqual(rng.next(), 0xE220A8397B1DCDAF)
        self.assertEqual(rng.next(), 0x6E789E6AA1B965F4)


class Golden(unittest.TestCase):
    def test_committed_values_equal_a_fresh_evaluation(self):
        committed = bsdf_golden.read(bsdf_golden.GOLDEN_DIR)
        fresh = bsdf_golden.generate(committed[0]["pairs"])
        self.assertEqual(bsdf_golden.compare(committed, fresh), [])

    def test_size_stays_small(self):
        path = bsdf_golden.GOLDEN_DIR / bsdf_golden.VALUES
        self.assertLess(path.stat().st_size, 1_500_000)


if __name__ == "__main__":
    unittest.main()
