"""Model-predictive control of the Franka Emika Panda: iLQR on warpdyn's full Jacobians makes the arm's flange
track a target that runs round a vertical circle in front of the robot, in closed loop.

    pip install -e ".[examples]"                  # mujoco (the Panda's MJCF is read through it), matplotlib for --plot
    python examples/mpc.py                        # 4 s of control: prints the tracking error
    python examples/mpc.py --steps 700 --mass-error 0.3 --plot mpc.png

The robot: the Panda arm that warpdyn ships (`wd.assets.franka_panda_mjcf()`, MuJoCo Menagerie's, 7 joints,
torque-controlled), in float64. The target p*(t) runs round a circle of --radius 12 cm in the plane x = 0.55 m
facing the robot, centred on the flange's position at the keyframe "home" where the arm starts at rest (so the
first target is 12 cm away), once every --period 3 s.

The plant is warpdyn's simulation of the same robot at the file's 2 ms, with each link's mass and inertia scaled by
a random factor within +-(--mass-error) (default 10 %, seeded): the controller's model has the nominal ones, so
the loop has to be robust to them. Each control period of --dt 10 ms the plant holds the plan's first torques,
clipped to the Panda's limits (wd.assets.FRANKA_PANDA_TORQUE_LIMITS).

The controller, at each control step, from the measured state x0 = [q; v] (7 + 7):
1. warm start: the previous plan's torques and feedback gains shifted by one step (the last repeated) and rolled
   out from x0 through the controller's model, warpdyn's step of --dt;
2. up to --iterations iLQR iterations (Li and Todorov 2004; Tassa, Erez and Todorov 2012; Gauss-Newton: the
   dynamics' and the flange's first derivatives only):
   - linearise along the plan, x_{t+1} ~ A_t x_t + B_t u_t, t = 0 ... H - 1, by ONE call of
     wd.autodiff.transition_matrices over N = H environments (environment t holds the plan's state t), and the
     flange's position Jacobian at the H + 1 states by ONE call of wd.autodiff.jacobian (of wd.frame.transform)
     over N = H + 1 environments: the whole horizon in one batched backward pass each, the GPU's width;
   - the backward Riccati pass in NumPy: feedforward k_t and gains K_t (Q_uu + mu I, Levenberg-Marquardt);
   - the line search: one batched closed-loop rollout of N = 6 step sizes a = 1, 1/2, ..., 1/32 (u = u_plan +
     a k + K (x - x_plan)), their costs from one forward-kinematics call over all their states; the cheapest is
     kept if it lowers the cost, else mu grows tenfold and the plan stays; the iterations stop after a decrease
     of J below --tolerance (1 %);
3. the plan's first torques go to the plant.

The cost over the horizon of H = --horizon steps (30: 0.3 s ahead), p(q) the flange's position [m]:
    J = sum_{t < H} (w_p |p(q_t) - p*_t|^2 + w_q |q_t - q_home|^2 + w_v |v_t|^2 + w_u |u_t - g_t|^2)
        + w_p |p(q_H) - p*_H|^2 + w_q |q_H - q_home|^2 + w_v |v_H|^2
with w_p = 1e4 per m^2, w_q = 1 per rad^2 (the posture, which the 3 coordinates of the task leave free), w_v = 3 per
(rad/s)^2 and w_u = 1e-3 per (N m)^2, around g_t, the gravity torques at the warm start's states
(wd.model.free_floating_gravity_forces, one batched call), held while a control step's iterations run. w_v keeps
the first approach, 12 cm in 0.1 s, within the Panda's joint speed limits (2.2 to 2.6 rad/s: at most 1.4 rad/s
here; w_v = 0.1 tracks 0.3 mm closer but reaches 3.3 rad/s).

Expected output (defaults, float64, CPU): the tracking error falls from 120 mm to 1.3 mm in 0.25 s; after the first
second, RMS 0.80 mm (largest 1.1 mm) with the 10 % mass errors (0.57 mm with --mass-error 0, 1.8 mm with 0.3);
the joints stay 1.29 rad inside their ranges, which warpdyn does not enforce (the load's NotModelledWarning,
filtered here), and the torques reach their limits in the first 3 control steps only. The solver runs 3 iterations
at the first step (J from 4464 to 794), then 1 (the first lowers J by less than 1 %: the warm start is close). On a
2-core CPU: 400 control steps in 7 s warm (15 ms a step), 24 s the first time, when Warp compiles the kernels.
The plot shows the flange's path against the circle, the error and the plan's cost over time, and the torques.

`main(argv)` runs it and returns the history (tests/test_examples.py runs it with few steps).
"""

