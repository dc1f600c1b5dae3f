"""warpdyn against MuJoCo Warp and JaxSim: the same standing ergoCub, in one process, on one device.

    python benchmarks/compare.py [--device cpu | cuda:0] [--sizes 1,16] [--dtype float32|float64]
                                 [--repeats 5] [--libraries warpdyn,mjwarp,jaxsim] [--max-run-seconds 60]
                                 [--fresh-cache] [--output-dir DIR]

The scene (benchmarks/compare_scene.py builds it for each library from the URDF warpdyn ships):
- the ergoCub's legs (12 joints; every other joint locked at 0 and its links lumped into their parents:
  13 bodies), floating base, the four foot collision boxes of the URDF (32 corners), flat ground at z = 0;
- at t = 0 the joints are at 0, all velocities are zero and the base is at the height that puts the lowest
  box corner 3 mm below the ground; zero joint torques; dt = 1 ms; 100 steps per timed run.
What each library runs, N environments (worlds) at once:
- warpdyn: `wd.simulation.Rollout(model, steps=100, record=())` run with zero joint force references
  (N, 12): its default soft contacts (Hunt/Crossley, K = 1e6, D = 2000, mu = 0.5) on the 32 corners,
  semi-implicit Euler; each run copies the initial state in and replays one captured graph (a CUDA
  graph on GPUs, Warp's CPU graph on the CPU).
- MuJoCo Warp: an MjModel compiled by MuJoCo from the same URDF (fixed joints fused, a free joint added),
  the boxes as box geoms against a plane (box-plane collisions, up to 4 contacts a box; box-box pairs
  filtered by contype/conaffinity), friction 0.5, MuJoCo's default soft constraints (solref 0.02,
  Newton solver, pyramidal cone), Euler integrator, no actuators. A graph of 100 `mujoco_warp.step` calls
  (plus resetting qpos, qvel, warm start and time to the initial state) is captured with
  `wp.ScopedCapture` and replayed. nconmax = 16 contacts a world (4 boxes x 4), njmax = 80 rows.
  MuJoCo Warp computes in float32 only.
- JaxSim: `js.model.reduce` of a JaxSimModel of the same URDF (given to it as SDF: rod 0.5 converts URDF
  only through Gazebo's `gz sdf`, which neither machine has) with its default contact model, SoftContacts
  (the same Hunt/Crossley model and parameters as warpdyn), flat terrain, semi-implicit Euler;
  `jax.lax.scan` over 100 steps of `jax.vmap(js.model.step)`, jitted; float32 unless --dtype float64.
Each run is timed with the device synchronised before and after (`wp.synchronize_device`,
`jax.block_until_ready`); the first run (kernel compilation, graph capture, JIT) is reported apart, a second
run warms up, and the table gives the median of at least --repeats timed runs (more while they add up to
less than 0.5 s). us per step = run / 100; env-steps/s = N x 100 / run. Ratios are warpdyn's throughput
over the other's (the other's time over warpdyn's). A library that is missing
or fails shows why in its cells; the others still run. A size that runs out of memory, or a library whose
run exceeds --max-run-seconds (or would, extrapolated linearly in N on the CPU), skips the larger sizes.
Sanity (printed, not asserted): base height after 100 steps over the environments, and how many stayed finite.

Locally (CPU, 2 cores): python benchmarks/compare.py --device cpu        (sizes 1,16 by default)
On a GPU machine, with the peers installed (pip install mujoco-warp==4.0.0 jaxsim==0.9.0 "jax[cuda13]"):
    python benchmarks/compare.py --device cuda:0 [--output-dir DIR]
  (sizes 1,4096,32768,131072 by default on CUDA). It prints the report and writes it as
  compare_<device>.md (compare_<device>_float64.md with --dtype float64) into --output-dir (default
  benchmarks/results; $OUT brings it back from the GPU machine), rewriting it after each library, so
  a run stopped at the device's 600 s limit keeps what it finished. Compilation dominates the first run:
  MuJoCo Warp's kernels (~2 min on an empty cache), JAX's JIT once per N; Warp's kernel cache and JAX's
  compilation cache (~/.cache/warpdyn-compare-jax) stay on a warm machine, so a second call compiles
  less (the first-run column then shows cached times). If one call cannot hold all three, split it by
  --libraries (e.g. warpdyn,mjwarp then warpdyn,jaxsim): the figures then come from two processes.
"""

