"""The mesh-free fixtures derived from MuJoCo Menagerie (tests/models/menagerie/, whose README says where each
comes from and how make_fixtures.py made it): MuJoCo loads each on its own, and each is the case it stands for
in issue 35 (ball joints inside Cassie's tree; a free cube beside a fixed Panda, two trees; RB-Y1's armature
and damping on its free joint).

`compare_with_mujoco(path, dtype)` is warpdyn against MuJoCo on any MJCF file (tests/mjcf_compare.py, whose
state mapping benchmarks/menagerie.py shares). Cassie and the cube scene are compared in
tests/test_joint_kinds.py (ball joints, several trees); here RB-Y1, whose floating base's free joint carries
armature and damping.
"""

import pathlib
import re
import warnings

import mujoco
import numpy as np
import pytest

import mjcf_compare
import warpdyn as wd

FOLDER = pathlib.Path(__file__).parent / "models" / "menagerie"
CASSIE = FOLDER / "cassie.xml"
CUBE = FOLDER / "mjx_single_cube.xml"
RBY1 = FOLDER / "rby1a_1.2.xml"
FIXTURES = (CASSIE, CUBE, RBY1)
TOLERANCE = {np.float64: 1e-8, np.float32: 1e-4}
"""Issue 35's 1e-8 in float64; float32's rounding on RB-Y1 measured 3e-7 to 7e-7 (M, h, qacc; three seeds)."""


def compare_with_mujoco(path, dtype=np.float64, random_states: int = 3, seed: int = 0) -> dict:
    """warpdyn against MuJoCo on the MJCF file `path`: the largest relative error of M, h (qfrc_bias), the
    passive and actuator forces (ctrl = 0) and qacc (constraints disabled) over MuJoCo's qpos0 and
    `random_states` seeded random states, and "start", how far warpdyn's default state is from qpos0
    (mjcf_compare.compare_model: its docstring says how states and coordinates are mapped and errors
    scaled). warpdyn's refusal, or a MuJoCo dof it does not have, is raised."""
    mj = mujoco.MjModel.from_xml_path(str(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        warnings.simplefilter("ignore", wd.contact.NoCollidablePointsWarning)
        model = wd.model.Model.build_from_model_description(str(path), dtype=dtype)
    return mjcf_compare.compare_model(model, mj, random_states, seed)


def _load(path) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(path))


def _joints(m, kind) -> list[int]:
    return [j for j in range(m.njnt) if m.jnt_type[j] == kind.value]


@pytest.mark.parametrize("path", FIXTURES, ids=lambda p: p.name)
def test_mujoco_loads_each_fixture_without_meshes(path):
    """Each fixture compiles from the repository alone (no mesh, no include), is small, has a keyframe or
    actuators as its original, and names its origin and licence, which ships beside it and in the README."""
    m = _load(path)
    assert m.nmesh == 0 and m.nv > 0 and m.nu > 0
    assert path.stat().st_size < 64 * 1024
    header = re.search(r"Derived from MuJoCo Menagerie (\S+) \(commit ([0-9a-f]{40})\).*Licence: (LICENSE\.\S+)\.", path.read_text())
    assert header, f"{path.name} does not say where it comes from"
    original, commit, licence = header.groups()
    assert (FOLDER / licence).is_file() and (FOLDER / licence).stat().st_size > 500
    readme = (FOLDER / "README.md").read_text()
    assert all(text in readme for text in (path.name, original, commit, licence))


def test_cassie_has_ball_joints_inside_its_tree():
    """Cassie: a free pelvis and two ball joints (the achilles rods) below it, whose loops four connect
    constraints close; nq = nv + 1 (free) + 2 (balls)."""
    m = _load(CASSIE)
    balls = _joints(m, mujoco.mjtJoint.mjJNT_BALL)
    free = _joints(m, mujoco.mjtJoint.mjJNT_FREE)
    assert [m.joint(j).name for j in balls] == ["left-achilles-rod", "right-achilles-rod"]
    assert len(free) == 1 and m.body_parentid[m.jnt_bodyid[free[0]]] == 0
    assert all(m.body_parentid[m.jnt_bodyid[j]] != 0 for j in balls)
    assert (m.nq, m.nv) == (35, 32) and m.nq == m.nv + 1 + len(balls)
    assert m.neq == 4 and all(m.eq_type == mujoco.mjtEq.mjEQ_CONNECT.value)
    assert m.key("home").qpos.shape == (m.nq,)


def test_cube_scene_has_two_trees_one_free():
    """mjx_single_cube: the Panda welded to the world (9 hinge and slide dofs) and, beside it, a free cube at
    its description's pose (qpos0 = (0.5, 0, 0.03), the identity): two trees with dofs, one of them free; the
    mocap target is a third, static, body."""
    m = _load(CUBE)
    free = _joints(m, mujoco.mjtJoint.mjJNT_FREE)
    trees = {int(m.body_rootid[m.jnt_bodyid[j]]) for j in range(m.njnt)}
    assert len(trees) == 2 and len(free) == 1
    box = int(m.jnt_bodyid[free[0]])
    assert m.body(box).name == "box" and m.body_parentid[box] == 0
    np.testing.assert_array_equal(m.qpos0[m.jnt_qposadr[free[0]] :][:7], [0.5, 0.0, 0.03, 1.0, 0.0, 0.0, 0.0])
    assert (m.nq, m.nv, m.nmocap) == (16, 15, 1)
    assert [m.key(k).name for k in range(m.nkey)] == ["home", "pickup", "pickup1"]


def test_rby1_has_armature_and_damping_on_its_free_joint():
    """RB-Y1: its <default> joint class gives the free joint (type="free" takes defaults) armature 0.01 and
    damping 5 on all six dofs, as on its hinges."""
    m = _load(RBY1)
    (free,) = _joints(m, mujoco.mjtJoint.mjJNT_FREE)
    dofs = slice(m.jnt_dofadr[free], m.jnt_dofadr[free] + 6)
    np.testing.assert_array_equal(m.dof_armature[dofs], 0.01)
    np.testing.assert_array_equal(m.dof_damping[dofs], 5.0)


def test_rby1_matches_mujoco(dtype):
    """RB-Y1 (a floating base whose free joint has armature 0.01 and damping 5, 24 hinges with armature and
    damping, 2 wheels, position actuators, joint couplings left out as constraints) equals MuJoCo's M, h, passive
    and actuator forces and qacc at qpos0 and three random states. Tolerance: issue 35's 1e-8 relative in float64
    (measured 3e-14); float32's rounding 1e-4 (measured 3e-7)."""
    errors = compare_with_mujoco(RBY1, dtype)
    assert all(errors[name] < TOLERANCE[dtype] for name in mjcf_compare.QUANTITIES), errors
