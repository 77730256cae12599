"""The shared EXR format: channel names, float32, string metadata, values round-trip."""

import tempfile
import unittest
from pathlib import Path

import numpy as np

from harness import exrfile, oracle
from harness.render import PassStats


class ExrWriter(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        oracle.set_variant("scalar_rgb")

    def test_round_trip_channels_and_metadata(self):
        rng = np.random.default_rng(1)
        h, w = 5, 7  # non-square: catches transposed width/height
        mean = rng.random((h, w, 3)).astype(np.float32)
        var = (rng.random((h, w, 3)) * 1e-6).astype(np.float32)
        meta = {"dof": "31", "spp": "4096", "passes": "32", "renderer": "mitsuba 3.9.1 scalar_rgb",
                "scene_sha256": "ab" * 32, "K": "1.0,0.5,0.25"}
        with tempfile.TemporaryDirectory() as d:
            path = Path(d) / "img.exr"
            exrfile.write_image(path, mean, var, meta)
            exrfile.check_written(path, meta, (h, w))
            header = exrfile.read_header(path)
            self.assertEqual(set(header.channels), set(exrfile.CHANNELS))
            self.assertTrue(all(t == "float" for t in header.channels.values()))
            for k, v in meta.items():
                self.assertEqual(header.strings[k], v)
            self.assertEqual((header.width, header.height), (w, h))
            m2, v2 = exrfile.read_image(path)
            np.testing.assert_array_equal(m2, mean)
            np.testing.assert_array_equal(v2, var)

    def test_check_written_detects_missing_metadata(self):
        z = np.zeros((2, 3, 3), np.float32)
        with tempfile.TemporaryDirectory() as d:
            path = Path(d) / "img.exr"
            exrfile.write_image(path, z, z, {"dof": "1"})
            with self.assertRaises(ValueError):
                exrfile.check_written(path, {"dof": "1", "spp": "2"}, (2, 3))
            with self.assertRaises(ValueError):
                exrfile.check_written(path, {"dof": "1"}, (3, 2))

    def test_rejects_bad_input(self):
        z = np.zeros((2, 2, 3), np.float32)
        with tempfile.TemporaryDirectory() as d:
            path = Path(d) / "img.exr"
            with self.assertRaises(ValueError):
                exrfile.write_image(path, z + np.nan, z, {})
            with self.assertRaises(TypeError):
                exrfile.write_image(path, z, z, {"dof": 3})  # type: ignore[dict-item]
            with self.assertRaises(ValueError):
                exrfile.write_image(path, z, z[:, :1], {})
            self.assertFalse(path.exists())


class VarianceOfMean(unittest.TestCase):
    def test_matches_numpy(self):
        rng = np.random.default_rng(7)
        passes = rng.normal(3.0, 0.5, size=(32, 4, 6, 3))
        s = PassStats()
        for p in passes:
            s.add(p)
        np.testing.assert_allclose(s.mean, passes.mean(axis=0), rtol=1e-13)
        np.testing.assert_allclose(s.var_of_mean(), passes.var(axis=0, ddof=1) / 32, rtol=1e-11)
        dev2 = (passes - passes.mean(axis=0)) ** 2
        np.testing.assert_allclose(s.tail_share(), dev2.max(axis=0) / dev2.sum(axis=0), rtol=1e-9)

    def test_tail_share_of_one_outlier(self):
        s = PassStats()
        for p in range(10):
            s.add(np.full((1, 1, 3), 50.0 if p == 3 else 0.0))
        np.testing.assert_allclose(s.tail_share(), 0.9, rtol=1e-12)


if __name__ == "__main__":
    unittest.main()
