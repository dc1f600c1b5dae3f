"""Co-design through a differentiable rollout: the ergoCub's right leg (shipped; base welded 1 m above the ground)
must bring its sole to a point it cannot reach, and the optimiser may lengthen the thigh and the shank
(`wd.model.with_joint_origins`: the knee's and the ankle's joint origins scaled) as well as choose the torques.

    python examples/codesign.py --plot codesign.png   # 120 iterations of each run (the plot needs matplotlib)
    python examples/codesign.py --iterations 60

The leg: the six right-leg joints kept (the others locked at 0), no contacts, viscous joint friction from the
URDF, semi-implicit Euler, T = `--steps` 150 steps of 2 ms (0.3 s), starting at rest hanging straight down. The
target: the sole's point 6 cm below and 10 cm in front of where it hangs (`--reach`), which the fully
stretched leg does not reach. Two runs of Adam, from the same start:
- torques alone: the decision variables tau (T, 6) [N m];
- co-design: tau and the scales (s_thigh, s_shank) of the knee's and the ankle's joint origins (the hip-to-knee
  and knee-to-ankle offsets), started at 1.
The loss, recorded on the tape with the rollout:

    L = w_p |p_sole(T) - p*|^2 + w_v |sdot_T|^2 + w_tau dt sum_t |tau_t|^2 + w_s ((s_thigh - 1)^2 + (s_shank - 1)^2)

(w_p = 100 m^-2, w_v = 1e-3 s^2, w_tau = 1e-5 (N m)^-2 s^-1, w_s = 1: a longer bone has a price). The link
masses and inertias stay as they are: the shapes and densities that would scale with the bones are not
parameters yet (issue 38's next item). Prints the loss, the sole's distance to the target and the scales every
`--print-every` iterations, and at the end each run's final distance. Measured with the defaults (2-core CPU,
50 s with both runs, kernels cached): the torques alone end 66.1 mm from the target (loss 0.438); co-design
3.9 mm (loss 0.034), the thigh 1.103 and the shank 1.144 times as long. `main(argv)` returns the histories
(tests/test_examples.py runs it with few iterations).
"""

import argparse
import functools
import time

import numpy as np
import warp as wp

import warpdyn as wd
from common import Adam, pyplot

LEG_JOINTS = ("r_hip_pitch", "r_hip_roll", "r_hip_yaw", "r_knee", "r_ankle_pitch", "r_ankle_roll")
SCALED = ("r_knee", "r_ankle_pitch")  # their origins: the thigh's and the shank's offsets
SOLE = "r_sole"


def build_model(time_step: float, device: str) -> wd.model.Model:
    """The right leg, welded 1 m above the ground, float64, without collidable points."""
    W_H_B = np.eye(4)
    W_H_B[2, 3] = 1.0
    full = wd.model.Model.build_from_model_description(
        wd.assets.ergocub_urdf(), fixed_base=True, base_pose=W_H_B, dtype=np.float64, device=device, time_step=time_step
    )
    model = wd.model.reduce(full, considered_joints=list(LEG_JOINTS))
    return wd.contact.with_collidable_points(model, enabled_links=())


@functools.cache
def kernels():
    """The scaled origins and the loss's terms, recorded on the tape."""

    @wp.kernel
    def scaled_origins(base: wp.array2d(dtype=wp.float64), which: wp.array(dtype=int), scales: wp.array(dtype=wp.float64),
                       positions: wp.array2d(dtype=wp.float64)):
        """positions[j] = scales[which[j]] base[j] (which[j] = -1: base[j]); launched over (nj, 3)."""
        j, k = wp.tid()
        s = wp.float64(1.0)
        if which[j] >= 0:
            s = scales[which[j]]
        positions[j, k] = s * base[j, k]

    @wp.kernel
    def reach_cost(W_H_S: wp.array2d(dtype=wp.float64), target: wp.array(dtype=wp.float64), sd: wp.array2d(dtype=wp.float64),
                   w_p: wp.float64, w_v: wp.float64, out: wp.array(dtype=wp.float64)):
        """w_p |sole - target|^2 + w_v |sdot_T|^2, the sole W_H_S (4, 4), sdot the records (T + 1, n)."""
        k = wp.tid()
        if k < 3:
            e = W_H_S[k, 3] - target[k]
            wp.atomic_add(out, 0, w_p * e * e)
        for j in range(sd.shape[1]):
            if k == 0:
                v = sd[sd.shape[0] - 1, j]
                wp.atomic_add(out, 0, w_v * v * v)

    @wp.kernel
    def squares(x: wp.array2d(dtype=wp.float64), w: wp.float64, out: wp.array(dtype=wp.float64)):
        t, j = wp.tid()
        wp.atomic_add(out, 0, w * x[t, j] * x[t, j])

    @wp.kernel
    def scale_cost(scales: wp.array(dtype=wp.float64), w: wp.float64, out: wp.array(dtype=wp.float64)):
        k = wp.tid()
        e = scales[k] - wp.float64(1.0)
        wp.atomic_add(out, 0, w * e * e)

    return scaled_origins, reach_cost, squares, scale_cost


