"""Gradient reproducibility on a device: what varies from run to run, and between two backward passes.

    python benchmarks/reproducibility.py [--device cuda:0]

The seed's legs with collidable points standing on flat ground (float64, Body representation), per-step
joint torques and link forces, a rollout under a wp.Tape, a random linear loss of its records. Prints:
1. run to run (a fresh forward and backward each time, three runs): the largest difference of every
   gradient, with the marked parameters shared by the environments (default, and
   parameters_requiring_grad(..., deterministic=True)) and given per environment (their shared value
   tiled), at N = 8 (T = 6) and N = 4096 (T = 50, checkpointed), and the median time of a forward and
   backward pass (the cost of deterministic=True);
2. ABA's backward kernel replayed four times with the same output adjoints: whether its input adjoints
   differ between replays, and how many entries of its forward scratch it rewrites (and by how much),
   with the scratch left as the replays leave it and restored before each replay.
--no-fuse-fp compiles every kernel without floating-point contraction (warpdyn.config.fuse_fp = False):
the replays then agree, and the times show its cost. On the CPU every difference is 0; docs/differentiation.md
("Reproducibility") and RESULTS.md quote a GPU's.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import warp as wp

import warpdyn as wd
from common import header, init_warp, seed_model
from warpdyn import VelRepr
from warpdyn.engine import warp_private
from warpdyn.kernels.aba import kernels as aba_kernels

PARAMETERS = ("link_mass", "friction_viscous", "K", "terrain_height")
RECORD = ("joint_positions", "base_velocity", "tangential_deformation", "joint_torques", "link_contact_forces")


def legs(device, N: int, per_environment: bool):
    model = wd.contact.with_collidable_points(seed_model(np.float64, device))
    model.contact_params = wd.model.SoftContactsParams(K=1e6, D=2e3, mu=0.5)
    model.terrain = wd.terrain.FlatTerrain(height=0.0)
    model.set_joint_parameters(friction_viscous=np.full(model.dofs(), 0.3))
    if per_environment:
        model.set_link_parameters(mass=np.tile(model.link_mass.numpy(), (N, 1)))
        model.set_joint_parameters(friction_viscous=np.full((N, model.dofs()), 0.3))
        model.contact_params = wd.model.SoftContactsParams(K=np.full(N, 1e6), D=np.full(N, 2e3), mu=np.full(N, 0.5))
        model.terrain = wd.terrain.FlatTerrain(height=np.zeros(N))
    return model


def standing(model, N: int, requires_grad: bool = True):
    return wd.data.random_model_data(
        model, key=4, num_envs=N, velocity_representation=VelRepr.Body, requires_grad=requires_grad,
        base_pos_bounds=((-0.1, -0.1, 0.56), (0.1, 0.1, 0.58)), base_rpy_bounds=(-0.2, 0.2), joint_pos_bounds=(-0.3, 0.3),
    )  # fmt: skip


@wp.kernel
def _weighted_sum_2d(x: wp.array2d(dtype=wp.float64), w: wp.array2d(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
    i, j = wp.tid()
    wp.atomic_add(out, 0, w[i, j] * x[i, j])


@wp.kernel
def _weighted_sum_3d(x: wp.array3d(dtype=wp.float64), w: wp.array3d(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
    i, j, k = wp.tid()
    wp.atomic_add(out, 0, w[i, j, k] * x[i, j, k])


@wp.kernel
def _weighted_sum_4d(x: wp.array4d(dtype=wp.float64), w: wp.array4d(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
    i, j, k, m = wp.tid()
    wp.atomic_add(out, 0, w[i, j, k, m] * x[i, j, k, m])


WEIGHTED_SUM = {2: _weighted_sum_2d, 3: _weighted_sum_3d, 4: _weighted_sum_4d}


MODES = ("shared", "shared, deterministic=True", "per environment")


def gradients(device, N: int, T: int, mode: str, storage: str) -> tuple[dict, float]:
    """({name: gradient}, seconds) of one fresh forward and backward pass."""
    model = legs(device, N, mode == "per environment")
    params = wd.model.parameters_requiring_grad(model, names=PARAMETERS, deterministic=mode == "shared, deterministic=True")
    data = standing(model, N)
    rng = np.random.default_rng(2)
    tau = wp.array(5.0 * rng.normal(size=(T, N, model.dofs())), dtype=wp.float64, requires_grad=True, device=device)
    f = wp.array(rng.normal(size=(T, N, model.number_of_links(), 6)), dtype=wp.float64, requires_grad=True, device=device)
    wp.synchronize_device(device)
    start = time.perf_counter()
    tape = wp.Tape()
    with tape:
        final, rec = wd.simulation.Rollout(model, steps=T, record=RECORD, storage=storage).run(data, joint_force_references=tau, link_forces=f)
        loss = wp.zeros(1, dtype=wp.float64, requires_grad=True, device=device)
        weights = np.random.default_rng(3)
        for x in [rec[name] for name in RECORD] + [final.joint_positions_state]:
            w = wp.array(weights.normal(size=x.shape), dtype=wp.float64, device=device)
            wp.launch(WEIGHTED_SUM[x.ndim], dim=x.shape, inputs=[x, w], outputs=[loss], device=device)
    tape.backward(loss)
    wp.synchronize_device(device)
    seconds = time.perf_counter() - start
    state = {"base_position": data.base_position_state, "joint_positions": data.joint_positions_state,
             "base_velocity": data.base_velocity_state, "tangential_deformation": data.tangential_deformation_state}  # fmt: skip
    return {k: a.grad.numpy().copy() for k, a in {**state, "tau": tau, "link_forces": f, **params}.items()}, seconds


def run_to_run(device, N: int, T: int, storage: str) -> None:
    for mode in MODES:
        gradients(device, N, T, mode, storage)  # compiles what the mode needs
        runs, seconds = zip(*(gradients(device, N, T, mode, storage) for _ in range(3)))
        diffs = {k: max(float(np.abs(runs[0][k] - r[k]).max()) for r in runs[1:]) for k in runs[0]}
        cells = ", ".join(f"{k} {v:.2g}" for k, v in diffs.items())
        print(f"| {N} | {T} | {storage} | {mode} | {1e3 * float(np.median(seconds)):.1f} | {cells} |", flush=True)


def arrays_of(x) -> list:
    if isinstance(x, wp.array):
        return [x]
    fields = warp_private.struct_fields(x)
    return [a for name in fields for a in arrays_of(getattr(x, name))] if fields is not None else []


def _step_tape(model, data, device):
    rng = np.random.default_rng(2)
    tape = wp.Tape()
    with tape:
        tau = wp.array(5.0 * rng.normal(size=(1, model.dofs())), dtype=wp.float64, requires_grad=True, device=device)
        wd.model.step(model, data, joint_force_references=tau)
    return tape, next(launch for launch in warp_private.tape_kernel_launches(tape) if launch.kernel is aba_kernels(wp.float64, "tuned", False).aba)


def aba_replays(device) -> None:
    model = wd.contact.with_collidable_points(seed_model(np.float64, device))
    data = standing(model, 1)
    tape, recorded = _step_tape(model, data, device)
    rng = np.random.default_rng(2)
    kernel, dim, max_blocks, inputs, outputs, dev, block_dim = recorded[:7]
    scratch = inputs[-1]
    ins = [a for x in inputs for a in arrays_of(x) if a.grad is not None and a.size]
    outs = [a for x in outputs for a in arrays_of(x) if a.grad is not None and a.size]
    values = [rng.normal(size=o.shape) for o in outs]
    forward = scratch.numpy().copy()
    for restore in (False, True):
        grads, scratches = [], []
        for _ in range(4):
            for a in ins:
                a.grad.zero_()
            for o, v in zip(outs, values):
                o.grad.assign(v)
            if restore:
                scratch.assign(forward)
            adj_in, adj_out = [tape.get_adjoint(x) for x in inputs], [tape.get_adjoint(x) for x in outputs]
            wp.launch(kernel, dim=dim, inputs=inputs, outputs=outputs, adj_inputs=adj_in, adj_outputs=adj_out,
                      adjoint=True, device=dev, block_dim=block_dim, max_blocks=max_blocks)  # fmt: skip
            grads.append([a.grad.numpy().copy() for a in ins])
            scratches.append(scratch.numpy().copy())
        grad_diff = max(float(np.abs(g0 - g).max()) for other in grads[1:] for g0, g in zip(grads[0], other))
        after = scratches[-1]
        rewritten = (after != forward) & ~(np.isnan(after) & np.isnan(forward))  # entries the forward never writes hold what they held
        change = float(np.abs(after - forward)[rewritten].max()) if rewritten.any() else 0.0
        label = "restored before each replay" if restore else "as the replays leave it"
        print(f"| {label} | {grad_diff:.2g} | {int(rewritten.sum())} of {forward.size} | {change:.2g} |", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--device", default=None)
    parser.add_argument("--large", type=int, default=4096, help="N of the second run-to-run case (T = 50)")
    parser.add_argument("--no-fuse-fp", action="store_true", help="warpdyn.config.fuse_fp = False: no fused multiply-adds")
    args = parser.parse_args()
    wd.config.fuse_fp = not args.no_fuse_fp
    init_warp()
    device = wp.get_device(args.device)
    print(header(device))
    print(f"warpdyn.config.fuse_fp = {wd.config.fuse_fp}")
    print("\nRun to run: largest difference of each gradient over three fresh forward and backward passes\n")
    print("| N | T | storage | parameters | forward + backward [ms] | gradients |\n| ---: | ---: | --- | --- | ---: | --- |")
    run_to_run(device, 8, 6, "trajectory")
    run_to_run(device, args.large, 50, "checkpointed")
    print("\nABA's backward kernel, N = 1, four replays with the same output adjoints\n")
    print("| forward scratch | input adjoints differ by | scratch entries rewritten | by up to |\n| --- | ---: | ---: | ---: |")
    aba_replays(device)


if __name__ == "__main__":
    main()
