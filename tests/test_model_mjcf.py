"""Models loaded from MJCF: the same robot as MJCF (exported by MuJoCo from its URDF) and as URDF, and what
URDF cannot say (joint pivots off the body origin, `ref`, degrees, a body without a joint).

References: C MuJoCo on the same MJCF, and the URDF-loaded model of tests/test_model.py (its robots by
case name and random states are in tests/robots.py).
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import robots
import warpdyn as wd
from robots import H_of, assert_close, built, random_data, rng_for, text_of

Model = wd.model.Model


# ------------------------------------------------------------------------------------ MJCF


def mjcf_of(text: str, floating: bool) -> str:
    """The URDF exported to MJCF by MuJoCo (every link a body: fusestatic off; a free joint if floating)."""
    spec = robots.mujoco_spec(text, None, floating=floating, fuse_static=False)
    spec.compile()
    return spec.to_xml()


@pytest.mark.parametrize("case,which", [("icub", None), ("ergocub", "seed"), ("random-15", None), ("randomfixed-101", None)])
@pytest.mark.parametrize("source", ["path", "string"])
def test_mjcf_matches_urdf(case, which, source, tmp_path):
    """The same robot as MJCF (exported by MuJoCo from the URDF), loaded by warpdyn from a path and from a
    string, has the same links, joints and frames (by name), the same base type and masses, and the same
    FK, link by link and frame by frame, as the URDF-loaded model, at a random state mapped by joint name.
    Tolerances: vs MuJoCo on the same MJCF, float64 1e-10 (exact same numbers); vs the URDF model 1e-5
    relative for poses and 1e-4 for masses, because MuJoCo's XML writer keeps 6 significant digits
    (rounding 5e-7 relative per number, over ~10 composed transforms, observed ~2e-6)."""
    text = text_of(case)
    urdf_model = built(case, which)
    floating = urdf_model.floating_base()
    xml = mjcf_of(text, floating)
    considered = None if which is None else list(urdf_model.joint_names())
    if source == "path":
        path = tmp_path / "robot.xml"
        path.write_text(xml)
        mjcf_model = Model.build_from_model_description(str(path), considered_joints=considered, dtype=np.float64)
        as_path = Model.build_from_model_description(path, considered_joints=considered, dtype=np.float64)
        assert as_path.link_names() == mjcf_model.link_names()
        np.testing.assert_array_equal(as_path.tree.parent_H_joint, mjcf_model.tree.parent_H_joint)
    else:
        mjcf_model = Model.build_from_model_description(xml, considered_joints=considered, dtype=np.float64)
    assert mjcf_model.floating_base() == floating
    assert mjcf_model.base_link() == urdf_model.base_link()
    assert set(mjcf_model.link_names()) == set(urdf_model.link_names())
    assert set(mjcf_model.joint_names()) == set(urdf_model.joint_names())
    assert set(mjcf_model.frame_names()) == set(urdf_model.frame_names())
    assert np.all(mjcf_model.tree.parent[1:] < np.arange(1, mjcf_model.number_of_links()))
    urdf_parent = {n: urdf_model.link_names()[p] for n, p in zip(urdf_model.link_names()[1:], urdf_model.tree.parent[1:])}
    for name, p in zip(mjcf_model.link_names()[1:], mjcf_model.tree.parent[1:]):
        assert mjcf_model.link_names()[p] == urdf_parent[name], name
    assert abs(wd.model.total_mass(mjcf_model) - wd.model.total_mass(urdf_model)) <= 1e-4 * wd.model.total_mass(urdf_model)
    lower_u, upper_u = wd.joint.position_limits(urdf_model, joint_names=mjcf_model.joint_names())
    lower_m, upper_m = wd.joint.position_limits(mjcf_model)
    for a, b in ((lower_m, lower_u), (upper_m, upper_u)):
        finite = np.isfinite(b)
        np.testing.assert_array_equal(np.isfinite(a), finite)
        assert_close(a[finite], b[finite], 1e-5, "position limits: MJCF vs URDF")

    data, (p, q, s, v, sd) = random_data(urdf_model, rng_for(case, which, "mjcf"))
    order = [urdf_model.joint_names().index(name) for name in mjcf_model.joint_names()]
    mjcf_data = wd.data.Data.build(mjcf_model, base_position=p, base_quaternion=q, joint_positions=s[order]) if floating \
        else wd.data.Data.build(mjcf_model, joint_positions=s[order])  # fmt: skip
    H_urdf = wd.model.forward_kinematics(urdf_model, data).numpy()
    H_mjcf = wd.model.forward_kinematics(mjcf_model, mjcf_data).numpy()
    # Against MuJoCo compiled from the very same MJCF: exact up to rounding.
    mj = mujoco.MjModel.from_xml_string(xml)
    st = robots.MujocoState(mj, mjcf_model.joint_names(), floating)
    st.set(p, q, s[order], np.zeros(6), np.zeros(len(s)))
    for i, name in enumerate(mjcf_model.link_names()):
        pm, Rm = st.body_pose(name)
        assert_close(H_mjcf[i], H_of(Rm, pm), 1e-10, f"MJCF link '{name}' vs MuJoCo")
        j = urdf_model.link_names().index(name)
        assert_close(H_mjcf[i], H_urdf[j], 1e-5, f"link '{name}': MJCF vs URDF")
        mass_u = urdf_model.tree.link_mass[j]
        assert abs(mjcf_model.tree.link_mass[i] - mass_u) <= 1e-4 * max(1.0, mass_u), f"mass of '{name}'"
    nL_u, nL_m = urdf_model.number_of_links(), mjcf_model.number_of_links()
    for k, name in enumerate(mjcf_model.frame_names()):
        H_m = wd.frame.transform(mjcf_model, mjcf_data, frame_index=nL_m + k).numpy()
        H_u = wd.frame.transform(urdf_model, data, frame_index=nL_u + urdf_model.frame_names().index(name)).numpy()
        pm, Rm = st.body_pose(name)
        assert_close(H_m, H_of(Rm, pm), 1e-10, f"MJCF frame '{name}' vs MuJoCo")
        assert_close(H_m, H_u, 1e-5, f"frame '{name}': MJCF vs URDF")


PIVOTS = """
<mujoco model="pivots">
  <worldbody>
    <body name="base" pos="0.1 0.2 0.3">
      <freejoint/>
      <inertial pos="0 0 0" mass="2" diaginertia="0.1 0.2 0.3"/>
      <body name="a" pos="0.3 0 0" quat="0.9 0.1 0.3 -0.2">
        <joint name="hinge_a" type="hinge" axis="0 1 1" pos="0.05 -0.1 0.2" ref="20" range="-30 60"/>
        <inertial pos="0.1 0 0" mass="1" diaginertia="0.01 0.02 0.03"/>
        <body name="b" pos="0 0.4 0" euler="0.3 0.2 0.1">
          <joint name="slide_b" type="slide" axis="1 0.5 0" pos="0.3 0.3 0.3" ref="-0.2" range="-0.5 0.25"/>
          <inertial pos="0 0.1 0" mass="0.5" diaginertia="0.01 0.01 0.01"/>
          <body name="c" pos="0 0 0.2" quat="0.5 0.5 0.5 0.5">
            <inertial pos="0 0 0.1" mass="0.3" diaginertia="0.01 0.01 0.01"/>
            <body name="d" pos="0.1 0 0">
              <joint name="hinge_d" type="hinge" axis="1 0 0" pos="0 0.2 0" ref="-45"/>
              <inertial pos="0 0 0" mass="0.2" diaginertia="0.01 0.01 0.01"/>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>"""
"""An MJCF with what URDF cannot say: hinge and slide joints off their body's origin, `ref` != 0, a lumped body ('c')."""


