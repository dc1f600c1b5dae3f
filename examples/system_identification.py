"""System identification through a differentiable simulation: the link masses and viscous joint friction of
the iCub's legs, recovered from a simulated trajectory by gradient descent on gradients that `wp.Tape`
computes through `wd.simulation.Rollout` with respect to model parameters.

    pip install -e ".[examples]"                            # icub-models, matplotlib
    python examples/system_identification.py                # 200 iterations -> system_identification.png
    python examples/system_identification.py --plot out/sysid.png --dtype float32
    python examples/system_identification.py --noise 1 --iterations 600    # noisy measurements

The robot: iCubGazeboV2_5 (icub-models) with its root link welded 1 m above the ground (a `world` link
and a fixed joint added to the URDF text: that is how a description makes a fixed base), both legs' hip,
knee and ankle joints (12) kept, the others locked at 0, collidable points disabled (the feet never reach
the ground). Semi-implicit Euler, `--time-step` 2 ms.

1. "Measurements": the true robot (the URDF's masses and its viscous joint friction, <damping>, 1 N m s/rad
   on every joint) driven for `--duration` 2 s by known torques: per joint a sum of 5 sines (0.6 to 4.3 Hz,
   seeded random phases) plus a constant that spreads the hips and bends the knees, so that every joint
   moves (0.2 to 0.8 rad) without leaving its limits. Joint positions and velocities are recorded;
   `--noise k` adds Gaussian noise of k mrad to the positions and k 1e-2 rad/s to the velocities.
2. The model to fit: the same robot with each leg link's mass off by 10-20 % (seeded signs) and each
   joint's viscous friction off by a factor between 1/2 and 2. Its `link_mass` and `friction_viscous` are
   marked with `wd.model.parameters_requiring_grad`; gradient descent moves their logarithms (so they stay
   positive and a relative error costs the same whatever the size), with Adam (learning rate 0.1, cosine
   decay to 5 %), written in NumPy.
3. The loss: multiple shooting. The measured trajectory is cut into windows of `--horizon` 25 steps (50 ms);
   one batched rollout (one environment per window, 40 for 2 s) starts each window from its measured
   state, applies the measured torques, and the loss is the mean over windows, steps and joints of
   ((s - s_meas) / 1 mrad)^2 + ((sdot - sdot_meas) / 1e-2 rad/s)^2, a Warp kernel on the rollout's records.
   Short windows keep the loss nearly quadratic in the parameters (a free simulation of the whole 2 s
   would drift apart and make it rugged); all windows run in parallel, so an iteration costs 25 steps.
   With noise, starting a window from a noisy measured state biases the parameters (errors in variables):
   `--fit-states` (the default with --noise) makes the windows' initial states decision variables too
   (Data built from Warp arrays with requires_grad: the tape gives their gradients as well).

Identifiability, honestly: the root link is welded to the world, so its mass does nothing and is not a
parameter. A mass enters the dynamics only through m g c and m c x c terms (its CoM c relative to the joint
axes that move it; the rotational inertia about the CoM is a separate parameter, left as it is), so a link
whose CoM lies on the axis that moves it is not identifiable from a fixed base, whatever the excitation:
the hip_1 links (moved by hip pitch alone, CoM ~1 mm from its axis). The example measures this rather
than asserting it: before fitting it builds the Gauss-Newton information J^T J of the normalised residuals
(J by central differences of the batched rollout, the windows' initial states as nuisance parameters) and
prints, per parameter, the Cramer-Rao bound: the standard deviation of its relative error that noise of
1 mrad and 1e-2 rad/s on every sample leaves. Parameters whose bound exceeds 10 % (the hip_1 masses:
50-80 %) are not fitted and stay at their initial values (`--fit-all` fits them anyway: they wander); the
hip_2 masses (3-5 %) are fitted but are the least certain. Viscous friction is the smooth friction term;
Coulomb friction (`friction_static`) has a sign(sdot) switch whose gradient is 0 except at sdot = 0 and is
left out here.

Expected output (float64, CPU): the loss falls from ~1e2 to ~2e-5 in 200 iterations (the floor is what the
two unfitted hip_1 masses, 16-17 % off, leave); the fitted masses come back from 10-20 % to within
0.3 % (the hip_2 links; the others within 0.05 %), the frictions from factors up to 2 to within 1e-4;
the free simulation of the whole 2 s with the fitted parameters follows the measurements to 1e-4 rad
(0.13 rad with the initial ones). With `--noise 1 --iterations 600` the loss falls to the noise floor (~1.9)
and the estimates land within about one to two Cramer-Rao bounds of the truth. Runtime on a 2-core CPU:
15-20 s warm (0.05 s per iteration, ~4 s for the models, the measurements and the identifiability
analysis), 35-45 s the first time, when Warp compiles the kernels; float32 takes as long and ends the same.
On an NVIDIA H100 (the default device where there is one) the 200 iterations take 9.5 s, with the same
figures. The plot shows the loss, the relative mass and friction errors per iteration,
and the free simulation before and after the fit against the measurements.

`main(argv)` runs it and returns the history (tests/test_examples.py runs it on a short trajectory).
"""