from __future__ import annotations

import os

os.environ.setdefault("ROD_SKIP_SDFORMAT_CHECK", "1")  # rod (JaxSim's parser): no sdformat version check
os.environ.setdefault("XLA_PYTHON_CLIENT_PREALLOCATE", "false")  # else JAX takes 75 % of the GPU at its first use

import argparse
import dataclasses
import gc
import importlib.metadata as md
import pathlib
import platform
import re
import statistics
import sys
import time
import traceback
import warnings

import numpy as np
import warp as wp

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from compare_scene import count_boxes, lowest_box_corner, mujoco_lowest_corner, mujoco_spec, strip_urdf, urdf_to_sdf  # noqa: E402

STEPS = 100  # steps per timed run
DT = 1e-3  # [s]
DEPTH = 0.003  # [m] of the lowest box corner below the ground at t = 0
MU = 0.5  # friction coefficient (warpdyn's and JaxSim's default)
MJW_NCONMAX = 16  # contacts per world: 4 boxes x 4 (MuJoCo's box-plane collision keeps at most 4)
MJW_NJMAX = 80  # constraint rows per world: 16 pyramidal contacts x 4 + 12 joint limits, rounded up
LIBRARIES = ("warpdyn", "mjwarp", "jaxsim")
TITLES = {"warpdyn": "warpdyn", "mjwarp": "MuJoCo Warp", "jaxsim": "JaxSim"}


@dataclasses.dataclass
class Result:
    """One library at one N: timings, or why there are none, and the state after the last run."""

    status: str = "ok"  # "ok", "not installed", "failed: ...", "skipped: ..."
    run_s: float | None = None  # median seconds of a run of STEPS steps
    first_s: float | None = None  # seconds of the first run (compilation, capture, JIT included)
    z0: float | None = None  # base height at t = 0
    z: np.ndarray | None = None  # (N,) base heights after the last run
    finite: int | None = None  # environments whose state stayed finite (and, for warpdyn, valid)
    note: str = ""


@dataclasses.dataclass
class Scene:
    urdf: str  # the stripped URDF text: boxes as the only collision shapes
    urdf_legs: str  # the same with the joints outside `joints` made fixed (for MuJoCo, which has no reduce)
    joints: tuple  # the 12 leg joints
    z0: float  # base height at t = 0
    dtype: str
    device: str  # Warp's device name ("cpu", "cuda:0")
    jax_cache: str  # JAX's persistent compilation cache (a second call on a warm machine skips the JIT)


def timed_runs(run, sync, repeats: int, min_seconds: float = 0.5):
    """(seconds of the first call, median seconds of the timed calls): after the first call and one more
    warm-up call, `repeats` timed calls, or more while they add up to less than min_seconds (at most 200)."""
    sync()
    start = time.perf_counter()
    run()
    sync()
    first = time.perf_counter() - start
    run()  # warm-up
    sync()
    times = []
    while len(times) < repeats or (sum(times) < min_seconds and len(times) < 200):
        sync()
        start = time.perf_counter()
        run()
        sync()
        times.append(time.perf_counter() - start)
    return first, statistics.median(times)


# --------------------------------------------------------------------------------------------- warpdyn


class Warpdyn:
    name = "warpdyn"

    def __init__(self, scene: Scene):
        import warpdyn as wd

        self.wd, self.scene = wd, scene
        dtype = {"float32": np.float32, "float64": np.float64}[scene.dtype]
        full = wd.model.Model.build_from_model_description(scene.urdf, dtype=dtype, device=scene.device)
        self.model = wd.model.reduce(full, list(scene.joints))
        points = len(self.model.kin_dyn_parameters.contact_parameters.body)
        self.describe = (
            f"{self.model.number_of_links()} links, {self.model.dofs()} joints, {points} collidable points, "
            f"{self.model.contact_params}, integrator {wd.model.IntegratorType(self.model.integrator).name}, "
            f"dt {self.model.time_step}, {scene.dtype}"
        )

    def lowest_point(self) -> float:
        wd = self.wd
        zero = wd.data.Data.build(self.model)
        return float(wd.contact.collidable_point_positions(self.model, zero).numpy()[:, 2].min())

    def run(self, N: int, repeats: int) -> Result:
        wd, model, device = self.wd, self.model, self.scene.device
        position = np.tile([0.0, 0.0, self.scene.z0], (N, 1))
        data = wd.data.Data.build(model, num_envs=N, base_position=position)
        tau = wp.zeros((N, model.dofs()), dtype=model.scalar, device=device)
        roll = wd.simulation.Rollout(model, steps=STEPS, record=())
        out = {}

        def run():
            out["final"], _ = roll.run(data, joint_force_references=tau)

        first, run_s = timed_runs(run, lambda: wp.synchronize_device(device), repeats)
        final = out["final"]
        z = final.base_position.numpy()[:, 2].astype(np.float64)
        finite = np.isfinite(final.base_position.numpy()).all(axis=1) & np.isfinite(final.joint_positions.numpy()).all(axis=1)
        finite &= final.healthy.numpy().astype(bool)
        return Result(run_s=run_s, first_s=first, z0=self.scene.z0, z=z, finite=int(finite.sum()))


