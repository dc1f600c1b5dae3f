"""Latency from Python: one call of each entry point a script or a controller makes, against MuJoCo's C calls.

    python benchmarks/latency.py [--device cpu | cuda:0] [--dtype float64] [--repeats 2000] [--batched 1024]

Robot: the seed's ergoCub legs (12 joints, 13 links, 32 collidable points), standing with the feet 3 mm deep,
dt = 1 ms, zero torques. Each row is the median wall time of one call after a warm-up (compilation, graph
capture), the device synchronised around it:
- `wd.model.step`: the functional step (new Data whose arrays the caller owns: from the output pool,
  replayed from a graph, warpdyn.engine.fast_step), one environment: from the same data at every call, with
  the torques as a Warp or a NumPy array, and in the loop `data = step(model, data, ...)`;
- `Stepper.step`: `wd.simulation.Stepper`, in place, one call = one step (a replayed graph);
- `Stepper.step`, batched: N = --batched environments, reported per env-step;
- `Rollout.run`: a 1000-step rollout (ping-pong, graph), per step;
- `forward_dynamics_aba` (with Warp joint forces, and without), `free_floating_mass_matrix`,
  `free_floating_bias_forces`: one call each, one environment;
- MuJoCo (CPU only): `mj_step` and `mj_forward` on the same legs compiled from the URDF (fused fixed joints,
  a free joint, no contacts: its collision geoms are dropped, so it is a lower bound of MuJoCo's cost).
Prints the header and a Markdown table (µs).
"""

from __future__ import annotations

import argparse
import threading

import numpy as np
import warp as wp

import warpdyn as wd
from common import header, median_time, np_dtype, seed_model


def standing(model, N=None):
    zero = wd.data.Data.build(model)
    lowest = float(wd.contact.collidable_point_positions(model, zero).numpy()[:, 2].min())
    kwargs = dict(base_position=(0.0, 0.0, -lowest - 0.003))
    return wd.data.Data.build(model, num_envs=N, **kwargs)


def mujoco_rows(model, repeats: int) -> list:
    try:
        import mujoco
    except ImportError:
        return [("MuJoCo `mj_step`", "not installed"), ("MuJoCo `mj_forward`", "not installed")]
    import xml.etree.ElementTree as ET

    root = ET.parse(str(wd.assets.ergocub_urdf())).getroot()
    for link in root.findall("link"):
        for tag in ("visual", "collision"):
            for element in link.findall(tag):
                link.remove(element)
    kept = set(model.joint_names())
    for joint in root.findall("joint"):
        if joint.get("type") != "fixed" and joint.get("name") not in kept:
            joint.set("type", "fixed")
    spec = mujoco.MjSpec.from_string(ET.tostring(root, encoding="unicode"))
    spec.worldbody.first_body().add_freejoint()
    m = spec.compile()
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    rows = []
    for label, fn in (("MuJoCo `mj_step` (no contacts)", lambda: mujoco.mj_step(m, d)), ("MuJoCo `mj_forward`", lambda: mujoco.mj_forward(m, d))):
        rows.append((label, f"{median_time(fn, 'cpu', repeats, 0.5) * 1e6:.3g}"))
    return rows


def row_with_another_thread(row, dtype: str, device, tau_host) -> None:
    """The loop above on a new model while another thread that has worked through warpdyn is alive (idle):
    graphs are not captured then (docs/simulation.md, "Threads"), the launches are replayed as recorded."""
    model = seed_model(np_dtype[dtype], device)
    started, done = threading.Event(), threading.Event()

    def idle():
        wd.model.forward_kinematics(model, standing(model))
        started.set()
        done.wait()

    other = threading.Thread(target=idle)
    other.start()
    started.wait()
    state = [standing(model)]

    def loop():
        state[0] = wd.model.step(model, state[0], joint_force_references=tau_host)

    try:
        row("`data = wd.model.step(model, data, ...)`, NumPy torques, another warpdyn thread alive (no graphs)", loop)
    finally:
        done.set()
        other.join()


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--dtype", default="float64")
    parser.add_argument("--repeats", type=int, default=2000)
    parser.add_argument("--batched", type=int, default=1024)
    args = parser.parse_args()
    wp.config.quiet = True
    wp.init()
    device = wp.get_device(args.device)
    model = seed_model(np_dtype[args.dtype], device)
    n = model.dofs()
    data = standing(model)
    tau = wp.zeros(n, dtype=model.scalar, device=device)
    print(header(device))
    print(f"\nergoCub legs standing, {args.dtype}, dt 1 ms; median of >= {args.repeats} calls\n")
    print("| call | µs |")
    print("| --- | ---: |", flush=True)

    def row(label, fn, per=1):
        fn()
        print(f"| {label} | {median_time(fn, device, args.repeats, 0.5) / per * 1e6:.3g} |", flush=True)

    row("`wd.model.step`, one environment, Warp torques", lambda: wd.model.step(model, data, joint_force_references=tau))
    tau_host = np.zeros(n)
    row("`wd.model.step`, one environment, NumPy torques", lambda: wd.model.step(model, data, joint_force_references=tau_host))
    state = [data]

    def loop():
        state[0] = wd.model.step(model, state[0], joint_force_references=tau_host)

    row("`data = wd.model.step(model, data, ...)`, one environment, NumPy torques", loop)
    row_with_another_thread(row, args.dtype, device, tau_host)
    stepper = wd.simulation.Stepper(model, data)
    row("`Stepper.step`, one environment", stepper.step)
    batched = wd.simulation.Stepper(model, standing(model, args.batched))
    row(f"`Stepper.step`, N = {args.batched}, per env-step", batched.step, per=args.batched)
    T = 1000
    roll = wd.simulation.Rollout(model, steps=T, record=())
    row(f"`Rollout.run` of {T} steps, one environment, per step", lambda: roll.run(data), per=T)
    row("`forward_dynamics_aba`, one environment", lambda: wd.model.forward_dynamics_aba(model, data, joint_forces=tau))
    row("`forward_dynamics_aba`, one environment, no forces", lambda: wd.model.forward_dynamics_aba(model, data))
    row("`free_floating_mass_matrix`, one environment", lambda: wd.model.free_floating_mass_matrix(model, data))
    row("`free_floating_bias_forces`, one environment", lambda: wd.model.free_floating_bias_forces(model, data))
    if not device.is_cuda:
        for label, value in mujoco_rows(model, args.repeats):
            print(f"| {label} | {value} |")


if __name__ == "__main__":
    main()
