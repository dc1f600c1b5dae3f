"""What a step's A = ∂x'/∂x and B = ∂x'/∂τ cost: warpdyn's batched reverse pass (`wd.autodiff.transition_matrices`)
against MuJoCo's finite differences (`mujoco.mjd_transitionFD`, centred) and JaxSim's forward mode (`jax.jacfwd` of
`js.model.step`, vmapped and jitted), on one device, in one process.

    python benchmarks/jacobians.py [--device cpu | cuda:0] [--sizes 1,64,1024] [--dtype float64]
                                   [--libraries warpdyn,warpdyn-central,mujoco,jaxsim] [--repeats 5] [--output-dir DIR]

The scene: the ergoCub legs (12 joints, every other joint locked and lumped), floating base, in the air (no
contacts: the three compute the same smooth dynamics), dt = 1 ms, semi-implicit Euler (MuJoCo: its Euler with
implicit damping; the URDF has no damping, so the same); per environment a random state (joint positions
±0.3 rad, velocities ~0.5) and random torques. The state's tangent has nx = 2 (6 + 12) = 36 numbers, B 12 columns.
- warpdyn: `transition_matrices(model, data, joint_force_references=tau)`, N environments at once (N x 36 copies in
  one taped step and one backward pass), A and B exact to rounding; and `method="central"`: MuJoCo's scheme, central
  differences of h = 1e-6 in the tangent, N x 97 copies in one untaped (fused) step.
- MuJoCo: `mjd_transitionFD(m, d, 1e-6, centred)` once per environment, one CPU thread (the same call per
  environment; N calls). Its A has MuJoCo's tangent (base rotation in base axes).
- JaxSim 0.9: `jax.jit(jax.vmap(jax.jacfwd(f, argnums=(0, 1))))` with f(x, τ) the next state of `js.model.step` as one
  vector (base position, quaternion, joints, base velocity (Inertial) and joint velocities: 37 inputs, 43 with the
  quaternion counted in), so its Jacobians are in JaxSim's coordinates, not the tangent: what a JaxSim user gets.
Each is timed by benchmarks/compare.py's timed_runs (the first call apart, the median of --repeats after a warm-up). The
table gives per N the time of one call and the time per environment; a library missing or failing says why.
JaxSim and MuJoCo here run on the CPU whatever --device says (MuJoCo has no GPU path for this; JaxSim on a GPU needs
jax[cuda] on the device machine); their rows say where they ran.
"""

from __future__ import annotations

import os

os.environ.setdefault("ROD_SKIP_SDFORMAT_CHECK", "1")
os.environ.setdefault("XLA_PYTHON_CLIENT_PREALLOCATE", "false")

import argparse
import pathlib
import sys
import warnings

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import header, init_warp  # noqa: E402
from compare import timed_runs  # noqa: E402
from compare_scene import mujoco_spec, strip_urdf, urdf_to_sdf  # noqa: E402

DT = 1e-3


def states(N: int, n: int, seed: int = 0) -> dict:
    rng = np.random.default_rng(seed)
    return {
        "s": rng.uniform(-0.3, 0.3, (N, n)),
        "sdot": rng.normal(0.0, 0.5, (N, n)),
        "v": rng.normal(0.0, 0.2, (N, 6)),
        "tau": rng.normal(0.0, 5.0, (N, n)),
    }


def run_warpdyn(args, N: int, joints, method: str = "reverse") -> tuple:
    import warp as wp

    import warpdyn as wd

    dtype = np.float64 if args.dtype == "float64" else np.float32
    full = wd.model.Model.build_from_model_description(wd.assets.ergocub_urdf(), dtype=dtype, device=args.device)
    model = wd.contact.with_collidable_points(wd.model.reduce(full, considered_joints=joints), enabled_links=())
    model.time_step = DT
    x = states(N, model.dofs())
    data = wd.data.Data.build(model, num_envs=N, base_position=(0.0, 0.0, 1.0), joint_positions=x["s"], joint_velocities=x["sdot"],
                              base_linear_velocity=x["v"][:, :3], base_angular_velocity=x["v"][:, 3:])
    tau = wp.array(x["tau"], dtype=model.scalar, device=model.device)
    out = {}

    def run():
        out["AB"] = wd.autodiff.transition_matrices(model, data, joint_force_references=tau, method=method)

    first, median = timed_runs(run, lambda: wp.synchronize_device(model.device), args.repeats)
    finite = bool(np.isfinite(out["AB"]["A"].numpy()).all())
    return first, median, f"{wp.get_device(args.device).name}, {args.dtype}, A and B finite: {finite}"


def run_mujoco(args, N: int, joints) -> tuple:
    import mujoco

    from warpdyn.assets import ergocub_urdf

    spec = mujoco_spec(strip_urdf(pathlib.Path(ergocub_urdf()).read_text(), keep_joints=joints), time_step=DT, mu=0.5)
    m = spec.compile()
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    nv = m.nv
    x = states(N, nv - 6)
    datas = []
    for e in range(N):
        d = mujoco.MjData(m)
        d.qpos[2] = 1.0
        d.qpos[7:] = x["s"][e]
        d.qvel[:6] = x["v"][e]
        d.qvel[6:] = x["sdot"][e]
        d.qfrc_applied[6:] = x["tau"][e]
        datas.append(d)
    A = np.zeros((2 * nv, 2 * nv))
    B = np.zeros((2 * nv, m.nu))

    def run():
        for d in datas:
            mujoco.mjd_transitionFD(m, d, 1e-6, 1, A, B, None, None)

    first, median = timed_runs(run, lambda: None, args.repeats)
    return first, median, f"CPU, one thread, float64, mujoco {mujoco.__version__}; B over qfrc_applied is not MuJoCo's (it has no actuators here): A only"