# ----------------------------------------------------------------------------------------- MuJoCo Warp


class MujocoWarp:
    name = "mjwarp"

    def __init__(self, scene: Scene):
        import mujoco
        import mujoco_warp as mjw

        self.mujoco, self.mjw, self.scene = mujoco, mjw, scene
        self.mjm = mujoco_spec(scene.urdf_legs, time_step=DT, mu=MU).compile()
        mjm = self.mjm
        boxes = int((mjm.geom_type == mujoco.mjtGeom.mjGEOM_BOX).sum())
        self.describe = (
            f"{mjm.nbody - 1} bodies, nq {mjm.nq}, nv {mjm.nv}, {boxes} box geoms + plane, "
            f"integrator {mujoco.mjtIntegrator(mjm.opt.integrator).name}, solver {mujoco.mjtSolver(mjm.opt.solver).name} "
            f"(iterations {mjm.opt.iterations}, ls {mjm.opt.ls_iterations}), cone {mujoco.mjtCone(mjm.opt.cone).name}, "
            f"dt {mjm.opt.timestep}, nconmax {MJW_NCONMAX}, njmax {MJW_NJMAX}, float32"
        )

    def lowest_point(self) -> float:
        return mujoco_lowest_corner(self.mjm)

    def run(self, N: int, repeats: int) -> Result:
        mujoco, mjw, mjm = self.mujoco, self.mjw, self.mjm
        mjd = mujoco.MjData(mjm)
        mjd.qpos[2] = self.scene.z0  # free joint first: (x, y, z, qw, qx, qy, qz), then the legs at 0
        mujoco.mj_forward(mjm, mjd)
        device = wp.get_device(self.scene.device)
        # MuJoCo Warp asks wp.get_device() in places (graph conditionals, CPU paths): make ours the default
        with wp.ScopedDevice(device):
            m = mjw.put_model(mjm)
            d = mjw.put_data(mjm, mjd, nworld=N, nconmax=MJW_NCONMAX, njmax=MJW_NJMAX)
            qpos0, qvel0 = wp.clone(d.qpos), wp.clone(d.qvel)
            warmstart0, time0 = wp.clone(d.qacc_warmstart), wp.clone(d.time)

            def steps():
                wp.copy(d.qpos, qpos0)
                wp.copy(d.qvel, qvel0)
                wp.copy(d.qacc_warmstart, warmstart0)
                wp.copy(d.time, time0)
                for _ in range(STEPS):
                    mjw.step(m, d)

            graph = {}

            def run():
                if not graph:  # first run: compile (one eager step), then capture
                    mjw.step(m, d)
                    with wp.ScopedCapture(device=device) as capture:
                        steps()
                    graph["g"] = capture.graph
                wp.capture_launch(graph["g"])

            first, run_s = timed_runs(run, lambda: wp.synchronize_device(device), repeats)
            qpos = d.qpos.numpy()
            nacon, nefc, niter = int(d.nacon.numpy()[0]), d.nefc.numpy(), d.solver_niter.numpy()
            overflow = int(np.bitwise_or.reduce(d.overflow.numpy()))
        flags = [f.name for f in mjw.OverflowType if f.value and not f.value & (f.value - 1) and overflow & f.value]
        note = f"contacts per world {nacon / N:.1f}, max rows {int(nefc.max())}"
        note += f", solver iterations (last step) mean {niter.mean():.1f} max {int(niter.max())}"
        if flags:
            note += f", overflow flags: {', '.join(flags)}"
        finite = np.isfinite(qpos).all(axis=1)
        return Result(run_s=run_s, first_s=first, z0=float(mjd.qpos[2]), z=qpos[:, 2].astype(np.float64), finite=int(finite.sum()), note=note)


