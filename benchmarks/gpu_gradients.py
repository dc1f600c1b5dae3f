"""GPU correctness of differentiable simulation: tape gradients through a contact rollout on the GPU equal the
CPU's, a checkpointed rollout equals the plain one there, and the torch bridge on CUDA equals the plain tape.

    python benchmarks/gpu_gradients.py --write-reference grad_ref.npz     # here, on the CPU
    python benchmarks/gpu_gradients.py --reference grad_ref.npz           # on the GPU machine

CI has no GPU: the CPU's gradients (checked against finite differences by tests/test_rollout_gradients.py
and tests/test_domain_randomisation.py) are the reference for the environment-fastest layout, the CUDA
kernels' adjoints and their atomics. The case: the seed's ergoCub legs standing 3 mm deep on flat ground,
N = 33 environments (not a multiple of a warp), 20 steps of 1 ms, with per-environment link masses,
contact stiffness K and ground heights; gradients of a fixed random weighted sum of the recorded base
positions, joint positions and link contact wrenches with respect to the initial base position, joint
positions and velocities, the per-step torques and the parameters link_mass (N, nL), friction_viscous (n,)
shared, K (N,) and terrain_height (N,). Tolerances, relative to each gradient's largest entry: 1e-9 in
float64 (the GPU sums shared-parameter gradients with atomics in another order: rounding 1e-16 amplified
by the stiff contacts), 1e-2 in float32; the torch bridge and the checkpointed rollout against the plain
tape on the same device: 1e-12 (the same kernels; only sums reorder). Exits non-zero on a failure.
"""

import argparse
import functools
import sys

import numpy as np
import warp as wp

import warpdyn as wd
from common import header, init_warp, np_dtype, seed_model, write_reference

N, T = 33, 20
TOLERANCE = {"float64": 1e-9, "float32": 1e-2}
SAME_DEVICE = 1e-12
INPUTS = ("base_position", "joint_positions", "joint_velocities")
PARAMETERS = ("link_mass", "friction_viscous", "K", "terrain_height")
RECORDS = ("base_position", "joint_positions", "link_contact_forces")


def case(model, seed: int = 0) -> dict[str, np.ndarray]:
    """The initial state, torques, per-environment parameters and loss weights (NumPy, float64)."""
    rng = np.random.default_rng(seed)
    n, nL = model.dofs(), model.number_of_links()
    low = wd.contact.collidable_point_positions(model, wd.data.Data.build(model)).numpy()[:, 2].min()
    heights = rng.uniform(-0.01, 0.01, N)
    base = np.zeros((N, 3))
    base[:, 0] = rng.uniform(-0.1, 0.1, N)
    base[:, 2] = heights - low - 0.003
    return {
        "base_position": base,
        "joint_positions": rng.uniform(-0.05, 0.05, (N, n)),
        "joint_velocities": rng.uniform(-0.1, 0.1, (N, n)),
        "tau": rng.normal(size=(T, N, n)),
        "link_mass": model.tree.link_mass[None] * rng.uniform(0.9, 1.1, (N, nL)),
        "friction_viscous": np.full(n, 0.1),
        "K": rng.uniform(5e5, 1e6, N),
        "terrain_height": heights,
        "w/base_position": rng.normal(size=(T + 1, N, 3)),
        "w/joint_positions": rng.normal(size=(T + 1, N, n)),
        "w/link_contact_forces": rng.normal(size=(T, N, nL, 6)) * 1e-3,
    }


def configure(model, c: dict) -> dict:
    """Set the case's parameters on the model and mark them; {name: Warp array}."""
    model.set_link_parameters(mass=c["link_mass"])
    model.set_joint_parameters(friction_viscous=c["friction_viscous"])
    model.contact_params = wd.model.SoftContactsParams(K=c["K"], D=2000.0)
    model.terrain = wd.terrain.FlatTerrain(height=c["terrain_height"])
    return wd.model.parameters_requiring_grad(model, names=PARAMETERS)