def run_jaxsim(args, N: int, joints) -> tuple:
    import jax
    import jax.numpy as jnp
    import jaxsim  # noqa: F401
    import jaxsim.api as js

    from warpdyn.assets import ergocub_urdf

    jax.config.update("jax_enable_x64", args.dtype == "float64")
    cpu = jax.devices("cpu")[0]
    with warnings.catch_warnings(), jax.default_device(cpu):
        warnings.simplefilter("ignore")
        full = js.model.JaxSimModel.build_from_model_description(urdf_to_sdf(strip_urdf(pathlib.Path(ergocub_urdf()).read_text())), time_step=DT)
        model = js.model.reduce(full, considered_joints=tuple(joints))
        model = js.contact.with_collidable_points(model, []) if hasattr(js.contact, "with_collidable_points") else model
        n = model.dofs()
        x = states(N, n)
        one = js.data.JaxSimModelData.build(model=model, base_position=jnp.array([0.0, 0.0, 1.0]))

        def split(v):
            return v[:3], v[3:7], v[7 : 7 + n], v[7 + n : 13 + n], v[13 + n :]

        def f(v, tau):
            p, Q, s, base_v, sdot = split(v)
            data = one.replace(model=model, base_position=p, base_quaternion=Q, joint_positions=s, base_linear_velocity=base_v[:3],
                               base_angular_velocity=base_v[3:], joint_velocities=sdot, validate=False)
            new = js.model.step(model, data, joint_force_references=tau)
            return jnp.concatenate([new.base_position, new.base_quaternion, new.joint_positions, new.base_velocity, new.joint_velocities])

        v0 = np.concatenate([np.tile([0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0], (N, 1)), x["s"], x["v"], x["sdot"]], axis=1)
        v0, tau = jnp.asarray(v0), jnp.asarray(x["tau"])
        jac = jax.jit(jax.vmap(jax.jacfwd(f, argnums=(0, 1))))
        out = {}

        def run():
            out["J"] = jac(v0, tau)

        first, median = timed_runs(run, lambda: jax.block_until_ready(out.get("J")), args.repeats)
    finite = bool(np.isfinite(np.asarray(out["J"][0])).all())
    return first, median, f"CPU, jax {jax.__version__}, {args.dtype}, jaxsim {jaxsim.__version__}, Jacobians finite: {finite}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--sizes", default=None, help="comma-separated N (default 1,64,1024 on the CPU; 1,1024,4096,16384 on CUDA)")
    parser.add_argument("--dtype", default="float64", choices=("float32", "float64"))
    parser.add_argument("--libraries", default="warpdyn,warpdyn-central,mujoco,jaxsim")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--max-mujoco-envs", type=int, default=1024, help="larger N are skipped for MuJoCo and JaxSim (CPU)")
    parser.add_argument("--output-dir", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "results"))
    args = parser.parse_args()
    init_warp()
    import warp as wp

    import warpdyn as wd

    cuda = wp.get_device(args.device).is_cuda
    sizes = [int(s) for s in (args.sizes or ("1,1024,4096,16384" if cuda else "1,64,1024")).split(",")]
    joints = tuple(wd.assets.ERGOCUB_LEG_JOINTS)
    runners = {"warpdyn": run_warpdyn, "warpdyn-central": lambda *a: run_warpdyn(*a, method="central"), "mujoco": run_mujoco, "jaxsim": run_jaxsim}
    titles = {"warpdyn": "warpdyn reverse (exact)", "warpdyn-central": "warpdyn central differences", "mujoco": "MuJoCo mjd_transitionFD",
              "jaxsim": "JaxSim jax.jacfwd"}
    lines = [header(args.device), "", f"A, B of one step of the ergoCub legs (12 joints, floating base, no contacts), {args.dtype}; "
             "times per call (N environments) and per environment, medians.", "",
             "| library | N | first call | call | per environment | where |", "| --- | --- | --- | --- | --- | --- |"]
    for name in args.libraries.split(","):
        for N in sizes:
            if not name.startswith("warpdyn") and N > args.max_mujoco_envs:
                continue
            try:
                first, median, where = runners[name](args, N, joints)
                row = f"| {titles[name]} | {N} | {first * 1e3:.1f} ms | {median * 1e3:.3f} ms | {median / N * 1e6:.2f} µs | {where} |"
            except ImportError as error:
                row = f"| {titles[name]} | {N} | not installed ({error.name}) | | | |"
            except Exception as error:  # a failing library is reported; the others still run
                row = f"| {titles[name]} | {N} | failed: {type(error).__name__}: {str(error).splitlines()[0][:120]} | | | |"
            print(row, flush=True)
            lines.append(row)
    os.makedirs(args.output_dir, exist_ok=True)
    device = wp.get_device(args.device)
    path = os.path.join(args.output_dir, f"jacobians_{'cpu' if not device.is_cuda else device.name.lower().replace(' ', '_')}.md")
    pathlib.Path(path).write_text("\n".join(lines) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
