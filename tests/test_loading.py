"""Loading robot descriptions as users have them: paths, strings and bytes, XML declarations and encodings,
byte-order marks, comments; every URDF icub-models ships; bases welded or freed at build time; the warning
for a floating base without collidable points.

Reference for "loads the same": the ergoCub read from its file by path, compared link by link (names,
masses, inertias, joint frames: exactly equal, since the same numbers are parsed). The icub-models sweep
compares each robot's mass matrix and forward dynamics with MuJoCo's on the same URDF (float64, 1e-9
relative, as tests/test_dynamics.py).
"""

import pathlib
import warnings

import icub_models
import mujoco
import numpy as np
import pytest

import robots
import warpdyn as wd

URDF_TEXT = robots.ERGOCUB.read_text(encoding="utf-8")
BODY = URDF_TEXT.split("?>", 1)[1]  # the document after its XML declaration


def _load(source, **kwargs):
    return wd.model.Model.build_from_model_description(source, dtype=np.float64, **kwargs)


def _assert_same_model(model, reference, label):
    assert model.link_names() == reference.link_names(), label
    assert model.joint_names() == reference.joint_names(), label
    tree, ref = model.tree, reference.tree
    for name in ("link_mass", "link_com", "link_inertia", "parent_H_joint", "joint_axis"):
        np.testing.assert_array_equal(getattr(tree, name), getattr(ref, name), err_msg=f"{label}: {name}")


def _variants(tmp_path):
    """(label, source): the ergoCub in every form a user may hand over."""
    declared = '<?xml version="1.0" encoding="utf-8"?>\n<!-- a comment before the root -->' + BODY
    latin1 = '<?xml version="1.0" encoding="ISO-8859-1"?>\n<!-- Größe: déclaré en latin-1 -->' + BODY
    files = {
        "declared utf-8": declared.encode("utf-8"),
        "utf-8 with BOM": b"\xef\xbb\xbf" + declared.encode("utf-8"),
        "declared latin-1": latin1.encode("latin-1"),
        "utf-16 with BOM": ('<?xml version="1.0" encoding="UTF-16"?>' + BODY).encode("utf-16"),
    }
    out = [("path str", str(robots.ERGOCUB)), ("pathlib.Path", robots.ERGOCUB)]
    for label, content in files.items():
        path = tmp_path / f"{label.replace(' ', '_')}.urdf"
        path.write_bytes(content)
        out += [(f"file, {label}", path), (f"bytes, {label}", content)]
    out += [
        ("str", URDF_TEXT),
        ("str, declared utf-8", declared),
        ("str with a BOM", "\ufeff" + declared),
        ("str, declared latin-1 (already decoded)", latin1),
    ]
    return out


def test_every_form_of_a_urdf_loads_the_same_model(tmp_path):
    reference = _load(robots.ERGOCUB)
    for label, source in _variants(tmp_path):
        _assert_same_model(_load(source), reference, label)


def test_mjcf_as_string_bytes_and_path(tmp_path):
    """An MJCF with an XML declaration and comments, as a string, bytes and a file, loads the same model."""
    mjcf = """<?xml version="1.0" encoding="utf-8"?>
<!-- a two-link arm -->
<mujoco model="arm">
  <worldbody>
    <body name="upper" pos="0 0 1">
      <joint name="shoulder" type="hinge" axis="0 1 0"/>
      <geom type="capsule" size="0.05" fromto="0 0 0 0 0 -0.5" mass="2"/>
      <body name="lower" pos="0 0 -0.5">
        <joint name="elbow" type="hinge" axis="0 1 0"/>
        <geom type="capsule" size="0.04" fromto="0 0 0 0 0 -0.4" mass="1"/>
      </body>
    </body>
  </worldbody>
</mujoco>"""
    path = tmp_path / "arm.xml"
    path.write_text(mjcf, encoding="utf-8")
    reference = _load(path)
    assert reference.joint_names() == ("shoulder", "elbow") and not reference.floating_base()
    for label, source in (("str", mjcf), ("bytes", mjcf.encode("utf-8")), ("BOM bytes", b"\xef\xbb\xbf" + mjcf.encode())):
        _assert_same_model(_load(source), reference, label)


@pytest.mark.parametrize("source", [b"\x00\x01\x02\xff binary", "not a path and not xml", 42])
def test_what_is_not_a_description_is_named(source, tmp_path):
    """Bytes that are not XML, a string that is neither XML nor a file, another type: each a clear error."""
    if isinstance(source, bytes):
        path = tmp_path / "robot.urdf"
        path.write_bytes(source)
        with pytest.raises(ValueError, match="robot.urdf' is not well-formed XML"):
            _load(path)
        with pytest.raises(ValueError, match="the given XML document is not well-formed XML"):
            _load(source)
    elif isinstance(source, str):
        with pytest.raises(FileNotFoundError, match="does not exist"):
            _load(source)
    else:
        with pytest.raises(TypeError, match="a path, an XML string or XML bytes"):
            _load(source)