@functools.cache
def _loss_kernels(scalar):
    """{ndim: kernel} adding sum of w * x over 2-D to 4-D arrays of any strides to out (no `from __future__
    import annotations` in this file: Warp reads the annotations' scalar)."""

    @wp.kernel
    def weighted2(x: wp.array(dtype=scalar, ndim=2), w: wp.array(dtype=scalar, ndim=2), out: wp.array(dtype=scalar)):
        i, j = wp.tid()
        wp.atomic_add(out, 0, w[i, j] * x[i, j])

    @wp.kernel
    def weighted3(x: wp.array(dtype=scalar, ndim=3), w: wp.array(dtype=scalar, ndim=3), out: wp.array(dtype=scalar)):
        i, j, k = wp.tid()
        wp.atomic_add(out, 0, w[i, j, k] * x[i, j, k])

    @wp.kernel
    def weighted4(x: wp.array(dtype=scalar, ndim=4), w: wp.array(dtype=scalar, ndim=4), out: wp.array(dtype=scalar)):
        i, j, k, l = wp.tid()
        wp.atomic_add(out, 0, w[i, j, k, l] * x[i, j, k, l])

    return {2: weighted2, 3: weighted3, 4: weighted4}


def tape_gradients(model, c: dict, storage: str = "trajectory", **kwargs) -> dict[str, np.ndarray]:
    """Gradients of the case's loss by wp.Tape through wd.simulation.rollout (storage as given)."""
    s, d = model.scalar, model.device
    params = configure(model, c)
    state = {k: wp.array(c[k], dtype=s, device=d, requires_grad=True) for k in INPUTS}
    tau = wp.array(c["tau"], dtype=s, device=d, requires_grad=True)
    kernels = _loss_kernels(s)
    tape = wp.Tape()
    with tape:
        data = wd.data.Data.build(model, num_envs=N, requires_grad=True, **state)
        _, rec = wd.simulation.rollout(model, data, steps=T, joint_force_references=tau, record=RECORDS, storage=storage, **kwargs)
        loss = wp.zeros(1, dtype=s, device=d, requires_grad=True)
        for name in RECORDS:
            x = rec[name]
            w = wp.array(c[f"w/{name}"], dtype=s, device=d)
            wp.launch(kernels[x.ndim], dim=x.shape, inputs=[x, w], outputs=[loss], device=d)
    tape.backward(loss)
    out = {k: a.grad.numpy() for k, a in state.items()}
    out["tau"] = tau.grad.numpy()
    out.update({k: a.grad.numpy() for k, a in params.items()})
    out["loss"] = loss.numpy()
    return out


def bridge_gradients(model, c: dict) -> dict[str, np.ndarray]:
    """The same gradients through warpdyn.torch.rollout with CUDA tensors (torch's autograd)."""
    import torch

    import warpdyn.torch as wdt

    configure(model, c)
    dev = wp.device_to_torch(model.device)
    dtype = wp.dtype_to_torch(model.scalar)

    def t(x):
        return torch.tensor(np.asarray(x), dtype=dtype, device=dev, requires_grad=True)

    state = {k: t(c[k]) for k in INPUTS}
    tau = t(c["tau"])
    params = {k: t(c[k]) for k in PARAMETERS}
    rec = wdt.rollout(model, steps=T, **state, joint_force_references=tau, parameters=params, record=RECORDS, num_envs=N)
    loss = sum((torch.tensor(c[f"w/{k}"], dtype=dtype, device=dev) * rec[k]).sum() for k in RECORDS)
    loss.backward()
    out = {k: v.grad.cpu().numpy() for k, v in state.items()}
    out["tau"] = tau.grad.cpu().numpy()
    out.update({k: v.grad.cpu().numpy() for k, v in params.items()})
    return out


