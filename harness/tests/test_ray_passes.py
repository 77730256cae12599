"""`--ray`: reference passes as Ray tasks on a local Ray instance of 2 workers (harness/ray_passes.py).

- The pooled reference is bit-identical (mean, variance, tail) to the same passes rendered
  locally by render.render_passes.
- A pass whose worker dies is re-run, and the reference records every pass with its seed and
  attempts; a pass that keeps losing its worker stops the render (never dropped).

Skipped, saying so, when ray is not installed (`scripts/setup-oracle --with-ray` installs it).
Runs in scripts/test-harness (the `harness` stage of scripts/test); ~1 min on two cores.
"""

import importlib.util
import os
import tempfile
import unittest
from pathlib import Path

import numpy as np

from harness import oracle, ray_passes, render

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "references" / "scenes" / "floor-tube.xml"
DEFINES = {"res": "16"}
PASSES, SPP = 4, 8

HAVE_RAY = importlib.util.find_spec("ray") is not None


def crash_once(job, seed):
    """render_pass, but the first attempt of seed 1 kills its worker process (a lost worker).
    The marker lives next to the scene files of the job, in a directory the test owns."""
    marker = Path(os.environ["LINLIGHT_RAY_TEST_DIR"]) / f"crashed-{seed}"
    if seed == 1 and not marker.exists():
        marker.write_text("x")
        os._exit(1)
    return ray_passes.render_pass(job, seed)


def crash_always(job, seed):
    if seed == 2:
        os._exit(1)
    return ray_passes.render_pass(job, seed)


@unittest.skipUnless(HAVE_RAY, "ray is not installed: run scripts/setup-oracle --with-ray to test --ray")
class RayPasses(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        os.environ["LINLIGHT_RAY_TEST_DIR"] = cls.tmp.name
        cls.variant = oracle.choose_variant(None)
        oracle.set_variant(cls.variant)
        cls.loaded = oracle.load_scene(SCENE, DEFINES, None)
        cls.local = render.render_passes(cls.loaded, cls.variant, PASSES, SPP, DEFINES, quiet=True)
        cls.ray = ray_passes.connect("local:2")
        cls.job = ray_passes.scene_job(SCENE, DEFINES, None, cls.variant, SPP)

    @classmethod
    def tearDownClass(cls):
        cls.ray.shutdown()
        os.environ.pop("LINLIGHT_RAY_TEST_DIR", None)
        cls.tmp.cleanup()

    def assert_same_pixels(self, r):
        np.testing.assert_array_equal(r.mean, self.local.mean)
        np.testing.assert_array_equal(r.var, self.local.var)
        np.testing.assert_array_equal(r.tail, self.local.tail)
        np.testing.assert_array_equal(r.pass_means, self.local.pass_means)

    def test_pooled_reference_is_bit_identical_to_local(self):
        r = ray_passes.render_passes_ray(self.ray, self.job, self.loaded, PASSES, DEFINES, quiet=True)
        self.assertGreater(float(self.local.mean.mean()), 0.0)
        self.assert_same_pixels(r)
        self.assertEqual([p["seed"] for p in r.pass_records], list(range(PASSES)))
        self.assertEqual([p["attempts"] for p in r.pass_records], [1] * PASSES)
        for k in ("dof", "spp", "passes", "seeds", "scene_sha256", "renderer"):
            self.assertEqual(r.meta[k], self.local.meta[k], k)

    def test_lost_worker_pass_is_rerun_and_recorded(self):
        r = ray_passes.render_passes_ray(
            self.ray, self.job, self.loaded, PASSES, DEFINES, quiet=True, pass_fn=crash_once
        )
        self.assert_same_pixels(r)
        self.assertEqual([p["attempts"] for p in r.pass_records], [1, 2, 1, 1])
        self.assertEqual(len(r.pass_records[1]["lost"]), 1)
        self.assertEqual(r.meta["pass_attempts"], "1,2,1,1")
        with tempfile.TemporaryDirectory() as d:
            out = Path(d) / "ref.exr"
            render.write_result(r, out)
            import json

            side = json.loads(out.with_suffix(".json").read_text())
        self.assertEqual([(p["pass"], p["seed"], p["attempts"]) for p in side["passes"]],
                         [(0, 0, 1), (1, 1, 2), (2, 2, 1), (3, 3, 1)])

    def test_a_pass_that_keeps_failing_stops_the_render(self):
        with self.assertRaisesRegex(RuntimeError, r"pass 2 \(seed 2\) failed 2 times .*not written"):
            ray_passes.render_passes_ray(
                self.ray, self.job, self.loaded, PASSES, DEFINES, quiet=True, retries=1, pass_fn=crash_always
            )


class RayUnavailable(unittest.TestCase):
    def test_bad_local_address_is_refused(self):
        if not HAVE_RAY:
            with self.assertRaisesRegex(ray_passes.RayUnavailable, "setup-oracle --with-ray"):
                ray_passes.connect("local:2")
        else:
            with self.assertRaisesRegex(ray_passes.RayUnavailable, "local:N"):
                ray_passes.connect("local:zero")


if __name__ == "__main__":
    unittest.main()