# ---------------------------------------------------------------------------------------------- JaxSim


class Jaxsim:
    name = "jaxsim"

    def __init__(self, scene: Scene):
        import jax
        import jaxsim  # noqa: F401  (turns float64 on at import)
        import jaxsim.api as js

        jax.config.update("jax_enable_x64", scene.dtype == "float64")
        jax.config.update("jax_compilation_cache_dir", scene.jax_cache)
        self.jax, self.js, self.scene = jax, js, scene
        self.device = jax_device(scene.device)
        with warnings.catch_warnings(), jax.default_device(self.device):
            warnings.simplefilter("ignore")  # JaxSim hashes the joints' 1e9 effort limits with overflows; joint reordering
            full = js.model.JaxSimModel.build_from_model_description(urdf_to_sdf(scene.urdf), time_step=DT)
            model = js.model.reduce(full, considered_joints=tuple(scene.joints))
        self.model = jax.device_put(model, self.device)
        params = self.model.contact_params
        self.describe = (
            f"{self.model.number_of_links()} links, {self.model.dofs()} joints, "
            f"{len(self.model.kin_dyn_parameters.contact_parameters.body)} collidable points, "
            f"{type(self.model.contact_model).__name__}(K={float(params.K):g}, D={float(params.D):g}, mu={float(params.mu):g}, "
            f"p={float(params.p):g}, q={float(params.q):g}), terrain {type(self.model.terrain).__name__}, "
            f"integrator {self.model.integrator.name}, dt {float(self.model.time_step):g}, jax {jax.__version__} on {self.device}"
        )

    def lowest_point(self) -> float:
        js = self.js
        with self.jax.default_device(self.device):
            zero = js.data.JaxSimModelData.build(model=self.model)
            return float(js.contact.collidable_point_positions(self.model, zero)[:, 2].min())

    def run(self, N: int, repeats: int) -> Result:
        jax, js, model = self.jax, self.js, self.model
        import jax.numpy as jnp

        with jax.default_device(self.device):
            one = js.data.JaxSimModelData.build(model=model, base_position=jnp.array([0.0, 0.0, self.scene.z0]))
            data = jax.device_put(jax.tree.map(lambda x: jnp.broadcast_to(x, (N, *x.shape)), one), self.device)
            tau = jax.device_put(jnp.zeros((N, model.dofs())), self.device)

        def rollout(model, data, tau):
            step = jax.vmap(lambda d, t: js.model.step(model, d, joint_force_references=t))
            return jax.lax.scan(lambda d, _: (step(d, tau), None), data, None, length=STEPS)[0]

        rollout = jax.jit(rollout)
        out = {}

        def run():
            out["final"] = rollout(model, data, tau)

        first, run_s = timed_runs(run, lambda: jax.block_until_ready(out.get("final")), repeats)
        final = out["final"]
        position = np.asarray(final.base_position)
        finite = np.isfinite(position).all(axis=1) & np.isfinite(np.asarray(final.joint_positions)).all(axis=1)
        dtype = str(position.dtype)
        note = "" if dtype == self.scene.dtype else f"computed in {dtype}"
        return Result(run_s=run_s, first_s=first, z0=self.scene.z0, z=position[:, 2].astype(np.float64), finite=int(finite.sum()), note=note)


def jax_device(warp_device: str):
    """JAX's device for a Warp device name ("cpu", "cuda:K")."""
    import jax

    if warp_device.startswith("cuda"):
        index = int(warp_device.split(":")[1]) if ":" in warp_device else 0
        for platform_name in ("cuda", "gpu"):
            try:
                return jax.devices(platform_name)[index]
            except RuntimeError:
                continue
        raise RuntimeError("JAX sees no CUDA device (is a CUDA jaxlib plugin installed?)")
    return jax.devices("cpu")[0]


# ---------------------------------------------------------------------------------------------- driver


def short_error(error: BaseException) -> str:
    text = f"{type(error).__name__}: {error}".replace("|", "/").replace("\n", " ")
    return re.sub(r"\s+", " ", text)[:160]


