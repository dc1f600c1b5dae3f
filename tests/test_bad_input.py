"""Bad input gives a clear exception that names the offending thing.

Reference: the façade's documented contract (warpdyn.description.load, Model.build_from_model_description,
Data.build, warpdyn.model.reduce, name and index look-ups): each case checks the exception type and, with
`match`, that the message names the argument, joint, link or value at fault. No tolerances: exact
messages, matched by regular expressions.
"""

from __future__ import annotations

import functools
import re
import types

import numpy as np
import pytest
import warp as wp

import robots
import warpdyn as wd
from warpdyn import arrays as _arrays

Model = wd.model.Model


@functools.cache
def _model(dtype=np.float64, fixed_base=False) -> Model:
    """A random tree with frames (floating base) or a welded one."""
    seed = 2 if fixed_base else 3
    return Model.build_from_model_description(robots.random_tree_urdf(seed, fixed_base=fixed_base), dtype=dtype)


def _urdf(joint_xml: str, extra_links: str = "") -> str:
    return (
        '<robot name="bad"><link name="base"/><link name="child"/>' + extra_links + joint_xml + "</robot>"
    )


# ---------------------------------------------------------------------------------------- descriptions


def test_missing_file_raises_file_not_found(tmp_path):
    """A path that does not exist: FileNotFoundError naming the path."""
    path = tmp_path / "no_such_robot.urdf"
    with pytest.raises(FileNotFoundError, match=re.escape(str(path))):
        Model.build_from_model_description(path)
    with pytest.raises(FileNotFoundError, match="no_such_robot.urdf"):
        Model.build_from_model_description(str(path))


def test_directory_instead_of_file_raises_file_not_found(tmp_path):
    """A directory is not a description file: FileNotFoundError naming it."""
    with pytest.raises(FileNotFoundError, match=re.escape(str(tmp_path))):
        Model.build_from_model_description(tmp_path)


def test_malformed_xml_raises_value_error(tmp_path):
    """Not well-formed XML, as a string and as a file: ValueError saying so (and naming the file)."""
    with pytest.raises(ValueError, match="not well-formed XML"):
        Model.build_from_model_description('<robot name="r"><link name="a"></robot>')
    path = tmp_path / "broken.urdf"
    path.write_text('<robot name="r"><link name="a">')
    with pytest.raises(ValueError, match=r"broken\.urdf.*not well-formed XML"):
        Model.build_from_model_description(path)


def test_unknown_root_element_raises_value_error():
    """XML that is neither URDF, SDF nor MJCF: ValueError naming the root element."""
    with pytest.raises(ValueError, match=r"<world>.*expected <robot> \(URDF\), <mujoco> \(MJCF\) or <sdf> \(SDFormat\)"):
        Model.build_from_model_description('<world name="w"><model name="m"/></world>')


def test_description_of_wrong_type_raises_type_error():
    """Neither a path nor a string: TypeError naming the type given."""
    with pytest.raises(TypeError, match="model_description.*int"):
        Model.build_from_model_description(42)


def test_unsupported_urdf_joint_inside_the_tree_names_joint_and_type():
    """A planar joint between two links: ValueError naming the joint and its type (a floating one is a free
    joint: tests/test_joint_kinds.py)."""
    urdf = _urdf(
        '<joint name="odd_joint" type="planar"><parent link="base"/><child link="child"/>'
        '<axis xyz="0 0 1"/></joint>'
    )
    with pytest.raises(ValueError, match=r"joint 'odd_joint' has type 'planar'"):
        Model.build_from_model_description(urdf)


def _mjcf(body_joint: str) -> str:
    return (
        '<mujoco model="m"><worldbody><body name="torso"><freejoint name="root"/>'
        '<geom type="sphere" size="0.1"/>'
        f'<body name="arm" pos="0 0 0.2">{body_joint}<geom type="sphere" size="0.05"/></body>'
        "</body></worldbody></mujoco>"
    )


def test_mjcf_free_joint_inside_the_tree_names_body():
    """A free joint on a body that is not a child of the world: ValueError naming the free joint and its body.

    MuJoCo's compiler rejects it first; its message (passed on) names the body, not the joint.
    """
    with pytest.raises(ValueError, match=r"(?s)not a valid MJCF.*free joint.*'arm'"):
        Model.build_from_model_description(_mjcf('<freejoint name="inner_free"/>'))