def solver_gradients(model, c: dict, solver) -> dict[str, np.ndarray]:
    """Gradients of sum(w * accelerations) of one forward-dynamics solver at the case's initial state
    (per-environment masses) w.r.t. the joint positions, velocities, torques and link masses: ABA against
    CRBA + Cholesky, whose solve has a hand-registered implicit adjoint."""
    s, d = model.scalar, model.device
    model.set_link_parameters(mass=c["link_mass"])
    params = wd.model.parameters_requiring_grad(model, names=("link_mass",))
    state = {k: wp.array(c[k], dtype=s, device=d, requires_grad=True) for k in ("joint_positions", "joint_velocities")}
    tau = wp.array(c["tau"][0], dtype=s, device=d, requires_grad=True)
    kernels = _loss_kernels(s)
    tape = wp.Tape()
    with tape:
        data = wd.data.Data.build(model, base_position=c["base_position"], num_envs=N, requires_grad=True, **state)
        base, joints = solver(model, data, joint_forces=tau)
        loss = wp.zeros(1, dtype=s, device=d, requires_grad=True)
        for x, w in ((base, np.tile(c["w/base_position"][0], (1, 2))), (joints, c["w/joint_positions"][0])):
            wp.launch(kernels[2], dim=x.shape, inputs=[x, wp.array(w, dtype=s, device=d)], outputs=[loss], device=d)
    tape.backward(loss)
    out = {k: a.grad.numpy() for k, a in state.items()}
    out["tau"] = tau.grad.numpy()
    out["link_mass"] = params["link_mass"].grad.numpy()
    return out


def compare(name: str, got: dict, reference: dict, tol: float) -> int:
    failures = 0
    for key, ref in reference.items():
        if key == "loss":
            continue
        scale = max(float(np.abs(ref).max()), 1e-300)
        error = float(np.abs(got[key] - ref).max()) / scale
        ok = error <= tol and np.all(np.isfinite(got[key]))
        failures += not ok
        print(f"{name:34s} {key:18s} max diff / max |g| {error:.2e} {'ok' if ok else 'FAIL'}")
    return failures


def main() -> int:
    parser = argparse.ArgumentParser()
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--write-reference")
    group.add_argument("--reference")
    parser.add_argument("--device", default="cuda:0", help="device checked against the reference")
    args = parser.parse_args()
    init_warp()
    if args.write_reference:
        write_reference(args.write_reference, TOLERANCE, case, tape_gradients, labels=("case", "grad"))
        return 0
    reference = np.load(args.reference)
    print(header(args.device))
    failures = 0
    for dtype_name, tol in TOLERANCE.items():
        c = {k.split("/", 2)[2]: reference[k] for k in reference.files if k.startswith(f"{dtype_name}/case/")}
        ref = {k.split("/", 2)[2]: reference[k] for k in reference.files if k.startswith(f"{dtype_name}/grad/")}
        got = tape_gradients(seed_model(np_dtype[dtype_name], args.device), c)
        failures += compare(f"{dtype_name} tape vs CPU", got, ref, tol)
        if dtype_name == "float64":
            aba = solver_gradients(seed_model(np.float64, args.device), c, wd.model.forward_dynamics_aba)
            crb = solver_gradients(seed_model(np.float64, args.device), c, wd.model.forward_dynamics_crb)
            failures += compare("float64 CRB (implicit adjoint) vs ABA", crb, aba, 1e-9)
            checkpointed = tape_gradients(seed_model(np.float64, args.device), c, storage="checkpointed", checkpoint_every=6)
            failures += compare("float64 checkpointed vs tape", checkpointed, got, SAME_DEVICE)
            try:
                import torch  # noqa: F401
            except ImportError:
                print("torch is not installed: the bridge is not checked")
                continue
            failures += compare("float64 torch bridge vs tape", bridge_gradients(seed_model(np.float64, args.device), c), got, SAME_DEVICE)
    print(f"{wp.get_device(args.device).name}: {failures} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
