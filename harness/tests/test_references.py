"""The committed references match their scenes and, where a closed form exists, the R -> 0 limit.

The limit test is a two-sided z-test of the global image mean per channel against the
closed-form limit, alpha = 1e-4 per scene with Sidak correction over 3 scenes x 3 channels
(|z| < 4.3); the finite-radius bias at R = 1e-4 (|c| R < 1e-5) is far below the standard error
(<= 2e-4). It fails if a scene changed without regenerating its reference, if K or the floor
were read wrongly, or if Mitsuba's normalisation differed from (rho/pi) K Omega_perp_R."""

import json
import unittest
from pathlib import Path

import numpy as np

from harness import exrfile, line_limit, oracle

ROOT = Path(__file__).resolve().parents[2]
SCENES = ROOT / "references" / "scenes"
REFS = ROOT / "references" / "mitsuba"
ALL = ["floor-tube", "floor-crossing", "two-tubes", "cornell-tube", "mesh-occluder",
       "glossy-conductor-sharp", "glossy-conductor-rough", "glossy-blend", "glossy-principled",
       "glossy-cornell"]
CLOSED_FORM = ["floor-tube", "floor-crossing", "two-tubes"]
Z_MAX = 4.3  # two-sided, 1 - (1 - 1e-4)^(1/9) per test ~ 1.1e-5 -> z ~ 4.4; rounded down


class References(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        oracle.set_variant("scalar_rgb")

    def test_every_reference_is_current(self):
        for s in ALL:
            with self.subTest(scene=s):
                header = exrfile.read_header(REFS / f"{s}.exr")
                self.assertEqual(header.strings["scene_sha256"], oracle.sha256_file(SCENES / f"{s}.xml"))
                self.assertEqual(int(header.strings["dof"]), int(header.strings["passes"]) - 1)
                self.assertGreaterEqual(int(header.strings["passes"]), 32)
                side = json.loads((REFS / f"{s}.json").read_text())
                for key, value in side["metadata"].items():  # the EXR also has Mitsuba's own
                    self.assertEqual(header.strings.get(key), value, key)
                mean, var = exrfile.read_image(REFS / f"{s}.exr")
                self.assertTrue(np.isfinite(mean).all() and (var >= 0).all())
                rel = np.sqrt(var.sum(axis=(0, 1))) / mean.sum(axis=(0, 1))
                self.assertTrue((rel <= 2e-4).all(), f"{s}: global rel. std. error {rel}")

    def test_closed_form_limit(self):
        for s in CLOSED_FORM:
            with self.subTest(scene=s):
                mean, var = exrfile.read_image(REFS / f"{s}.exr")
                h, w = mean.shape[:2]
                path = SCENES / f"{s}.xml"
                loaded = oracle.load_scene(path, {"res": str(w)}, None)
                cam, plane = line_limit.from_scene(loaded.scene, path.read_text())
                limit = line_limit.image_limit(cam, plane, loaded.lights, 8).mean(axis=(0, 1))
                m = mean.astype(np.float64).mean(axis=(0, 1))
                se = np.sqrt(var.astype(np.float64).sum(axis=(0, 1))) / (h * w)
                z = (m - limit) / se
                self.assertTrue((np.abs(z) < Z_MAX).all(), f"{s}: mean {m}, limit {limit}, z {z}")


if __name__ == "__main__":
    unittest.main()
