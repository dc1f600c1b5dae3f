"""A robot's legs dropped onto the terrain, recorded with rerun: link frames, collision shapes, collidable
points coloured by penetration, contact forces as arrows, the terrain; written to an .rrd file.

    pip install -e ".[viz]"                                 # rerun-sdk
    python examples/visualize_drop.py                       # the seed's ergoCub legs onto flat ground -> drop.rrd
    python examples/visualize_drop.py --terrain plane --slope 5     # onto a plane inclined by 5 degrees
    python examples/visualize_drop.py --terrain heightfield         # onto gentle bumps
    python examples/visualize_drop.py --robot icub out/icub.rrd     # the iCub (icub-models: its meshes resolve)
    python examples/visualize_drop.py path/to/robot.urdf            # any URDF or MJCF
    rerun drop.rrd                                          # open it

The robot: the description's hip, knee and ankle joints (the others locked at 0), its z axis along the
terrain's normal under the origin (upright on flat ground, tilted with an inclined plane), its lowest
collidable point `--height` above the terrain, at rest. Joint PD holds the initial posture
s0 = 0: tau = -Kp (s - s0) - Kd sdot, made of the model's joint parameters, so the whole second runs as
one captured rollout without a control loop on the host: both position limits at s0 with a limit spring
Kp (the spring acts on s - s0 on either side) and viscous joint friction Kd. JaxSim's soft contacts
(K = 1e6, D = 2000, mu = 0.5), 1 ms steps (semi-implicit Euler). The rollout records the base pose,
the joint positions and the points' forces on the device; `wd.visualization.record_rollout` then logs
every `--every`-th state (FK for all of them in one batch).

The seed's ergoCub URDF comes without its mesh files: its feet's boxes, the link frames and the skeleton are
drawn (a warning lists the meshes not found); the iCub's meshes come with icub-models and are drawn.
Measured (float32, CPU): the ergoCub from 2 cm lands, rocks by up to 3 degrees and stands; on the 5 degree
plane up to 8 degrees; from 5 cm it bounces and rocks by 9 degrees. The iCub stands on flat ground and tips
over on the plane (there is no balance controller). Runs on the CPU in a few seconds (plus Warp's one-time kernel compilation).
"""

from __future__ import annotations

import argparse
import pathlib
import time

import numpy as np
import warp as wp

import warpdyn as wd
import warpdyn.visualization  # noqa: F401  (wd.visualization; rerun itself is imported when recording)

ERGOCUB = wd.assets.ergocub_urdf()
LEG_PARTS = ("hip", "knee", "ankle")


def description_path(robot: str) -> pathlib.Path:
    if robot == "icub":
        try:
            import icub_models
        except ImportError:
            raise SystemExit("--robot icub needs icub-models: pip install icub-models") from None
        return pathlib.Path(icub_models.get_model_file("iCubGazeboV2_5"))
    if robot == "ergocub":
        return ERGOCUB
    return pathlib.Path(robot)


def make_terrain(kind: str, slope_deg: float):
    if kind == "flat":
        return wd.terrain.FlatTerrain()
    if kind == "plane":  # descends along +x
        theta = np.radians(slope_deg)
        return wd.terrain.PlaneTerrain(normal=(np.sin(theta), 0.0, np.cos(theta)))
    if kind == "heightfield":  # bumps of +-2 cm, 0.8 m apart, on a 3 m x 3 m grid of 5 cm cells
        x = np.arange(-1.5, 1.5 + 1e-9, 0.05)
        X, Y = np.meshgrid(x, x, indexing="ij")
        heights = 0.02 * np.sin(2 * np.pi * X / 0.8) * np.cos(2 * np.pi * Y / 0.8)
        return wd.terrain.HeightfieldTerrain(heights, origin=(-1.5, -1.5), spacing=(0.05, 0.05))
    raise SystemExit(f"unknown terrain {kind!r}")