def test_mjcf_body_with_two_joints_becomes_a_chain():
    """Two joints on one body are no longer refused: the body becomes a chain through a massless link named
    '{body}/{first joint}' (warpdyn.description.mjcf; kinematics checked in tests/test_mjcf_description.py)."""
    joints = '<joint name="j_a" type="hinge" axis="1 0 0"/><joint name="j_b" type="hinge" axis="0 1 0"/>'
    model = Model.build_from_model_description(_mjcf(joints))
    assert model.joint_names() == ("j_a", "j_b")
    assert model.link_names() == ("torso", "arm/j_a", "arm")


def test_joint_naming_an_undefined_link():
    """A joint whose child link is not defined: ValueError naming the joint and the link."""
    urdf = _urdf('<joint name="j" type="revolute"><parent link="base"/><child link="ghost"/>'
                 '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>')
    with pytest.raises(ValueError, match=r"ghost"):
        Model.build_from_model_description(urdf)


def test_unknown_considered_joint_lists_the_names():
    """considered_joints with names the model lacks: ValueError listing exactly those names."""
    urdf = robots.random_tree_urdf(3)
    with pytest.raises(ValueError, match=r"\['no_such_joint', 'joint999'\]"):
        Model.build_from_model_description(urdf, considered_joints=["joint1", "no_such_joint", "joint999"])


# -------------------------------------------------------------------------------------- model options


@pytest.mark.parametrize("dtype", [np.int32, np.float16, "complex128"])
def test_bad_model_dtype(dtype):
    """A scalar type other than float32/float64: TypeError naming the accepted types."""
    with pytest.raises(TypeError, match=r"dtype must be np.float32 or np.float64"):
        Model.build_from_model_description(robots.random_tree_urdf(3), dtype=dtype)


@pytest.mark.parametrize("time_step", [0.0, -1e-3, float("nan"), float("inf")])
def test_non_positive_time_step(time_step):
    """time_step <= 0 or non-finite: ValueError naming time_step and the value."""
    with pytest.raises(ValueError, match=rf"time_step must be positive and finite, got {time_step}"):
        Model.build_from_model_description(robots.random_tree_urdf(3), time_step=time_step)


def test_non_finite_gravity():
    """Non-finite gravity: ValueError naming gravity."""
    with pytest.raises(ValueError, match=r"gravity must be finite"):
        Model.build_from_model_description(robots.random_tree_urdf(3), gravity=float("nan"))


def test_reduce_with_unknown_joint_names():
    """reduce naming joints the model lacks: ValueError listing them."""
    model = _model()
    keep = list(model.joint_names()[:2])
    with pytest.raises(ValueError, match=r"\['elbow_of_nobody'\]"):
        wd.model.reduce(model, keep + ["elbow_of_nobody"])


def test_reduce_with_a_whole_posture():
    """locked_joint_positions may name the joints the reduction keeps, as JaxSim's (a whole posture): their
    positions lock nothing; the locked joints' are used."""
    model = _model()
    keep = list(model.joint_names()[:2])
    posture = {name: 0.1 * k for k, name in enumerate(model.joint_names())}
    reduced = wd.model.reduce(model, keep, locked_joint_positions=posture)
    assert reduced.joint_names() == tuple(keep)
    assert reduced.tree.locked_joints == {name: value for name, value in posture.items() if name not in keep}


def test_reduce_locking_an_unknown_joint():
    """locked_joint_positions naming a joint the model does not have: ValueError naming it."""
    model = _model()
    with pytest.raises(ValueError, match=r"'phantom'"):
        wd.model.reduce(model, list(model.joint_names()[:2]), locked_joint_positions={"phantom": 0.3})


# ------------------------------------------------------------------------------- names and indices


