"""Closed-form R -> 0 limit: Omega_perp_R against quadrature, camera against Mitsuba's."""

import unittest
from pathlib import Path

import numpy as np

from harness import line_limit, oracle, scene_xml

SCENES = Path(__file__).resolve().parents[2] / "references" / "scenes"


def quadrature(x, n, p0, p1, count=400001):
    """Omega_perp_R = integral of max(0, n.w) 2 d / r^3 along the line (per-radius measure)."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    t = (np.arange(count) + 0.5) / count
    pts = p0 + t[:, None] * (p1 - p0)
    v = pts - x
    r = np.linalg.norm(v, axis=1)
    u = (p1 - p0) / np.linalg.norm(p1 - p0)
    d = np.linalg.norm(np.cross(v, u), axis=1)
    cos = np.maximum(0.0, v @ n / r)
    return float(np.sum(cos * 2 * d / r**3) * np.linalg.norm(p1 - p0) / count)


class ProjectedSolidAngle(unittest.TestCase):
    def omega(self, x, n, p0, p1):
        return float(line_limit.projected_solid_angle_per_radius(np.array([x], float), np.array([n], float), p0, p1)[0])

    def test_paper_sanity_value(self):
        self.assertAlmostEqual(self.omega((0, 0, 0), (0, 0, 1), (-1, 0, 1), (1, 0, 1)), 1 + np.pi / 2, places=12)

    def test_against_quadrature_with_clipping(self):
        rng = np.random.default_rng(3)
        for _ in range(20):
            x = rng.normal(size=3)
            n = rng.normal(size=3)
            n /= np.linalg.norm(n)
            p0, p1 = x + rng.normal(size=3), x + rng.normal(size=3)  # often crosses the horizon
            q = quadrature(x, n, p0, p1)
            self.assertAlmostEqual(self.omega(x, n, p0, p1), q, delta=2e-6 * max(q, 1.0))

    def test_below_horizon_and_degenerate(self):
        self.assertEqual(self.omega((0, 0, 0), (0, 0, 1), (-1, 0, -1), (1, 0, -0.5)), 0.0)
        self.assertEqual(self.omega((0, 0, 0), (0, 0, 1), (-1, 0, 0), (1, 0, 0)), 0.0)  # in the plane
        self.assertEqual(self.omega((0, 0, 0), (0, 0, 1), (0, 0, 1), (0, 0, 2)), 0.0)  # d = 0
        self.assertEqual(self.omega((0, 0, 0), (0, 0, 1), (1, 0, 1), (1, 0, 1)), 0.0)  # no length


class CameraMatchesMitsuba(unittest.TestCase):
    def test_rays(self):
        mi = oracle.set_variant("scalar_rgb")
        path = SCENES / "floor-tube.xml"
        loaded = oracle.load_scene(path, {"res": "16"}, None)
        cam, plane = line_limit.from_scene(loaded.scene, path.read_text())
        self.assertEqual((cam.width, cam.height), (16, 16))
        np.testing.assert_allclose(plane.reflectance, [0.7, 0.5, 0.3], rtol=1e-6)
        sensor = loaded.scene.sensors()[0]
        for sx, sy in [(0.1, 0.2), (0.5, 0.5), (0.93, 0.77), (0.0, 1.0)]:
            ray, _ = sensor.sample_ray(0.0, 0.5, mi.ScalarPoint2f(sx, sy), mi.ScalarPoint2f(0.5, 0.5))
            _, d = cam.rays(np.array(sx), np.array(sy))
            np.testing.assert_allclose(d, np.array(ray.d), atol=2e-6)

    def test_refuses_occluded_scenes(self):
        oracle.set_variant("scalar_rgb")
        path = SCENES / "cornell-tube.xml"
        loaded = oracle.load_scene(path, {"res": "8"}, None)
        with self.assertRaises(scene_xml.SceneError):
            line_limit.from_scene(loaded.scene, path.read_text())


if __name__ == "__main__":
    unittest.main()
