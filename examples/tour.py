"""warpdyn as a multibody dynamics library: JaxSim's notebook "JaxSim as a multibody dynamics library",
ported cell by cell (cells 5 to 18: model, data, references, links, frames, equations of motion, forward
and inverse dynamics, centroidal dynamics, contact frames).

    python examples/tour.py                   # the seed's ergoCub (shipped: warpdyn.assets), legs only
    python examples/tour.py path/to.urdf      # any URDF or MJCF (the joints kept: those the seed keeps)
    python examples/tour.py --num-envs 4      # the same quantities for a batch of random states
    python examples/tour.py --dtype float32   # in single precision (looser tolerances on the checks)

Runs on the GPU when Warp finds one, otherwise on the CPU. The first run on a machine compiles warpdyn's
kernels (Warp caches them); the tour ends by timing itself a second time, with the kernels loaded. Every warpdyn function returns Warp arrays
on the model's device; `.numpy()` brings them to the host, where NumPy does what the notebook does with
jax.numpy. With --num-envs every cell runs batched: every quantity gains a leading environment axis and
every check holds for each environment.

`run_tour(...)` runs the cells and returns what they compute; tests/test_seed_tour.py checks it.
"""

from __future__ import annotations

import argparse
import pathlib
import time

import numpy as np
import warp as wp

import warpdyn as wd
from warpdyn import VelRepr

# Cell 4: the seed keeps the joints whose names contain none of these (no sensors, head, hands, upper body).
EXCLUDED = ("camera", "neck", "wrist", "thumb", "index", "middle", "ring", "pinkie", "torso", "elbow", "shoulder")

# The relations the notebook asserts, checked as max |lhs - rhs| <= TOLERANCE * max(1, max |rhs|):
# relative to the size of the quantity, because the accelerations of light links reach 1e3 here. Over
# 1000 random states of the ergoCub and the iCub the largest errors were 1.3e-13 (float64) and 6e-5
# (float32, in f_B == link_forces[0] and ν̇_eom == ν̇_aba, through pinv(M) of a float32 M).
TOLERANCE = {"float64": 1e-9, "float32": 1e-3}


def default_description() -> pathlib.Path:
    """The seed's robot, the ergoCub that warpdyn ships."""
    return wd.assets.ergocub_urdf()


def names(items, shown: int = 6) -> str:
    """A long list of names, its first and last few: 'a, b, c, ..., y, z (26)'."""
    items = list(items)
    if len(items) <= shown:
        return ", ".join(items) + f" ({len(items)})"
    half = shown // 2
    return ", ".join(items[:half]) + ", ..., " + ", ".join(items[-half:]) + f" ({len(items)})"


def section(say, title: str) -> None:
    say(f"\n== {title}")


def shape(say, symbol: str, array, meaning: str) -> None:
    """One line: the symbol, its shape and what it is."""
    say(f"{symbol + ':':<9} shape={str(tuple(np.shape(array))):<14} {meaning}")


def mv(A, x):
    """A @ x for one environment or a batch (leading axes of A and x)."""
    return np.einsum("...ij,...j->...i", A, x)


def check(relation: str, lhs, rhs, dtype: str, say=print) -> float:
    """Assert lhs == rhs within TOLERANCE[dtype] relative to the size of rhs; return the relative error."""
    lhs, rhs = np.asarray(lhs, dtype=np.float64), np.asarray(rhs, dtype=np.float64)
    error = float(np.max(np.abs(lhs - rhs), initial=0.0)) / max(1.0, float(np.max(np.abs(rhs), initial=0.0)))
    assert error <= TOLERANCE[dtype], f"{relation} does not hold: relative error {error:.3g} > {TOLERANCE[dtype]:g}"
    say(f"{relation} holds (relative error {error:.1e})")
    return error


