"""Reference passes as tasks on a Ray cluster (`scripts/harness render --ray ADDRESS`).

Each pass p is one task: it renders the scene with mi.render(seed=seed_offset + p) on a worker
and returns the image; the driver accumulates the images in pass order with the same Welford
accumulation as a local render (render.PassStats), so the pooled mean and variance are bit for
bit those of the same passes rendered locally (Mitsuba's image depends on the scene, variant,
spp and seed only). The scene file and every file of its directory tree are sent with the task,
so the workers need the oracle venv (Mitsuba, numpy) but no copy of the repository.

A pass whose worker is lost (the process or its node dies) is submitted again, up to `retries`
times; a pass that still fails stops the render with an error, it is never dropped. The result
records every pass with its seed and the number of attempts it took.

Ray is optional (`scripts/setup-oracle --with-ray`); nothing here is imported without --ray.
"""

from __future__ import annotations

import hashlib
import os
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from harness import oracle
from harness.render import PassStats, RenderResult, pass_metadata

# Files sent with a scene: its directory tree, up to this many bytes (Ray's object store holds
# them once per job).
MAX_SCENE_BYTES = 256 * 1024 * 1024
# Environment that selects and runs the Mitsuba variant on the workers.
WORKER_ENV = ("DRJIT_LIBLLVM_PATH", "LINLIGHT_ORACLE_VARIANT")


class RayUnavailable(RuntimeError):
    """Ray is not installed or the cluster cannot be reached."""


@dataclass(frozen=True)
class SceneJob:
    """Everything a worker needs to render one pass: the scene's files, not their paths."""

    scene_rel: str  # path of the scene file inside `files`
    files: tuple[tuple[str, bytes], ...]  # (relative path, content) of the scene's directory tree
    defines: tuple[tuple[str, str], ...]
    radius: float | None
    variant: str
    spp: int
    linearlight: str | None = None  # the linearlight plugin's sampling (--emitter linearlight)

    def key(self) -> str:
        h = hashlib.sha256()
        for rel, data in self.files:
            h.update(rel.encode() + b"\0" + hashlib.sha256(data).digest())
        h.update(repr((self.scene_rel, self.defines, self.radius, self.variant, self.linearlight)).encode())
        return h.hexdigest()


def scene_job(
    scene: Path,
    defines: Mapping[str, str],
    radius: float | None,
    variant: str,
    spp: int,
    linearlight: str | None = None,
) -> SceneJob:
    root = scene.resolve().parent
    files, total = [], 0
    for p in sorted(root.rglob("*")):
        if p.is_file():
            data = p.read_bytes()
            total += len(data)
            if total > MAX_SCENE_BYTES:
                raise ValueError(
                    f"{root}: the scene's directory holds more than {MAX_SCENE_BYTES >> 20} MiB; "
                    "--ray sends it with every job (move the scene into a smaller directory)"
                )
            files.append((p.relative_to(root).as_posix(), data))
    return SceneJob(
        scene.resolve().relative_to(root).as_posix(),
        tuple(files),
        tuple(sorted(defines.items())),
        radius,
        variant,
        spp,
        linearlight,
    )


# Per worker process: the scene of the last job (key -> LoadedScene), so that a worker that
# renders several passes of one job loads it once.
_LOADED: dict[str, Any] = {}


def _loaded(job: SceneJob) -> Any:
    key = job.key()
    if key not in _LOADED:
        _LOADED.clear()
        oracle.set_variant(job.variant)
        d = Path(tempfile.mkdtemp(prefix="linlight-ray-"))
        for rel, data in job.files:
            f = d / rel
            f.parent.mkdir(parents=True, exist_ok=True)
            f.write_bytes(data)
        _LOADED[key] = oracle.load_scene(d / job.scene_rel, dict(job.defines), job.radius, job.linearlight)
    return _LOADED[key]


def render_pass(job: SceneJob, seed: int) -> np.ndarray:
    """One pass on a worker: the (H, W, 3) float64 image of mi.render(seed=seed), exactly as
    render.render_passes computes it locally."""
    import mitsuba as mi

    loaded = _loaded(job)
    img = np.array(mi.render(loaded.scene, spp=job.spp, seed=seed), dtype=np.float64)
    if img.ndim != 3 or img.shape[2] < 3:
        raise RuntimeError(f"unexpected render output shape {img.shape}")
    img = img[:, :, :3]
    if not np.isfinite(img).all():
        raise RuntimeError(f"seed {seed}: non-finite pixels")
    return img


@dataclass
class PassRecord:
    index: int
    seed: int
    attempts: int = 0
    errors: list[str] = field(default_factory=list)