import argparse
import functools
import pathlib
import time
import warnings

import numpy as np
import warp as wp

import warpdyn as wd
from common import default_device, pyplot

STEP_SIZES = (1.0, 0.5, 0.25, 0.125, 0.0625, 0.03125)  # the line search's candidates, one batched rollout
W_P, W_Q, W_V, W_U = 1e4, 1.0, 3.0, 1e-3  # the cost's weights (module docstring)
MU_MIN, MU_MAX = 1e-6, 1e6  # Levenberg-Marquardt regularisation of Q_uu [cost / (N m)^2]


def build_model(device, time_step: float | None = None, mass_factors=None):
    """The Panda in float64, with `time_step` [s] (default: the file's 2 ms) and its link masses and inertias scaled
    by `mass_factors` (nL,) if given."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)  # the joint limits: main checks them
        model = wd.model.Model.build_from_model_description(wd.assets.franka_panda_mjcf(), dtype=np.float64, device=device)
    if time_step is not None:
        model.time_step = time_step
    if mass_factors is not None:
        f = np.asarray(mass_factors, dtype=np.float64)
        model.set_link_parameters(mass=model.link_mass.numpy() * f, inertia=model.link_inertia.numpy() * f[:, None, None])
    return model


def data_of(model, x: np.ndarray):
    """Data of N environments at the states x (N, 14) = [q; v] [rad, rad/s]."""
    n = model.dofs()
    return wd.data.Data.build(model, num_envs=len(x), joint_positions=x[:, :n], joint_velocities=x[:, n:])


class Controller:
    """iLQR over a horizon of H steps of the model's time step; the plan (x (H + 1, 14), u (H, 7), gains K (H, 7,
    14)) is kept between control steps as the next one's warm start."""

    def __init__(self, model, horizon: int, iterations: int, tolerance: float, u_limit: np.ndarray):
        self.model, self.H, self.iterations, self.tolerance = model, horizon, iterations, tolerance
        self.n = model.dofs()
        self.flange = wd.frame.name_to_idx(model, frame_name=wd.assets.FRANKA_PANDA_FLANGE)
        self.transform = functools.partial(wd.frame.transform, frame_index=self.flange)
        self.q_home = wd.data.keyframe(model, "home").joint_positions.numpy()
        self.u_limit = u_limit
        self.x = self.u = None  # the plan's states (H + 1, 14) and torques (H, 7) [N m]
        self.K = np.zeros((horizon, self.n, 2 * self.n))
        self.mu = MU_MIN

    def positions(self, x: np.ndarray) -> np.ndarray:
        """The flange's positions (..., 3) [m, world] at the states x (..., 14), by one batched call."""
        lead = x.shape[:-1]
        W_H_F = self.transform(self.model, data_of(self.model, x.reshape(-1, 2 * self.n))).numpy()
        return W_H_F[:, :3, 3].reshape(*lead, 3)

    def cost(self, x, u, p, p_star, u_ref) -> np.ndarray:
        """J of the module docstring for plans x (..., H + 1, 14), u (..., H, 7) with flange positions p (..., H + 1, 3)."""
        n = self.n
        state = W_P * ((p - p_star) ** 2).sum(-1) + W_Q * ((x[..., :n] - self.q_home) ** 2).sum(-1) + W_V * (x[..., n:] ** 2).sum(-1)
        return state.sum(-1) + W_U * ((u - u_ref) ** 2).sum((-2, -1))

    def rollout(self, x0, x_plan, u_plan, k, K, step_sizes) -> tuple[np.ndarray, np.ndarray]:
        """Closed-loop rollouts from x0 of u = clip(u_plan + a k + K (x - x_plan)), one environment per step size a:
        (states (S, H + 1, 14), torques (S, H, 7)), S = len(step_sizes), by H batched steps."""
        a = np.asarray(step_sizes)[:, None]
        S, n = len(a), self.n
        x = np.zeros((S, self.H + 1, 2 * n))
        u = np.zeros((S, self.H, n))
        x[:, 0] = x0
        data = data_of(self.model, x[:, 0])
        for t in range(self.H):
            u[:, t] = np.clip(u_plan[t] + a * k[t] + (x[:, t] - x_plan[t]) @ K[t].T, -self.u_limit, self.u_limit)
            data = wd.model.step(self.model, data, joint_force_references=u[:, t])
            x[:, t + 1, :n] = data.joint_positions.numpy()
            x[:, t + 1, n:] = data.joint_velocities.numpy()
        return x, u

    def linearise(self, x, u):
        """(A (H, 14, 14), B (H, 14, 7), the flange position's Jacobians (H + 1, 3, 7) with respect to q): two batched
        backward passes over the horizon, environment t at the plan's state t."""
        AB = wd.autodiff.transition_matrices(self.model, data_of(self.model, x[:-1]), joint_force_references=u)
        J = wd.autodiff.jacobian(self.transform, self.model, data_of(self.model, x))["state"].numpy()  # (H + 1, 16, 14)
        J_p = J.reshape(self.H + 1, 4, 4, 2 * self.n)[:, :3, 3, : self.n]  # the rows of W_H_F's translation
        return AB["A"].numpy(), AB["B"].numpy(), J_p

    def backward(self, x, u, p, J_p, A, B, p_star, u_ref):
        """The Riccati pass of Gauss-Newton iLQR along the plan x (H + 1, 14), u (H, 7) with flange positions p
        (H + 1, 3): feedforward k (H, 7) [N m] and gains K (H, 7, 14). Q_uu is positive definite (W_U > 0, V_xx
        positive semi-definite in Gauss-Newton); mu I added to it shortens the steps after a failed line search."""
        n, H = self.n, self.H

        def state_terms(t):
            e = p[t] - p_star[t]
            l_x = np.concatenate([2 * W_P * J_p[t].T @ e + 2 * W_Q * (x[t, :n] - self.q_home), 2 * W_V * x[t, n:]])
            l_xx = np.zeros((2 * n, 2 * n))
            l_xx[:n, :n] = 2 * W_P * J_p[t].T @ J_p[t] + 2 * W_Q * np.eye(n)
            l_xx[n:, n:] = 2 * W_V * np.eye(n)
            return l_x, l_xx

        V_x, V_xx = state_terms(H)
        k, K = np.zeros((H, n)), np.zeros((H, n, 2 * n))
        for t in reversed(range(H)):
            l_x, l_xx = state_terms(t)
            Q_x = l_x + A[t].T @ V_x
            Q_u = 2 * W_U * (u[t] - u_ref[t]) + B[t].T @ V_x
            Q_xx = l_xx + A[t].T @ V_xx @ A[t]
            Q_ux = B[t].T @ V_xx @ A[t]
            Q_uu = 2 * W_U * np.eye(n) + B[t].T @ V_xx @ B[t]
            gains = -np.linalg.solve(Q_uu + self.mu * np.eye(n), np.column_stack([Q_u, Q_ux]))
            k[t], K[t] = gains[:, 0], gains[:, 1:]
            V_x = Q_x + K[t].T @ Q_uu @ k[t] + K[t].T @ Q_u + Q_ux.T @ k[t]
            V_xx = Q_xx + K[t].T @ Q_uu @ K[t] + K[t].T @ Q_ux + Q_ux.T @ K[t]
            V_xx = 0.5 * (V_xx + V_xx.T)
        return k, K

    def solve(self, x0: np.ndarray, p_star: np.ndarray) -> dict:
        """One control step from the measured state x0 (14,) towards the targets p_star (H + 1, 3) [m] at the plan's
        times: the new plan; its first torques [N m] and the solver's figures."""
        H, n = self.H, self.n
        if self.u is None:  # the first step: gravity torques at x0, no feedback
            self.u = np.tile(wd.model.free_floating_gravity_forces(self.model, data_of(self.model, x0[None])).numpy()[0, 6:], (H, 1))
            self.x = np.tile(x0, (H + 1, 1))
        else:  # the previous plan, shifted one step
            self.u = np.concatenate([self.u[1:], self.u[-1:]])
            self.K = np.concatenate([self.K[1:], self.K[-1:]])
            self.x = np.concatenate([self.x[1:], self.x[-1:]])
        xs, us = self.rollout(x0, self.x, self.u, np.zeros((H, n)), self.K, (0.0,))
        x, u, p = xs[0], us[0], self.positions(xs[0])
        u_ref = wd.model.free_floating_gravity_forces(self.model, data_of(self.model, x[:-1])).numpy()[:, 6:]
        J = start = float(self.cost(x, u, p, p_star, u_ref))
        iterations = 0
        for iterations in range(1, self.iterations + 1):
            A, B, J_p = self.linearise(x, u)
            k, K = self.backward(x, u, p, J_p, A, B, p_star, u_ref)
            xs, us = self.rollout(x0, x, u, k, K, STEP_SIZES)
            ps = self.positions(xs)
            costs = self.cost(xs, us, ps, p_star, u_ref)
            best = int(np.argmin(costs))
            if costs[best] >= J:  # no step size lowers the cost: keep the plan, regularise more
                self.mu = min(self.mu * 10.0, MU_MAX)
                break
            converged = J - costs[best] < self.tolerance * J
            x, u, p, J, self.K = xs[best], us[best], ps[best], float(costs[best]), K
            self.mu = max(self.mu / 10.0, MU_MIN)
            if converged:
                break
        self.x, self.u = x, u
        return {"u": u[0].copy(), "cost": J, "start_cost": start, "iterations": iterations, "mu": self.mu}