@pytest.mark.parametrize(
    "module, kwarg",
    [(wd.link, "link_name"), (wd.frame, "frame_name"), (wd.joint, "joint_name")],
    ids=["link", "frame", "joint"],
)
def test_unknown_name_names_it_and_lists_the_known_ones(module, kwarg):
    """An unknown link/frame/joint name: ValueError naming it and listing the model's names."""
    model = _model()
    kind = kwarg.split("_")[0]
    with pytest.raises(ValueError, match=rf"no {kind} named 'nonexistent'.*\[.*'"):
        module.name_to_idx(model, **{kwarg: "nonexistent"})
    with pytest.raises(ValueError, match=r"'nonexistent'"):
        module.names_to_idxs(model, **{f"{kind}_names": [getattr(model, f"{kind}_names")()[0], "nonexistent"]})


def test_out_of_range_link_index():
    """A link index outside [0, nL): IndexError naming link_index, the value and the range."""
    model = _model()
    data = wd.data.Data.zero(model)
    nL = model.number_of_links()
    for bad in (nL, -1, 10**6):
        with pytest.raises(IndexError, match=rf"link_index {bad} is out of range \[0, {nL}\)"):
            wd.link.transform(model, data, link_index=bad)
    with pytest.raises(IndexError, match=r"link_index"):
        wd.link.jacobian(model, data, link_index=nL)
    with pytest.raises(IndexError, match=r"link_index"):
        wd.link.velocity(model, data, link_index=nL)
    with pytest.raises(IndexError, match=r"link_index"):
        wd.link.idx_to_name(model, link_index=nL)


def test_out_of_range_frame_index():
    """Frame indices start at nL: a link index, or one past the last frame, is an IndexError naming frame_index."""
    model = _model()
    data = wd.data.Data.zero(model)
    nL, nF = model.number_of_links(), model.number_of_frames()
    for bad in (0, nL - 1, nL + nF):
        with pytest.raises(IndexError, match=rf"frame_index {bad} is out of range \[{nL}, {nL + nF}\)"):
            wd.frame.transform(model, data, frame_index=bad)
    with pytest.raises(IndexError, match=r"frame_index"):
        wd.frame.jacobian(model, data, frame_index=nL + nF)
    with pytest.raises(IndexError, match=r"frame_index"):
        wd.frame.idx_of_parent_link(model, frame_index=0)


def test_out_of_range_joint_index():
    """A joint index outside [0, n): IndexError naming joint_index."""
    model = _model()
    with pytest.raises(IndexError, match=rf"joint_index {model.dofs()} is out of range"):
        wd.joint.idx_to_name(model, joint_index=model.dofs())
    with pytest.raises(IndexError, match=r"joint_index -1 is out of range"):
        wd.joint.position_limit(model, joint_index=-1)


@pytest.mark.parametrize("bad", [1.0, True, "1", None])
def test_non_integer_index(bad):
    """An index that is not an integer (bool included): TypeError naming link_index and the value."""
    model = _model()
    with pytest.raises(TypeError, match=rf"link_index must be an integer, got {re.escape(repr(bad))}"):
        wd.link.transform(model, wd.data.Data.zero(model), link_index=bad)


# ------------------------------------------------------------------------------------------- state


@pytest.mark.parametrize(
    "field, shape",
    [("joint_positions", "n+1"), ("joint_velocities", "2n"), ("base_position", 2), ("base_quaternion", 3),
     ("base_linear_velocity", 4), ("base_angular_velocity", (3, 1))],
)
def test_state_of_wrong_shape_names_the_argument(field, shape):
    """A state argument of the wrong shape (NumPy): ValueError naming the argument and the shapes."""
    model = _model()
    n = model.dofs()
    shape = {"n+1": (n + 1,), "2n": (2, n)}.get(shape, shape)
    shape = (shape,) if isinstance(shape, int) else shape
    with pytest.raises(ValueError, match=rf"{field} has shape {re.escape(str(tuple(shape)))}, expected"):
        wd.data.Data.build(model, **{field: np.ones(shape)})


