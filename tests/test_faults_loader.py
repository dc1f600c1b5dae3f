"""Impossible robots are refused at load time, naming the file and the link, joint or value at fault.

Reference: the physical checks of warpdyn.description.physical (one set: the loader per element, the model's
setters per array) and the tree checks of warpdyn.description.model.finish_tree and .tree.build_tree. Each
case is a two-link URDF (or an MJCF fixture) with one fault; the test checks the exception type and, with
`match`, that the message names the element and its value. Real descriptions keep loading: every
icub-models URDF, the ergoCub and the MJCF fixtures (their rounding noise and massless chain links are
within the documented tolerances), with an UnphysicalInertiaWarning for the two kinds of inertia that
compute but that no rigid body has.
"""

from __future__ import annotations

import pathlib
import warnings

import icub_models
import numpy as np
import pytest

import mjcf_fixtures as mf
import robots
import warpdyn as wd

pytestmark = pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")  # yourdfpy's rpy of inf

Model = wd.model.Model
UNIT = '<inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>'


def _inertial(mass="1", ixx="0.1", iyy="0.1", izz="0.1", ixy="0", xyz="0 0 0", rpy="0 0 0") -> str:
    return (
        f'<inertial><origin xyz="{xyz}" rpy="{rpy}"/><mass value="{mass}"/>'
        f'<inertia ixx="{ixx}" iyy="{iyy}" izz="{izz}" ixy="{ixy}" ixz="0" iyz="0"/></inertial>'
    )


def _urdf(link1=UNIT, link2=UNIT, origin='<origin xyz="0 0 0.5"/>', axis='<axis xyz="0 1 0"/>', limit="-1 1", j2="j2",
          link2_name="link2", j2_type="revolute", extra="") -> str:
    """base -> j1 (revolute, the fault's origin, axis and limits) -> link1 -> j2 -> link2."""
    lower, upper = limit.split()
    return (
        f'<robot name="faulty"><link name="base">{UNIT}</link><link name="link1">{link1}</link>'
        f'<link name="{link2_name}">{link2}</link>'
        f'<joint name="j1" type="revolute"><parent link="base"/><child link="link1"/>{origin}{axis}'
        f'<limit lower="{lower}" upper="{upper}" effort="10" velocity="1"/></joint>'
        f'<joint name="{j2}" type="{j2_type}"><parent link="link1"/><child link="{link2_name}"/><origin xyz="0 0 0.5"/>'
        f'<axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>{extra}</robot>'
    )


def _load(text, **kwargs) -> Model:
    return Model.build_from_model_description(text, dtype=np.float64, **kwargs)


# --------------------------------------------------------------------------------- links' inertial values


@pytest.mark.parametrize(
    "link1, message",
    [
        (_inertial(mass="-1"), r"link 'link1': mass -1 kg is negative"),
        (_inertial(mass="nan"), r"link 'link1': mass nan kg is not finite"),
        (_inertial(mass="inf"), r"link 'link1': mass inf kg is not finite"),
        (_inertial(ixx="-0.1"), r"link 'link1': inertia has a negative principal moment -0.1 kg m\^2"),
        (_inertial(ixy="0.5"), r"link 'link1': inertia has a negative principal moment -0.4 kg m\^2"),
        (_inertial(ixx="nan"), r"link 'link1': inertia has non-finite entries"),
        (_inertial(xyz="0 nan 0"), r"link 'link1': centre of mass \[.*nan.*\] is not finite"),
        (_inertial(rpy="0 inf 0"), r"link 'link1': (centre of mass|inertia).* (is not finite|non-finite)"),
    ],
    ids=["negative mass", "NaN mass", "inf mass", "negative moment", "indefinite", "NaN inertia", "NaN CoM", "inf CoM frame"],
)
def test_impossible_link_inertial_values_name_the_file_and_link(link1, message):
    """Negative or non-finite masses (which the lumping turned into 0 kg), indefinite or non-finite
    inertias, non-finite centres of mass: a ValueError naming the document and the link."""
    with pytest.raises(ValueError, match="the given XML document: " + message):
        _load(_urdf(link1=link1))