def circle(centre: np.ndarray, radius: float, period: float):
    """p*(t) (..., 3) [m]: the target round the circle of `radius` about `centre` in the plane x = centre's x, from
    centre + (0, radius, 0) at t = 0, towards +z first."""

    def target(t):
        phase = 2.0 * np.pi * np.asarray(t, dtype=np.float64)[..., None] / period
        return centre + radius * np.concatenate([np.zeros_like(phase), np.cos(phase), np.sin(phase)], axis=-1)

    return target


def parse_args(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=400, help="control steps (default 400: 4 s)")
    parser.add_argument("--dt", type=float, default=0.01, help="control period and the model's step [s] (default 0.01)")
    parser.add_argument("--horizon", type=int, default=30, help="the plan's steps H (default 30)")
    parser.add_argument("--iterations", type=int, default=3, help="iLQR iterations per control step at most (default 3)")
    parser.add_argument("--tolerance", type=float, default=1e-2, help="stop after a relative decrease of J below this (default 1e-2)")
    parser.add_argument("--radius", type=float, default=0.12, help="the circle's radius [m] (default 0.12)")
    parser.add_argument("--period", type=float, default=3.0, help="one turn of the target [s] (default 3)")
    parser.add_argument("--mass-error", type=float, default=0.1, help="the plant's masses off by up to this fraction (default 0.1)")
    parser.add_argument("--transient", type=float, default=1.0, help="the RMS error is taken after this [s] (default 1)")
    parser.add_argument("--device", default=None, help="Warp device (default: cuda if available, else cpu)")
    parser.add_argument("--plot", default="", help="PNG to write (default: none)")
    parser.add_argument("--print-every", type=int, default=25, help="print every k-th control step (default 25)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the mass errors (default 0)")
    return parser.parse_args(argv)


