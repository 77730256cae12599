"""The Mitsuba plugin `linearlight` (harness/linearlight.py) in scalar_rgb, and the scene
conversion (harness/linearlight_scene.py). Its certification against references and the sampler
suite is scripts/test-linearlight (in scripts/test-live-oracle)."""

import math
import os
import unittest
from pathlib import Path

import numpy as np

from harness import line_limit, linearlight_scene, oracle, scene_xml

SCENES = Path(__file__).resolve().parents[2] / "references" / "scenes"
# The docs' check value: n = (0,0,1), line (-1,0,1) -> (1,0,1) from the origin.
CHECK = {"x": (0.0, 0.0, 0.0), "n": (0.0, 0.0, 1.0), "p0": (-1.0, 0.0, 1.0), "p1": (1.0, 0.0, 1.0)}


def emitter_xml(**props: str) -> str:
    body = "".join(props.values())
    return f'<scene version="3.0.0"><emitter type="linearlight">{body}</emitter></scene>'


P0 = '<point name="p0" value="-1, 0, 1"/>'
P1 = '<point name="p1" value="1, 0, 1"/>'
K = '<rgb name="K" value="1, 2, 3"/>'


class Plugin(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.mi = oracle.set_variant("scalar_rgb")
        from harness import linearlight

        linearlight.register()  # for scalar_rgb, whatever variant imported it first
        cls.ll = linearlight

    def load(self, sampling="psa", p0=CHECK["p0"], p1=CHECK["p1"], k=(1.0, 2.0, 3.0)):
        mi = self.mi
        return mi.load_dict(
            {"type": "linearlight", "p0": mi.ScalarPoint3f(p0), "p1": mi.ScalarPoint3f(p1),
             "K": mi.ScalarColor3f(k), "sampling": sampling}
        )

    def interaction(self, x, n):
        it = self.mi.Interaction3f()
        it.p, it.n = self.mi.Point3f(x), self.mi.Normal3f(n)
        return it

    def test_bad_input_names_the_property(self):
        cases = {
            "p0": emitter_xml(p1=P1, k=K),
            "p1": emitter_xml(p0=P0, p1='<point name="p1" value="-1, 0, 1"/>', k=K),
            "K": emitter_xml(p0=P0, p1=P1, k='<float name="K" value="-0.5"/>'),
            "sampling": emitter_xml(p0=P0, p1=P1, k=K, s='<string name="sampling" value="ltc"/>'),
            "radius": emitter_xml(p0=P0, p1=P1, r='<rgb name="radiance" value="1, 1, 1"/>'),
        }
        cases["K (NaN)"] = emitter_xml(p0=P0, p1=P1, k='<float name="K" value="nan"/>')
        cases["K (both)"] = emitter_xml(p0=P0, p1=P1, k=K, r='<rgb name="radiance" value="1, 1, 1"/>',
                                        rr='<float name="radius" value="0.1"/>')
        cases["p0 (NaN)"] = emitter_xml(p0='<point name="p0" value="nan, 0, 1"/>', p1=P1, k=K)
        cases["radius (0)"] = emitter_xml(p0=P0, p1=P1, r='<rgb name="radiance" value="1, 1, 1"/>',
                                          rr='<float name="radius" value="0"/>')
        for prop, xml in cases.items():
            with self.subTest(prop), self.assertRaises(RuntimeError) as ctx:
                self.mi.load_string(xml)
            self.assertIn(f'linearlight: property "{prop.split()[0]}"', str(ctx.exception))
            self.assertIn("line 1", str(ctx.exception))  # Mitsuba's loader adds the place

    def test_radiance_and_radius_give_k(self):
        e = self.mi.load_string(emitter_xml(p0=P0, p1=P1, r='<rgb name="radiance" value="100, 200, 300"/>',
                                            rr='<float name="radius" value="0.01"/>')).emitters()[0]
        ds, w = e.sample_direction(self.interaction(CHECK["x"], CHECK["n"]), self.mi.Point2f(0.3, 0.5), True)
        cos = ds.d[2]
        for c, k in enumerate((1.0, 2.0, 3.0)):
            self.assertAlmostEqual(w[c] * cos / k, 1.0 + math.pi / 2, places=5)

    def test_weights_are_k_over_the_per_radius_density(self):
        """PSA: K / p_R x cos = K Omega_perp_R (1 + pi/2 at the check geometry) for every xi;
        solid angle: K / p_R = K Omega_R = 2 sqrt(2) K; every sample is delta and its pdf equals
        pdf_direction at its direction."""
        it = self.interaction(CHECK["x"], CHECK["n"])
        for sampling, expected in (("psa", 1.0 + math.pi / 2), ("solid-angle", 2.0 * math.sqrt(2.0))):
            e = self.load(sampling)
            for xi in (0.0, 3e-6, 0.1, 0.5, 0.77, 1.0 - 1e-7):
                ds, w = e.sample_direction(it, self.mi.Point2f(xi, 0.5), True)
                self.assertTrue(bool(ds.delta))
                value = w[0] * ds.d[2] if sampling == "psa" else w[0]
                self.assertAlmostEqual(value, expected, places=5, msg=f"{sampling} xi={xi}")
                self.assertAlmostEqual(w[1], 2.0 * w[0], places=4)
                self.assertAlmostEqual(e.pdf_direction(it, ds, True) / ds.pdf, 1.0, places=5)
                # the shadow ray's end is on the line, at ds.dist along ds.d
                p = [it.p[i] + ds.dist * ds.d[i] for i in range(3)]
                self.assertAlmostEqual(p[2], 1.0, places=5)
                self.assertAlmostEqual(p[1], 0.0, places=5)
                self.assertLess(abs(ds.p[0] - p[0]), 1e-5)

    def test_every_technique_integrates_the_projected_solid_angle(self):
        """Midpoint rule over xi of cos+ / p_R equals Omega_perp_R (line_limit's closed form) on
        configurations that cross the horizon, for psa, solid-angle and area."""
        rng = np.random.default_rng(7)
        count = 4000
        for case in range(6):
            x = rng.normal(size=3) * 0.3
            n = rng.normal(size=3)
            n /= np.linalg.norm(n)
            p0, p1 = tuple(rng.normal(size=3)), tuple(rng.normal(size=3))
            exact = float(line_limit.projected_solid_angle_per_radius(x[None], n[None], p0, p1)[0])
            it = self.interaction(tuple(x), tuple(n))
            for sampling in ("psa", "solid-angle", "area"):
                e = self.load(sampling, p0, p1, (1.0, 1.0, 1.0))
                total = 0.0
                for i in range(count):
                    ds, w = e.sample_direction(it, self.mi.Point2f((i + 0.5) / count, 0.5), True)
                    total += w[0] * max(0.0, float(np.dot(n, [ds.d[0], ds.d[1], ds.d[2]])))
                got = total / count
                # the midpoint rule's error: the psa integrand is constant, the others smooth
                tol = 1e-5 if sampling == "psa" else 2e-3
                self.assertLess(abs(got - exact), tol * max(exact, 1e-3), f"case {case} {sampling}: {got} vs {exact}")

    def test_no_visible_line_and_delta_flag(self):
        e = self.load()
        self.assertTrue(self.mi.has_flag(e.flags(), self.mi.EmitterFlags.DeltaPosition))
        si = self.mi.SurfaceInteraction3f()
        self.assertEqual(list(e.eval(si, True)), [0.0, 0.0, 0.0])

    def test_below_the_horizon_gives_nothing(self):
        e = self.load()
        it = self.interaction((0.0, 0.0, 0.0), (0.0, 0.0, -1.0))
        ds, w = e.sample_direction(it, self.mi.Point2f(0.5, 0.5), True)
        self.assertEqual(ds.pdf, 0.0)
        self.assertEqual(list(w), [0.0, 0.0, 0.0])

    def test_floor_tube_render_matches_the_closed_form_limit(self):
        """scalar_rgb render of floor-tube (8x8, plugin in place of the tube) against the R -> 0
        limit computed without any sampling (line_limit), within 4 standard errors of 8 passes."""
        path = SCENES / "floor-tube.xml"
        loaded = oracle.load_scene(path, {"res": "8"}, None, "psa")
        means = []
        for seed in range(8):
            img = np.array(self.mi.render(loaded.scene, spp=16, seed=seed), dtype=np.float64)[:, :, :3]
            means.append(img.mean(axis=(0, 1)))
        means = np.array(means)
        mean, se = means.mean(axis=0), means.std(axis=0, ddof=1) / math.sqrt(len(means))
        scene = self.mi.load_file(str(path), res="8")
        camera, plane = line_limit.from_scene(scene, path.read_text())
        limit = line_limit.image_limit(camera, plane, scene_xml.linear_lights(path.read_text(), {"res": "8"}), 8)
        limit = np.asarray(limit).mean(axis=(0, 1))
        for c in range(3):
            self.assertLess(abs(mean[c] - limit[c]), 4.0 * se[c] + 1e-6 * limit[c], f"channel {c}: {mean} vs {limit}")


@unittest.skipUnless(os.environ.get("DRJIT_LIBLLVM_PATH"), "needs the llvm variant (source .venv/oracle.env)")
class PluginLlvm(unittest.TestCase):
    def test_llvm_equals_scalar(self):
        """The same xi gives the same direction and density in llvm_ad_rgb as in scalar_rgb."""
        xis = [0.0, 1e-6, 0.1, 0.35, 0.5, 0.9, 1.0 - 1e-6]
        out = {}
        for variant in ("scalar_rgb", "llvm_ad_rgb"):
            mi = oracle.set_variant(variant)
            from harness import linearlight

            linearlight.register()
            e = mi.load_dict({"type": "linearlight", "p0": mi.ScalarPoint3f(0.3, -1, 0.5),
                              "p1": mi.ScalarPoint3f(-0.2, 2, 1.5), "K": 1.0})
            rows = []
            for xi in xis:
                it = mi.Interaction3f() if variant == "scalar_rgb" else __import__("drjit").zeros(mi.Interaction3f, 1)
                it.p, it.n = mi.Point3f(0.1, 0.2, 0.0), mi.Normal3f(0.0, 0.6, 0.8)
                ds, _ = e.sample_direction(it, mi.Point2f(xi, 0.5), True)
                rows.append([float(ds.d[0][0] if variant != "scalar_rgb" else ds.d[0]),
                             float(ds.d[1][0] if variant != "scalar_rgb" else ds.d[1]),
                             float(ds.d[2][0] if variant != "scalar_rgb" else ds.d[2]),
                             float(ds.pdf[0] if variant != "scalar_rgb" else ds.pdf)])
            out[variant] = np.array(rows)
        oracle.set_variant("scalar_rgb")
        np.testing.assert_allclose(out["llvm_ad_rgb"], out["scalar_rgb"], rtol=1e-5, atol=1e-6)


IDIOM = """<scene version="3.0.0">
    <default name="esamples" value="3"/>
    <integrator type="direct"><integer name="emitter_samples" value="$esamples"/></integrator>
    <shape type="cylinder" id="idiom">
        <transform name="to_world">
            <scale x="0.001" y="0.001" z="2.5"/>
            <rotate x="0.6" y="0.8" angle="35"/>
            <translate x="0.2" y="-0.4" z="1.1"/>
        </transform>
        <emitter type="area"><rgb name="radiance" value="1000, 500, 250"/></emitter>
    </shape>
    <shape type="cylinder" id="both">
        <point name="p0" value="0, 0, 1"/><point name="p1" value="1, 0, 1"/>
        <float name="radius" value="0.002"/>
        <transform name="to_world"><rotate z="1" angle="90"/><translate x="1"/></transform>
        <emitter type="area"><float name="radiance" value="100"/><float name="sampling_weight" value="2"/></emitter>
    </shape>
    <shape type="cylinder" id="plain"><float name="radius" value="0.3"/></shape>
</scene>"""


class Conversion(unittest.TestCase):
    def test_idiom_and_combined_placement(self):
        text, lights, divisor = linearlight_scene.convert(IDIOM)
        self.assertEqual(divisor, 3)
        a, b = lights
        self.assertEqual((a.id, b.id), ("idiom", "both"))
        # scale(R, R, L) . rotate(axis (0.6, 0.8, 0), 35 deg) . translate
        axis = np.array([0.6, 0.8, 0.0])
        z = np.array([0.0, 0.0, 1.0])
        ang = math.radians(35)
        rz = z * math.cos(ang) + np.cross(axis, z) * math.sin(ang) + axis * np.dot(axis, z) * (1 - math.cos(ang))
        np.testing.assert_allclose(a.p0, (0.2, -0.4, 1.1), atol=1e-12)
        np.testing.assert_allclose(a.p1, np.array([0.2, -0.4, 1.1]) + 2.5 * rz, atol=1e-12)
        self.assertAlmostEqual(a.radius, 0.001, places=12)
        np.testing.assert_allclose(a.k, (1.0, 0.5, 0.25), rtol=1e-12)
        np.testing.assert_allclose(a.k_scene, (1 / 3, 0.5 / 3, 0.25 / 3), rtol=1e-12)
        # p0/p1/radius, then to_world: rotate 90 deg about z, translate x + 1
        np.testing.assert_allclose(b.p0, (1.0, 0.0, 1.0), atol=1e-12)
        np.testing.assert_allclose(b.p1, (1.0, 1.0, 1.0), atol=1e-12)
        self.assertAlmostEqual(b.radius, 0.002, places=12)
        self.assertEqual(b.sampling_weight, 2.0)
        root = scene_xml.parse(text)
        self.assertEqual(len(root.findall("emitter")), 2)
        self.assertEqual([s.get("id") for s in root.iter("shape")], ["plain"])
        self.assertEqual(linearlight_scene.convert(IDIOM, {"esamples": "1"})[2], 1)

    def test_agrees_with_mitsubas_own_cylinder(self):
        """The converted tube's bounding box equals the bounding box Mitsuba computes for the
        cylinder it loads from the same XML."""
        mi = oracle.set_variant("scalar_rgb")
        shapes = scene_xml.parse(IDIOM).findall("shape")[:2]
        _, lights, _ = linearlight_scene.convert(IDIOM)
        import xml.etree.ElementTree as ET

        for shape, light in zip(shapes, lights):
            for e in shape.findall("emitter"):
                shape.remove(e)
            scene = mi.load_string(f'<scene version="3.0.0">{ET.tostring(shape, encoding="unicode")}</scene>')
            box = scene.shapes()[0].bbox()
            p0, p1 = np.array(light.p0), np.array(light.p1)
            d = (p1 - p0) / np.linalg.norm(p1 - p0)
            ext = light.radius * np.sqrt(np.maximum(0.0, 1.0 - d * d))
            lo, hi = np.minimum(p0, p1) - ext, np.maximum(p0, p1) + ext
            np.testing.assert_allclose(np.array(box.min), lo, atol=2e-6)
            np.testing.assert_allclose(np.array(box.max), hi, atol=2e-6)

    def test_refuses_by_name(self):
        cases = {
            "shear": '<transform name="to_world"><matrix value="1 0.3 0 0  0 1 0 0  0 0 1 0  0 0 0 1"/></transform>'
            '<emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>',
            "unnormalised-axis": '<transform name="to_world"><scale x="0.01" y="0.01" z="1"/>'
            '<rotate x="1" y="1" angle="35"/></transform>'
            '<emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>',
            "uneven": '<transform name="to_world"><scale x="0.01" y="0.02" z="1"/></transform>'
            '<emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>',
            "flipped": '<boolean name="flip_normals" value="true"/>'
            '<emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>',
            "textured": '<emitter type="area"><texture name="radiance" type="bitmap"/></emitter>',
            "not-area": '<emitter type="point"/>',
        }
        for name, body in cases.items():
            xml = f'<scene version="3.0.0"><shape type="cylinder" id="{name}">{body}</shape></scene>'
            with self.subTest(name), self.assertRaises(scene_xml.SceneError) as ctx:
                linearlight_scene.convert(xml)
            self.assertIn(f"cylinder {name!r}", str(ctx.exception))
        nested = ('<scene version="3.0.0"><shapegroup id="g"><shape type="cylinder" id="inner">'
                  '<emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter></shape></shapegroup></scene>')
        with self.assertRaises(scene_xml.SceneError) as ctx:
            linearlight_scene.convert(nested)
        self.assertIn("cylinder 'inner'", str(ctx.exception))

    def test_every_committed_scene_converts(self):
        for path in sorted(SCENES.glob("*.xml")):
            text = path.read_text()
            _, lights, divisor = linearlight_scene.convert(text)
            tubes = scene_xml.linear_lights(text)
            self.assertEqual([l.id for l in lights], [t.id for t in tubes], path.name)
            for l, t in zip(lights, tubes):
                np.testing.assert_allclose(l.k, t.k, rtol=1e-12)
                np.testing.assert_allclose(l.p0, t.p0, atol=1e-12)
                np.testing.assert_allclose(l.p1, t.p1, atol=1e-12)
            self.assertGreaterEqual(divisor, 1)


if __name__ == "__main__":
    unittest.main()