def test_mjcf_joint_pivot_and_reference():
    """An MJCF with what URDF cannot say: hinge and slide joints with a `pos` off the body origin and a
    `ref` (qpos0) != 0, angles in MJCF's default degrees, and a body with no joint (lumped). warpdyn's q
    equals MuJoCo's qpos (radians); limits are converted to radians; poses, Mixed Jacobians and velocities
    vs MuJoCo at random states, float64 1e-12 (a few transforms of O(1) numbers)."""
    model = Model.build_from_model_description(PIVOTS, dtype=np.float64)
    assert model.name() == "pivots"
    assert model.floating_base()
    assert model.link_names() == ("base", "a", "b", "d")
    assert model.joint_names() == ("hinge_a", "slide_b", "hinge_d")
    assert model.frame_names() == ("c",)
    lower, upper = wd.joint.position_limits(model)
    np.testing.assert_allclose(lower, [-np.pi / 6, -0.5, -np.inf], rtol=1e-15)
    np.testing.assert_allclose(upper, [np.pi / 3, 0.25, np.inf], rtol=1e-15)
    mj = mujoco.MjModel.from_xml_string(PIVOTS)
    st = robots.MujocoState(mj, model.joint_names(), True)
    rng = rng_for("pivots")
    for _ in range(3):
        data, state = random_data(model, rng)
        st.set(*state)
        H = wd.model.forward_kinematics(model, data).numpy()
        J = wd.model.generalized_free_floating_jacobian(model, data).numpy()
        for i, name in enumerate(model.link_names()):
            p, R = st.body_pose(name)
            assert_close(H[i], H_of(R, p), 1e-12, f"link '{name}'")
            assert_close(J[i], st.body_jacobian_mixed(name), 1e-12, f"Jacobian of link '{name}'")
            v = wd.link.velocity(model, data, link_index=i).numpy()
            assert_close(v, st.body_velocity_mixed(name), 1e-12, f"velocity of '{name}'")
        p, R = st.body_pose("c")
        assert_close(wd.frame.transform(model, data, frame_index=4).numpy(), H_of(R, p), 1e-12, "frame 'c'")


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_joint_transforms_at_extreme_positions(dtype):
    """The kernels move a joint by its terms (warpdyn.types.model's joint_motion_terms, kernels/spatial.py's
    joint_coefficients: half-angle sines and cosines, Rodrigues' formula about the pivot): link poses equal
    the description's parent_H_joint @ joint_motion(q) composed down the tree (`ref` folded into
    parent_H_joint) for PIVOTS' hinges off their body's origin at angles up to 1e3 rad and its slide at 1e2 m.
    Tolerance: float64 1e-10 (the sines of 1e3 rad carry ~1e-13 absolute), float32 2e-4 of the poses' largest
    entry (ulps of 1e3 rad and 1e2 m)."""
    model = Model.build_from_model_description(PIVOTS, dtype=dtype)
    tree = model.tree
    cases = np.array([[1e3 + 0.3, 1e2, -1e3 - 1.1], [-np.pi, -1e2, np.pi], [0.0, 0.0, 0.0], [1e-8, 1e-9, -1e-8]])
    data = wd.data.Data.build(model, num_envs=len(cases), joint_positions=cases)
    H = wd.model.forward_kinematics(model, data).numpy()
    kinds = {1: "revolute", 2: "prismatic"}
    for e, q in enumerate(cases):
        expected = [np.eye(4)]
        expected[0][:3, 3] = [0.1, 0.2, 0.3]  # the free body's pose, where Data.build starts it (MuJoCo's qpos0)
        for i in range(1, tree.number_of_links):
            motion = wd.description.joint_motion(kinds[tree.joint_type[i]], tree.joint_axis[i], tree.joint_pivot[i], q[i - 1])
            expected.append(expected[tree.parent[i]] @ tree.parent_H_joint[i] @ motion)
        for i, name in enumerate(model.link_names()):
            atol = 1e-10 if dtype == np.float64 else 2e-4 * max(1.0, np.abs(expected[i]).max())
            np.testing.assert_allclose(H[e, i], expected[i], rtol=0, atol=atol, err_msg=f"link '{name}', q = {q}")