def test_the_file_is_named_and_every_fault_listed(tmp_path):
    path = tmp_path / "two_faults.urdf"
    path.write_text(_urdf(link1=_inertial(mass="-2"), link2=_inertial(izz="-1")))
    with pytest.raises(ValueError, match=r"two_faults.urdf': link 'link1': mass -2 kg is negative; link 'link2': inertia has a"):
        _load(path)


def test_rounding_noise_of_real_inertias_is_accepted():
    """Within the tolerances (1e-6 of the largest principal moment, 1e-9 of the largest inertia entry): a
    point mass written with +-1e-20 entries (as icub-models does) and a moment rounded 1e-7 below zero load."""
    noise = _inertial(ixx="1e-20", iyy="-1e-20", izz="0", ixy="2e-35")
    rounded = _inertial(ixx="-1e-8", iyy="0.1", izz="0.1")
    model = _load(_urdf(link1=noise, link2=rounded))
    assert model.number_of_links() == 3


def test_triangle_inequality_and_massless_inertia_warn_and_are_kept():
    """Positive semi-definite inertias no rigid body has compute; they are kept as given (the lumping kept no
    inertia of a massless link before) and named in one UnphysicalInertiaWarning."""
    with pytest.warns(wd.model.UnphysicalInertiaWarning, match=r"link 'link1': principal moments \(0.1, 0.1, 0.5\) kg m\^2 violate"):
        model = _load(_urdf(link1=_inertial(izz="0.5")))
    np.testing.assert_array_equal(model.tree.link_inertia[1], np.diag([0.1, 0.1, 0.5]))
    with pytest.warns(wd.model.UnphysicalInertiaWarning, match=r"link 'link1': principal moments \(0.1, 0.1, 0.1\) kg m\^2 without mass"):
        model = _load(_urdf(link1=_inertial(mass="0")))
    np.testing.assert_array_equal(model.tree.link_inertia[1], 0.1 * np.eye(3))


def test_the_setters_apply_the_same_checks():
    """set_link_parameters refuses what the loader refuses, naming the entry, and warns where it warns."""
    model = _load(_urdf())
    inertia = np.tile(0.1 * np.eye(3), (3, 1, 1))
    inertia[2, 0, 1] = inertia[2, 1, 0] = 0.5
    with pytest.raises(ValueError, match=r"link_inertia must hold positive semi-definite matrices: entry \(2,\)"):
        model.set_link_parameters(inertia=inertia)
    inertia[2] = np.diag([0.1, 0.1, 0.5])
    with pytest.warns(wd.model.UnphysicalInertiaWarning, match=r"link_inertia: entry \(2,\)"):
        model.set_link_parameters(inertia=inertia)
    inertia[2] = np.diag([-1e-8, 0.1, 0.1])  # within the tolerance, as at load time
    model.set_link_parameters(inertia=inertia)


# ---------------------------------------------------------------------------------------------- joints


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"origin": '<origin xyz="0 nan 0.5"/>'}, r"joint 'j1': origin \(the joint frame in the parent link\) has non-finite"),
        ({"origin": '<origin xyz="0 0 0.5" rpy="inf 0 0"/>'}, r"joint 'j1': origin .* non-finite"),
        ({"axis": '<axis xyz="0 nan 1"/>'}, r"joint 'j1' has a zero or non-finite axis \[0.0, nan, 1.0\]"),
        ({"axis": '<axis xyz="0 0 0"/>'}, r"joint 'j1' has a zero or non-finite axis"),
        ({"limit": "nan 1"}, r"joint 'j1': position limits \(nan, 1.0\) holds NaN"),
        ({"limit": "1 -1"}, r"joint 'j1': position limits has lower 1 above upper -1"),
    ],
    ids=["NaN origin", "inf rpy", "NaN axis", "zero axis", "NaN limit", "crossed limits"],
)
def test_impossible_joints_name_the_joint(kwargs, message):
    with pytest.raises(ValueError, match=message):
        _load(_urdf(**kwargs))


def test_negative_joint_dynamics_and_limits_name_the_joint():
    text = _urdf().replace('velocity="1"/></joint>', 'velocity="1"/><dynamics damping="-1" friction="0"/></joint>', 1)
    with pytest.raises(ValueError, match=r"joint 'j1': damping -1 is negative"):
        _load(text)
    with pytest.raises(ValueError, match=r"joint 'j1': effort limit -10.0 \[N m or N\] must be non-negative"):
        _load(_urdf().replace('effort="10"', 'effort="-10"', 1))


