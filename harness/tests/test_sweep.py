"""The radius sweep's order check (sweep.check_order) on synthetic biases with known order."""

import unittest

import numpy as np

from harness import sweep

RADII = [0.3, 0.1, 0.03]


def biases(c: float, p: float, rel_err: float) -> tuple[list[float], list[float]]:
    """Exact biases c R^p with standard errors rel_err * bias (noise-free values: the check's
    decision then depends only on p and the stated errors)."""
    b = [c * r**p for r in RADII]
    return b, [rel_err * x for x in b]


class OrderCheck(unittest.TestCase):
    def test_first_order_passes(self):
        ok, p, se, why = sweep.check_order(RADII, *biases(0.045, 1.0, 0.1))
        self.assertTrue(ok, why)
        self.assertAlmostEqual(p, 1.0, places=9)
        self.assertLess(se, sweep.ORDER_MAX_SE)

    def test_measured_sweep_passes(self):
        # floor-tube, res 32, llvm_ad_rgb, 16 x 2048 spp per radius (the numbers in the report)
        b = [1.355e-02, 4.507e-03, 1.533e-03]
        s = [0.000132 / 0.17232202, 3.97e-05 / 0.17232202, 5.18e-05 / 0.17232202]
        ok, p, se, why = sweep.check_order(RADII, b, s)
        self.assertTrue(ok, why)
        self.assertLess(abs(p - 1.0), 0.1)

    def test_scatter_beyond_the_errors_widens_the_tolerance(self):
        # First order on average, but the points scatter by 3x their stated errors: the Birge
        # ratio must widen se(p) by about that factor.
        radii = [0.3, 0.1, 0.03]
        b = [0.045 * r for r in radii]
        s = [x * 0.02 for x in b]
        noisy = [b[0] * (1 + 0.06), b[1] * (1 - 0.06), b[2] * (1 + 0.06)]
        _, _, se_exact, _ = sweep.check_order(radii, b, s)
        _, _, se_noisy, _ = sweep.check_order(radii, noisy, s)
        self.assertGreater(se_noisy, 2.0 * se_exact)

    def test_wrong_orders_fail(self):
        for p in (0.5, 0.7, 1.4, 2.0):
            ok, fitted, _, why = sweep.check_order(RADII, *biases(0.045, p, 0.05))
            self.assertFalse(ok, f"p = {p}: {why}")
            self.assertAlmostEqual(fitted, p, places=9)

    def test_no_bias_or_unresolved_bias_fails(self):
        ok, _, _, why = sweep.check_order(RADII, [1e-2, 3e-3, 0.0], [1e-4, 1e-4, 1e-4])
        self.assertFalse(ok)
        self.assertIn("not resolved", why)
        ok, _, _, why = sweep.check_order(RADII, [1e-2, 3e-3, 1e-3], [1e-4, 1e-4, 5e-4])
        self.assertFalse(ok)
        self.assertIn("R = 0.03", why)

    def test_imprecise_fit_fails(self):
        # Every bias resolved at 5 se, but over a quarter decade p cannot be pinned down.
        radii = [0.1, 0.075]
        b = [0.045 * r for r in radii]
        ok, _, se, why = sweep.check_order(radii, b, [x / 5 for x in b])
        self.assertFalse(ok)
        self.assertGreater(se, sweep.ORDER_MAX_SE)
        self.assertIn("too uncertain", why)

    def test_degenerate_input(self):
        self.assertFalse(sweep.check_order([0.1], [1e-3], [1e-5])[0])
        self.assertFalse(sweep.check_order([0.1, 0.1], [1e-3, 1e-3], [1e-5, 1e-5])[0])
        self.assertTrue(np.isnan(sweep.check_order([0.1], [1e-3], [1e-5])[1]))


if __name__ == "__main__":
    unittest.main()