def test_per_environment_state_with_wrong_number_of_environments():
    """(N', n) with N' != num_envs, NumPy and Warp: ValueError naming the argument."""
    model = _model()
    n = model.dofs()
    with pytest.raises(ValueError, match=r"joint_positions has shape \(2, "):
        wd.data.Data.build(model, joint_positions=np.zeros((2, n)), num_envs=3)
    with pytest.raises(ValueError, match=r"joint_velocities has shape \(4, "):
        wd.data.Data.build(model, joint_velocities=wp.zeros((4, n), dtype=wp.float64), num_envs=3)
    with pytest.raises(ValueError, match=r"joint_positions has shape \(1, "):
        wd.data.Data.build(model, joint_positions=np.zeros((1, n)))  # single environment: no leading axis


def test_warp_state_of_wrong_shape_names_the_argument():
    """A Warp array of the wrong shape: ValueError naming the argument."""
    model = _model()
    with pytest.raises(ValueError, match=r"joint_positions has shape \(3,\)"):
        wd.data.Data.build(model, joint_positions=wp.zeros(3, dtype=wp.float64))


def test_non_numeric_state_names_the_argument():
    """A state argument that is not numbers: TypeError or ValueError naming it."""
    model = _model()
    with pytest.raises((TypeError, ValueError), match=r"base_position"):
        wd.data.Data.build(model, base_position=["a", "b", "c"])


def test_warp_array_of_wrong_dtype_names_the_argument():
    """A float32 Warp array into a float64 model (and the converse): TypeError naming argument and dtypes."""
    m64, m32 = _model(np.float64), _model(np.float32)
    n = m64.dofs()
    with pytest.raises(TypeError, match=r"joint_positions has dtype float32, but the model computes in float64"):
        wd.data.Data.build(m64, joint_positions=wp.zeros(n, dtype=wp.float32))
    with pytest.raises(TypeError, match=r"base_quaternion has dtype float64, but the model computes in float32"):
        wd.data.Data.build(m32, base_quaternion=wp.array([1.0, 0.0, 0.0, 0.0], dtype=wp.float64))


def test_data_of_another_dtype_or_model():
    """Data of a float32 model into a float64 one, or of a model with other joints: named errors."""
    m64, m32 = _model(np.float64), _model(np.float32)
    with pytest.raises(TypeError, match=r"data is in float32 but the model computes in float64"):
        wd.model.forward_kinematics(m64, wd.data.Data.zero(m32))
    other = Model.build_from_model_description(robots.random_tree_urdf(11), dtype=np.float64)
    with pytest.raises(ValueError, match=rf"data.joint_positions_state has shape \(1, {other.dofs()}\), expected \(1, {m64.dofs()}\)"):
        wd.model.generalized_free_floating_jacobian(m64, wd.data.Data.zero(other))


class _FakeDevice:
    """A device whose string is not the model's: what a Warp array on another GPU reports."""

    def __init__(self, name: str):
        self.name = name

    def __str__(self) -> str:
        return self.name


def test_array_on_another_device_names_the_argument_and_devices():
    """check_device_array rejects an array on a device other than the model's, naming both.

    Only the CPU exists here, so the array's device is faked (an object standing for 'cuda:1'); the
    same array on the model's own device must pass.
    """
    cpu = wp.get_device("cpu")
    array = wp.zeros(3, dtype=wp.float64, device=cpu)
    _arrays.check_device_array(array, "base_position", wp.float64, cpu)  # same device: no error
    fake = types.SimpleNamespace(dtype=wp.float64, device=_FakeDevice("cuda:1"))
    with pytest.raises(ValueError, match=r"base_position is on device 'cuda:1', but the model is on 'cpu'"):
        _arrays.check_device_array(fake, "base_position", wp.float64, cpu)
    with pytest.raises(ValueError, match=r"joint_positions is on device 'cpu', but the model is on 'cuda:0'"):
        _arrays.check_device_array(array, "joint_positions", wp.float64, _FakeDevice("cuda:0"))


def test_data_on_another_device_is_rejected_before_launch():
    """Data whose arrays live on another device: ValueError naming both devices, before any kernel runs."""
    model = _model()
    data = wd.data.Data.zero(model)
    fake = types.SimpleNamespace(
        scalar=data.scalar,
        dtype=np.dtype(np.float64),
        joint_positions_state=data.joint_positions_state,
        joint_velocities_state=data.joint_velocities_state,
        device=_FakeDevice("cuda:3"),
    )
    with pytest.raises(ValueError, match=rf"data is on device 'cuda:3' but the model is on '{model.device}'"):
        wd.model.forward_kinematics(model, fake)