def main(argv=None) -> dict:
    """Run the closed loop. Returns NumPy arrays per control step: "time" [s], "error" (the flange's distance to
    the target [m]), "position" and "target" (., 3) [m], "torque" (., 7) [N m], "joint_positions" (., 7) [rad],
    "joint_velocities" (., 7) [rad/s],
    "cost" and "start_cost" (the plan's J after and before the iterations), "iterations", "solve_time" [s]; and
    "rms" [m] after the transient, "mass_factors" (nL,), "wall_time" [s]."""
    args = parse_args(argv)
    wp.config.quiet = True
    wp.config.log_level = wp.LOG_WARNING
    wp.init()
    device = args.device or default_device()
    started = time.perf_counter()
    model = build_model(device, args.dt)
    rng = np.random.default_rng(args.seed)
    mass_factors = 1.0 + args.mass_error * rng.uniform(-1.0, 1.0, model.number_of_links())
    plant = build_model(device, mass_factors=mass_factors)
    n, substeps = model.dofs(), max(1, round(args.dt / plant.time_step))
    u_limit = np.array(wd.assets.FRANKA_PANDA_TORQUE_LIMITS)
    data = wd.data.keyframe(plant, "home", num_envs=1)
    x = np.concatenate([data.joint_positions.numpy()[0], data.joint_velocities.numpy()[0]])
    controller = Controller(model, args.horizon, args.iterations, args.tolerance, u_limit)
    centre = controller.positions(x[None])[0]
    target = circle(centre, args.radius, args.period)

    print(f"{model!r}: the Panda, {n} joints, on '{device}'; plant: {plant.time_step * 1e3:g} ms steps, link masses x "
          f"{np.array2string(mass_factors[1:], precision=3)}")
    print(f"target: a circle of {args.radius * 100:g} cm about {np.round(centre, 4)} m (plane x = {centre[0]:.3f} m), "
          f"{args.period:g} s a turn; MPC: H = {args.horizon} steps of {args.dt * 1e3:g} ms, {args.iterations} iLQR iterations at most")
    print(f"{'t [s]':>6} {'error [mm]':>11} {'cost':>10} {'(start)':>10} {'iter':>5} {'solve [ms]':>11} {'max|tau| [N m]':>15}")
    names = ("time", "error", "position", "target", "torque", "joint_positions", "joint_velocities", "cost", "start_cost", "iterations",
             "solve_time")
    history = {name: [] for name in names}
    for i in range(args.steps):
        t = i * args.dt
        p = controller.positions(x[None])[0]
        tic = time.perf_counter()
        out = controller.solve(x, target(t + args.dt * np.arange(args.horizon + 1)))
        solve_time = time.perf_counter() - tic
        u = out["u"]  # within the limits: the rollouts clip
        for name, value in (("time", t), ("error", np.linalg.norm(p - target(t))), ("position", p), ("target", target(t)), ("torque", u),
                            ("joint_positions", x[:n]), ("joint_velocities", x[n:]), ("cost", out["cost"]), ("start_cost", out["start_cost"]),
                            ("iterations", out["iterations"]), ("solve_time", solve_time)):
            history[name].append(value)
        if i % args.print_every == 0 or i == args.steps - 1:
            print(f"{t:6.2f} {history['error'][-1] * 1e3:11.2f} {out['cost']:10.4g} {out['start_cost']:10.4g} {out['iterations']:5d} "
                  f"{solve_time * 1e3:11.1f} {np.abs(u).max():15.2f}")
        for _ in range(substeps):
            data = wd.model.step(plant, data, joint_force_references=u[None])
        x = np.concatenate([data.joint_positions.numpy()[0], data.joint_velocities.numpy()[0]])
    result = {k: np.array(v) for k, v in history.items()}
    after = result["time"] >= args.transient
    result["rms"] = float(np.sqrt(np.mean(result["error"][after] ** 2))) if after.any() else float("nan")
    result["mass_factors"] = mass_factors
    result["wall_time"] = time.perf_counter() - started
    limits = model.parameter("position_limits").numpy()  # (7, 2) [rad]: not enforced by warpdyn (NotModelledWarning)
    q = result["joint_positions"]
    margin = float(min((q - limits[:, 0]).min(), (limits[:, 1] - q).min()))
    saturated = int((np.abs(result["torque"]) >= u_limit).any(axis=1).sum())
    print(f"tracking error: {result['error'][0] * 1e3:.1f} mm at the start, RMS {result['rms'] * 1e3:.2f} mm after "
          f"{args.transient:g} s (largest {result['error'][after].max(initial=0.0) * 1e3:.2f} mm)")
    print(f"joints {'inside' if margin > 0 else 'OUTSIDE'} their ranges (closest {abs(margin):.3f} rad "
          f"{'inside' if margin > 0 else 'beyond'} a limit), at most {np.abs(result['joint_velocities']).max():.2f} rad/s; "
          f"torques at a limit in {saturated} of {args.steps} steps")
    print(f"solver: median {np.median(result['solve_time']) * 1e3:.1f} ms a control step, {result['iterations'].mean():.2f} "
          f"iterations on average; {args.steps} steps in {result['wall_time']:.1f} s")
    if args.plot:
        plot(result, args.plot)
        print(f"wrote {args.plot}")
    return result


