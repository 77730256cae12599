"""K-preserving radius override (stdlib only, plus one Mitsuba load of the rewritten XML)."""

import math
import unittest
from pathlib import Path

from harness import scene_xml

SCENES = Path(__file__).resolve().parents[2] / "references" / "scenes"

PARAM_SCENE = """<scene version="3.0.0">
    <default name="r" value="0.002"/>
    <default name="L" value="500"/>
    <shape type="cylinder" id="a">
        <point name="p0" x="0" y="0" z="$r"/>
        <point name="p1" value="1, 2, 3"/>
        <float name="radius" value="$r"/>
        <emitter type="area"><float name="radiance" value="$L"/></emitter>
    </shape>
    <shape type="cylinder" id="plain"><float name="radius" value="0.5"/></shape>
</scene>"""


class OverrideRadius(unittest.TestCase):
    def assert_k_equal(self, a, b):
        for x, y in zip(a, b):
            self.assertLessEqual(abs(x - y), 1e-15 * abs(y))

    def test_two_tubes_keeps_every_k(self):
        text = (SCENES / "two-tubes.xml").read_text()
        before = scene_xml.linear_lights(text)
        self.assertEqual([l.id for l in before], ["tube-long", "tube-short"])
        for r in (0.1, 1e-3, 1e-7):
            new_text, after = scene_xml.override_radius(text, r)
            reparsed = scene_xml.linear_lights(new_text)
            for b, a, p in zip(before, after, reparsed):
                self.assertEqual(a.radius, r)
                self.assertEqual(p.radius, r)
                self.assert_k_equal(p.k, b.k)
                self.assert_k_equal(tuple(x * r for x in p.radiance), b.k)
                self.assertEqual((p.p0, p.p1), (b.p0, b.p1))

    def test_k_read_from_file(self):
        lights = scene_xml.linear_lights((SCENES / "two-tubes.xml").read_text())
        self.assert_k_equal(lights[0].k, (1.0, 0.35, 0.1))
        self.assert_k_equal(lights[1].k, (0.15, 0.4, 1.2))

    def test_parameters_and_float_radiance(self):
        lights = scene_xml.linear_lights(PARAM_SCENE)
        self.assertEqual(len(lights), 1)  # the cylinder without an emitter is not a light
        self.assertEqual(lights[0].p0, (0.0, 0.0, 0.002))
        self.assertEqual(lights[0].p1, (1.0, 2.0, 3.0))
        self.assertAlmostEqual(lights[0].k[0], 1.0, places=15)
        over = scene_xml.linear_lights(PARAM_SCENE, {"L": "1000"})
        self.assertAlmostEqual(over[0].k[0], 2.0, places=15)
        new_text, after = scene_xml.override_radius(PARAM_SCENE, 0.25, {"L": "1000"})
        self.assertAlmostEqual(after[0].radiance[0], 8.0, places=12)
        self.assertIn('value="8.0"', new_text)
        # the override does not touch ordinary cylinders
        self.assertIn('value="0.5"', new_text)

    def test_bad_input(self):
        text = (SCENES / "floor-tube.xml").read_text()
        for r in (0.0, -1.0, math.inf, math.nan):
            with self.assertRaises(scene_xml.SceneError):
                scene_xml.override_radius(text, r)
        with self.assertRaises(scene_xml.SceneError):
            scene_xml.linear_lights(PARAM_SCENE.replace('value="$L"', 'value="$missing"'))
        with self.assertRaises(scene_xml.SceneError):
            scene_xml.linear_lights("<scene><shape")
        no_rad = '<scene><shape type="cylinder"><emitter type="area"/></shape></scene>'
        with self.assertRaises(scene_xml.SceneError):
            scene_xml.linear_lights(no_rad)


class OverrideLoadsInMitsuba(unittest.TestCase):
    def test_mesh_scene_with_override_loads_and_keeps_k(self):
        from harness import oracle

        mi = oracle.set_variant("scalar_rgb")
        path = SCENES / "mesh-occluder.xml"
        loaded = oracle.load_scene(path, {"res": "8"}, 1e-2)  # relative meshes/torus.obj resolves
        emitters = [s for s in loaded.scene.shapes() if s.is_emitter()]
        self.assertEqual(len(emitters), 1)
        params = mi.traverse(emitters[0].emitter())
        radiance = [float(x) for x in params["radiance.value"]]
        k_file = scene_xml.linear_lights(path.read_text())[0].k
        for rad, k in zip(radiance, k_file):
            self.assertAlmostEqual(rad * 1e-2, k, delta=1e-6 * k)  # float32 in Mitsuba
        self.assertEqual(loaded.sha256, oracle.sha256_file(path))


if __name__ == "__main__":
    unittest.main()
