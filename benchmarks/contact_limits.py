"""Where each contact model breaks: a high-speed impact and sliding on a slope at the friction limit.

    python benchmarks/contact_limits.py [--device cuda:0] [--dt 1e-3] [--tag cpu]

Scene: the 2 kg box of tests/jaxsim/box.sdf (0.5 x 0.3 x 0.2 m; its 8 corners are the collidable points),
semi-implicit Euler at --dt, float64 and float32, for each contact model: soft (JaxSim's defaults K = 1e6,
D = 2000, and K = 1e5, D = 430, mu = 0.5), relaxed rigid (JaxSim's defaults) and rigid (mu = 0.5, JaxSim's
Baumgarte K = D = 0).
- impact: the box flat, 5 mm above the ground, falling at 1, 5 and 20 m/s; 0.5 s. Printed: the deepest
  penetration of a corner [m], the highest rebound of the lowest corner after the first contact [m], whether
  the environment stayed healthy.
- slope: a plane tilted by theta about the world's y axis, the box resting on it (1 mm into it) at rest, theta at
  0.8 and 1.2 times the friction angle atan(mu) (mu = 0.5: 21.8 and 31.0 deg); 1 s. Coulomb's law: the box
  sticks below the angle and slides above it, 1/2 g (sin theta - mu cos theta) t^2 = 0.43 m in 1 s at 1.2x.
  Printed: the distance the box moved along the slope [m].
Stiff stacking (boxes on boxes) needs contacts between bodies, which warpdyn does not have yet (issue 37).

Writes results/contact_limits_<tag>.md.
"""

from __future__ import annotations

import argparse
import pathlib
import re

import numpy as np
import warp as wp

import warpdyn as wd
from common import header

ROOT = pathlib.Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
BOX = ROOT / "tests" / "jaxsim" / "box.sdf"
MU = 0.5
HALF_HEIGHT = 0.1  # [m] the box's


def settings() -> dict:
    """{label: (contact model, its parameters)}."""
    c = wd.rbda.contacts
    return {
        "soft K=1e6": (c.SoftContacts.build(), c.SoftContactsParams(K=1e6, D=2000.0, mu=MU)),
        "soft K=1e5": (c.SoftContacts.build(), c.SoftContactsParams(K=1e5, D=430.0, mu=MU)),
        "relaxed": (c.RelaxedRigidContacts.build(), c.RelaxedRigidContactsParams()),
        "rigid": (c.RigidContacts.build(), c.RigidContactsParams(mu=MU)),
    }


def box(dtype, device, setting, dt: float, terrain=None):
    model = wd.model.JaxSimModel.build_from_model_description(BOX, dtype=dtype, device=device)
    contact_model, params = setting
    model = model.replace(contact_model=contact_model, contact_params=params, time_step=dt)
    if terrain is not None:
        model.terrain = terrain
    return model


def impact(model, speed: float) -> tuple[float, float, bool]:
    """(deepest penetration, highest rebound after the first contact, healthy) of the box falling at `speed`."""
    data = wd.data.JaxSimModelData.build(model=model, base_position=np.array([0.0, 0.0, HALF_HEIGHT + 0.005]), base_linear_velocity=np.array([0.0, 0.0, -speed]))
    deepest, rebound, touched = 0.0, 0.0, False
    for _ in range(int(round(0.5 / model.time_step))):
        data = wd.model.step(model, data)
        low = float(wd.contact.collidable_point_positions(model, data).numpy()[:, 2].min())
        touched |= low < 0.0
        deepest = max(deepest, -low)
        if touched:
            rebound = max(rebound, low)
    return deepest, rebound, bool(data.healthy.numpy().all())


def slope(model, theta: float) -> tuple[float, bool]:
    """(distance moved along the slope in 1 s, healthy) of the box at rest on the plane tilted by theta."""
    R = np.array([[np.cos(theta), 0.0, np.sin(theta)], [0.0, 1.0, 0.0], [-np.sin(theta), 0.0, np.cos(theta)]])  # about y
    normal = R @ np.array([0.0, 0.0, 1.0])
    model.terrain = wd.terrain.PlaneTerrain(normal=normal, point=(0.0, 0.0, 0.0))
    start = normal * (HALF_HEIGHT - 0.001)
    quaternion = np.array([np.cos(theta / 2), 0.0, np.sin(theta / 2), 0.0])
    data = wd.data.JaxSimModelData.build(model=model, base_position=start, base_quaternion=quaternion)
    for _ in range(int(round(1.0 / model.time_step))):
        data = wd.model.step(model, data)
    moved = data.base_position.numpy().reshape(3) - start
    along = moved - normal * float(moved @ normal)
    return float(np.linalg.norm(along)), bool(data.healthy.numpy().all())


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default=None)
    parser.add_argument("--dt", type=float, default=1e-3)
    parser.add_argument("--tag", default=None)
    args = parser.parse_args()
    wp.config.quiet = True
    device = wp.get_device(args.device)
    tag = args.tag or ("cpu" if not device.is_cuda else re.sub(r"[^a-z0-9]+", "_", device.name.lower()).strip("_"))
    lines = [
        "# Where each contact model breaks (benchmarks/contact_limits.py)",
        "",
        f"`python benchmarks/contact_limits.py{' --dt ' + format(args.dt, 'g') if args.dt != 1e-3 else ''}`; {header(device)}.",
        f"The 2 kg box of tests/jaxsim/box.sdf, semi-implicit Euler, dt = {args.dt * 1e3:g} ms. Impact: falling flat at the speed given;",
        "deepest corner penetration, highest rebound of the lowest corner after touching, health after 0.5 s. Slope: at rest on a",
        f"plane tilted by 0.8 and 1.2 times the friction angle atan({MU:g}) = {np.degrees(np.arctan(MU)):.1f} deg; distance moved along it in",
        "1 s (Coulomb: 0 below the angle, 0.43 m above it). Stiff stacking needs contacts between bodies (issue 37): not measured.",
        "",
        "| contact | dtype | impact 1 m/s: depth, rebound [m] | 5 m/s | 20 m/s | slope 0.8x: moved [m] | slope 1.2x: moved [m] |",
        "| --- | --- | --- | --- | --- | ---: | ---: |",
    ]
    for label, setting in settings().items():
        for dtype in (wp.float64, wp.float32):
            cells = []
            for speed in (1.0, 5.0, 20.0):
                try:
                    depth, rebound, healthy = impact(box(dtype, device, setting, args.dt), speed)
                    cells.append(f"{depth:.3g}, {rebound:.3g}" + ("" if healthy else " (flagged)"))
                except ValueError as error:
                    cells.append(f"refused: {str(error)[:60]}")
            for factor in (0.8, 1.2):
                try:
                    moved, healthy = slope(box(dtype, device, setting, args.dt), factor * np.arctan(MU))
                    cells.append(f"{moved:.3g}" + ("" if healthy else " (flagged)"))
                except ValueError as error:
                    cells.append(f"refused: {str(error)[:60]}")
            line = f"| {label} | {dtype.__name__} | " + " | ".join(cells) + " |"
            print(line, flush=True)
            lines.append(line)
    RESULTS.mkdir(exist_ok=True)
    out = RESULTS / f"contact_limits_{tag}.md"
    out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