MUJOCO_REFUSES = {"iCubGenova03": "positive eigenvalues", "iCubLisboa01": "positive eigenvalues", "iCubNancy01": "A \\+ B >= C"}
"""icub-models robots whose URDF MuJoCo does not compile, and why: links with a mass but a zero rotational
inertia (point masses, which warpdyn takes as they are), and the ankles of iCubNancy01, whose principal
moments (0.0035, 0.0043, 4.77 kg m^2) violate the triangle inequality."""


@pytest.mark.parametrize("robot", sorted(icub_models.get_robot_names()))
def test_every_icub_models_urdf_loads_and_matches_mujoco(robot):
    """Every URDF the icub-models package ships loads; its M and ABA equal MuJoCo's (float64, relative 1e-9;
    joints mapped by name, MuJoCo's free-joint velocity converted to warpdyn's Mixed one), or, where MuJoCo
    refuses the URDF (MUJOCO_REFUSES, checked), ABA equals the solve with CRBA's M (relative 1e-9)."""
    text = pathlib.Path(icub_models.get_model_file(robot)).read_text()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.contact.NoCollidablePointsWarning)  # mesh-only robots (tested below)
        warnings.simplefilter("ignore", wd.model.UnphysicalInertiaWarning)  # three robots: tests/test_faults_loader.py
        model = _load(text)
    data = wd.data.random_model_data(model, key=3)
    tau = np.random.default_rng(1).uniform(-1, 1, model.dofs())
    base, joints = wd.model.forward_dynamics_aba(model, data, joint_forces=tau)
    nu_dot = np.r_[base.numpy(), joints.numpy()]
    M = wd.model.free_floating_mass_matrix(model, data).numpy()
    if robot in MUJOCO_REFUSES:
        with pytest.raises(ValueError, match=MUJOCO_REFUSES[robot]):
            robots.mujoco_model(text, None, floating=model.floating_base())
        Q = np.r_[np.zeros(6), tau] - wd.model.free_floating_bias_forces(model, data).numpy()
        np.testing.assert_allclose(nu_dot, np.linalg.solve(M, Q), atol=1e-9 * max(1.0, np.abs(nu_dot).max()))
        return
    mj = robots.mujoco_model(text, None, floating=model.floating_base())
    off = mujoco.mjtDisableBit
    mj.opt.disableflags |= off.mjDSBL_CONSTRAINT | off.mjDSBL_DAMPER | off.mjDSBL_SPRING
    state = robots.MujocoState(mj, model.joint_names(), True)
    state.set(*(x.numpy() for x in (data.base_position, data.base_quaternion, data.joint_positions, data.base_velocity, data.joint_velocities)))
    idx = np.r_[0:6, state.dof_adr]
    P = np.eye(6 + model.dofs())
    P[3:6, 3:6] = robots.rotation_wxyz(data.base_quaternion.numpy()).T
    M_mj = np.zeros((mj.nv, mj.nv))
    mujoco.mj_fullM(mj, state.d, M_mj)
    np.testing.assert_allclose(M, P.T @ M_mj[np.ix_(idx, idx)] @ P, atol=1e-9 * np.abs(M).max())
    state.d.qfrc_applied[state.dof_adr] = tau
    mujoco.mj_forward(mj, state.d)
    expected = np.linalg.solve(P, state.d.qacc[idx])
    np.testing.assert_allclose(nu_dot, expected, atol=1e-9 * max(1.0, np.abs(expected).max()))


# ------------------------------------------------------------------------------------------ the base


