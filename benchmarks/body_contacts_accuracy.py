"""Speed against accuracy of contacts between bodies (issue 37: the speed/accuracy table's stacking and grasping
cases), for each contact law (`--laws`: JaxSim's soft law, relaxed-rigid and rigid laws, each with its defaults), time
step, dtype and, for the soft law, treatment of the contacts (explicit, or linearly implicit: model.implicit_contacts)
(model.geom_contacts, semi-implicit Euler):

- stacking: tests/test_body_contacts.py's stack of three boxes dropped a few millimetres, 1.5 s: whether it stays
  healthy, the largest distance of a box's resting position from the float64 reference at dt = 1/16 ms and from
  MuJoCo's (its defaults, 1 ms), and the throughput of N environments of it (steps x environments per second,
  median of the repeats);
- grasping: tests/test_body_contacts.py's pinch (two box fingers squeeze a 0.1 kg cube and a carrier lifts them
  15 cm): whether it stays healthy (a flag is the explicit damper's stability check; implicit contacts have none), the cube's height after the
  lift, and its slip down the fingers [mm/s] (the contacts' tangential deformation holds it; MuJoCo's soft
  constraints slip: its figure is printed beside).

    python benchmarks/body_contacts_accuracy.py --device cpu --num-envs 256 > benchmarks/results/body_contacts_accuracy_cpu.md

Each law's stack is measured against its own float64 reference at 1/16 ms.
"""

from __future__ import annotations

import argparse
import pathlib
import sys
import time
import warnings

import mujoco
import numpy as np
import warp as wp

import warpdyn as wd

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "tests"))
from test_body_contacts import PINCH, SCENES  # noqa: E402  (the scenes the tests hold against MuJoCo)

STACK = SCENES["a stack of boxes"]
BOXES = ("bottom", "middle", "top")
LIFT_BEGINS, LIFT_SPEED, LIFT_TOP = 0.5, 0.3, 0.15  # s, m/s, m: the pinch's carrier
SQUEEZE = 0.04  # m: the fingers' target, past the cube's faces
LAWS = {"soft": "SoftContacts", "relaxed": "RelaxedRigidContacts", "rigid": "RigidContacts"}  # --laws: the contact models


def build(xml: str, dt: float, dtype, device, implicit: bool, law: str = "soft") -> wd.model.Model:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        model = wd.model.Model.build_from_model_description(xml.replace('timestep="0.001"', f'timestep="{dt!r}"'), dtype=dtype, device=device)
    model.geom_contacts = True
    model.implicit_contacts = implicit
    if law != "soft":
        model.contact_model = getattr(wd.rbda.contacts, LAWS[law])()
        model.contact_params = getattr(wd.rbda.contacts, LAWS[law] + "Params")()
    return model


def stack_rest(dt: float, dtype, device, implicit: bool, law: str = "soft") -> tuple[np.ndarray, bool]:
    """The boxes' positions (3, 3) after 1.5 s, and whether the environment stayed healthy."""
    model = build(STACK, dt, dtype, device, implicit, law)
    data = wd.data.Data.build(model)
    for _ in range(int(round(1.5 / dt))):
        data = wd.model.step(model, data)
    H = wd.model.forward_kinematics(model, data).numpy()
    return np.array([H[model.link_names().index(name), :3, 3] for name in BOXES]), bool(data.healthy.numpy().all())


def mujoco_stack() -> np.ndarray:
    m = mujoco.MjModel.from_xml_string(STACK)
    d = mujoco.MjData(m)
    for _ in range(1500):
        mujoco.mj_step(m, d)
    return np.array([d.xpos[m.body(name).id] for name in BOXES])


def pinch_controls(t: float) -> np.ndarray:
    lift = 0.0 if t < LIFT_BEGINS else min(LIFT_TOP, LIFT_SPEED * (t - LIFT_BEGINS))
    squeeze = SQUEEZE if t > 0.2 else 0.0
    return np.array([lift, squeeze, squeeze])


def pinch(dt: float, dtype, device, implicit: bool, law: str = "soft") -> tuple[float, float, bool]:
    """(the cube's height [m] 1.6 s in, its slip down the fingers from 1.1 s to 1.6 s [m/s], healthy)."""
    model = build(PINCH, dt, dtype, device, implicit, law)
    data = wd.data.Data.build(model)
    cube, finger = model.link_names().index("cube"), model.link_names().index("left")
    gaps = {}
    for k in range(int(round(1.6 / dt))):
        data = wd.model.step(model, data, ctrl=pinch_controls(k * dt))
        if k in (int(round(1.1 / dt)), int(round(1.6 / dt)) - 1):
            H = wd.model.forward_kinematics(model, data).numpy()
            gaps[k] = (H[finger, 2, 3] - H[cube, 2, 3], H[cube, 2, 3])
    (k0, (g0, _)), (k1, (g1, z1)) = sorted(gaps.items())
    return z1, (g1 - g0) / ((k1 - k0) * dt), bool(data.healthy.numpy().all())


