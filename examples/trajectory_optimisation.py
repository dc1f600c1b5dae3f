"""Trajectory optimisation through a differentiable rollout: the joint torques, one per joint per step, that
swing the iCub's left leg (fixed base, 6 joints) from hanging straight down to a target pose and hold it
there, found by gradient descent (Adam, in NumPy) on gradients that `wp.Tape` computes through
`wd.simulation.Rollout`.

    pip install -e ".[examples]"                             # icub-models, matplotlib
    python examples/trajectory_optimisation.py               # 100 iterations -> trajectory_optimisation.png
    python examples/trajectory_optimisation.py --iterations 200 --plot out/leg.png
    python examples/trajectory_optimisation.py --dtype float32 --device cpu

The robot: iCubGazeboV2_5 (icub-models) with its root link welded 1 m above the ground (a `world` link and
a fixed joint added to the URDF text: that is how a description makes a fixed base) and only the left
leg's hip, knee and ankle joints kept (the others locked at 0). Its collidable points are disabled (the
foot never reaches the ground: no contact). Viscous joint friction 1 N m s/rad per joint, from the URDF's
<damping>, acts in the simulation. Semi-implicit Euler, `--time-step` 2 ms, `--steps` T = 200 (0.4 s).

The decision variables are the torques tau (T, n) [N m], a Warp array with requires_grad, starting at
(nearly) zero: the leg then just hangs. The loss, Warp kernels recorded on the same tape as the rollout:

    L = mean over the last H + 1 states (t = T - H ... T) of (|s_t - s*|^2 + w_v |sdot_t|^2) + w_tau dt sum_t |tau_t|^2

(reach the target pose s* and stay there, at rest, for the last `--hold-steps` H = 25 steps (50 ms), with a
small torque effort; w_v = 0.05 s^2, w_tau = 1e-4 s^-1 (N m)^-2; units of the loss: rad^2). Every iteration
runs the rollout under a tape (storage "trajectory": all states kept), `tape.backward`, reads tau.grad and
takes an Adam step (learning rate 1 N m, decayed to 5 % along a cosine). The rollout object is made once
and rerun: its buffers and the tape's gradient arrays are reused (`tape.zero()` between iterations).

Expected output (float64 and float32 alike, CPU, 100 iterations): the loss falls from 1.7 to 2.7e-3, the
final pose error from 1.3 rad to 7e-3 rad (0.4 degrees at most on any joint), the sole ends 3.5 mm from
where the target pose puts it, the final joint speed is 0.14 rad/s (mostly the hip pitch; 70 % of the
remaining loss is the torque effort, most of the rest the speeds while holding). Runtime on a
2-core CPU: 23 s warm (0.2 s per iteration; up to 36 s when other work shares the CPU), 33 s the first
time, when Warp compiles the kernels (up to 70 s under load). It runs on the CPU by default: one
environment's taped rollout is ~2,000 small launches per iteration, which an NVIDIA H100 runs in 58 s for
the same 100 iterations (same figures; `--device cuda` to try). The plot shows the loss, the pose error and
the speed per iteration, the joint trajectories before (zero torques) and after against the target, and
the optimised torques.

`main(argv)` runs it and returns the history (tests/test_examples.py runs it with few iterations).
"""

import argparse
import functools
import math
import pathlib
import time

import numpy as np
import warp as wp

import warpdyn as wd
from common import Adam, fixed_base_icub

LEG_JOINTS = ("l_hip_pitch", "l_hip_roll", "l_hip_yaw", "l_knee", "l_ankle_pitch", "l_ankle_roll")
TARGET = (0.7, 0.25, 0.2, -1.0, -0.3, 0.1)  # [rad], in the order of LEG_JOINTS; inside the joint limits
SOLE = "l_sole"


def build_model(dtype: str, device, time_step: float):
    """The fixed-base left leg, without collidable points."""
    full = fixed_base_icub(dtype=np.dtype(dtype), device=device, time_step=time_step)
    model = wd.model.reduce(full, considered_joints=list(LEG_JOINTS))
    assert not model.floating_base() and model.joint_names() == LEG_JOINTS
    return wd.contact.with_collidable_points(model, enabled_links=())