def run_tour(
    description=None,
    *,
    dtype: str = "float64",
    num_envs: int | None = None,
    device=None,
    seed: int = 0,
    verbose: bool = True,
) -> dict:
    """Run the notebook's cells on `description` (a URDF/MJCF path or text; default: the iCub).

    dtype: "float32" or "float64"; num_envs: None for one environment (JaxSim's shapes) or a batch size;
    device: a Warp device (default: Warp's); seed: of the random state and forces; verbose: print what
    the notebook prints. Returns a dict of the model, data and references and of every quantity the
    cells compute, by the notebook's names, as NumPy arrays (leading environment axis when batched).
    """
    say = print if verbose else (lambda *args, **kwargs: None)
    dtype = np.dtype(dtype).name
    description = default_description() if description is None else description
    out: dict = {}

    # --- cell 1: setup (warp is initialised by the caller or on first use).
    section(say, f"Model (cells 3-5): the robot, its fixed joints lumped, on device '{wp.get_device(device)}' in {dtype}")

    # --- cell 3: create the model from the model description.
    # warpdyn, as JaxSim, removes all fixed joints by lumping together their parent and child links.
    full_model = wd.model.Model.build_from_model_description(description, dtype=np.dtype(dtype), device=device)

    # --- cell 4: joint selection.
    model = wd.model.reduce(
        full_model,
        considered_joints=tuple(j for j in full_model.joint_names() if not any(word in j for word in EXCLUDED)),
    )
    # JaxSim's collidable points come from box and sphere collision shapes only (meshes need an
    # environment variable there): do the same, so that the seed's ergoCub has its 32 foot corners.
    model = wd.contact.with_collidable_points(model, options=wd.contact.CollidablePointsOptions(shapes=("box", "sphere")))
    out.update(full_model=full_model, model=model)

    # --- cell 5: print model quantities.
    say(f"Model name: {model.name()}  (reduced to the joints the seed keeps: {full_model.dofs()} -> {model.dofs()})")
    say(f"Number of links: {model.number_of_links()}")
    say(f"Number of joints: {model.number_of_joints()}")
    say(f"Links (breadth-first from the base; joint i moves link i + 1): {names(model.link_names())}")
    say(f"Joints: {names(model.joint_names())}")
    say(f"Frames (the links lumped into their parents): {names(model.frame_names())}")

    # --- cell 6: create a random data object from the reduced model (Mixed representation by default).
    section(say, "State (cell 6): a random state, in JaxSim's Mixed representation")
    data = wd.data.random_model_data(model, key=seed, num_envs=num_envs)
    W_H_B, s = (x.numpy() for x in data.generalized_position)
    ν = data.generalized_velocity.numpy()
    shape(say, "W_H_B", W_H_B, "the base's pose in the world (homogeneous transform)")
    shape(say, "s", s, "the joint positions [rad]")
    shape(say, "ν", ν, "the generalized velocity: the base's (6, Mixed) then the joints'")
    out.update(data=data, W_H_B=W_H_B, s=s, ν=ν)

    # --- cell 7: random link forces and joint force references (NumPy's generator for JAX's PRNGKey(0)).
    section(say, "References (cell 7): random external link forces and joint force references")
    rng = np.random.default_rng(seed)
    batch = () if num_envs is None else (num_envs,)
    link_forces = rng.uniform(-10.0, 10.0, size=(*batch, model.number_of_links(), 6))
    # These are called 'references' because the actual joint forces that are actuated might differ
    # due to effects like joint friction.
    joint_force_references = rng.uniform(-10.0, 10.0, size=(*batch, model.dofs()))
    # The references read the link forces in the data's representation (Mixed: L[W]_f_L).
    references = wd.references.References.build(
        model=model, data=data, link_forces=link_forces, joint_force_references=joint_force_references
    )
    shape(say, "f_L", references.link_forces(model, data), "a 6D force [force; torque] on each link, Mixed")
    shape(say, "τ", references.joint_force_references(model), "a force (torque) on each joint [N m]")
    out.update(references=references, link_forces=link_forces, joint_force_references=joint_force_references)

    # --- cell 8: find the index of a link (the seed's; the last link on robots without it).
    link_name = "l_ankle_2" if "l_ankle_2" in model.link_names() else model.link_names()[-1]
    link_index = wd.link.name_to_idx(model, link_name=link_name)
    section(say, f"Link '{link_name}' (cells 8-10): its pose and its velocity in the three representations")

    # --- cell 9: link pose, by forward kinematics.
    W_H_L = wd.link.transform(model, data, link_index=link_index).numpy()
    shape(say, "W_H_L", W_H_L, "the link's pose in the world")

    # --- cell 10: link 6D velocity, in the three representations.
    L_v_WL = wd.link.velocity(model, data, link_index=link_index, output_vel_repr=VelRepr.Body).numpy()
    LW_v_WL = wd.link.velocity(model, data, link_index=link_index, output_vel_repr=VelRepr.Mixed).numpy()
    W_v_WL = wd.link.velocity(model, data, link_index=link_index, output_vel_repr=VelRepr.Inertial).numpy()
    shape(say, "L_v_WL", L_v_WL, "Body: in the link's frame")
    shape(say, "LW_v_WL", LW_v_WL, "Mixed: the link origin's velocity, world axes")
    shape(say, "W_v_WL", W_v_WL, "Inertial: in the world frame")
    # The same through the link's free-floating Jacobian, whose input representation is the data's
    # (here Body, switched in place) and whose output representation is chosen.
    with data.switch_velocity_representation(VelRepr.Body):
        # Body-fixed generalized velocity.
        B_ν = data.generalized_velocity.numpy()
        # Free-floating Jacobian accepting a body-fixed generalized velocity and returning an
        # inertial-fixed link velocity.
        W_J_WL_B = wd.link.jacobian(model, data, link_index=link_index, output_vel_repr=VelRepr.Inertial).numpy()
    shape(say, "W_J_WL_B", W_J_WL_B, "the link's Jacobian: Body generalized velocity in, Inertial out")
    # Now the following relation should hold.
    check("W_v_WL == W_J_WL_B @ B_ν", W_v_WL, mv(W_J_WL_B, B_ν), dtype, say)
    out.update(link_name=link_name, link_index=link_index, W_H_L=W_H_L, L_v_WL=L_v_WL, LW_v_WL=LW_v_WL)
    out.update(W_v_WL=W_v_WL, B_ν=B_ν, W_J_WL_B=W_J_WL_B)

    # --- cell 11: find the index of a frame (the seed's; the iCub's sole; or the model's last frame).
    frame_names = model.frame_names()
    frame_name = next((f for f in ("l_foot_front", "l_sole") if f in frame_names), frame_names[-1] if frame_names else None)
    if frame_name is None:
        say("The model has no frames: cells 11-13 are skipped.")
    else:
        frame_index = wd.frame.name_to_idx(model, frame_name=frame_name)
        section(say, f"Frame '{frame_name}' (cells 11-13): a frame fixed to a link, as the link above")

        # --- cell 12: frame pose.
        W_H_F = wd.frame.transform(model, data, frame_index=frame_index).numpy()
        shape(say, "W_H_F", W_H_F, "the frame's pose in the world")

        # --- cell 13: frame 6D velocity, in the three representations, and through the Jacobian.
        F_v_WF = wd.frame.velocity(model, data, frame_index=frame_index, output_vel_repr=VelRepr.Body).numpy()
        FW_v_WF = wd.frame.velocity(model, data, frame_index=frame_index, output_vel_repr=VelRepr.Mixed).numpy()
        W_v_WF = wd.frame.velocity(model, data, frame_index=frame_index, output_vel_repr=VelRepr.Inertial).numpy()
        shape(say, "F_v_WF", F_v_WF, "Body")
        shape(say, "FW_v_WF", FW_v_WF, "Mixed")
        shape(say, "W_v_WF", W_v_WF, "Inertial")
        with data.switch_velocity_representation(VelRepr.Body):
            B_ν = data.generalized_velocity.numpy()
            W_J_WF_B = wd.frame.jacobian(model, data, frame_index=frame_index, output_vel_repr=VelRepr.Inertial).numpy()
        # Now the following relation should hold.
        check("W_v_WF == W_J_WF_B @ B_ν", W_v_WF, mv(W_J_WF_B, B_ν), dtype, say)
        out.update(frame_name=frame_name, frame_index=frame_index, W_H_F=W_H_F, F_v_WF=F_v_WF, FW_v_WF=FW_v_WF)
        out.update(W_v_WF=W_v_WF, W_J_WF_B=W_J_WF_B)

    # --- cell 14: EoM quantities (data is in its default representation, i.e. Mixed).
    section(say, f"Equations of motion (cell 14): M ν̇ + h = B τ + Σ J_L^T f_L, in VelRepr.{data.velocity_representation.name}")
    # Compute the mass matrix.
    M = wd.model.free_floating_mass_matrix(model, data).numpy()
    shape(say, "M", M, "the mass matrix (CRBA)")
    # Compute the vector of bias forces.
    h = wd.model.free_floating_bias_forces(model, data).numpy()
    shape(say, "h", h, "the bias forces C ν + g (RNEA)")
    # Compute the vector of gravity forces.
    g = wd.model.free_floating_gravity_forces(model, data).numpy()
    shape(say, "g", g, "the gravity forces")
    # Compute the Coriolis matrix.
    C = wd.model.free_floating_coriolis_matrix(model, data).numpy()
    shape(say, "C", C, "the Coriolis matrix")
    # Create the joint selector matrix.
    B = np.block([np.zeros((model.dofs(), 6)), np.eye(model.dofs())]).T
    shape(say, "B", B, "the joint selector: joint forces into generalized forces")
    # Compute the stacked tensor of link Jacobians.
    J = wd.model.generalized_free_floating_jacobian(model, data).numpy()
    shape(say, "J", J, "the Jacobians of all links")
    # Extract the joint forces from the references object.
    τ = references.joint_force_references(model).numpy()
    shape(say, "τ", τ, "the joint forces of the references")
    # Extract the link forces from the references object.
    f_L = references.link_forces(model, data).numpy()
    shape(say, "f_L", f_L, "the link forces of the references")
    # The following relation should hold.
    check("h == C @ ν + g", h, mv(C, ν) + g, dtype, say)
    out.update(M=M, h=h, g=g, C=C, B=B, J=J, τ=τ, f_L=f_L)

    # --- cell 15: forward dynamics, from the EoM with the pseudo-inverse of M and by ABA.
    section(say, "Forward dynamics (cell 15): ν̇ from the equations of motion and by the articulated-body algorithm")
    # The notebook's einsum "l6g,l6->g" is Σ_L J_L^T f_L (NumPy takes no digits as subscripts).
    Q = mv(B, τ) - h + np.einsum("...lig,...li->...g", J, f_L)
    # (A fixed base does not accelerate, and ABA returns zeros there: solve for the joints only.)
    k = 0 if model.floating_base() else 6
    ν̇_eom = np.zeros_like(Q)
    ν̇_eom[..., k:] = mv(np.linalg.pinv(M[..., k:, k:]), Q[..., k:])
    v̇_WB, s̈ = (
        x.numpy() for x in wd.model.forward_dynamics_aba(model, data, link_forces=f_L, joint_forces=joint_force_references)
    )
    ν̇_aba = np.concatenate([v̇_WB, s̈], axis=-1)
    shape(say, "ν̇", ν̇_aba, "the generalized acceleration: the base's then the joints'")
    # The following relation should hold.
    check("ν̇_eom == ν̇_aba", ν̇_eom, ν̇_aba, dtype, say)
    out.update(ν̇_eom=ν̇_eom, v̇_WB=v̇_WB, s̈=s̈, ν̇_aba=ν̇_aba)

    # --- cell 16: inverse dynamics.
    section(say, "Inverse dynamics (cell 16): the forces that produce ν̇ (RNEA)")
    # To check that f_B works, remove the force applied to the base link from the link forces.
    f_L_without_base = f_L.copy()
    f_L_without_base[..., 0, :] = 0.0
    f_B, τ_rnea = (
        x.numpy()
        for x in wd.model.inverse_dynamics(
            model, data, base_acceleration=v̇_WB, joint_accelerations=s̈, link_forces=f_L_without_base
        )
    )
    shape(say, "f_B", f_B, "the wrench the base needs (here: the force removed from the base)")
    shape(say, "τ_rnea", τ_rnea, "the joint forces")
    # The following relations should hold.
    check("τ_rnea == τ", τ_rnea, τ, dtype, say)
    if model.floating_base():
        # (f_L is in Mixed, as the data, so it equals the raw link_forces.)
        check("f_B == link_forces[0]", f_B, link_forces[..., 0, :], dtype, say)
    else:
        say("(fixed base: f_B is the wrench that holds the base, not link_forces[0])")
    out.update(f_B=f_B, τ_rnea=τ_rnea)

    # --- cell 17: centroidal dynamics.
    section(say, "Centroidal dynamics (cell 17): momentum about the centre of mass G, and the contact forces' effect on it")
    # Number of contact points. The notebook counts all of them (len(contact_parameters.body)) but the
    # contact functions return the enabled ones only: count those (the same here, all are enabled).
    n_cp = int(np.count_nonzero(model.kin_dyn_parameters.contact_parameters.enabled))
    say(f"Number of contact points: {n_cp}  (points of the collision boxes and spheres)")
    # Compute the centroidal momentum.
    J_CMM = wd.com.centroidal_momentum_jacobian(model, data).numpy()
    G_h = mv(J_CMM, ν)
    shape(say, "G_h", G_h, "the centroidal momentum [linear; angular] in G")
    shape(say, "J_CMM", J_CMM, "the centroidal momentum matrix: G_h = J_CMM ν")
    # The following relation should hold.
    check("G_h == centroidal_momentum", G_h, wd.com.centroidal_momentum(model, data).numpy(), dtype, say)
    # If we consider all contact points of the model as active (discouraged since they might be too
    # many), the 6D transforms of collidable points can be computed as follows:
    W_H_C = wd.contact.transforms(model, data).numpy()
    # Compute the pose of the G frame.
    W_p_CoM = wd.com.com_position(model, data).numpy()
    W_H_G = np.broadcast_to(np.eye(4), (*batch, 4, 4)).copy()
    W_H_G[..., 0:3, 3] = W_p_CoM
    G_H_W = wd.math.Transform.inverse(W_H_G)
    # Convert from SE(3) to the transforms for 6D forces. The notebook takes C_X_G, the motion adjoint
    # from_transform(G_H_C, inverse=True); the transform of 6D forces from C to G is its transpose,
    # G_Xf_C = C_X_G^T. wd.math works on any leading axes: no vmap needed.
    G_H_C = G_H_W[..., None, :, :] @ W_H_C
    G_Xf_C = np.swapaxes(wd.math.Adjoint.from_transform(transform=G_H_C, inverse=True), -1, -2)
    shape(say, "G_Xf_C", G_Xf_C, "per point: the transform of a 6D force from the point's frame C to G")
    # Random 3D linear forces applied to the contact points (in C, i.e. in the link's axes).
    C_fl = rng.uniform(-10.0, 10.0, size=(*batch, n_cp, 3))
    # The total mass of the robot and the gravity: model.gravity is the world's z component, -9.81, as JaxSim's.
    m = wd.model.total_mass(model)
    # The centroidal dynamics can be computed as follows. (The notebook's einsum "c66,c6->6" repeats a
    # subscript, which takes the diagonal of each G_Xf_C; the sum over the points of G_Xf_C @ C_f is
    # "cij,cj->i".)
    G_ḣ = np.zeros((*batch, 6))
    G_ḣ += m * np.array([0.0, 0.0, model.gravity, 0.0, 0.0, 0.0])
    G_ḣ += np.einsum("...cij,...cj->...i", G_Xf_C, np.concatenate([C_fl, np.zeros_like(C_fl)], axis=-1))
    shape(say, "G_ḣ", G_ḣ, "the rate of the centroidal momentum: gravity plus random point forces")
    out.update(n_cp=n_cp, J_CMM=J_CMM, G_h=G_h, W_p_CoM=W_p_CoM, G_H_W=G_H_W, G_Xf_C=G_Xf_C, C_fl=C_fl, m=m, G_ḣ=G_ḣ)

    # --- cell 18: contact frames.
    section(say, "Contact frames (cell 18): the collidable points' Jacobians, velocities and accelerations")
    with (
        data.switch_velocity_representation(VelRepr.Mixed),
        references.switch_velocity_representation(VelRepr.Mixed),
    ):
        # Compute the mixed generalized velocity.
        BW_ν = data.generalized_velocity.numpy()
        # Compute the mixed generalized acceleration.
        BW_ν̇ = np.concatenate(
            [
                x.numpy()
                for x in wd.model.forward_dynamics(
                    model,
                    data,
                    link_forces=references.link_forces(model, data),
                    joint_forces=references.joint_force_references(model),
                )
            ],
            axis=-1,
        )
        # Compute the mass matrix in mixed representation.
        BW_M = wd.model.free_floating_mass_matrix(model, data).numpy()
        # Compute the contact Jacobian and its derivative.
        Jl_WC = wd.contact.jacobian(model, data).numpy()[..., 0:3, :]
        J̇l_WC = wd.contact.jacobian_derivative(model, data).numpy()[..., 0:3, :]
    # Compute the Delassus matrix. (M is symmetric positive definite: np.linalg.solve gives the
    # notebook's lstsq solution, and works on a batch. A fixed base does not move: its columns drop out.)
    k = 0 if model.floating_base() else 6
    Jl = Jl_WC.reshape(*batch, -1, Jl_WC.shape[-1])[..., k:]  # jnp.vstack(Jl_WC): (3 nc, 6 + n)
    Ψ = Jl @ np.linalg.solve(BW_M[..., k:, k:], np.swapaxes(Jl, -1, -2))
    shape(say, "Ψ", Ψ, "the Delassus matrix J M^-1 J^T: how point forces accelerate the points")
    # Compute the transforms of the mixed frames implicitly associated to each collidable point.
    W_H_C = wd.contact.transforms(model, data).numpy()
    shape(say, "W_H_C", W_H_C, "the points' frames (world axes) in the world")
    # Compute the linear velocity of the collidable points (the notebook names it W_ṗ_B; the velocities
    # are already 3D, so its [:, 0:3] changes nothing).
    with data.switch_velocity_representation(VelRepr.Mixed):
        W_ṗ_B = wd.contact.collidable_point_velocities(model, data).numpy()[..., 0:3]
        shape(say, "W_ṗ_C", W_ṗ_B, "the points' velocities [m/s]")
    # Compute the linear acceleration of the collidable points (the notebook's "c3g,g->c3").
    W_p̈_C = 0
    W_p̈_C += np.einsum("...cig,...g->...ci", J̇l_WC, BW_ν)
    W_p̈_C += np.einsum("...cig,...g->...ci", Jl_WC, BW_ν̇)
    shape(say, "W_p̈_C", W_p̈_C, "the points' accelerations: J̇ ν + J ν̇ [m/s²]")
    out.update(BW_ν=BW_ν, BW_ν̇=BW_ν̇, BW_M=BW_M, Jl_WC=Jl_WC, J̇l_WC=J̇l_WC, Ψ=Ψ, W_H_C=W_H_C, W_ṗ_B=W_ṗ_B, W_p̈_C=W_p̈_C)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("description", nargs="?", help="URDF or MJCF path (default: the ergoCub warpdyn ships)")
    parser.add_argument("--dtype", choices=["float32", "float64"], default="float64")
    parser.add_argument("--num-envs", type=int, default=None, help="batch size (default: one environment)")
    parser.add_argument("--device", default=None, help="a Warp device, e.g. cpu or cuda:0 (default: Warp's)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random state and forces")
    args = parser.parse_args()
    path = pathlib.Path(args.description) if args.description else default_description()
    print(f"Robot: {path}")
    kwargs = dict(dtype=args.dtype, num_envs=args.num_envs, device=args.device, seed=args.seed)
    start = time.perf_counter()
    run_tour(path, **kwargs)
    first = time.perf_counter() - start
    start = time.perf_counter()
    run_tour(path, **kwargs, verbose=False)
    second = time.perf_counter() - start
    print(
        f"\nThe tour took {first:.2f} s, and {second:.2f} s when run again in this process. The difference is Warp "
        f"compiling warpdyn's kernels, or loading them from its cache ({wp.config.kernel_cache_dir}): the first "
        "run on a machine compiles them, later runs load them."
    )


if __name__ == "__main__":
    main()
