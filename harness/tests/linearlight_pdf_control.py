"""Power control of the linearlight certification: the plugin with its density x 1.01 (weight
/ 1.01), registered under the name `linearlight`, renders a scene like `scripts/harness render
SCENE --emitter linearlight`; `linlight compare` against the reference must reject it.

    python -m harness.tests.linearlight_pdf_control SCENE.xml --passes P --spp S [-D ...] --out FILE.exr
"""

from __future__ import annotations

import sys
from typing import Any

PDF_SCALE = 1.01


def register_control(scale: float = PDF_SCALE) -> None:
    """Replaces the registered `linearlight` by the plugin with its density x `scale`."""
    import mitsuba as mi

    from harness import linearlight

    base: Any = linearlight._emitter_class()

    class ScaledPdf(base):  # type: ignore[misc, valid-type]
        def sample_direction(self, it: Any, sample: Any, active: Any = True) -> tuple[Any, Any]:
            ds, weight = super().sample_direction(it, sample, active)
            ds.pdf = ds.pdf * scale
            return ds, weight / scale

    mi.register_emitter(linearlight.PLUGIN_NAME, lambda props: ScaledPdf(props))


def main(argv: list[str]) -> int:
    from harness import cli, oracle

    oracle.set_variant(oracle.choose_variant(None))
    register_control()
    return cli.main(["render", *argv, "--emitter", "linearlight"])


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
