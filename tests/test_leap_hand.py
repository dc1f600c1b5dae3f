"""The shipped LEAP hand and cube (wd.assets.leap_hand_cube_mjcf: MuJoCo Playground's LeapCubeReorient scene, issue
37's dexterous hand): MuJoCo compiles it alone, warpdyn names what it does not model, its dynamics equal MuJoCo's,
and the cube dropped from the keyframe "home" comes to rest in the palm near where MuJoCo's does. Its geom pairs and
their contacts against MuJoCo's: tests/test_geom_contacts.py (case "leap")."""

import warnings

import mujoco
import numpy as np
import torch
import warp as wp

import mjcf_compare
import warpdyn as wd
from warpdyn.description.mjcf import BODY_CONTACTS, FRICTIONLOSS, JOINT_LIMITS


def _load() -> tuple:
    """(the float64 model, MuJoCo's model, what the loader's one warning lists)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = wd.model.Model.build_from_model_description(wd.assets.leap_hand_cube_mjcf(), dtype=np.float64)
    assert [w.category for w in caught] == [wd.model.NotModelledWarning], [str(w.message) for w in caught]
    listed = str(caught[0].message).split(" holds elements that warpdyn does not model: ")[1]
    return model, mujoco.MjModel.from_xml_path(str(wd.assets.leap_hand_cube_mjcf())), listed


def test_mujoco_compiles_it_alone_and_warpdyn_names_what_it_does_not_model():
    """No mesh, texture, material or light; the 16 position servos drive LEAP_HAND_JOINTS in order; every collision
    geom is a box but the floor's plane. warpdyn warns once: the joints' limits and frictionloss, and the 325 geom
    pairs (off until model.geom_contacts is set); the cube is a free body, the mount is the world's."""
    model, m, listed = _load()
    assert (m.nq, m.nv, m.nu, m.nmesh, m.ntex, m.nmat, m.nlight) == (23, 22, 16, 0, 0, 0, 0)
    assert [m.joint(int(m.actuator_trnid[a, 0])).name for a in range(m.nu)] == list(wd.assets.LEAP_HAND_JOINTS)
    kinds = [mujoco.mjtGeom(int(t)).name for t in m.geom_type]
    assert kinds.count("mjGEOM_PLANE") == 1 and kinds.count("mjGEOM_BOX") == m.ngeom - 1
    joints = list(wd.assets.LEAP_HAND_JOINTS)
    assert listed == f"{JOINT_LIMITS}: {joints}; {FRICTIONLOSS}: {joints}; {BODY_CONTACTS}: ['325 geom pairs']"
    assert not model.floating_base() and set(model.joint_names()) == {"cube_freejoint", *joints}
    assert model.number_of_actuators() == 16 and model.dofs() == 22


def test_its_dynamics_equal_mujocos():
    """M, h (qfrc_bias), passive forces and qacc at qpos0 and 5 random states, float64, relative to 1e-10
    (mjcf_compare.compare_model, MuJoCo's constraints disabled; measured 3e-15)."""
    model, m, _ = _load()
    errors = mjcf_compare.compare_model(model, m, random_states=5, seed=3)
    assert all(errors[name] < 1e-10 for name in ("M", "h", "forces", "qacc")), errors
    assert errors["start"] == 0.0


def test_the_cube_comes_to_rest_in_the_palm_near_mujocos():
    """From the keyframe "home" (the cube 3.4 cm above the palm, the servos at the keyframe's targets), 1 s at the
    file's 1 ms with the cube's and the hand's box contacts acting (the soft law K = 5e5, D = 500): the cube falls into
    the palm and stays there, healthy, moving by less than 0.1 mm over the last 0.4 s, 1.6 cm above the mount as
    MuJoCo's (within 2 mm; measured 0.8) and within 2.5 cm of MuJoCo's rest across the palm (measured 1.45 cm: where
    the cube lands after it bounces is each contact law's own)."""
    model, m, _ = _load()
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    mujoco.mj_step(m, d, int(round(1.0 / m.opt.timestep)))
    reference = d.xpos[m.body("cube").id].copy()
    model.geom_contacts = True
    model.contact_params = wd.model.SoftContactsParams(K=5e5, D=500.0, mu=1.0)
    stepper = wd.simulation.Stepper(model, wd.data.keyframe(model, "home"), substeps=200)
    wp.to_torch(stepper.ctrl).copy_(torch.tensor(m.key("home").ctrl, dtype=torch.float64)[None])
    cube = model.link_names().index("cube")
    positions = []
    for _ in range(5):
        stepper.step()
        H = wd.model.forward_kinematics(model, stepper.data).numpy().reshape(-1, model.number_of_links(), 4, 4)
        positions.append(H[0, cube, :3, 3])
    assert stepper.data.healthy.numpy().all()
    assert np.linalg.norm(positions[-1] - positions[-3]) < 1e-4
    assert abs(positions[-1][2] - reference[2]) < 2e-3 and np.linalg.norm(positions[-1] - reference) < 0.025, (positions[-1], reference)