def out_of_memory(error: BaseException) -> bool:
    text = str(error).lower()
    return isinstance(error, MemoryError) or any(k in text for k in ("out of memory", "resource_exhausted", "memoryallocation", "failed to allocate"))


def run_library(cls, scene: Scene, sizes, repeats: int, max_run_s: float) -> tuple[dict, str]:
    """{N: Result} for one library, and a line describing its model (or why there is none)."""
    module = {"warpdyn": "warpdyn", "mjwarp": "mujoco_warp", "jaxsim": "jaxsim"}[cls.name]
    try:
        __import__(module)
        if cls.name == "mjwarp":
            __import__("mujoco")
    except ImportError as error:
        return {N: Result(status="not installed") for N in sizes}, f"not installed ({error})"
    try:
        lib = cls(scene)
    except Exception as error:
        traceback.print_exc()
        return {N: Result(status=f"failed: {short_error(error)}") for N in sizes}, f"failed to build: {short_error(error)}"
    describe = lib.describe
    print(f"{TITLES[cls.name]}: {describe}", flush=True)
    results, stop = {}, None
    last = None  # (N, seconds per run) of the last size that ran
    for N in sizes:
        if stop is not None:
            results[N] = Result(status=f"skipped: {stop}")
            continue
        # linear in N on the CPU; a GPU's time is flat until it fills, so only a run's own time stops it there
        if last is not None and not scene.device.startswith("cuda") and last[1] * N / last[0] > max_run_s:
            stop = f"a run would take ~{last[1] * N / last[0]:.0f} s (> --max-run-seconds)"
            results[N] = Result(status=f"skipped: {stop}")
            continue
        try:
            result = lib.run(N, repeats)
        except Exception as error:
            traceback.print_exc()
            result = Result(status=f"failed: {short_error(error)}")
            if out_of_memory(error):
                stop = f"out of memory at N = {N}"
        gc.collect()
        results[N] = result
        if result.status == "ok":
            last = (N, result.run_s)
            if result.run_s > max_run_s:
                stop = f"a run took {result.run_s:.0f} s at N = {N} (> --max-run-seconds)"
        print(f"  {TITLES[cls.name]} N = {N}: {cell(result, N)}; first run {first_cell(result)} s; {sanity_cell(result, N)}", flush=True)
    try:  # after the timed runs, so that the first run's time includes all compilation
        describe += f"; its lowest box corner at the zero pose: {lib.lowest_point():+.5f} m"
    except Exception as error:
        describe += f"; its lowest box corner: failed ({short_error(error)})"
    del lib
    gc.collect()
    return results, describe


def cell(r: Result, N: int) -> str:
    if r.status != "ok":
        return r.status
    return f"{r.run_s / STEPS * 1e6:.4g} us per step, {N * STEPS / r.run_s / 1e6:.4g} M env-steps/s"


def first_cell(r: Result) -> str:
    return "-" if r.first_s is None else f"{r.first_s:.3g}"


def sanity_cell(r: Result, N: int) -> str:
    if r.z is None:
        return "-"
    z = r.z[np.isfinite(r.z)]
    heights = "no finite env" if z.size == 0 else f"z {r.z0:.4f} -> {np.median(z):.4f} m (min {z.min():.4f}, max {z.max():.4f})"
    return f"{heights}, finite {r.finite}/{N}" + (f"; {r.note}" if r.note else "")


def device_slug(device: str) -> str:
    if not device.startswith("cuda"):
        return "cpu"
    return re.sub(r"[^a-z0-9]+", "_", wp.get_device(device).name.lower()).strip("_")


def versions() -> str:
    names = ("warpdyn", "warp-lang", "mujoco", "mujoco-warp", "jax", "jaxlib", "jaxsim", "numpy")
    out = []
    for name in names:
        try:
            out.append(f"{name} {md.version(name)}")
        except md.PackageNotFoundError:  # Warp unpacked without its metadata (the GPU machine) says its version
            out.append(f"{name} {wp.config.version}" if name == "warp-lang" else f"{name} -")
    return ", ".join(out)


