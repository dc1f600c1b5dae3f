"""warpdyn as a multibody dynamics library: JaxSim's notebook "JaxSim as a multibody dynamics library",
ported cell by cell (cells 5 to 18: model, data, references, links, frames, equations of motion, forward
and inverse dynamics, centroidal dynamics, contact frames).

    python examples/tour.py                   # the iCub (icub-models), legs only
    python examples/tour.py path/to.urdf      # any URDF or MJCF, e.g. ../shared/models/ergoCubSN001.urdf (the seed's)
    python examples/tour.py --num-envs 4      # the same quantities for a batch of random states
    python examples/tour.py --dtype float32   # in single precision (looser tolerances on the checks)

Runs on the GPU when Warp finds one, otherwise on the CPU. Every warpdyn function returns Warp arrays
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
    try:
        import icub_models
    except ImportError:
        raise SystemExit("the default robot is the iCub: `pip install icub-models`, or pass a URDF path") from None
    return pathlib.Path(icub_models.get_model_file("iCubGazeboV2_5"))


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
    say(f"Running on {wp.get_device(device)}")

    # --- cell 3: create the model from the model description.
    # warpdyn, as JaxSim, removes all fixed joints by lumping together their parent and child links.
    t0 = time.perf_counter()
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
    say(f"Model name: {model.name()}")
    say(f"Number of links: {model.number_of_links()}")
    say(f"Number of joints: {model.number_of_joints()}")
    say()
    say(f"Links:\n{model.link_names()}")
    say()
    say(f"Joints:\n{model.joint_names()}")
    say()
    say(f"Frames:\n{model.frame_names()}")
    say(f"(built in {time.perf_counter() - t0:.2f} s)\n")

    # --- cell 6: create a random data object from the reduced model (Mixed representation by default).
    data = wd.data.random_model_data(model, seed=seed, num_envs=num_envs)
    # Print the default state.
    W_H_B, s = (x.numpy() for x in data.generalized_position)
    ν = data.generalized_velocity.numpy()
    say(f"W_H_B: shape={W_H_B.shape}\n{W_H_B}\n")
    say(f"s: shape={s.shape}\n{s}\n")
    say(f"ν: shape={ν.shape}\n{ν}\n")
    out.update(data=data, W_H_B=W_H_B, s=s, ν=ν)

    # --- cell 7: random link forces and joint force references (NumPy's generator for JAX's PRNGKey(0)).
    rng = np.random.default_rng(seed)
    batch = () if num_envs is None else (num_envs,)
    link_forces = rng.uniform(-10.0, 10.0, size=(*batch, model.number_of_links(), 6))
    # These are called 'references' because the actual joint forces that are actuated might differ
    # due to effects like joint friction.
    joint_force_references = rng.uniform(-10.0, 10.0, size=(*batch, model.dofs()))
    # The references read the link forces in the data's representation (Mixed: L[W]_f_L).
    references = wd.references.References.build(
        model, data, link_forces=link_forces, joint_force_references=joint_force_references
    )
    say(f"link_forces: shape={references.link_forces(model, data).shape}")
    say(f"joint_force_references: shape={references.joint_force_references(model).shape}\n")
    out.update(references=references, link_forces=link_forces, joint_force_references=joint_force_references)

    # --- cell 8: find the index of a link (the seed's; the last link on robots without it).
    link_name = "l_ankle_2" if "l_ankle_2" in model.link_names() else model.link_names()[-1]
    link_index = wd.link.name_to_idx(model, link_name=link_name)

    # --- cell 9: link pose, by forward kinematics.
    W_H_L = wd.link.transform(model, data, link_index=link_index).numpy()
    say(f"Transform of '{link_name}': shape={W_H_L.shape}\n{W_H_L}")

    # --- cell 10: link 6D velocity, in the three representations.
    L_v_WL = wd.link.velocity(model, data, link_index=link_index, output_vel_repr=VelRepr.Body).numpy()
    LW_v_WL = wd.link.velocity(model, data, link_index=link_index, output_vel_repr=VelRepr.Mixed).numpy()
    W_v_WL = wd.link.velocity(model, data, link_index=link_index, output_vel_repr=VelRepr.Inertial).numpy()
    say(f"Body-fixed velocity      L_v_WL={L_v_WL}")
    say(f"Mixed velocity:         LW_v_WL={LW_v_WL}")
    say(f"Inertial-fixed velocity: W_v_WL={W_v_WL}")
    # The same through the link's free-floating Jacobian, whose input representation is the data's
    # (here Body, switched in place) and whose output representation is chosen.
    with data.switch_velocity_representation(VelRepr.Body):
        # Body-fixed generalized velocity.
        B_ν = data.generalized_velocity.numpy()
        # Free-floating Jacobian accepting a body-fixed generalized velocity and returning an
        # inertial-fixed link velocity.
        W_J_WL_B = wd.link.jacobian(model, data, link_index=link_index, output_vel_repr=VelRepr.Inertial).numpy()
    # Now the following relation should hold.
    check("W_v_WL == W_J_WL_B @ B_ν", W_v_WL, mv(W_J_WL_B, B_ν), dtype, say)
    say()
    out.update(link_name=link_name, link_index=link_index, W_H_L=W_H_L, L_v_WL=L_v_WL, LW_v_WL=LW_v_WL)
    out.update(W_v_WL=W_v_WL, B_ν=B_ν, W_J_WL_B=W_J_WL_B)

    # --- cell 11: find the index of a frame (the seed's; the iCub's sole; or the model's last frame).
    frame_names = model.frame_names()
    frame_name = next((f for f in ("l_foot_front", "l_sole") if f in frame_names), frame_names[-1] if frame_names else None)
    if frame_name is None:
        say("The model has no frames: cells 11-13 are skipped.\n")
    else:
        frame_index = wd.frame.name_to_idx(model, frame_name=frame_name)

        # --- cell 12: frame pose.
        W_H_F = wd.frame.transform(model, data, frame_index=frame_index).numpy()
        say(f"Transform of '{frame_name}': shape={W_H_F.shape}\n{W_H_F}")

        # --- cell 13: frame 6D velocity, in the three representations, and through the Jacobian.
        F_v_WF = wd.frame.velocity(model, data, frame_index=frame_index, output_vel_repr=VelRepr.Body).numpy()
        FW_v_WF = wd.frame.velocity(model, data, frame_index=frame_index, output_vel_repr=VelRepr.Mixed).numpy()
        W_v_WF = wd.frame.velocity(model, data, frame_index=frame_index, output_vel_repr=VelRepr.Inertial).numpy()
        say(f"Body-fixed velocity      F_v_WF={F_v_WF}")
        say(f"Mixed velocity:         FW_v_WF={FW_v_WF}")
        say(f"Inertial-fixed velocity: W_v_WF={W_v_WF}")
        with data.switch_velocity_representation(VelRepr.Body):
            B_ν = data.generalized_velocity.numpy()
            W_J_WF_B = wd.frame.jacobian(model, data, frame_index=frame_index, output_vel_repr=VelRepr.Inertial).numpy()
        # Now the following relation should hold.
        check("W_v_WF == W_J_WF_B @ B_ν", W_v_WF, mv(W_J_WF_B, B_ν), dtype, say)
        say()
        out.update(frame_name=frame_name, frame_index=frame_index, W_H_F=W_H_F, F_v_WF=F_v_WF, FW_v_WF=FW_v_WF)
        out.update(W_v_WF=W_v_WF, W_J_WF_B=W_J_WF_B)

    # --- cell 14: EoM quantities (data is in its default representation, i.e. Mixed).
    say(f"Velocity representation of data: VelRepr.{data.velocity_representation.name}\n")
    # Compute the mass matrix.
    M = wd.model.free_floating_mass_matrix(model, data).numpy()
    say(f"M:   shape={M.shape}")
    # Compute the vector of bias forces.
    h = wd.model.free_floating_bias_forces(model, data).numpy()
    say(f"h:   shape={h.shape}")
    # Compute the vector of gravity forces.
    g = wd.model.free_floating_gravity_forces(model, data).numpy()
    say(f"g:   shape={g.shape}")
    # Compute the Coriolis matrix.
    C = wd.model.free_floating_coriolis_matrix(model, data).numpy()
    say(f"C:   shape={C.shape}")
    # Create the joint selector matrix.
    B = np.block([np.zeros((model.dofs(), 6)), np.eye(model.dofs())]).T
    say(f"B:   shape={B.shape}")
    # Compute the stacked tensor of link Jacobians.
    J = wd.model.generalized_free_floating_jacobian(model, data).numpy()
    say(f"J:   shape={J.shape}")
    # Extract the joint forces from the references object.
    τ = references.joint_force_references(model).numpy()
    say(f"τ:   shape={τ.shape}")
    # Extract the link forces from the references object.
    f_L = references.link_forces(model, data).numpy()
    say(f"f_L: shape={f_L.shape}")
    # The following relation should hold.
    check("h == C @ ν + g", h, mv(C, ν) + g, dtype, say)
    say()
    out.update(M=M, h=h, g=g, C=C, B=B, J=J, τ=τ, f_L=f_L)

    # --- cell 15: forward dynamics, from the EoM with the pseudo-inverse of M and by ABA.
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
    say(f"ν̇: shape={ν̇_aba.shape}")
    # The following relation should hold.
    check("ν̇_eom == ν̇_aba", ν̇_eom, ν̇_aba, dtype, say)
    say()
    out.update(ν̇_eom=ν̇_eom, v̇_WB=v̇_WB, s̈=s̈, ν̇_aba=ν̇_aba)

    # --- cell 16: inverse dynamics.
    # To check that f_B works, remove the force applied to the base link from the link forces.
    f_L_without_base = f_L.copy()
    f_L_without_base[..., 0, :] = 0.0
    f_B, τ_rnea = (
        x.numpy()
        for x in wd.model.inverse_dynamics(
            model, data, base_acceleration=v̇_WB, joint_accelerations=s̈, link_forces=f_L_without_base
        )
    )
    say(f"f_B:    shape={f_B.shape}")
    say(f"τ_rnea: shape={τ_rnea.shape}")
    # The following relations should hold.
    check("τ_rnea == τ", τ_rnea, τ, dtype, say)
    if model.floating_base():
        # (f_L is in Mixed, as the data, so it equals the raw link_forces.)
        check("f_B == link_forces[0]", f_B, link_forces[..., 0, :], dtype, say)
    else:
        say("(fixed base: f_B is the wrench that holds the base, not link_forces[0])")
    say()
    out.update(f_B=f_B, τ_rnea=τ_rnea)

    # --- cell 17: centroidal dynamics.
    # Number of contact points. The notebook counts all of them (len(contact_parameters.body)) but the
    # contact functions return the enabled ones only: count those (the same here, all are enabled).
    n_cp = int(np.count_nonzero(model.kin_dyn_parameters.contact_parameters.enabled))
    say("Number of contact points:", n_cp, "\n")
    # Compute the centroidal momentum.
    J_CMM = wd.com.centroidal_momentum_jacobian(model, data).numpy()
    G_h = mv(J_CMM, ν)
    say(f"G_h:    shape={G_h.shape}")
    say(f"J_CMM:  shape={J_CMM.shape}")
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
    say(f"G_Xf_C: shape={G_Xf_C.shape}")
    # Random 3D linear forces applied to the contact points (in C, i.e. in the link's axes).
    C_fl = rng.uniform(-10.0, 10.0, size=(*batch, n_cp, 3))
    # The total mass of the robot and the gravity: JaxSim's model.gravity is -9.81 (the z component),
    # warpdyn's is the magnitude 9.81 (acting along -z).
    m = wd.model.total_mass(model)
    # The centroidal dynamics can be computed as follows. (The notebook's einsum "c66,c6->6" repeats a
    # subscript, which takes the diagonal of each G_Xf_C; the sum over the points of G_Xf_C @ C_f is
    # "cij,cj->i".)
    G_ḣ = np.zeros((*batch, 6))
    G_ḣ += m * np.array([0.0, 0.0, -model.gravity, 0.0, 0.0, 0.0])
    G_ḣ += np.einsum("...cij,...cj->...i", G_Xf_C, np.concatenate([C_fl, np.zeros_like(C_fl)], axis=-1))
    say(f"G_ḣ:    shape={G_ḣ.shape}")
    say()
    out.update(n_cp=n_cp, J_CMM=J_CMM, G_h=G_h, W_p_CoM=W_p_CoM, G_H_W=G_H_W, G_Xf_C=G_Xf_C, C_fl=C_fl, m=m, G_ḣ=G_ḣ)

    # --- cell 18: contact frames.
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
    say(f"Ψ:     shape={Ψ.shape}")
    # Compute the transforms of the mixed frames implicitly associated to each collidable point.
    W_H_C = wd.contact.transforms(model, data).numpy()
    say(f"W_H_C: shape={W_H_C.shape}")
    # Compute the linear velocity of the collidable points (the notebook names it W_ṗ_B; the velocities
    # are already 3D, so its [:, 0:3] changes nothing).
    with data.switch_velocity_representation(VelRepr.Mixed):
        W_ṗ_B = wd.contact.collidable_point_velocities(model, data).numpy()[..., 0:3]
        say(f"W_ṗ_B: shape={W_ṗ_B.shape}")
    # Compute the linear acceleration of the collidable points (the notebook's "c3g,g->c3").
    W_p̈_C = 0
    W_p̈_C += np.einsum("...cig,...g->...ci", J̇l_WC, BW_ν)
    W_p̈_C += np.einsum("...cig,...g->...ci", Jl_WC, BW_ν̇)
    say(f"W_p̈_C: shape={W_p̈_C.shape}")
    out.update(BW_ν=BW_ν, BW_ν̇=BW_ν̇, BW_M=BW_M, Jl_WC=Jl_WC, J̇l_WC=J̇l_WC, Ψ=Ψ, W_H_C=W_H_C, W_ṗ_B=W_ṗ_B, W_p̈_C=W_p̈_C)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("description", nargs="?", help="URDF or MJCF path (default: the iCub)")
    parser.add_argument("--dtype", choices=["float32", "float64"], default="float64")
    parser.add_argument("--num-envs", type=int, default=None, help="batch size (default: one environment)")
    parser.add_argument("--device", default=None, help="a Warp device, e.g. cpu or cuda:0 (default: Warp's)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random state and forces")
    args = parser.parse_args()
    wp.config.quiet = True
    wp.config.log_level = wp.LOG_WARNING
    wp.init()
    path = pathlib.Path(args.description) if args.description else default_description()
    print(f"Robot: {path}")
    run_tour(path, dtype=args.dtype, num_envs=args.num_envs, device=args.device, seed=args.seed)


if __name__ == "__main__":
    main()