import argparse
import functools
import math
import pathlib
import time

import numpy as np
import warp as wp

import warpdyn as wd
from common import Adam, default_device, fixed_base_icub

LEG_PARTS = ("hip", "knee", "ankle")
# Excitation [N m], by the end of the joint's name: amplitude of the sum of sines, and a constant.
AMPLITUDE = {"hip_pitch": 4.0, "hip_roll": 4.0, "hip_yaw": 0.7, "knee": 2.0, "ankle_pitch": 0.5, "ankle_roll": 0.4}
OFFSET = {"hip_roll": 2.0, "knee": -1.5}
FREQUENCIES = (0.6, 1.1, 1.7, 2.9, 4.3)  # [Hz]
SIGMA_S, SIGMA_V = 1e-3, 1e-2  # [rad], [rad/s]: the residuals' units in the loss, and the noise of --noise 1
NOT_IDENTIFIABLE = 0.1  # Cramer-Rao bound on the relative error above which a parameter is not fitted


def build_model(dtype: str, device, time_step: float):
    """The fixed-base legs (12 joints), without collidable points."""
    full = fixed_base_icub(dtype=np.dtype(dtype), device=device, time_step=time_step)
    legs = [j for j in full.joint_names() if any(part in j for part in LEG_PARTS)]
    model = wd.model.reduce(full, considered_joints=legs)
    assert not model.floating_base()
    return wd.contact.with_collidable_points(model, enabled_links=())


def excitation(joint_names, T: int, dt: float, seed: int) -> np.ndarray:
    """(T, n) torques [N m]: per joint a sum of sines with seeded random phases, plus a constant."""
    rng = np.random.default_rng(seed)
    t = np.arange(T) * dt
    tau = np.zeros((T, len(joint_names)))
    for j, name in enumerate(joint_names):
        kind = name[2:]  # "l_hip_pitch" -> "hip_pitch"
        phases = rng.uniform(0.0, 2.0 * np.pi, len(FREQUENCIES))
        waves = sum(np.sin(2.0 * np.pi * f * t + p) for f, p in zip(FREQUENCIES, phases))
        tau[:, j] = AMPLITUDE[kind] * waves / math.sqrt(len(FREQUENCIES)) + OFFSET.get(kind, 0.0)
    return tau


@functools.cache
def loss_kernel(scalar):
    @wp.kernel(module="unique")
    def shooting_loss(
        s: wp.array3d(dtype=scalar),  # (H + 1, K, n) simulated joint positions [rad], K windows
        sd: wp.array3d(dtype=scalar),  # (H + 1, K, n) simulated joint velocities [rad/s]
        s_meas: wp.array3d(dtype=scalar),  # (H + 1, K, n) measured
        sd_meas: wp.array3d(dtype=scalar),  # (H + 1, K, n) measured
        inv_sigma_s: scalar,
        inv_sigma_v: scalar,
        inv_count: scalar,
        out: wp.array(dtype=scalar),
    ):
        """out += mean over t = 0..H, windows and joints of ((s - s_meas)/sigma_s)^2 + ((sd - sd_meas)/sigma_v)^2."""
        t, k, j = wp.tid()
        e_s = (s[t, k, j] - s_meas[t, k, j]) * inv_sigma_s
        e_v = (sd[t, k, j] - sd_meas[t, k, j]) * inv_sigma_v
        wp.atomic_add(out, 0, (e_s * e_s + e_v * e_v) * inv_count)

    return shooting_loss