def report(args, scene: Scene, sizes, results: dict, described: dict, started: float) -> str:
    device = wp.get_device(scene.device)
    name = device.name if device.is_cuda else f"CPU ({platform.processor() or platform.machine()}, {os.cpu_count()} cores)"
    lines = [
        f"# warpdyn, MuJoCo Warp and JaxSim: ergoCub legs standing, {name}",
        "",
        f"device: {name} ({scene.device}); {versions()}",
        f"dtype: {scene.dtype} (MuJoCo Warp: float32 always); dt {DT * 1e3:g} ms; {STEPS} steps per timed run; "
        f"median of >= {args.repeats} timed runs (more while they add up to < 0.5 s) after a first run and a "
        "warm-up run; Warp kernel cache: "
        f"{'empty at start (--fresh-cache)' if args.fresh_cache else 'as found (compile times are lower when warm)'}; "
        f"JAX compilation cache: {scene.jax_cache} ({'empty at start' if args.fresh_cache else 'as found'}); "
        f"whole script {time.perf_counter() - started:.0f} s",
        "",
        "Scene: the ergoCub's 12 leg joints (other joints locked at 0, their links lumped), floating base, the URDF's 4 "
        f"foot boxes, flat ground at z = 0, base at z0 = {scene.z0:.5f} m (lowest corner {DEPTH * 1e3:g} mm deep), "
        "zero velocities, zero joint torques.",
        "",
    ]
    for lib in args.libraries:
        lines.append(f"- {TITLES[lib]}: {described[lib]}")
    lines += [
        "",
        "Per step: the median run divided by 100 steps; M env-steps/s = N x 100 / run / 1e6; ratios: warpdyn's "
        "env-steps/s over the other's (> 1: warpdyn faster). First run: compilation, graph capture or JIT, and the run.",
        "",
    ]
    head = ["N"]
    for lib in args.libraries:
        head += [f"{TITLES[lib]} us/step", f"{TITLES[lib]} M env-steps/s"]
    others = [lib for lib in ("mjwarp", "jaxsim") if lib in args.libraries]
    if "warpdyn" in args.libraries:
        head += [f"warpdyn / {TITLES[lib]}" for lib in others]
    head += [f"first run [s] {TITLES[lib]}" for lib in args.libraries]
    lines.append("| " + " | ".join(head) + " |")
    lines.append("| " + " | ".join(["---:"] * len(head)) + " |")
    for N in sizes:
        row = [str(N)]
        for lib in args.libraries:
            r = results[lib][N]
            if r.status == "ok":
                row += [f"{r.run_s / STEPS * 1e6:.4g}", f"{N * STEPS / r.run_s / 1e6:.4g}"]
            else:
                row += [r.status, "-"]
        if "warpdyn" in args.libraries:
            w = results["warpdyn"][N]
            for lib in others:
                o = results[lib][N]
                row.append(f"{o.run_s / w.run_s:.3g}" if w.status == "ok" and o.status == "ok" else "-")
        row += [first_cell(results[lib][N]) for lib in args.libraries]
        lines.append("| " + " | ".join(row) + " |")
    lines += ["", "Sanity after the last timed run (100 steps from the initial state): base height, finite environments.", ""]
    lines.append("| N | library | base z: t = 0 -> 100 ms (median, min, max) | finite | notes |")
    lines.append("| ---: | --- | --- | ---: | --- |")
    for N in sizes:
        for lib in args.libraries:
            r = results[lib][N]
            if r.z is None:
                lines.append(f"| {N} | {TITLES[lib]} | {r.status} | - | |")
                continue
            z = r.z[np.isfinite(r.z)]
            zs = "no finite env" if z.size == 0 else f"{r.z0:.4f} -> {np.median(z):.4f} ({z.min():.4f}, {z.max():.4f})"
            lines.append(f"| {N} | {TITLES[lib]} | {zs} | {r.finite}/{N} | {r.note} |")
    lines += [
        "",
        "Where the scenes differ:",
        "- Contact: warpdyn and JaxSim use the same soft point contacts on the 32 box corners (Hunt/Crossley "
        "K = 1e6, D = 2000, p = q = 0.5, mu = 0.5, tangential deformation state); MuJoCo Warp solves box-plane "
        "contacts (at most 4 points a box) as soft constraints (solref 0.02 1, solimp default) with its Newton solver "
        "and a pyramidal friction cone (mu = 0.5, condim 3): a different contact model, so the trajectories "
        "agree only roughly.",
        "- Joint damping 2 N m s/rad (URDF): explicit in warpdyn's and JaxSim's semi-implicit Euler, implicit in "
        "MuJoCo's Euler integrator.",
        "- Joint limits: MuJoCo adds limit constraints (none active while standing); warpdyn and JaxSim have no "
        "limit springs by default (the URDF gives none).",
        "- Precision: MuJoCo Warp runs float32 whatever --dtype says.",
        "- Per run, warpdyn and MuJoCo Warp copy the initial state into their buffers inside the timed region; "
        "JaxSim's jitted scan takes the initial state as an argument and returns a new one.",
        "",
    ]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--device", default=None, help="Warp device: cpu, cuda:0 (default: Warp's default device)")
    parser.add_argument("--sizes", default=None, help="comma-separated N (default: 1,4096,32768,131072 on CUDA, 1,16 on the CPU)")
    parser.add_argument("--dtype", default="float32", choices=("float32", "float64"))
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per size (at least 5)")
    parser.add_argument("--libraries", default=",".join(LIBRARIES), help="comma-separated subset of " + ",".join(LIBRARIES))
    parser.add_argument("--max-run-seconds", type=float, default=60.0, help="skip larger N once a run of 100 steps takes (or would take) longer")
    parser.add_argument("--fresh-cache", action="store_true", help="Warp kernels and JAX programs compile into empty caches (honest first-run times)")
    parser.add_argument("--output-dir", default=None, help="folder of compare_<device>[_float64].md (default: benchmarks/results; on the GPU machine: $OUT)")
    args = parser.parse_args()
    args.repeats = max(5, args.repeats)
    args.libraries = [lib.strip() for lib in args.libraries.split(",") if lib.strip()]
    unknown = set(args.libraries) - set(LIBRARIES)
    if unknown:
        parser.error(f"unknown libraries {sorted(unknown)}; known: {LIBRARIES}")
    started = time.perf_counter()
    wp.config.quiet = True
    wp.config.log_level = wp.LOG_WARNING
    jax_cache = os.path.join(os.path.expanduser("~"), ".cache", "warpdyn-compare-jax")
    if args.fresh_cache:
        import tempfile

        wp.config.kernel_cache_dir = tempfile.mkdtemp(prefix="warpdyn-compare-cache-")
        jax_cache = tempfile.mkdtemp(prefix="warpdyn-compare-jax-")
    wp.init()
    device = wp.get_device(args.device)
    sizes = [int(n) for n in args.sizes.split(",")] if args.sizes else ([1, 4096, 32768, 131072] if device.is_cuda else [1, 16])

    import warpdyn as wd

    legs = tuple(wd.assets.ERGOCUB_LEG_JOINTS)
    urdf = strip_urdf(wd.assets.ergocub_urdf().read_text())
    # base height from the box corners at the zero configuration, computed from the URDF with NumPy (so
    # that no library compiles anything before its first timed run); each library's own value is printed
    lowest = lowest_box_corner(urdf)
    scene = Scene(urdf, strip_urdf(urdf, keep_joints=legs), legs, -lowest - DEPTH, args.dtype, str(device), jax_cache)
    print(f"device {device.name} ({device}); N = {sizes}; dtype {args.dtype}; {versions()}", flush=True)
    print(f"scene: {count_boxes(urdf)} foot boxes, lowest corner {lowest:+.5f} m, base z0 = {scene.z0:.5f} m, dt {DT} s, {STEPS} steps per run", flush=True)

    suffix = "" if args.dtype == "float32" else f"_{args.dtype}"
    folder = pathlib.Path(args.output_dir) if args.output_dir else pathlib.Path(__file__).resolve().parent / "results"
    path = folder / f"compare_{device_slug(str(device))}{suffix}.md"
    folder.mkdir(parents=True, exist_ok=True)

    classes = {"warpdyn": Warpdyn, "mjwarp": MujocoWarp, "jaxsim": Jaxsim}
    results = {lib: {N: Result(status="not run (the script stopped before it)") for N in sizes} for lib in args.libraries}
    described = {lib: "not run" for lib in args.libraries}
    for lib in args.libraries:  # in this order, JaxSim last: JAX keeps the GPU memory it grew to
        results[lib], described[lib] = run_library(classes[lib], scene, sizes, args.repeats, args.max_run_seconds)
        path.write_text(report(args, scene, sizes, results, described, started))  # what is done so far survives a kill

    text = report(args, scene, sizes, results, described, started)
    print()
    print(text)
    path.write_text(text)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