def test_mjcf_values_mujoco_lets_through_are_named():
    """MuJoCo refuses negative masses itself (its message is passed on) but compiles NaN positions, axes and
    centres of mass: the loader names the body or joint."""
    arm = mf.ARMATURE
    with pytest.raises(ValueError, match="not a valid MJCF: .*mass and inertia of moving bodies"):
        _load(arm.replace('mass="1.0"', 'mass="-1.0"'))
    with pytest.raises(ValueError, match=r"joint 'j2': origin .* non-finite"):
        _load(arm.replace('pos="0.3 0 0"', 'pos="0.3 nan 0"'))
    with pytest.raises(ValueError, match=r"joint 'j1': axis \[0.0, nan, 1.0\] is not a finite non-zero vector"):
        _load(arm.replace('<joint name="j1" axis="0 0 1"/>', '<joint name="j1" axis="0 nan 1"/>'))
    with pytest.raises(ValueError, match=r"link 'link1': centre of mass \[0.15, nan, 0.0\] is not finite"):
        _load(arm.replace('pos="0.15 0 0"', 'pos="0.15 nan 0"'))


# ---------------------------------------------------------------------------------------- the tree


def test_duplicate_joint_names_are_refused():
    with pytest.raises(ValueError, match=r"joint names \['j1'\] are used more than once"):
        _load(_urdf(j2="j1"))


def test_empty_link_names_are_refused():
    with pytest.raises(ValueError, match=r"the links at positions \[2\] .* have empty names"):
        _load(_urdf(link2_name=""))


def test_a_detached_cycle_of_links_is_refused_not_dropped():
    cycle = (
        '<link name="a"/><link name="b"/>'
        '<joint name="ab" type="fixed"><parent link="a"/><child link="b"/></joint>'
        '<joint name="ba" type="fixed"><parent link="b"/><child link="a"/></joint>'
    )
    with pytest.raises(ValueError, match=r"links \['a', 'b'\] are not connected to the root link 'base': their joints form a cycle"):
        _load(_urdf(extra=cycle))


@pytest.mark.parametrize("j2_type", ["revolute", "prismatic"])
def test_a_massless_leaf_on_a_moving_joint_is_refused(j2_type):
    """A leaf of the lumped tree without inertia about its joint's axis makes that joint's acceleration 0 / 0
    (NaN dynamics): refused, naming the link and the joint."""
    with pytest.raises(ValueError, match=rf"link 'link2' ends the chain of {j2_type} joint 'j2' but has no inertia about its axis \(mass 0 kg\)"):
        _load(_urdf(link2="", j2_type=j2_type))


def test_a_point_mass_on_a_revolute_axis_is_refused():
    with pytest.raises(ValueError, match=r"link 'link2' ends the chain of revolute joint 'j2' but has no inertia about its axis \(mass 1 kg\)"):
        _load(_urdf(link2=_inertial(ixx="0", iyy="0", izz="0", xyz="0 0 0")))


def test_massless_links_inside_a_chain_and_on_fixed_joints_stay_allowed():
    """A massless link that carries others (URDF dummy links, MJCF multi-joint bodies) and a massless leaf on
    a fixed joint (a sensor frame) load, and the dynamics stay finite."""
    sensor = '<link name="sensor"/><joint name="to_sensor" type="fixed"><parent link="link2"/><child link="sensor"/></joint>'
    model = _load(_urdf(link1="", extra=sensor))
    assert model.frame_names() == ("sensor",)
    M = wd.model.free_floating_mass_matrix(model, wd.data.random_model_data(model, key=0)).numpy()
    assert np.all(np.isfinite(M)) and np.linalg.eigvalsh(M).min() > 0.0
    mjcf = _load(mf.MULTI_JOINT)
    assert mjcf.dofs() == 8


def test_a_floating_base_without_any_mass_is_refused():
    with pytest.raises(ValueError, match=r"the floating base 'alone' and everything it carries have no mass"):
        _load('<robot name="empty"><link name="alone"/></robot>')


# ----------------------------------------------------------------------------------- reduce and names


