"""warpdyn against MuJoCo Warp on a manipulation scene (issue 37 item 5): the shipped PandaPickCube scene
(`wd.assets.franka_panda_cube_mjcf()`, MuJoCo Playground's), the same file for both, in one process, on one device.

    python benchmarks/manipulation_compare.py [--device cpu | cuda:0] [--sizes 1,16] [--repeats 3]
                                              [--libraries warpdyn,mjwarp] [--dtype float32] [--output-dir DIR]

What runs, N environments (worlds) at once, each from the keyframe "pickup1" (the fingers around the cube): 2 s
of the scripted grasp of tests/test_panda.py (the gripper closes over 0.3 s, the arm lifts the cube from 0.5 s to
1 s, then holds), its 8 controls changed every 100 steps (20 segments of 100 steps of 1 ms, the file's time step).
- warpdyn: a `wd.simulation.Stepper` of 100 substeps, the pads' contacts acting (model.geom_contacts) with the soft
  law explicit at the file's 1 ms (K = 5e5, D = 500, PickCubeConfig's mu = 1: PickCubeEnv's law until it moved to 2 ms,
  implicit, D = 2000), the file's integrator; a run copies the initial state
  in, then per segment copies that segment's controls into the Stepper's and steps. On a GPU the whole run is one
  captured Warp graph; on the CPU the Stepper replays its own graph per segment.
- MuJoCo Warp: `mujoco_warp.put_model` of MuJoCo's compile of the same file (its implicitfast integrator, Newton
  solver, MuJoCo's soft contacts: box-box between the pads and the cube, box-plane and capsule-plane with the
  floor), the same controls and segments; a run is one captured graph on a GPU, eager on the CPU. float32 only.
Each run is timed with the device synchronised before and after; the first run (compilation, capture) apart, then
one warm-up and the median of --repeats runs. env-steps/s = N x 2000 / run. Sanity (printed, not asserted): the
environments whose cube ends above 0.3 m (held in the grip) and stayed finite, and the cube's mean height.

Locally (2 cores): python benchmarks/manipulation_compare.py --device cpu     (MuJoCo Warp compiles for minutes)
On a GPU (pip install mujoco-warp==4.0.0): python benchmarks/manipulation_compare.py --device cuda:0 --sizes 1,4096,32768
"""

from __future__ import annotations

import argparse
import pathlib
import statistics
import sys
import time
import warnings

import numpy as np
import warp as wp

import warpdyn as wd
from warpdyn.envs import PickCubeConfig

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "tests"))
from test_panda import _grasp_controls  # noqa: E402  (the scripted grasp the tests hold beside MuJoCo)

SEGMENTS, SEGMENT_STEPS = 20, 100  # 2 s of 1 ms steps, the controls changed every 0.1 s
KEYFRAME = "pickup1"


def schedule(ctrl0: np.ndarray) -> np.ndarray:
    """(SEGMENTS, 8): the scripted grasp's controls at each segment's start."""
    return np.array([_grasp_controls(ctrl0, k * SEGMENT_STEPS * 1e-3) for k in range(SEGMENTS)])


def timed(run, device, repeats: int) -> tuple[float, float]:
    """(first run [s], median of `repeats` runs after a warm-up [s])."""
    wp.synchronize_device(device)
    start = time.perf_counter()
    run()
    wp.synchronize_device(device)
    first = time.perf_counter() - start
    run()
    times = []
    for _ in range(repeats):
        wp.synchronize_device(device)
        start = time.perf_counter()
        run()
        wp.synchronize_device(device)
        times.append(time.perf_counter() - start)
    return first, statistics.median(times)


def captured(steps, warm_up, device):
    """A run of `steps()`: on a GPU one Warp graph, captured at the first call after `warm_up()` (compilation,
    recording) and replayed at each; eager on the CPU."""
    graph = {}

    def run():
        if not device.is_cuda:
            steps()
            return
        if not graph:
            warm_up()
            with wp.ScopedCapture(device=device) as capture:
                steps()
            graph["g"] = capture.graph
        wp.capture_launch(graph["g"])

    return run


CONTACT_K, CONTACT_D = 5e5, 500.0
"""warpdyn's soft law here [N/m^1.5, N s/m^1.5]: explicit at 1 ms, D = 500 keeps the squeezed cube within the
explicit damper's stable rate (the figures in benchmarks/RESULTS.md were measured with these)."""


