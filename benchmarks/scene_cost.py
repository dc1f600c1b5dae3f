"""What a free object adds to a step: MuJoCo Menagerie's Panda with a free cube beside it, against the Panda and
the cube alone.

    python benchmarks/scene_cost.py [--device cuda:0] [--sizes 1,4096,32768] [--dtypes float32,float64]
                                    [--repeats 20]

The scene is tests/models/menagerie/mjx_single_cube.xml (Menagerie's franka_emika_panda, its licence beside it):
the Panda (9 hinge and slide joints) and a cube on a free joint, two trees of one world, all three without the
fingers' equality constraint (`without`), so that every column measures the trees' step alone. The Panda alone is that
file without the cube's body, the cube alone without the Panda's; all at a time step of 2 ms (`TIME_STEP`). Each
row times one `wd.model.step` (median over repeats, after a warm-up, each call from the initial state; joint
torques 0, the arm's servos' ctrl 0) of:
- panda: the arm alone (its joints have one DoF each: the fused step, kernels/fused_step.py);
- cube: the cube alone (alone, a free body is a floating base: the fused step);
- scene: the Panda and the cube (the cube's free joint below the world: the fused step too);
- scene, staged: the scene with warpdyn.config.fused_step off (the launch list, as under a tape);
- scene, body contacts: the scene with model.geom_contacts set (its two geom pairs, the finger pads' boxes against the
  cube, collided and their soft-law wrenches added: the staged step, as a model with body contacts takes).
`scene / (panda + cube)` says whether the scene costs what its trees cost apart; `scene / panda` what a free
object costs a user of the arm. Prints the header (device, versions) and a Markdown table.
"""

from __future__ import annotations

import pathlib
import warnings
import xml.etree.ElementTree as ET

import numpy as np
import warp as wp

import warpdyn as wd
from common import header, median_time, np_dtype, side_by_side_setup

SCENE = pathlib.Path(__file__).resolve().parents[1] / "tests" / "models" / "menagerie" / "mjx_single_cube.xml"
ARM_ROOT, OBJECT = "link0", "box"
TIME_STEP = 0.002
"""[s]: the scene's 0.005 s is refused with the default soft contacts (dt K / D = 2.5: the fingers' slide joints,
whose range warpdyn does not enforce, move their collidable points without bound)."""


def without(body: str | None) -> str:
    """The scene's MJCF without the worldbody's `body` (None: none) and without its keyframes, contact pairs,
    equality constraints (the fingers' coupling, which takes the launch list: warpdyn.engine.equality) and
    tendons, and the actuators and sensors of the removed joints, as text."""
    root = ET.parse(SCENE).getroot()
    joints = set()
    if body is not None:
        world = root.find("worldbody")
        removed = world.find(f"body[@name='{body}']")
        joints = {j.get("name") for j in removed.iter("joint")} | {j.get("name") for j in removed.iter("freejoint")}
        world.remove(removed)
    for section in ("keyframe", "contact", "equality", "tendon"):
        for element in root.findall(section):
            root.remove(element)
    for section in ("actuator", "sensor"):
        for parent in root.findall(section):
            for element in list(parent):
                if element.get("joint") in joints:
                    parent.remove(element)
    return ET.tostring(root, encoding="unicode")


def load(xml: str, dtype, device) -> wd.model.Model:
    """The model of `xml` with the time step TIME_STEP."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # what the scene holds that warpdyn does not model (its warnings name it)
        model = wd.model.Model.build_from_model_description(xml, dtype=dtype, device=device)
    model.time_step = TIME_STEP
    return model


def step_time(model, N: int, device, repeats: int, fused: bool) -> float:
    """The median seconds of one `wd.model.step` of N environments, each call from the model's initial state
    (the same work at every call, whatever a long run would do)."""
    wd.config.fused_step = fused
    model.notify_model_changed()  # its plan and recorded launches built again for the setting
    data = wd.data.Data.build(model, num_envs=N)
    ctrl = {"ctrl": wp.zeros((N, model.number_of_actuators()), dtype=model.scalar, device=device)} if model.number_of_actuators() else {}
    out = {}

    def one():
        out["data"] = wd.model.step(model, data, **ctrl)

    for _ in range(3):
        one()
    seconds = median_time(one, device, repeats)
    if not bool(np.all(out["data"].valid_state.numpy() == 1)):
        raise RuntimeError(f"{model.name()}: an environment was flagged")
    return seconds


def main() -> None:
    args, device, Ns = side_by_side_setup(repeats=20)
    print(header(device))
    print()
    print("| dtype | N | panda [ms] | cube [ms] | scene [ms] | scene, staged [ms] | scene, body contacts [ms] | scene / (panda + cube) | scene / panda |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    fused_setting = wd.config.fused_step
    try:
        for dtype_name in args.dtypes.split(","):
            dtype = np_dtype[dtype_name]
            arm, cube = load(without(OBJECT), dtype, device), load(without(ARM_ROOT), dtype, device)
            scene = load(without(None), dtype, device)
            touching = load(without(None), dtype, device)
            touching.geom_contacts = True
            for N in Ns:
                t_arm = step_time(arm, N, device, args.repeats, True)
                t_cube = step_time(cube, N, device, args.repeats, True)
                t_scene = step_time(scene, N, device, args.repeats, True)
                t_staged = step_time(scene, N, device, args.repeats, False)
                t_touching = step_time(touching, N, device, args.repeats, True)
                ms = [1e3 * t for t in (t_arm, t_cube, t_scene, t_staged, t_touching)]
                print(f"| {dtype_name} | {N} | " + " | ".join(f"{t:.4f}" for t in ms) + f" | {t_scene / (t_arm + t_cube):.2f} | {t_scene / t_arm:.2f} |", flush=True)
    finally:
        wd.config.fused_step = fused_setting


if __name__ == "__main__":
    main()