def build(description, *, terrain, height: float, Kp: float, Kd: float, dtype=np.float32):
    """(model, data): the legs with joint PD to s0 = 0 as joint parameters, `height` above `terrain`."""
    full = wd.model.Model.build_from_model_description(str(description), dtype=dtype)
    legs = [j for j in full.joint_names() if any(part in j for part in LEG_PARTS)]
    model = wd.model.reduce(full, legs) if legs else full
    model.terrain = terrain
    n = model.dofs()
    s0 = np.zeros(n)
    model.set_joint_parameters(
        position_limits=np.stack([s0, s0], axis=1),  # the limit spring pulls s back to s0 from either side
        limit_spring=np.full(n, Kp),
        limit_damper=np.zeros(n),
        friction_viscous=model.tree.damping + Kd,
    )
    data = wd.data.Data.build(model, joint_positions=s0)
    if model.floating_base():
        n_terrain = terrain.normal(0.0, 0.0).reshape(3)
        if n_terrain[2] < 1.0 - 1e-12:  # tilt the base so that the robot's z axis is the terrain's normal there
            axis = np.cross([0.0, 0.0, 1.0], n_terrain)
            angle = np.arccos(np.clip(n_terrain[2], -1.0, 1.0))
            axis = axis / np.linalg.norm(axis)
            data = data.replace(model, base_quaternion=np.r_[np.cos(angle / 2), np.sin(angle / 2) * axis])
        p = wd.contact.collidable_point_positions(model, data).numpy().astype(np.float64)
        if len(p):
            lift = np.max(terrain.height(p[:, 0], p[:, 1]) - p[:, 2]) + height  # lowest point `height` above
            data = data.replace(model, base_position=[0.0, 0.0, lift])
    return model, data


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("robot", nargs="?", default="ergocub", help="'ergocub' (the seed's, default), 'icub', or a URDF/MJCF path")
    parser.add_argument("out", nargs="?", default="drop.rrd", help="the .rrd file to write (default drop.rrd)")
    parser.add_argument("--robot", dest="robot_flag", default=None, help="same as the positional robot")
    parser.add_argument("--terrain", choices=("flat", "plane", "heightfield"), default="flat")
    parser.add_argument("--slope", type=float, default=5.0, help="the plane's inclination [deg], descending along +x (--terrain plane)")
    parser.add_argument("--height", type=float, default=0.02, help="drop height of the lowest point [m] (default 2 cm)")
    parser.add_argument("--duration", type=float, default=1.0, help="simulated time [s]")
    parser.add_argument("--every", type=int, default=5, help="log every k-th state (1 ms steps; default 5: 200 frames/s)")
    parser.add_argument("--kp", type=float, default=3000.0, help="joint stiffness [N m/rad]")
    parser.add_argument("--kd", type=float, default=5.0, help="joint damping [N m s/rad], added to the description's")
    parser.add_argument("--no-meshes", action="store_true", help="do not log mesh collision shapes")
    args = parser.parse_args(argv)
    if args.robot.endswith(".rrd") and args.out == "drop.rrd":  # `visualize_drop.py out.rrd`
        args.robot, args.out = "ergocub", args.robot
    robot = args.robot_flag or args.robot

    wp.config.quiet = True
    wp.init()
    description = description_path(robot)
    terrain = make_terrain(args.terrain, args.slope)
    model, data = build(description, terrain=terrain, height=args.height, Kp=args.kp, Kd=args.kd)
    steps = max(1, int(round(args.duration / model.time_step)))
    print(f"{model.name()}: {model.dofs()} joints, {len(wd.contact.collidable_point_positions(model, data).numpy())} "
          f"collidable points, on {type(terrain).__name__}, {steps} steps on '{model.device}'")

    start = time.perf_counter()
    final, records = wd.visualization.record_rollout(
        model, data, steps=steps, path=args.out, every=args.every, meshes=not args.no_meshes,
        application_id=f"warpdyn_drop_{model.name()}",
    )
    elapsed = time.perf_counter() - start
    out = pathlib.Path(args.out).resolve()
    base = final.base_position.numpy().reshape(-1)
    print(f"simulated {steps * model.time_step:.3f} s and logged {steps // args.every + 1} frames in {elapsed:.2f} s; "
          f"final base position {np.round(base, 4).tolist()}, valid = {bool(final.healthy.numpy().reshape(-1)[0])}")
    print(f"wrote {out} ({out.stat().st_size / 1e6:.2f} MB); open it with:\n    rerun {args.out}")
    return {"model": model, "final": final, "records": records, "path": out, "seconds": elapsed}


if __name__ == "__main__":
    main()