def plot(result: dict, path) -> None:
    plt = pyplot()

    fig, axes = plt.subplots(2, 2, figsize=(12, 8))
    ax = axes[0, 0]
    ax.plot(result["target"][:, 1], result["target"][:, 2], "k:", label="target p*")
    ax.plot(result["position"][:, 1], result["position"][:, 2], label="flange p")
    ax.set_aspect("equal")
    ax.set_xlabel("y [m]")
    ax.set_ylabel("z [m]")
    ax.set_title("the flange's path in the plane of the circle")
    ax.legend()
    t = result["time"]
    ax = axes[0, 1]
    ax.semilogy(t, result["error"] * 1e3)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("|p - p*| [mm]")
    ax.set_title("tracking error")
    ax = axes[1, 0]
    ax.semilogy(t, result["start_cost"], ":", label="warm start")
    ax.semilogy(t, result["cost"], label="after iLQR")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("J")
    ax.set_title("the plan's cost")
    ax.legend()
    ax = axes[1, 1]
    for j in range(result["torque"].shape[1]):
        ax.plot(t, result["torque"][:, j], label=f"joint{j + 1}")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("torque [N m]")
    ax.set_title("the plant's torques")
    ax.legend(fontsize=8)
    fig.tight_layout()
    pathlib.Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


if __name__ == "__main__":
    main()