def mujoco_pinch() -> tuple[float, float]:
    m = mujoco.MjModel.from_xml_string(PINCH)
    d = mujoco.MjData(m)
    dt, cube, finger = m.opt.timestep, m.body("cube").id, m.body("left").id
    gaps = {}
    for k in range(1600):
        d.ctrl[:] = pinch_controls(k * dt)
        mujoco.mj_step(m, d)
        if k in (1100, 1599):
            gaps[k] = (d.xpos[finger, 2] - d.xpos[cube, 2], d.xpos[cube, 2])
    return gaps[1599][1], (gaps[1599][0] - gaps[1100][0]) / (499 * dt)


def throughput(dt: float, dtype, device, implicit: bool, N: int, steps: int, repeats: int, law: str = "soft") -> float:
    """Environment-steps per second of N copies of the stack (median of `repeats` rollouts of `steps`)."""
    model = build(STACK, dt, dtype, device, implicit, law)
    data = wd.data.Data.build(model, num_envs=N)
    wd.simulation.rollout(model, data, steps=steps)  # compile and warm up
    times = []
    for _ in range(repeats):
        wp.synchronize_device(device)
        start = time.perf_counter()
        wd.simulation.rollout(model, data, steps=steps)
        wp.synchronize_device(device)
        times.append(time.perf_counter() - start)
    return N * steps / float(np.median(times))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--device", default=None, help="Warp device (default: Warp's)")
    parser.add_argument("--num-envs", type=int, default=256, help="environments of the throughput column (default 256)")
    parser.add_argument("--steps", type=int, default=200, help="steps of each timed rollout (default 200)")
    parser.add_argument("--repeats", type=int, default=5, help="timed rollouts, median (default 5)")
    parser.add_argument("--time-steps", default="0.002,0.001,0.0005,0.00025", help="dt [s], comma-separated")
    parser.add_argument("--contacts", default="explicit,implicit", help="the soft law's: explicit, implicit (model.implicit_contacts), comma-separated")
    parser.add_argument("--laws", default="soft", help="soft, relaxed, rigid (JaxSim's contact models), comma-separated (default soft)")
    parser.add_argument("--throughput-only", action="store_true",
                        help="print only the stack's throughput per dtype and dt (to compare versions: PYTHONPATH=<a checkout's package>)")
    args = parser.parse_args()
    treatments = [{"explicit": False, "implicit": True}[name] for name in args.contacts.split(",")]
    laws = args.laws.split(",")
    unknown = sorted(set(laws) - set(LAWS))
    if unknown:
        parser.error(f"--laws takes {', '.join(LAWS)}; got {', '.join(unknown)}")

    def cases():  # (law, implicit): the solved laws have no implicit treatment
        return [(law, implicit) for law in laws for implicit in (treatments if law == "soft" else [False])]

    wp.config.quiet = True
    device = wp.get_device(args.device)
    if args.throughput_only:
        print(f"warpdyn from {pathlib.Path(wd.__file__).parent}; device {device}; N = {args.num_envs}, {args.steps} steps, median of {args.repeats}")
        for dtype in (np.float32, np.float64):
            for dt in (float(v) for v in args.time_steps.split(",")):
                for law, implicit in cases():
                    rate = throughput(dt, dtype, device, implicit, args.num_envs, args.steps, args.repeats, law)
                    print(f"| {law} | {np.dtype(dtype).name} | {1e3 * dt:g} | {'implicit' if implicit else 'explicit'} | {rate:.4g} |", flush=True)
        return
    references = {law: stack_rest(1.0 / 16000.0, np.float64, device, False, law)[0] for law in laws}
    theirs = mujoco_stack()
    z_mj, slip_mj = mujoco_pinch()
    print(f"device: {device.name} ({device}); warp {wp.config.version}, mujoco {mujoco.__version__}; the stack's reference: float64 at 1/16 ms;"
          f" MuJoCo's stack and pinch at 1 ms (its defaults); throughput: N = {args.num_envs}, {args.steps} steps, median of {args.repeats}\n")
    print("| law | dtype | dt [ms] | contacts | stack healthy | stack: from the reference [mm] | stack: from MuJoCo [mm] "
          "| stack throughput [env-steps/s] | pinch healthy | pinch: cube height [m] | pinch: slip [mm/s] |")
    print("| --- | --- | ---: | --- | --- | ---: | ---: | ---: | --- | ---: | ---: |")
    for dtype in (np.float32, np.float64):
        for dt in (float(v) for v in args.time_steps.split(",")):
            for law, implicit in cases():
                rest, healthy = stack_rest(dt, dtype, device, implicit, law)
                far_ref = 1e3 * np.linalg.norm(rest - references[law], axis=1).max()
                far_mj = 1e3 * np.linalg.norm(rest - theirs, axis=1).max()
                rate = throughput(dt, dtype, device, implicit, args.num_envs, args.steps, args.repeats, law)
                z, slip, held = pinch(dt, dtype, device, implicit, law)
                stack = f"yes | {far_ref:.3f} | {far_mj:.3f}" if healthy else "flagged | - | -"  # a flagged environment is frozen
                grasp = f"yes | {z:.4f} | {1e3 * slip:.3g}" if held else "flagged | - | -"
                row = f"| {law} | {np.dtype(dtype).name} | {1e3 * dt:g} | {'implicit' if implicit else 'explicit'} | {stack} | {rate:.3g} | {grasp} |"
                print(row, flush=True)
    print(f"\nMuJoCo's pinch: the cube at {z_mj:.4f} m, slipping {1e3 * slip_mj:.2f} mm/s.")


if __name__ == "__main__":
    main()