def optimise(model, args, codesign: bool) -> dict:
    """One run of Adam; {"loss", "distance" [m], "scales"} per iteration and the final plan."""
    scaled_origins, reach_cost, squares, scale_cost = kernels()
    T, n, dt = args.steps, model.dofs(), args.time_step
    base_positions, rotations = wd.model.joint_origins(model)
    base = wp.array(base_positions, dtype=wp.float64)
    which = wp.array([SCALED.index(name) if name in SCALED else -1 for name in model.joint_names()], dtype=int)
    sole = wd.frame.name_to_idx(model, frame_name=SOLE)
    data0 = wd.data.Data.build(model)
    rest = wd.frame.transform(model, data0, frame_index=sole).numpy()[:3, 3]
    target = wp.array(rest + np.array([args.reach[0], 0.0, -args.reach[1]]), dtype=wp.float64)
    rng = np.random.default_rng(args.seed)
    tau_host, scale_host = 1e-3 * rng.standard_normal((T, n)), np.ones(2)
    adam_tau, adam_scale = Adam(tau_host.shape), Adam(scale_host.shape)
    history = {"loss": [], "distance": [], "scales": []}
    for k in range(args.iterations):
        tau = wp.array(tau_host, dtype=wp.float64, requires_grad=True)
        scales = wp.array(scale_host, dtype=wp.float64, requires_grad=codesign)
        positions = wp.zeros(base.shape, dtype=wp.float64, requires_grad=codesign)
        loss = wp.zeros(1, dtype=wp.float64, requires_grad=True)
        with wp.Tape() as tape:
            wp.launch(scaled_origins, dim=base.shape, inputs=[base, which, scales], outputs=[positions])
            moved = wd.model.with_joint_origins(model, positions=positions, rotations=rotations)
            final, rec = wd.simulation.rollout(moved, data0, steps=T, joint_force_references=tau, record=("joint_velocities",))
            W_H_S = wd.frame.transform(moved, final, frame_index=sole)
            wp.launch(reach_cost, dim=3, inputs=[W_H_S, target, rec["joint_velocities"], 100.0, 1e-3], outputs=[loss])
            wp.launch(squares, dim=(T, n), inputs=[tau, 1e-5 * dt], outputs=[loss])
            wp.launch(scale_cost, dim=2, inputs=[scales, 1.0], outputs=[loss])
        tape.backward(loss)
        distance = float(np.linalg.norm(W_H_S.numpy()[:3, 3] - target.numpy()))
        history["loss"].append(float(loss.numpy()[0]))
        history["distance"].append(distance)
        history["scales"].append(scale_host.copy())
        lr = 0.5 * (1.0 + np.cos(np.pi * k / args.iterations))  # cosine decay from 1
        tau_host = adam_tau.step(tau_host, tau.grad.numpy(), args.lr * lr)
        if codesign:
            scale_host = adam_scale.step(scale_host, scales.grad.numpy(), args.lr_scale * lr)
        if k % args.print_every == 0 or k == args.iterations - 1:
            print(f"{'co-design' if codesign else 'torques  '} {k:4d}  loss {history['loss'][-1]:10.4f}  sole to target {1e3 * distance:7.1f} mm"
                  f"  thigh x{scale_host[0]:.3f}  shank x{scale_host[1]:.3f}", flush=True)
    return {name: np.array(value) for name, value in history.items()}


def parse_args(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--iterations", type=int, default=120, help="Adam iterations per run (default 120)")
    parser.add_argument("--steps", type=int, default=150, help="rollout steps T (default 150)")
    parser.add_argument("--time-step", type=float, default=0.002, help="dt [s] (default 0.002)")
    parser.add_argument("--reach", type=float, nargs=2, default=(0.10, 0.06), help="target ahead and below the hanging sole [m]")
    parser.add_argument("--lr", type=float, default=2.0, help="Adam's initial learning rate for the torques [N m] (default 2)")
    parser.add_argument("--lr-scale", type=float, default=0.01, help="Adam's initial learning rate for the scales (default 0.01)")
    parser.add_argument("--print-every", type=int, default=20, help="print every k-th iteration (default 20)")
    parser.add_argument("--device", default="cpu", help="Warp device (default cpu: one environment is launch-bound on a GPU)")
    parser.add_argument("--plot", default="", help="PNG to write (default: none; needs matplotlib: pip install -e '.[examples]')")
    parser.add_argument("--seed", type=int, default=0)
    return parser.parse_args(argv)


def main(argv=None) -> dict:
    args = parse_args(argv)
    wp.config.quiet = True
    started = time.perf_counter()
    with wp.ScopedDevice(args.device):  # the arrays of the loss and Adam live with the model
        model = build_model(args.time_step, args.device)
        runs = {"torques": optimise(model, args, codesign=False), "co-design": optimise(model, args, codesign=True)}
    for name, run in runs.items():
        s = run["scales"][-1]
        print(f"{name}: sole {1e3 * run['distance'][-1]:.1f} mm from the target, loss {run['loss'][-1]:.4f}, thigh x{s[0]:.3f}, shank x{s[1]:.3f}")
    print(f"{time.perf_counter() - started:.1f} s")
    if args.plot:
        plot(runs, args.plot)
    return runs


def plot(runs: dict, path: str) -> None:
    plt = pyplot()

    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    for name, run in runs.items():
        axes[0].semilogy(run["loss"], label=name)
        axes[1].plot(1e3 * run["distance"], label=name)
    scales = runs["co-design"]["scales"]
    axes[2].plot(scales[:, 0], label="thigh")
    axes[2].plot(scales[:, 1], label="shank")
    for ax, title in zip(axes, ("loss", "sole to target [mm]", "co-design's scales")):
        ax.set_title(title)
        ax.set_xlabel("iteration")
        ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
