"""The description layer (warpdyn.description: load, build_tree) on what it does not model, and on URDF. An
MJCF with features warpdyn does not model gives exactly one NotModelledWarning naming every one of them,
a fixture without any gives none; URDF robots carry none of MuJoCo's parameters (armature, passive
damping, stiffness, gravcomp, actuators, options) and keep `<dynamics>` as JaxSim's viscous friction.

References: what the fixtures carry (tests/mjcf_fixtures.py; UNSUPPORTED_FEATURES), and the URDF read with
ElementTree (0 tolerance). The parameters against MuJoCo: tests/test_mjcf_description.py. Host only: no
device is touched.
"""

from __future__ import annotations

import warnings
import xml.etree.ElementTree as ET

import mjcf_models as mm
import numpy as np
import pytest
import robots

import warpdyn.assets
from warpdyn.description import NotModelledWarning, load
from warpdyn.description.tree import build_tree


# ------------------------------------------------------------------------------------ the warning


def test_unsupported_gives_one_warning_naming_everything():
    """UNSUPPORTED (mjcf_models.UNSUPPORTED_FEATURES): exactly one NotModelledWarning, pointing at this file
    (the caller), naming every kind (fluid, joint limits, frictionloss, equality, tendon, muscle, activation
    dynamics, non-joint transmission) and every element (u_j1, u_j2, couple, t_diff, mus, filtered,
    tendon_motor); the supported part still loads (no actuator is kept)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        description = load(mm.UNSUPPORTED)
    assert [w.category for w in caught] == [NotModelledWarning], [str(w.message) for w in caught]
    assert caught[0].filename == __file__
    message = str(caught[0].message)
    for kind in ("fluid", "joint limits", "frictionloss", "equality", "tendon", "muscle", "activation dynamics", "non-joint transmission"):
        assert kind in message, kind
    for name in ("u_j1", "u_j2", "couple", "t_diff", "mus", "filtered", "tendon_motor"):
        assert f"'{name}'" in message, name
    assert "density=1.2 viscosity=1.8e-05" in message
    assert "u_j3" not in message  # no limit, no frictionloss
    assert description.actuators == []
    assert len(mm.UNSUPPORTED_FEATURES) == 8


def test_more_unsupported_elements_are_listed():
    """A heightfield on a body, a plane on a static body beside the free one (dropped as scenery), a geom fluid shape, polynomial damping, a body-transmission and an
    integrator actuator: each named in one warning; a world plane (the floor), sensors and the free joint's
    damping (the floating base's, modelled) and a box on the world (a geom that does not move: modelled) are not."""
    xml = """<mujoco model="more"><compiler angle="radian"/>
      <asset><hfield name="bumps" nrow="2" ncol="2" size="0.1 0.1 0.05 0.01"/></asset>
      <worldbody>
        <geom name="floor" type="plane" size="5 5 0.1"/>
        <geom name="rock" type="box" size="0.1 0.1 0.1" pos="1 0 0"/>
        <body name="shelf" pos="0 2 0"><geom name="wall" type="plane" size="1 1 0.1"/></body>
        <body name="base" pos="0 0 1"><joint name="root" type="free" damping="0.3"/>
          <geom name="egg" type="hfield" hfield="bumps"/>
          <geom name="blade" type="box" size="0.1 0.1 0.01" fluidshape="ellipsoid"/>
          <inertial pos="0 0 0" mass="1" diaginertia="0.01 0.01 0.01"/>
          <body name="arm"><joint name="elbow" axis="0 1 0" damping="1 0.5"/>
            <geom name="g_arm" type="capsule" size="0.02 0.1"/>
          </body>
        </body>
      </worldbody>
      <contact><pair name="touch" geom1="egg" geom2="rock"/><pair name="grip" geom1="floor" geom2="g_arm" friction="2"/>
        <exclude name="no_self" body1="base" body2="arm"/></contact>
      <actuator><adhesion name="glue" body="arm" ctrlrange="0 1"/><intvelocity name="iv" joint="elbow" actrange="-1 1"/>
        <motor name="ok" joint="elbow"/></actuator>
      <sensor><jointpos joint="elbow"/></sensor>
    </mujoco>"""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        description = load(xml)
    assert len(caught) == 1 and caught[0].category is NotModelledWarning
    message = str(caught[0].message)
    for name in ("egg (hfield)", "wall (plane)", "shelf", "base (fluidshape)", "elbow", "glue", "iv"):
        assert f"'{name}'" in message, name
    assert "rock (box)" not in message and [g.name for g in description.world_geoms] == ["rock"]
    assert "'1 hfield-box (e.g. rock/egg)'" in message  # the <pair> touch: a heightfield on a body, which nothing collides
    assert "'1 with the ground (e.g. floor/g_arm)'" in message  # the <pair> grip: the terrain's law, not its friction
    assert "'root'" not in message  # the floating base's free-joint damping is modelled
    assert "'floor" not in message and "jointpos" not in message and "'ok'" not in message
    assert [a.name for a in description.actuators] == ["ok"]


@pytest.mark.parametrize(
    "name", ["ARMATURE", "DAMPING", "SPRINGS", "MOTOR", "POSITION", "VELOCITY", "GENERAL", "MULTI_JOINT", "WORLD_CHILDREN",
             "OPTIONS", "DRONE", "FLOATING_HUMANOID", "JOINT_ACTUATORFRCRANGE", "ACTUATOR_ARMATURE_DAMPING"]
)  # fmt: skip
def test_clean_fixtures_do_not_warn(name):
    """A fixture with nothing warpdyn misses loads without any NotModelledWarning."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", NotModelledWarning)
        description = load(mm.FIXTURES[name])
    assert description.not_modelled == {}


# ------------------------------------------------------------------------------------ URDF


def _urdf_dynamics(path):
    root = ET.parse(path).getroot()
    out = {}
    for joint in root.iter("joint"):
        dynamics = joint.find("dynamics")
        damping = float(dynamics.get("damping", 0.0)) if dynamics is not None else 0.0
        friction = float(dynamics.get("friction", 0.0)) if dynamics is not None else 0.0
        out[joint.get("name")] = (damping, friction)
    return out


@pytest.mark.parametrize("which", ["ergocub_asset", "ergocub_tests", "icub"])
def test_urdf_robots_have_no_mujoco_parameters(which, tmp_path):
    """ergoCub (the shipped asset and the test copy) and iCub: armature, passive_damping, stiffness, springref,
    gravcomp 0, actuator_force_range +-inf, no actuators, no options, no warning; `damping`/`friction` keep
    `<dynamics damping/friction>` as read from the XML by ElementTree (0 tolerance)."""
    path = {"ergocub_asset": str(warpdyn.assets.ergocub_urdf()), "ergocub_tests": robots.ERGOCUB, "icub": robots.icub_path()}[which]
    with warnings.catch_warnings():
        warnings.simplefilter("error", NotModelledWarning)
        description = load(path)
    tree = build_tree(description)
    n = tree.dofs
    for array in (tree.armature, tree.passive_damping, tree.stiffness, tree.springref):
        np.testing.assert_array_equal(array, np.zeros(n))
    np.testing.assert_array_equal(tree.actuator_force_range, np.tile([-np.inf, np.inf], (n, 1)))
    assert not tree.actuator_gravcomp.any()
    np.testing.assert_array_equal(tree.gravcomp_mass, np.zeros(tree.number_of_links))
    np.testing.assert_array_equal(tree.gravcomp_com, np.zeros((tree.number_of_links, 3)))
    assert tree.actuators == [] and description.actuators == []
    assert (description.gravity, description.time_step, description.integrator) == (None, None, None)
    assert description.disabled == frozenset() and description.not_modelled == {}
    dynamics = _urdf_dynamics(path)
    for i, name in enumerate(tree.joint_names):
        assert (tree.damping[i], tree.friction[i]) == dynamics[name], name


def test_urdf_dynamics_damping_stays_viscous_friction():
    """A URDF joint's <dynamics damping="0.7" friction="0.2">: damping 0.7 (JaxSim's viscous friction), friction
    0.2, passive_damping 0 (MuJoCo's damper is MJCF-only)."""
    urdf = """<robot name="r"><link name="base"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <link name="arm"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <joint name="j" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
        <limit lower="-1" upper="1" effort="5" velocity="2"/><dynamics damping="0.7" friction="0.2"/></joint></robot>"""
    tree = build_tree(load(urdf))
    assert (tree.damping[0], tree.friction[0], tree.passive_damping[0], tree.armature[0]) == (0.7, 0.2, 0.0, 0.0)


def test_random_urdf_trees_have_zero_mujoco_parameters():
    """tests/robots.py random trees (floating and fixed): the new arrays have the right shapes and are zero."""
    for seed in range(4):
        for fixed in (False, True):
            tree = build_tree(load(robots.random_tree_urdf(seed, fixed_base=fixed)))
            assert tree.armature.shape == (tree.dofs,) and not tree.armature.any()
            assert tree.gravcomp_mass.shape == (tree.number_of_links,) and not tree.gravcomp_mass.any()
            assert np.isinf(tree.actuator_force_range).all()