def parse_args(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--iterations", type=int, default=200, help="Adam iterations (default 200)")
    parser.add_argument("--duration", type=float, default=2.0, help="measured trajectory [s] (default 2)")
    parser.add_argument("--horizon", type=int, default=25, help="steps per shooting window (default 25)")
    parser.add_argument("--time-step", type=float, default=0.002, help="dt [s] (default 0.002)")
    parser.add_argument("--lr", type=float, default=0.1, help="Adam's initial learning rate, in log units (default 0.1)")
    parser.add_argument("--noise", type=float, default=0.0, help="measurement noise, in 1 mrad and 1e-2 rad/s (default 0)")
    parser.add_argument("--dtype", choices=("float64", "float32"), default="float64")
    parser.add_argument("--device", default=None, help="Warp device (default: cuda if available, else cpu)")
    parser.add_argument("--plot", default="system_identification.png", help="PNG to write ('' for none)")
    parser.add_argument("--print-every", type=int, default=10, help="print every k-th iteration (default 10)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the excitation, perturbation and noise (default 0)")
    parser.add_argument(
        "--fit-states",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="fit the windows' initial states too (default: with --noise)",
    )
    parser.add_argument("--lr-states", type=float, default=0.3, help="Adam's learning rate for the states, in noise units")
    parser.add_argument("--fit-all", action="store_true", help="fit the parameters found not identifiable too")
    return parser.parse_args(argv)


def main(argv=None) -> dict:
    """Run the identification. Returns a dict: "loss" (iterations + 1,), "error" (iterations + 1, 24): the
    signed relative error of every parameter per iteration, "names", "is_mass" and "fitted" (24,) masks,
    "true", "initial", "estimate" (24,) values, "cramer_rao" (24,) bounds, "free_error" (max joint error of
    the free simulation with the initial and the fitted parameters [rad]), and the trajectories plotted."""
    args = parse_args(argv)
    wp.config.quiet = True
    wp.config.log_level = wp.LOG_WARNING
    wp.init()
    device = args.device or default_device()
    started = time.perf_counter()
    dt, H = args.time_step, args.horizon
    truth = build_model(args.dtype, device, dt)
    fit = build_model(args.dtype, device, dt)
    scalar, n, nL = fit.scalar, fit.dofs(), fit.number_of_links()
    links, joints = fit.link_names(), fit.joint_names()
    leg_links = np.arange(1, nL)  # link 0, the root link, is welded to the world: its mass does nothing
    rng = np.random.default_rng(args.seed)

    # 1. Measurements: the true robot under the excitation.
    T = int(round(args.duration / dt)) // H * H
    if T < H:
        raise SystemExit(f"--duration {args.duration} s is shorter than one window of {H} steps")
    tau = excitation(joints, T, dt, args.seed)
    _, rec = wd.simulation.rollout(truth, wd.data.Data.build(truth), steps=T, joint_force_references=tau)
    s_meas = rec["joint_positions"].numpy().astype(np.float64)  # (T + 1, n)
    sd_meas = rec["joint_velocities"].numpy().astype(np.float64)
    if args.noise > 0.0:
        s_meas = s_meas + args.noise * SIGMA_S * rng.standard_normal(s_meas.shape)
        sd_meas = sd_meas + args.noise * SIGMA_V * rng.standard_normal(sd_meas.shape)

    # 2. The model to fit: perturbed masses and friction, marked for gradients. The parameters, in log space:
    # theta = (log masses of the leg links, log frictions of the joints).
    mass_true = truth.tree.link_mass.copy()
    friction_true = truth.friction_viscous.numpy().astype(np.float64)
    mass_init = mass_true.copy()
    signs = rng.choice([-1.0, 1.0], size=len(leg_links))
    mass_init[leg_links] *= 1.0 + signs * rng.uniform(0.1, 0.2, size=len(leg_links))
    friction_init = friction_true * np.exp(rng.uniform(-math.log(2.0), math.log(2.0), size=n))
    fit.set_joint_parameters(friction_viscous=friction_init)  # new arrays: mark them after this
    fit.link_mass.assign(mass_init)
    params = wd.model.parameters_requiring_grad(fit, names=("link_mass", "friction_viscous"))
    names = [f"mass {links[i]} [kg]" for i in leg_links] + [f"friction {j} [N m s/rad]" for j in joints]
    is_mass = np.arange(len(names)) < len(leg_links)
    true_values = np.concatenate([mass_true[leg_links], friction_true])
    initial_values = np.concatenate([mass_init[leg_links], friction_init])

    def set_parameters(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Write exp(theta) into the model's arrays, in place; (masses (nL,), frictions (n,))."""
        mass = mass_true.copy()  # the root link's entry is never used
        mass[leg_links] = np.exp(theta[is_mass])
        friction = np.exp(theta[~is_mass])
        params["link_mass"].assign(mass)
        params["friction_viscous"].assign(friction)
        return mass, friction

    # 3. Multiple shooting: K windows of H steps, one environment each. Window k starts at sample k H from
    # the state x_k = (s_k, sdot_k): the measured one, or, with --fit-states, an estimate fitted along with
    # the parameters (a noisy measured start would bias the parameters: errors in variables).
    K = T // H
    starts = np.arange(K) * H
    steps = starts[None, :] + np.arange(H + 1)[:, None]  # (H + 1, K) sample indices
    fit_states = args.noise > 0.0 if args.fit_states is None else args.fit_states
    start_s = wp.array(s_meas[starts], dtype=scalar, device=device, requires_grad=fit_states)  # (K, n)
    start_sd = wp.array(sd_meas[starts], dtype=scalar, device=device, requires_grad=fit_states)
    window_tau = wp.array(tau[steps[:-1]], dtype=scalar, device=device)  # (H, K, n)
    window_s = wp.array(s_meas[steps], dtype=scalar, device=device)  # (H + 1, K, n)
    window_sd = wp.array(sd_meas[steps], dtype=scalar, device=device)
    record = ("joint_positions", "joint_velocities")
    rollout = wd.simulation.Rollout(fit, steps=H, record=record)
    kernel = loss_kernel(scalar)
    inv = (scalar(1.0 / SIGMA_S), scalar(1.0 / SIGMA_V), scalar(1.0 / ((H + 1) * K * n)))

    def loss_on_tape():
        tape = wp.Tape()
        with tape:
            data = wd.data.Data.build(
                fit, joint_positions=start_s, joint_velocities=start_sd, num_envs=K, requires_grad=fit_states, validate=False
            )
            _, rec = rollout.run(data, joint_force_references=window_tau)
            loss = wp.zeros(1, dtype=scalar, device=device, requires_grad=True)
            wp.launch(
                kernel,
                dim=(H + 1, K, n),
                inputs=[rec["joint_positions"], rec["joint_velocities"], window_s, window_sd, *inv],
                outputs=[loss],
                device=device,
            )
        return tape, loss

    def window_residuals(theta, ds=0.0, dsd=0.0):
        """((s - s_meas)/sigma_s, (sdot - sdot_meas)/sigma_v), each (H + 1, K, n), from the measured starts
        plus (ds, dsd), without a tape."""
        set_parameters(theta)
        s0, sd0 = s_meas[starts] + ds, sd_meas[starts] + dsd
        data = wd.data.Data.build(fit, joint_positions=s0, joint_velocities=sd0, num_envs=K)
        _, rec = free_windows.run(data, joint_force_references=window_tau)
        e_s = (rec["joint_positions"].numpy() - s_meas[steps]) / SIGMA_S
        e_v = (rec["joint_velocities"].numpy() - sd_meas[steps]) / SIGMA_V
        return e_s, e_v

    free_windows = wd.simulation.Rollout(fit, steps=H, record=record, use_graph=False)

    # 4. Identifiability at the initial guess (what one knows before fitting): parameters whose Cramer-Rao
    # bound exceeds NOT_IDENTIFIABLE stay at their initial values (unless --fit-all).
    print(
        f"{fit!r}: both legs; {len(names)} parameters ({len(leg_links)} link masses, {n} viscous frictions), "
        f"{T} samples ({T * dt:g} s), {K} shooting windows of {H} steps"
        + (f"; the windows' {2 * n * K} initial states are fitted too" if fit_states else "")
    )
    theta = np.log(initial_values)
    h = 1e-5 if fit.dtype == np.float64 else 3e-3  # central differences: steps in log units and in sigmas
    bounds = cramer_rao_bounds(window_residuals, theta, n, h)
    set_parameters(theta)
    fitted = np.ones(len(names), dtype=bool) if args.fit_all else bounds <= NOT_IDENTIFIABLE
    left = [f"{names[p]} ({bounds[p]:.0%})" for p in np.flatnonzero(~fitted)]
    print(
        f"identifiability (Cramer-Rao bound on the relative error for noise of {SIGMA_S * 1e3:g} mrad and "
        f"{SIGMA_V:g} rad/s per sample): {bounds[is_mass].min():.1e} to {bounds[is_mass].max():.1e} for the masses, "
        f"{bounds[~is_mass].min():.1e} to {bounds[~is_mass].max():.1e} for the frictions; "
        + (f"not fitted, above {NOT_IDENTIFIABLE:.0%}: {', '.join(left)}" if left else "all fitted")
    )
    print(f"(not a parameter: the mass of {links[0]}, welded to the world, does nothing to a fixed-base robot)")

    fit_started = time.perf_counter()

    # 5. Gradient descent (Adam) on the fitted parameters' logarithms and, with --fit-states, on the windows'
    # initial states in units of the noise (x / sigma), with a learning rate of `--lr-states` of those units.
    n_theta = int(fitted.sum())
    lr_scale = np.ones(n_theta)
    if fit_states:
        lr_scale = np.concatenate([lr_scale, np.full(2 * K * n, args.lr_states / args.lr)])
        z = np.concatenate([s_meas[starts].ravel() / SIGMA_S, sd_meas[starts].ravel() / SIGMA_V])
    adam = Adam(len(lr_scale), eps=1e-12)
    history = {"loss": [], "error": []}
    print(f"{'iter':>5} {'loss':>11} {'mass: max|rel err|':>19} {'rms':>9} {'friction: max|rel err|':>23} {'rms':>9}")
    for k in range(args.iterations + 1):
        mass, friction = set_parameters(theta)
        tape, loss = loss_on_tape()
        error = np.exp(theta) / true_values - 1.0
        history["loss"].append(float(loss.numpy()[0]))
        history["error"].append(error)
        if k % args.print_every == 0 or k == args.iterations:
            e_m, e_f = error[fitted & is_mass], error[fitted & ~is_mass]
            print(
                f"{k:5d} {history['loss'][-1]:11.4e} {np.abs(e_m).max(initial=0.0):19.3e} "
                f"{np.sqrt(np.mean(e_m**2)) if e_m.size else 0.0:9.2e} {np.abs(e_f).max(initial=0.0):23.3e} "
                f"{np.sqrt(np.mean(e_f**2)) if e_f.size else 0.0:9.2e}"
            )
        if k == args.iterations:
            break  # the last evaluation is of the fitted parameters
        tape.backward(loss)
        g_mass = params["link_mass"].grad.numpy().astype(np.float64)
        g_friction = params["friction_viscous"].grad.numpy().astype(np.float64)
        grad = np.concatenate([g_mass[leg_links], g_friction]) * np.exp(theta)  # d loss / d log x = x d loss / d x
        x, g = theta[fitted], grad[fitted]
        if fit_states:  # d loss / d (x / sigma) = sigma d loss / d x
            g_states = [start_s.grad.numpy().ravel() * SIGMA_S, start_sd.grad.numpy().ravel() * SIGMA_V]
            x, g = np.concatenate([x, z]), np.concatenate([g, *g_states])
            start_s.grad.zero_()
            start_sd.grad.zero_()
        tape.zero()
        if not np.all(np.isfinite(g)):
            raise FloatingPointError(f"non-finite gradient at iteration {k}")
        lr = args.lr * (0.05 + 0.95 * 0.5 * (1.0 + math.cos(math.pi * k / max(args.iterations, 1))))
        x = adam.step(x, g, lr * lr_scale)
        theta[fitted] = x[:n_theta]
        if fit_states:
            z = x[n_theta:]
            start_s.assign((z[: K * n] * SIGMA_S).reshape(K, n))
            start_sd.assign((z[K * n :] * SIGMA_V).reshape(K, n))
    fit_time = time.perf_counter() - fit_started

    # Free simulation of the whole trajectory, with the initial and with the fitted parameters.
    free = wd.simulation.Rollout(fit, steps=T, record=record, use_graph=False)
    start = wd.data.Data.build(fit, joint_positions=s_meas[0], joint_velocities=sd_meas[0])

    def free_simulation(theta):
        set_parameters(theta)
        _, rec = free.run(start, joint_force_references=tau)
        return rec["joint_positions"].numpy().astype(np.float64)

    s_initial = free_simulation(np.log(initial_values))
    s_fitted = free_simulation(theta)
    free_error = {"initial": float(np.abs(s_initial - s_meas).max()), "fitted": float(np.abs(s_fitted - s_meas).max())}

    fitted_values = np.exp(theta)
    print(f"\n{'parameter':>31} {'true':>8} {'initial':>8} {'fitted':>8} {'rel. error':>11} {'CR bound':>9}")
    for p, name in enumerate(names):
        note = "" if fitted[p] else "  not identifiable: not fitted"
        print(
            f"{name:>31} {true_values[p]:8.4f} {initial_values[p]:8.4f} {fitted_values[p]:8.4f} "
            f"{fitted_values[p] / true_values[p] - 1.0:11.2e} {bounds[p]:9.1e}{note}"
        )
    final = history["error"][-1]
    print(
        f"loss {history['loss'][0]:.3e} -> {history['loss'][-1]:.3e}; max relative error of the fitted "
        f"masses {np.abs(history['error'][0][fitted & is_mass]).max(initial=0.0):.1%} -> "
        f"{np.abs(final[fitted & is_mass]).max(initial=0.0):.2e}, frictions "
        f"{np.abs(history['error'][0][fitted & ~is_mass]).max(initial=0.0):.1%} -> "
        f"{np.abs(final[fitted & ~is_mass]).max(initial=0.0):.2e}; free simulation of {T * dt:g} s, max joint "
        f"error {free_error['initial']:.3f} rad (initial) -> {free_error['fitted']:.2e} rad (fitted); "
        f"{args.iterations} iterations in {fit_time:.1f} s ({time.perf_counter() - started:.1f} s in all)"
    )
    result = {
        "loss": np.array(history["loss"]),
        "error": np.array(history["error"]),
        "names": names,
        "is_mass": is_mass,
        "fitted": fitted,
        "true": true_values,
        "initial": initial_values,
        "estimate": fitted_values,
        "cramer_rao": bounds,
        "free_error": free_error,
        "time": np.arange(T + 1) * dt,
        "measured": s_meas,
        "simulated_initial": s_initial,
        "simulated_fitted": s_fitted,
        "joints": list(joints),
    }
    if args.plot:
        plot(result, args.plot)
        print(f"wrote {args.plot}")
    return result


def cramer_rao_bounds(window_residuals, theta, n: int, h: float) -> np.ndarray:
    """The Cramer-Rao bound on each entry of theta (log parameters: the std of its relative error) for a
    least-squares fit of the windows' normalised residuals that also estimates each window's initial state.

    With Gaussian noise of sigma_s, sigma_v on every sample, the information is J^T J, J the Jacobian of the
    normalised residuals with respect to (theta, the K initial states). The states are nuisance parameters:
    the bound on theta is sqrt(diag(S^-1)), S = A - sum_k B_k D_k^-1 B_k^T the Schur complement of the
    block-diagonal state information D (window k's residuals depend only on its own start). J by central
    differences of the batched rollout (no tape): one rollout per parameter and per state component (a
    state component is moved in all windows at once, each window seeing only its own)."""
    e_s, _ = window_residuals(theta)
    K = e_s.shape[1]

    def by_window(e_s, e_v):  # (K, 2 (H + 1) n): each window's residuals
        return np.concatenate([e_s.transpose(1, 0, 2).reshape(K, -1), e_v.transpose(1, 0, 2).reshape(K, -1)], axis=1)

    J_theta = np.empty((K, 2 * e_s.shape[0] * n, len(theta)))
    for p in range(len(theta)):
        step = np.zeros_like(theta)
        step[p] = h
        plus, minus = by_window(*window_residuals(theta + step)), by_window(*window_residuals(theta - step))
        J_theta[:, :, p] = (plus - minus) / (2.0 * h)
    J_state = np.empty((K, J_theta.shape[1], 2 * n))
    for c in range(2 * n):
        delta = np.zeros(n)
        delta[c % n] = h * (SIGMA_S if c < n else SIGMA_V)  # a step of h noise units
        kind = "ds" if c < n else "dsd"
        plus = by_window(*window_residuals(theta, **{kind: delta}))
        minus = by_window(*window_residuals(theta, **{kind: -delta}))
        J_state[:, :, c] = (plus - minus) / (2.0 * h)
    A = np.einsum("kri,krj->ij", J_theta, J_theta)
    B = np.einsum("kri,krj->kij", J_theta, J_state)
    D = np.einsum("kri,krj->kij", J_state, J_state)  # includes the start's own measurement (t = 0)
    S = A - np.einsum("kij,kjl,kml->im", B, np.linalg.inv(D), B)
    return np.sqrt(np.diag(np.linalg.inv(S)))


def plot(result: dict, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(13, 8.5))
    ax = axes[0, 0]
    ax.semilogy(result["loss"])
    ax.set_xlabel("iteration")
    ax.set_ylabel("loss (normalised squared residuals)")
    ax.set_title("convergence")
    error, names, fitted = np.abs(result["error"]), result["names"], result["fitted"]
    panels = ((axes[0, 1], result["is_mass"], "link masses"), (axes[1, 0], ~result["is_mass"], "viscous joint friction"))
    for ax, mask, title in panels:
        for p in np.flatnonzero(mask):
            label = names[p].split(" ")[1] + ("" if fitted[p] else " (not fitted)")
            color = plt.cm.tab20(len(ax.lines) % 20)
            ax.semilogy(error[:, p], linewidth=1, linestyle="-" if fitted[p] else ":", color=color, label=label)
        ax.set_xlabel("iteration")
        ax.set_ylabel("|relative error|")
        ax.set_title(title)
        ax.legend(fontsize=7, ncol=2)
    ax = axes[1, 1]
    t = result["time"]
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for c, name in enumerate(("l_hip_pitch", "l_knee", "l_ankle_pitch")):
        j = result["joints"].index(name)
        color = colors[c]
        ax.plot(t, result["measured"][:, j], color=color, linewidth=2.5, alpha=0.4, label=f"{result['joints'][j]} measured")
        ax.plot(t, result["simulated_initial"][:, j], color=color, linestyle=":", label="initial parameters")
        ax.plot(t, result["simulated_fitted"][:, j], color=color, linestyle="--", label="fitted parameters")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("joint position [rad]")
    ax.set_title("free simulation of the whole trajectory")
    ax.legend(fontsize=7, ncol=3)
    fig.tight_layout()
    pathlib.Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


if __name__ == "__main__":
    main()