def test_fixed_base_welds_the_root_at_base_pose():
    """fixed_base=True welds a floating URDF's root at base_pose: the base is where base_pose puts it in the
    zero data, does not accelerate, and the joint block of M equals the floating model's (the same links)."""
    H = np.eye(4)
    H[:3, :3] = robots.rotation_wxyz([np.cos(0.3), 0.0, 0.0, np.sin(0.3)])
    H[:3, 3] = (0.1, -0.2, 1.0)
    floating = _load(robots.ERGOCUB, considered_joints=wd.assets.ERGOCUB_LEG_JOINTS)
    welded = _load(robots.ERGOCUB, considered_joints=wd.assets.ERGOCUB_LEG_JOINTS, fixed_base=True, base_pose=H)
    assert floating.floating_base() and not welded.floating_base()
    data = wd.data.Data.build(welded, joint_positions=np.full(welded.dofs(), 0.2))
    np.testing.assert_allclose(wd.link.transform(welded, data, link_index=0).numpy(), H, atol=1e-12)
    base, _ = wd.model.forward_dynamics_aba(welded, data)
    np.testing.assert_array_equal(base.numpy(), np.zeros(6))
    free = wd.data.Data.build(floating, base_position=H[:3, 3], base_quaternion=[np.cos(0.3), 0, 0, np.sin(0.3)],
                              joint_positions=np.full(floating.dofs(), 0.2))
    np.testing.assert_allclose(
        wd.model.free_floating_mass_matrix(welded, data).numpy()[6:, 6:],
        wd.model.free_floating_mass_matrix(floating, free).numpy()[6:, 6:],
        atol=1e-12,
    )
    reduced = wd.model.reduce(welded, considered_joints=welded.joint_names()[:4])
    assert not reduced.floating_base()  # reduce keeps the weld


def test_fixed_base_for_mjcf_and_freeing_a_welded_root():
    """An MJCF free joint becomes a weld; fixed_base=False frees a URDF root welded to `world`."""
    mjcf = """<mujoco><worldbody><body name="box" pos="0 0 2"><freejoint name="root"/>
      <geom type="box" size="0.1 0.1 0.1" mass="1"/>
      <body name="arm" pos="0.2 0 0"><joint name="hinge" axis="0 0 1"/><geom type="sphere" size="0.05" mass="0.5"/></body>
      </body></worldbody></mujoco>"""
    assert _load(mjcf).floating_base()
    welded = _load(mjcf, fixed_base=True)
    assert not welded.floating_base() and welded.joint_names() == ("hinge",)
    urdf = robots.pendulum_chain_urdf(2)  # rooted at `world` by a fixed joint
    assert not _load(urdf).floating_base()
    with pytest.warns(wd.contact.NoCollidablePointsWarning):  # freed, the chain has nothing to stand on
        assert _load(urdf, fixed_base=False).floating_base()


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(fixed_base=True, base_pose=np.ones((4, 4))), "homogeneous transform"),
        (dict(fixed_base=True, base_pose=np.eye(3)), r"\(4, 4\)"),
        (dict(fixed_base=True, base_pose=np.full((4, 4), np.nan)), "finite"),
        (dict(base_pose=np.eye(4)), "pass fixed_base=True"),
        (dict(fixed_base=False, base_pose=np.eye(4)), "pass fixed_base=True"),
    ],
)
def test_bad_base_arguments_are_named(kwargs, message):
    with pytest.raises(ValueError, match=message):
        _load(robots.ERGOCUB, **kwargs)


# ------------------------------------------------------------------------------------------ collidable points

_MESH_ONLY = """<robot name="mesh_bot">
  <link name="base"><inertial><mass value="2"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><mesh filename="package://mesh_bot/base.stl"/></geometry></collision></link>
  <link name="leg"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><mesh filename="package://mesh_bot/leg.stl"/></geometry></collision></link>
  <joint name="hip" type="revolute"><parent link="base"/><child link="leg"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="10" velocity="10"/></joint>
</robot>"""


def test_a_floating_base_without_collidable_points_warns_once_at_build():
    """A floating robot whose collision shapes are meshes only (as Solo12's) has no points by default: it would
    fall through the terrain, so building it warns, naming the model, its meshes and the option to sample them."""
    with pytest.warns(wd.contact.NoCollidablePointsWarning) as record:
        model = _load(_MESH_ONLY)
    assert len(record) == 1
    message = str(record[0].message)
    assert "'mesh_bot'" in message and "2 collision meshes" in message and "mesh_max_points=16" in message
    assert len(model.kin_dyn_parameters.contact_parameters.body) == 0
    bare = _MESH_ONLY.replace("<collision><geometry><mesh filename=\"package://mesh_bot/base.stl\"/></geometry></collision>", "")
    bare = bare.replace("<collision><geometry><mesh filename=\"package://mesh_bot/leg.stl\"/></geometry></collision>", "")
    with pytest.warns(wd.contact.NoCollidablePointsWarning, match="no collision shapes"):
        _load(bare)


def test_no_warning_with_points_or_a_fixed_base():
    with warnings.catch_warnings():
        warnings.simplefilter("error", wd.contact.NoCollidablePointsWarning)
        _load(robots.ERGOCUB)  # 32 box corners on the feet (and more elsewhere)
        _load(_MESH_ONLY, fixed_base=True)  # a welded robot does not fall