def run_warpdyn(N: int, device, dtype, repeats: int) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        model = wd.model.Model.build_from_model_description(wd.assets.franka_panda_cube_mjcf(), dtype=dtype, device=device)
    model.geom_contacts = True
    model.contact_params = wd.model.SoftContactsParams(K=CONTACT_K, D=CONTACT_D, mu=PickCubeConfig().friction)
    start = wd.data.keyframe(model, KEYFRAME, num_envs=N)
    key = next(k for k in model.description.keyframes if k.name == KEYFRAME)
    controls = [wp.array(np.tile(c, (N, 1)), dtype=model.scalar, device=device) for c in schedule(np.asarray(key.ctrl, dtype=np.float64))]
    stepper = wd.simulation.Stepper(model, start, substeps=SEGMENT_STEPS, use_graph=not device.is_cuda)

    def steps():
        stepper.set_state(start)
        for c in controls:
            wp.copy(stepper.ctrl, c)
            stepper.step()

    first, run_s = timed(captured(steps, steps, device), device, repeats)  # the launches recorded once, eagerly
    cube = model.link_names().index("box")
    z = wd.model.forward_kinematics(model, stepper.data).numpy().reshape(N, -1, 4, 4)[:, cube, 2, 3]
    healthy = stepper.data.healthy.numpy().astype(bool)
    return dict(first=first, run=run_s, z=z, ok=healthy & np.isfinite(z))


def run_mjwarp(N: int, device, repeats: int) -> dict:
    import mujoco
    import mujoco_warp as mjw

    mjm = mujoco.MjModel.from_xml_path(str(wd.assets.franka_panda_cube_mjcf()))
    mjd = mujoco.MjData(mjm)
    key = mujoco.mj_name2id(mjm, mujoco.mjtObj.mjOBJ_KEY, KEYFRAME)
    mujoco.mj_resetDataKeyframe(mjm, mjd, key)
    mujoco.mj_forward(mjm, mjd)
    with wp.ScopedDevice(device):
        m = mjw.put_model(mjm)
        d = mjw.put_data(mjm, mjd, nworld=N, nconmax=32, njmax=160)
        state0 = {name: wp.clone(getattr(d, name)) for name in ("qpos", "qvel", "qacc_warmstart", "time", "act")}
        controls = [wp.array(np.tile(c, (N, 1)), dtype=wp.float32) for c in schedule(mjm.key_ctrl[key].copy())]

        def steps():
            for name, value in state0.items():
                wp.copy(getattr(d, name), value)
            for c in controls:
                wp.copy(d.ctrl, c)
                for _ in range(SEGMENT_STEPS):
                    mjw.step(m, d)

        first, run_s = timed(captured(steps, lambda: mjw.step(m, d), device), device, repeats)  # compile, then capture
        z = d.xpos.numpy()[:, mjm.body("box").id, 2].astype(np.float64)
        ok = np.isfinite(d.qpos.numpy()).all(axis=1)
    return dict(first=first, run=run_s, z=z, ok=ok)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--device", default=None, help="Warp device (default: Warp's default)")
    parser.add_argument("--sizes", default=None, help="comma-separated N (default: 1,4096,32768 on CUDA, 1,16 on the CPU)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--libraries", default="warpdyn,mjwarp")
    parser.add_argument("--dtype", default="float32", choices=("float32", "float64"), help="warpdyn's (MuJoCo Warp: float32)")
    parser.add_argument("--output-dir", default=None, help="write manipulation_compare_<device>.md there too")
    args = parser.parse_args()
    wp.config.quiet = True
    device = wp.get_device(args.device)
    sizes = [int(s) for s in (args.sizes or ("1,4096,32768" if device.is_cuda else "1,16")).split(",")]
    dtype = {"float32": np.float32, "float64": np.float64}[args.dtype]
    lines = [
        f"# PandaPickCube: warpdyn {wd.__version__} against MuJoCo Warp, {device.name} ({device})",
        "",
        f"`python benchmarks/manipulation_compare.py --device {device} --sizes {','.join(map(str, sizes))}`: 2 s (2000 steps of 1 ms) of the "
        f"scripted grasp from '{KEYFRAME}', median of {args.repeats} runs; warpdyn in {args.dtype}, MuJoCo Warp in float32.",
        "",
        "| library | N | first run [s] | run [s] | env-steps/s | cube held (z > 0.3 m) | mean cube z [m] |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    print("\n".join(lines), flush=True)
    path = pathlib.Path(args.output_dir) / f"manipulation_compare_{device.alias.replace(':', '')}.md" if args.output_dir else None
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
    for library in args.libraries.split(","):
        for N in sizes:
            try:
                r = run_warpdyn(N, device, dtype, args.repeats) if library == "warpdyn" else run_mjwarp(N, device, args.repeats)
            except Exception as error:  # a library that fails shows why; the others still run
                line = f"| {library} | {N} | {type(error).__name__}: {str(error)[:120]} | | | | |"
            else:
                held = int((r["ok"] & (r["z"] > 0.3)).sum())
                line = (f"| {library} | {N} | {r['first']:.2f} | {r['run']:.4f} | {N * SEGMENTS * SEGMENT_STEPS / r['run']:.3g} | "
                        f"{held} of {N} | {float(np.mean(r['z'][r['ok']])) if r['ok'].any() else float('nan'):.4f} |")  # fmt: skip
            lines.append(line)
            print(line, flush=True)
            if path is not None:  # rewritten after each row: a run stopped by a time limit keeps the rows it measured
                path.write_text("\n".join(lines) + "\n")
    if path is not None:
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