def connect(address: str) -> Any:
    """ray.init for ADDRESS: `local` or `local:N` starts a local instance of N CPUs (default: all)
    for this run; anything else (`auto`, `HOST:PORT`, `ray://HOST:PORT`) joins that cluster."""
    try:
        import ray
    except ImportError as e:
        raise RayUnavailable("--ray needs the ray package: run scripts/setup-oracle --with-ray") from e
    harness_dir = str(Path(__file__).resolve().parent)
    env = {k: os.environ[k] for k in WORKER_ENV if k in os.environ}
    runtime_env = {"py_modules": [harness_dir], "env_vars": env}
    try:
        if address == "local" or address.startswith("local:"):
            n = address.partition(":")[2]
            if n and not (n.isdigit() and int(n) >= 1):
                raise RayUnavailable(f"--ray {address}: expected local or local:N with N >= 1")
            ray.init(num_cpus=int(n) if n else None, runtime_env=runtime_env, include_dashboard=False,
                     log_to_driver=False, logging_level="ERROR")
        else:
            ray.init(address=address, runtime_env=runtime_env, log_to_driver=False, logging_level="ERROR")
    except (ConnectionError, RuntimeError, ValueError) as e:
        if isinstance(e, RayUnavailable):
            raise
        raise RayUnavailable(f"--ray {address}: cannot connect: {e}") from e
    return ray


def render_passes_ray(
    ray: Any,
    job: SceneJob,
    loaded: oracle.LoadedScene,
    passes: int,
    overrides: Mapping[str, str],
    quiet: bool = False,
    seed_offset: int = 0,
    retries: int = 3,
    pass_fn: Callable[[SceneJob, int], np.ndarray] = render_pass,
) -> RenderResult:
    """The passes of render.render_passes as Ray tasks (one CPU each); the same result, plus the
    record of every pass (seed, attempts). `pass_fn` renders one pass on a worker."""
    if passes < 2 or job.spp < 1:
        raise ValueError("need passes >= 2 and spp >= 1")
    task = ray.remote(num_cpus=1, max_retries=0)(pass_fn)
    job_ref = ray.put(job)
    records = [PassRecord(p, seed_offset + p) for p in range(passes)]
    images: dict[int, np.ndarray] = {}
    pending: dict[Any, PassRecord] = {}

    def submit(r: PassRecord) -> None:
        r.attempts += 1
        pending[task.remote(job_ref, r.seed)] = r

    t0 = time.perf_counter()
    for r in records:
        submit(r)
    lost = (ray.exceptions.WorkerCrashedError, ray.exceptions.NodeDiedError, ray.exceptions.ObjectLostError)
    while pending:
        done, _ = ray.wait(list(pending), num_returns=1)
        r = pending.pop(done[0])
        try:
            images[r.index] = ray.get(done[0])
        except lost as e:
            r.errors.append(type(e).__name__)
            if r.attempts > retries:
                raise RuntimeError(
                    f"pass {r.index} (seed {r.seed}) failed {r.attempts} times (lost worker: "
                    f"{', '.join(r.errors)}); the reference is incomplete and was not written"
                ) from e
            if not quiet:
                print(f"  pass {r.index + 1}/{passes}: worker lost ({type(e).__name__}), re-running",
                      file=sys.stderr, flush=True)
            submit(r)
            continue
        except ray.exceptions.RayTaskError as e:  # the pass itself raised: not a lost worker
            raise RuntimeError(f"pass {r.index} (seed {r.seed}): {e.cause if hasattr(e, 'cause') else e}") from e
        if not quiet:
            m = images[r.index].mean(axis=(0, 1))
            print(f"  pass {r.index + 1}/{passes} done ({len(images)}/{passes}), mean RGB "
                  f"{m[0]:.6g} {m[1]:.6g} {m[2]:.6g}", file=sys.stderr, flush=True)
    wall = time.perf_counter() - t0
    stats = PassStats()
    pass_means = []
    for p in range(passes):  # pass order: the same floating-point sums as a local render
        stats.add(images[p])
        pass_means.append(images[p].mean(axis=(0, 1)))
    assert stats.mean is not None
    meta = pass_metadata(loaded, job.variant, passes, job.spp, overrides, seed_offset, wall)
    meta["distributed"] = "ray"
    meta["pass_attempts"] = ",".join(str(r.attempts) for r in records)
    return RenderResult(
        stats.mean,
        stats.var_of_mean(),
        stats.tail_share(),
        meta,
        np.array(pass_means),
        [{"pass": r.index, "seed": r.seed, "attempts": r.attempts, "lost": r.errors} for r in records],
    )
