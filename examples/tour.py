"""warpdyn as a multibody dynamics library: JaxSim's notebook "JaxSim as a multibody dynamics library",
ported cell by cell.

    python examples/tour.py                 # the iCub (icub-models), legs only
    python examples/tour.py path/to.urdf    # any URDF or MJCF, e.g. ../shared/models/ergoCubSN001.urdf
    python examples/tour.py --num-envs 1024 # the same quantities for a batch of random states

Runs on the GPU when Warp finds one, otherwise on the CPU. Every quantity is a Warp array on the
model's device; `.numpy()` brings it to the host.
"""

from __future__ import annotations

import argparse
import pathlib
import time

import numpy as np
import warp as wp

import warpdyn as wd
from warpdyn import VelRepr

EXCLUDED = ("camera", "neck", "wrist", "thumb", "index", "middle", "ring", "pinkie", "torso", "elbow", "shoulder")


def default_description() -> pathlib.Path:
    try:
        import icub_models
    except ImportError:
        raise SystemExit("the default robot is the iCub: `pip install icub-models`, or pass a URDF path") from None
    return pathlib.Path(icub_models.get_model_file("iCubGazeboV2_5"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("description", nargs="?", help="URDF or MJCF path (default: the iCub)")
    parser.add_argument("--dtype", choices=["float32", "float64"], default="float64")
    parser.add_argument("--num-envs", type=int, default=None, help="batch size (default: one environment)")
    parser.add_argument("--device", default=None, help="a Warp device, e.g. cpu or cuda:0 (default: Warp's)")
    args = parser.parse_args()
    wp.config.quiet = True
    wp.config.log_level = wp.LOG_WARNING
    wp.init()
    path = pathlib.Path(args.description) if args.description else default_description()
    print(f"Running on {wp.get_device(args.device)}; robot: {path}")

    # Model: lump fixed joints, keep the legs as the notebook does.
    t0 = time.perf_counter()
    full_model = wd.model.Model.build_from_model_description(path, dtype=np.dtype(args.dtype), device=args.device)
    model = wd.model.reduce(
        full_model, considered_joints=tuple(j for j in full_model.joint_names() if not any(w in j for w in EXCLUDED))
    )
    print(f"Model name: {model.name()}")
    print(f"Number of links: {model.number_of_links()}")
    print(f"Number of joints: {model.number_of_joints()}")
    print(f"\nLinks:\n{model.link_names()}")
    print(f"\nJoints:\n{model.joint_names()}")
    print(f"\nFrames:\n{model.frame_names()}")
    print(f"(built in {time.perf_counter() - t0:.2f} s)\n")

    # Data: a random state, in the Mixed representation by default.
    data = wd.data.random_model_data(model, num_envs=args.num_envs)
    W_H_B, s = data.generalized_position
    ν = data.generalized_velocity
    print(f"W_H_B: shape={W_H_B.shape}\n{W_H_B.numpy()}\n")
    print(f"s: shape={s.shape}\n{s.numpy()}\n")
    print(f"ν: shape={ν.shape}\n{ν.numpy()}\n")

    # References: random link forces and joint force references.
    rng = np.random.default_rng(0)
    batch = () if args.num_envs is None else (args.num_envs,)
    link_forces = rng.uniform(-10.0, 10.0, size=(*batch, model.number_of_links(), 6))
    joint_force_references = rng.uniform(-10.0, 10.0, size=(*batch, model.dofs()))
    references = wd.references.References.build(
        model, data, link_forces=link_forces, joint_force_references=joint_force_references
    )
    print(f"link_forces: shape={references.link_forces(model, data).shape}")
    print(f"joint_force_references: shape={references.joint_force_references(model).shape}\n")

    # A link: pose, velocity in the three representations, and the Jacobian relation.
    link_name = model.link_names()[-1]
    link_index = wd.link.name_to_idx(model, link_name=link_name)
    W_H_L = wd.link.transform(model, data, link_index=link_index)
    print(f"Transform of '{link_name}': shape={W_H_L.shape}\n{W_H_L.numpy()}")
    L_v_WL = wd.link.velocity(model, data, link_index=link_index, output_vel_repr=VelRepr.Body)
    LW_v_WL = wd.link.velocity(model, data, link_index=link_index, output_vel_repr=VelRepr.Mixed)
    W_v_WL = wd.link.velocity(model, data, link_index=link_index, output_vel_repr=VelRepr.Inertial)
    print(f"Body-fixed velocity      L_v_WL={L_v_WL.numpy()}")
    print(f"Mixed velocity:         LW_v_WL={LW_v_WL.numpy()}")
    print(f"Inertial-fixed velocity: W_v_WL={W_v_WL.numpy()}")
    with data.switch_velocity_representation(VelRepr.Body):
        B_ν = data.generalized_velocity.numpy()
        W_J_WL_B = wd.link.jacobian(model, data, link_index=link_index, output_vel_repr=VelRepr.Inertial).numpy()
    assert np.allclose(W_v_WL.numpy(), np.einsum("...ij,...j->...i", W_J_WL_B, B_ν))
    print("W_v_WL == W_J_WL_B @ B_ν holds\n")

    # A frame: the same for a lumped link.
    if model.number_of_frames():
        frame_name = "l_foot_front" if "l_foot_front" in model.frame_names() else model.frame_names()[-1]
        frame_index = wd.frame.name_to_idx(model, frame_name=frame_name)
        W_H_F = wd.frame.transform(model, data, frame_index=frame_index)
        print(f"Transform of '{frame_name}': shape={W_H_F.shape}\n{W_H_F.numpy()}")
        W_v_WF = wd.frame.velocity(model, data, frame_index=frame_index, output_vel_repr=VelRepr.Inertial)
        with data.switch_velocity_representation(VelRepr.Body):
            B_ν = data.generalized_velocity.numpy()
            W_J_WF_B = wd.frame.jacobian(model, data, frame_index=frame_index, output_vel_repr=VelRepr.Inertial).numpy()
        assert np.allclose(W_v_WF.numpy(), np.einsum("...ij,...j->...i", W_J_WF_B, B_ν))
        print("W_v_WF == W_J_WF_B @ B_ν holds\n")

    J = wd.model.generalized_free_floating_jacobian(model, data)
    print(f"J:   shape={J.shape}")


if __name__ == "__main__":
    main()
