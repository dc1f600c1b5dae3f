"""Objects that touch each other: boxes stacked on a table, a ball and a capsule beside them, in many environments at
once, with contacts between bodies (`model.geom_contacts`), against MuJoCo.

    python examples/body_contacts.py                                   # 64 environments on the CPU, 4096 on a GPU
    python examples/body_contacts.py --num-envs 1 --dtype float64      # one environment, double precision
    python examples/body_contacts.py --contact-model rigid --dtype float64 --num-envs 16   # JaxSim's rigid law

The scene is the MJCF string SCENE: a table of the world body (its top and legs are geoms that do not move), three
boxes stacked on its top, turned about the vertical, a ball and a capsule lying on it. Each environment but the first
starts with every object moved by up to 1 cm and turned by up to 10 degrees about the vertical (the first starts as
the file places them). One `wd.simulation.Rollout` of `--seconds` (1 ms steps, semi-implicit Euler, the contact law on
the objects' contacts with each other and with the table, the terrain under the table) runs every environment; then
the example prints each object's resting height (the first environment's beside MuJoCo's for the same file, and the
spread over the others) and the simulation's rate. `--contact-model` picks JaxSim's law: soft (the default: a law at
each contact, the fastest), relaxed (relaxed-rigid) or rigid, whose forces an environment's contacts solve together
(dense float64 linear algebra per environment: slower, and the rigid law warns in float32).

`run(...)` returns what it prints; tests/test_examples.py runs it small.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np
import warp as wp

import warpdyn as wd

SCENE = """<mujoco model="table_and_objects"><option timestep="0.001"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <geom name="top" type="box" size="0.4 0.3 0.02" pos="0 0 0.5"/>
    <geom name="leg1" type="box" size="0.02 0.02 0.24" pos="0.35 0.25 0.24"/>
    <geom name="leg2" type="box" size="0.02 0.02 0.24" pos="-0.35 0.25 0.24"/>
    <geom name="leg3" type="box" size="0.02 0.02 0.24" pos="0.35 -0.25 0.24"/>
    <geom name="leg4" type="box" size="0.02 0.02 0.24" pos="-0.35 -0.25 0.24"/>
    <body name="bottom" pos="-0.1 0 0.5705"><freejoint/><geom type="box" size="0.05 0.05 0.05" mass="1"/></body>
    <body name="middle" pos="-0.095 0.004 0.6659" euler="0 0 20"><freejoint/><geom type="box" size="0.04 0.04 0.045" mass="0.8"/></body>
    <body name="top_box" pos="-0.1 -0.005 0.7456" euler="0 0 -30"><freejoint/><geom type="box" size="0.035 0.03 0.035" mass="0.5"/></body>
    <body name="ball" pos="0.15 0.1 0.5705"><freejoint/><geom type="sphere" size="0.05" mass="0.4"/></body>
    <body name="capsule" pos="0.12 -0.12 0.5505" euler="0 90 30"><freejoint/><geom type="capsule" size="0.03 0.08" mass="0.5"/></body>
  </worldbody>