@pytest.mark.parametrize("as_warp", [False, True], ids=["numpy", "warp"])
def test_non_unit_quaternion(as_warp):
    """A base quaternion whose norm is not 1: ValueError naming base_quaternion, the env and the norm."""
    model = _model()
    q = np.array([[1.0, 0.0, 0.0, 0.0], [1.0, 0.1, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]])
    value = wp.array(q, dtype=wp.float64) if as_warp else q
    with pytest.raises(ValueError, match=r"base_quaternion must be a unit quaternion.*environment\(s\) \[1\]"):
        wd.data.Data.build(model, base_quaternion=value, num_envs=3)
    with pytest.raises(ValueError, match=r"base_quaternion must be a unit quaternion"):
        wd.data.Data.build(model, base_quaternion=np.zeros(4))


@pytest.mark.parametrize("as_warp", [False, True], ids=["numpy", "warp"])
@pytest.mark.parametrize(
    "field, size", [("joint_positions", "n"), ("joint_velocities", "n"), ("base_position", 3),
                    ("base_quaternion", 4), ("base_linear_velocity", 3), ("base_angular_velocity", 3)]
)
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf], ids=["nan", "inf", "-inf"])
def test_non_finite_state_names_the_argument(field, size, bad, as_warp):
    """NaN or ±inf in a state argument, NumPy or Warp: ValueError naming the argument."""
    model = _model()
    size = model.dofs() if size == "n" else size
    value = np.full(size, 0.1)
    value[size // 2] = bad
    if as_warp:
        value = wp.array(value, dtype=wp.float64)
    with pytest.raises(ValueError, match=rf"{field} has non-finite values"):
        wd.data.Data.build(model, **{field: value})


@pytest.mark.parametrize("num_envs", [0, -1, 2.5, "3", True, 2.0])
def test_bad_num_envs(num_envs):
    """num_envs that is not a positive integer (a bool or a float included): ValueError naming num_envs
    and the value (not an error from deep inside the array code)."""
    model = _model()
    with pytest.raises(ValueError, match=rf"num_envs must be a positive integer or None, got {re.escape(repr(num_envs))}"):
        wd.data.Data.build(model, num_envs=num_envs)


def test_bad_num_envs_in_zero_data():
    """Data.zero forwards num_envs and its check."""
    with pytest.raises(ValueError, match=r"num_envs must be a positive integer"):
        wd.data.Data.zero(_model(), num_envs=0)


def test_bad_velocity_representation():
    """A velocity representation that is not a VelRepr value: ValueError naming the value."""
    with pytest.raises(ValueError, match=r"7"):
        wd.data.Data.build(_model(), velocity_representation=7)


def test_fixed_base_with_base_velocity():
    """A non-zero base velocity for a fixed-base model: ValueError naming the model and the base."""
    model = _model(fixed_base=True)
    with pytest.raises(ValueError, match=rf"model '{model.name()}' has a fixed base: base velocities must be zero"):
        wd.data.Data.build(model, base_linear_velocity=[0.0, 0.0, 1.0])


def test_replace_checks_like_build():
    """Data.replace validates what it is given as Data.build does: a named error, the data untouched. The
    base quaternion is normalised, as JaxSim's replace does; a zero or non-finite one is refused."""
    model = _model()
    data = wd.data.random_model_data(model, key=7)
    before = data.joint_positions.numpy().copy()
    with pytest.raises(ValueError, match=r"joint_positions has non-finite values"):
        data.replace(model, joint_positions=np.full(model.dofs(), np.nan))
    for bad in ([0.0, 0.0, 0.0, 0.0], [np.nan, 0.0, 0.0, 1.0]):
        with pytest.raises(ValueError, match=r"base_quaternion must be finite, non-zero"):
            data.replace(model, base_quaternion=bad)
    np.testing.assert_array_equal(data.joint_positions.numpy(), before)
    np.testing.assert_allclose(data.replace(model, base_quaternion=[2.0, 0.0, 0.0, 0.0]).base_quaternion.numpy(), [1.0, 0.0, 0.0, 0.0])