def test_reduce_refuses_non_finite_locked_positions():
    model = _load(_urdf())
    for bad in (float("nan"), float("inf")):
        with pytest.raises(ValueError, match=rf"locked_joint_positions\['j1'\] is {bad}: a locked position must be finite"):
            wd.model.reduce(model, ["j2"], locked_joint_positions={"j1": bad})
    with pytest.raises(TypeError, match=r"locked_joint_positions\['j1'\] must be a number \[rad or m\], got 'up'"):
        wd.model.reduce(model, ["j2"], locked_joint_positions={"j1": "up"})
    with pytest.raises(TypeError, match=r"locked_joint_positions must be a dict"):
        wd.model.reduce(model, ["j2"], locked_joint_positions=[0.1])


def test_one_joint_name_as_a_string_is_not_read_as_letters():
    model = _load(_urdf())
    with pytest.raises(TypeError, match=r"considered_joints must be a list of names, got the string 'j2' \(write \['j2'\]\)"):
        wd.model.reduce(model, "j2")
    with pytest.raises(TypeError, match=r"considered_joints must be a list of names, got the string 'l_knee'"):
        _load(robots.ergocub_urdf(), considered_joints="l_knee")
    with pytest.raises(TypeError, match=r"considered_joints must hold names \(strings\), got \[3\]"):
        wd.model.reduce(model, ["j2", 3])


# ------------------------------------------------------------------------------- documents and files


def test_a_non_utf8_mjcf_file_names_the_file(tmp_path):
    """MuJoCo reads a file's bytes as UTF-8 whatever its XML declaration says (its names then failed to
    decode with a bare UnicodeDecodeError): the file is named. Its text, as a str, loads."""
    text = '<?xml version="1.0" encoding="latin-1"?>\n' + mf.ARMATURE.replace('model="armature"', 'model="bras à trois"')
    path = tmp_path / "latin1.xml"
    path.write_bytes(text.encode("latin-1"))
    with pytest.raises(ValueError, match=r"latin1.xml' is not UTF-8 \(byte \d+\): MuJoCo reads MJCF files as UTF-8"):
        _load(path)
    assert _load(text).name() == "bras à trois"


def test_binary_content_is_named_not_decoded(tmp_path):
    """A binary file as a path, and binary text as a str (neither XML nor a file): each named, the long
    string shortened in the message."""
    path = tmp_path / "robot.bin"
    path.write_bytes(bytes(range(256)) * 8)
    with pytest.raises(ValueError, match=r"robot.bin' is not well-formed XML"):
        _load(path)
    with pytest.raises(FileNotFoundError, match=r"does not exist or is not a file \(nor an XML document\)") as error:
        _load((bytes(range(1, 256)) * 8).decode("latin-1"))
    assert len(str(error.value)) < 400


# ------------------------------------------------------------------------------- real descriptions


UNPHYSICAL = {
    "iCubGenova03": ["torso_1", "torso_2"],
    "iCubLisboa01": ["torso_1", "torso_2"],
    "iCubNancy01": ["l_ankle_1", "r_ankle_1", "torso_1", "torso_2"],
}
"""icub-models URDFs with inertias no rigid body has: mass 0 with a rotational inertia (the torsos), and
iCubNancy01's ankles, whose principal moments (0.0035, 0.0043, 4.77 kg m^2) violate the triangle inequality."""


@pytest.mark.parametrize("robot", sorted(icub_models.get_robot_names()))
def test_every_icub_models_urdf_passes_the_checks(robot):
    """Every real URDF loads without an error; exactly the UNPHYSICAL ones warn, naming those links."""
    text = pathlib.Path(icub_models.get_model_file(robot)).read_text()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        wd.description.load(text)
    named = [w for w in caught if issubclass(w.category, wd.model.UnphysicalInertiaWarning)]
    if robot not in UNPHYSICAL:
        assert not named, str(named[0].message)
        return
    assert len(named) == 1
    message = str(named[0].message)
    for link in UNPHYSICAL[robot]:
        assert f"link '{link}'" in message, message


def test_the_ergocub_and_the_mjcf_fixtures_pass_the_checks():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        warnings.simplefilter("error", wd.model.UnphysicalInertiaWarning)
        wd.description.load(robots.ergocub_urdf())
        for name, text in mf.FIXTURES.items():
            if name in ("GRAVCOMP", "BALL"):  # refused for other reasons (tests/test_mjcf_description.py)
                continue
            wd.description.load(text)