</mujoco>"""
OBJECTS = ("bottom", "middle", "top_box", "ball", "capsule")
CONTACT_MODELS = {"soft": "SoftContacts", "relaxed": "RelaxedRigidContacts", "rigid": "RigidContacts"}  # --contact-model


def build(dtype=np.float32, device=None, contact_model: str = "soft") -> wd.model.Model:
    """SCENE's model, its body contacts on, under JaxSim's `contact_model` (CONTACT_MODELS' keys) with its defaults."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)  # it names the body contacts, off until set here
        model = wd.model.Model.build_from_model_description(SCENE, dtype=dtype, device=device)
    model.geom_contacts = True
    kind = CONTACT_MODELS[contact_model]
    model.contact_model = getattr(wd.rbda.contacts, kind)()
    model.contact_params = getattr(wd.rbda.contacts, kind + "Params")()
    return model


def initial_positions(model, num_envs: int, seed: int) -> np.ndarray:
    """(N, nq): the file's placement in environment 0; in the others each object moved by up to 1 cm horizontally
    and turned by up to 10 degrees about the vertical."""
    q0 = np.asarray(wd.data.Data.build(model).joint_positions.numpy(), dtype=np.float64)
    q = np.tile(q0, (num_envs, 1))
    rng = np.random.default_rng(seed)
    for name in OBJECTS:
        start = wd.joint.position_slice(model, joint_index=model.link_names().index(name) - 1).start  # link i is moved by joint i - 1
        shift = rng.uniform(-0.01, 0.01, (num_envs, 2))
        yaw = np.radians(rng.uniform(-10.0, 10.0, num_envs))
        shift[0], yaw[0] = 0.0, 0.0
        q[:, start : start + 2] += shift
        turn = np.stack([np.cos(yaw / 2), np.zeros(num_envs), np.zeros(num_envs), np.sin(yaw / 2)], axis=1)  # wxyz about z
        w0, v0 = q[:, start + 3 : start + 4].copy(), q[:, start + 4 : start + 7].copy()
        w1, v1 = turn[:, :1], turn[:, 1:]
        q[:, start + 3 : start + 4] = w1 * w0 - np.sum(v1 * v0, axis=1, keepdims=True)
        q[:, start + 4 : start + 7] = w1 * v0 + w0 * v1 + np.cross(v1, v0)
    return q


def mujoco_rest(seconds: float) -> dict:
    """{object: (3,) world position} after `seconds` of MuJoCo's own simulation of SCENE."""
    import mujoco

    m = mujoco.MjModel.from_xml_string(SCENE)
    d = mujoco.MjData(m)
    for _ in range(int(round(seconds / m.opt.timestep))):
        mujoco.mj_step(m, d)
    return {name: np.array(d.xpos[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)]) for name in OBJECTS}


def run(num_envs: int, dtype=np.float32, device=None, seconds: float = 1.5, seed: int = 0, contact_model: str = "soft") -> dict:
    """{"positions": {object: (N, 3)}, "healthy": (N,) bool, "seconds": the rollout's wall time (compiled kernels),
    "steps": its steps}."""
    model = build(dtype, device, contact_model)
    data = wd.data.Data.build(model, num_envs=num_envs, joint_positions=initial_positions(model, num_envs, seed))
    steps = int(round(seconds / model.time_step))
    rollout = wd.simulation.Rollout(model, steps=steps, record=())
    rollout.run(data)  # compiles the kernels and captures the graph
    wp.synchronize_device(model.device)
    started = time.perf_counter()
    final, _ = rollout.run(data)
    wp.synchronize_device(model.device)
    wall = time.perf_counter() - started
    W_H_L = wd.model.forward_kinematics(model, final).numpy()
    links = model.link_names()
    positions = {name: W_H_L[:, links.index(name), :3, 3] for name in OBJECTS}
    return {"positions": positions, "healthy": final.healthy.numpy().astype(bool), "seconds": wall, "steps": steps}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--num-envs", type=int, default=None, help="default: 4096 on a GPU, 64 on the CPU")
    parser.add_argument("--dtype", choices=("float32", "float64"), default="float32")
    parser.add_argument("--device", default=None, help="Warp device (default: a GPU if there is one)")
    parser.add_argument("--seconds", type=float, default=1.5)
    parser.add_argument("--contact-model", choices=tuple(CONTACT_MODELS), default="soft", help="JaxSim's contact law (default soft)")
    args = parser.parse_args()
    wp.config.quiet = True
    device = wp.get_device(args.device)
    N = args.num_envs or (4096 if device.is_cuda else 64)
    result = run(N, {"float32": np.float32, "float64": np.float64}[args.dtype], device, args.seconds, contact_model=args.contact_model)
    theirs = mujoco_rest(args.seconds)
    print(f"{N} environments on {device.name}, {args.dtype}, {args.contact_model} contacts, {args.seconds:g} s of 1 ms steps: "
          f"{int(result['healthy'].sum())} healthy, {result['seconds']:.2f} s, "
          f"{N * result['steps'] / result['seconds'] / 1e6:.2f} M env-steps/s")  # fmt: skip
    print("| object | resting height, environment 0 [m] | MuJoCo [m] | heights over the environments [m] |")
    print("| --- | ---: | ---: | --- |")
    for name in OBJECTS:
        z = result["positions"][name][:, 2]
        print(f"| {name} | {z[0]:.4f} | {theirs[name][2]:.4f} | {z.min():.4f} .. {z.max():.4f} |")


if __name__ == "__main__":
    main()