@functools.cache
def loss_kernels(scalar):
    """Warp kernels adding the loss's terms into out[0] (recorded on the tape, differentiated by it)."""

    @wp.kernel(module="unique")
    def hold_cost(
        s: wp.array2d(dtype=scalar),  # (T + 1, n) joint positions [rad]
        sd: wp.array2d(dtype=scalar),  # (T + 1, n) joint velocities [rad/s]
        target: wp.array(dtype=scalar),  # (n,) [rad]
        hold: int,  # the last `hold` states before T and s_T, hold + 1 in all, are averaged
        w_v: scalar,
        out: wp.array(dtype=scalar),
    ):
        k, j = wp.tid()  # k = 0 ... hold
        t = s.shape[0] - 1 - k
        e = s[t, j] - target[j]
        wp.atomic_add(out, 0, (e * e + w_v * sd[t, j] * sd[t, j]) / scalar(hold + 1))

    @wp.kernel(module="unique")
    def effort_cost(tau: wp.array2d(dtype=scalar), w: scalar, out: wp.array(dtype=scalar)):
        t, j = wp.tid()
        wp.atomic_add(out, 0, w * tau[t, j] * tau[t, j])

    return hold_cost, effort_cost


def parse_args(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--iterations", type=int, default=100, help="Adam iterations (default 100)")
    parser.add_argument("--steps", type=int, default=200, help="rollout steps T (default 200)")
    parser.add_argument("--time-step", type=float, default=0.002, help="dt [s] (default 0.002)")
    parser.add_argument("--hold-steps", type=int, default=25, help="the pose is held over the last k steps (default 25)")
    parser.add_argument("--lr", type=float, default=1.0, help="Adam's initial learning rate [N m] (default 1.0)")
    parser.add_argument("--w-velocity", type=float, default=0.05, help="weight of |sdot_T|^2 [s^2] (default 0.05)")
    parser.add_argument("--w-torque", type=float, default=1e-4, help="weight of dt sum |tau|^2 (default 1e-4)")
    parser.add_argument("--dtype", choices=("float64", "float32"), default="float64")
    parser.add_argument("--device", default="cpu", help="Warp device (default cpu: one environment is launch-bound on a GPU)")
    parser.add_argument("--plot", default="trajectory_optimisation.png", help="PNG to write ('' for none)")
    parser.add_argument("--print-every", type=int, default=10, help="print every k-th iteration (default 10)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the initial torques' tiny noise (default 0)")
    return parser.parse_args(argv)


def main(argv=None) -> dict:
    """Run the optimisation; returns {"loss", "pose_error", "final_speed"} per iteration (NumPy arrays), the
    trajectories before/after, the torques and the final sole error [m]."""
    args = parse_args(argv)
    wp.config.quiet = True
    wp.config.log_level = wp.LOG_WARNING
    wp.init()
    device = args.device
    started = time.perf_counter()
    model = build_model(args.dtype, device, args.time_step)
    scalar, n, T, dt = model.scalar, model.dofs(), args.steps, args.time_step
    hold_cost, effort_cost = loss_kernels(scalar)
    hold = min(args.hold_steps, T)
    target = wp.array(np.array(TARGET), dtype=scalar, device=device)
    data0 = wd.data.Data.build(model)  # hanging straight down, at rest
    rollout = wd.simulation.Rollout(model, steps=T, record=("joint_positions", "joint_velocities"))

    # Tiny seeded noise breaks the symmetry of the all-zero start (any start works).
    rng = np.random.default_rng(args.seed)
    tau_host = 1e-3 * rng.standard_normal((T, n))
    tau = wp.array(tau_host, dtype=scalar, device=device, requires_grad=True)
    adam = Adam(tau_host.shape)

    def evaluate(tape=None):
        """Run the rollout (under `tape` when given) and the loss kernels; (loss array, records)."""
        _, rec = rollout.run(data0, joint_force_references=tau)
        loss = wp.zeros(1, dtype=scalar, device=device, requires_grad=True)
        wp.launch(
            hold_cost,
            dim=(hold + 1, n),
            inputs=[rec["joint_positions"], rec["joint_velocities"], target, hold, scalar(args.w_velocity)],
            outputs=[loss],
            device=device,
        )
        wp.launch(effort_cost, dim=(T, n), inputs=[tau, scalar(args.w_torque * dt)], outputs=[loss], device=device)
        return loss, rec

    history = {"loss": [], "pose_error": [], "hold_error": [], "final_speed": []}
    before = None
    print(f"{model!r}: the left leg, {n} joints, T = {T} steps of {dt * 1e3:g} ms, {T * n} torques to optimise")
    print(f"target pose {TARGET} rad, held over the last {hold} steps ({hold * dt * 1e3:g} ms)")
    print(
        f"{'iter':>5} {'loss':>11} {'|s_T - s*| [rad]':>17} {'hold: max|s-s*|':>16} "
        f"{'|sdot_T| [rad/s]':>17} {'max|tau| [N m]':>15}"
    )
    for k in range(args.iterations + 1):
        tape = wp.Tape()
        with tape:
            loss, rec = evaluate()
        s = rec["joint_positions"].numpy()
        sd = rec["joint_velocities"].numpy()
        if before is None:
            before = s.copy()
        history["loss"].append(float(loss.numpy()[0]))
        window = slice(T - hold, T + 1)  # the hold window, s_T included
        history["pose_error"].append(float(np.linalg.norm(s[T] - np.array(TARGET))))
        history["hold_error"].append(float(np.linalg.norm(s[window] - np.array(TARGET), axis=1).max()))
        history["final_speed"].append(float(np.linalg.norm(sd[T])))
        if k % args.print_every == 0 or k == args.iterations:
            print(
                f"{k:5d} {history['loss'][-1]:11.4e} {history['pose_error'][-1]:17.4e} {history['hold_error'][-1]:16.4e} "
                f"{history['final_speed'][-1]:17.4e} {np.abs(tau_host).max():15.3f}"
            )
        if k == args.iterations:
            break  # the last evaluation is of the final torques
        tape.backward(loss)
        grad = tau.grad.numpy().astype(np.float64)
        tape.zero()
        if not np.all(np.isfinite(grad)):
            raise FloatingPointError(f"non-finite gradient at iteration {k}")
        lr = args.lr * (0.05 + 0.95 * 0.5 * (1.0 + math.cos(math.pi * k / max(args.iterations, 1))))
        tau_host = adam.step(tau_host, grad, lr)
        tau.assign(tau_host)
    elapsed = time.perf_counter() - started
    after = s

    # Where the sole ends up, against where the target pose puts it (forward kinematics, no tape).
    sole = wd.frame.name_to_idx(model, frame_name=SOLE)
    W_H_reached = wd.frame.transform(model, wd.data.Data.build(model, joint_positions=after[-1]), frame_index=sole)
    W_H_target = wd.frame.transform(model, wd.data.Data.build(model, joint_positions=np.array(TARGET)), frame_index=sole)
    sole_error = float(np.linalg.norm(W_H_reached.numpy()[:3, 3] - W_H_target.numpy()[:3, 3]))
    print(
        f"final: loss {history['loss'][0]:.3e} -> {history['loss'][-1]:.3e}, pose error "
        f"{history['pose_error'][0]:.3f} -> {history['pose_error'][-1]:.2e} rad "
        f"(max {np.degrees(np.abs(after[-1] - np.array(TARGET)).max()):.2f} deg), sole {sole_error * 1e3:.1f} mm "
        f"from the target pose's; at most {history['hold_error'][-1]:.2e} rad off while holding, "
        f"final speed {history['final_speed'][-1]:.2e} rad/s; "
        f"{args.iterations} iterations in {elapsed:.1f} s"
    )
    result = {k: np.array(v) for k, v in history.items()}
    result.update(
        before=before,
        after=after,
        final_velocity=sd[-1].copy(),
        torques=tau_host.copy(),
        sole_error=sole_error,
        time=np.arange(T + 1) * dt,
    )
    if args.plot:
        plot(result, args.plot)
        print(f"wrote {args.plot}")
    return result


def plot(result: dict, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(12, 8))
    ax = axes[0, 0]
    ax.semilogy(result["loss"], label="loss")
    ax.semilogy(result["pose_error"], label="|s_T - s*| [rad]")
    ax.semilogy(result["hold_error"], label="max |s_t - s*| over the hold [rad]")
    ax.semilogy(result["final_speed"], label="|sdot_T| [rad/s]")
    ax.set_xlabel("iteration")
    ax.set_title("convergence")
    ax.legend()
    t = result["time"]
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, key, title in ((axes[0, 1], "before", "before (zero torques)"), (axes[1, 0], "after", "after")):
        for j, name in enumerate(LEG_JOINTS):
            c = colors[j % len(colors)]
            ax.plot(t, result[key][:, j], color=c, label=name)
            ax.axhline(TARGET[j], color=c, linestyle=":", linewidth=1)
        ax.set_xlabel("t [s]")
        ax.set_ylabel("joint position [rad]")
        ax.set_title(f"joint trajectories {title}; dotted: target")
    axes[1, 0].legend(fontsize=8)
    ax = axes[1, 1]
    for j, name in enumerate(LEG_JOINTS):
        ax.plot(t[:-1], result["torques"][:, j], color=colors[j % len(colors)], label=name)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("torque [N m]")
    ax.set_title("optimised torques")
    fig.tight_layout()
    pathlib.Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


if __name__ == "__main__":
    main()
