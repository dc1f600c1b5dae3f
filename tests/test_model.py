"""Model building and queries: names, orders, lumping, reduction, frames, limits, URDF loading (mimic and
world joints, no joints at all). MJCF loading: tests/test_model_mjcf.py; the robots both use, by case
name, and their random states: tests/robots.py.

References: the URDF itself read with ElementTree and composed in NumPy (independent of the yourdfpy
parser warpdyn uses), and C MuJoCo on the same description, either with fixed links fused
(`robots.mujoco_model`) or with every URDF link a body (`fusestatic` off) where lumped links are compared.
"""

from __future__ import annotations

import pathlib
import warnings
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest

import robots
import warpdyn as wd
from robots import H_of, assert_close, built, considered_of, full_model, random_data, rng_for, skew, text_of

Model = wd.model.Model

SEED_LINKS = (
    "root_link", "l_hip_1", "r_hip_1", "l_hip_2", "r_hip_2", "l_upper_leg", "r_upper_leg",
    "l_lower_leg", "r_lower_leg", "l_ankle_1", "r_ankle_1", "l_ankle_2", "r_ankle_2",
)  # fmt: skip
SEED_JOINTS = (
    "l_hip_pitch", "r_hip_pitch", "l_hip_roll", "r_hip_roll", "l_hip_yaw", "r_hip_yaw",
    "l_knee", "r_knee", "l_ankle_pitch", "r_ankle_pitch", "l_ankle_roll", "r_ankle_roll",
)  # fmt: skip


# ------------------------------------------------------------------------------------ the URDF in NumPy


def rpy_matrix(rpy) -> np.ndarray:
    """URDF's fixed-axis roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = rpy
    Rx = np.array([[1, 0, 0], [0, np.cos(r), -np.sin(r)], [0, np.sin(r), np.cos(r)]])
    Ry = np.array([[np.cos(p), 0, np.sin(p)], [0, 1, 0], [-np.sin(p), 0, np.cos(p)]])
    Rz = np.array([[np.cos(y), -np.sin(y), 0], [np.sin(y), np.cos(y), 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def origin_of(element) -> np.ndarray:
    H = np.eye(4)
    origin = element.find("origin") if element is not None else None
    if origin is not None:
        H[:3, :3] = rpy_matrix([float(v) for v in origin.get("rpy", "0 0 0").split()])
        H[:3, 3] = [float(v) for v in origin.get("xyz", "0 0 0").split()]
    return H


def rodrigues(axis, angle) -> np.ndarray:
    a = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
    K = skew(a)
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * K @ K


class Urdf:
    """The URDF read with ElementTree: joints (in order) and links' inertial parameters."""

    def __init__(self, text: str):
        root = ET.fromstring(text)
        self.joints = []
        for j in root.findall("joint"):
            axis = j.find("axis")
            limit = j.find("limit")
            self.joints.append(
                dict(
                    name=j.get("name"),
                    type=j.get("type"),
                    parent=j.find("parent").get("link"),
                    child=j.find("child").get("link"),
                    origin=origin_of(j),
                    axis=np.array([float(v) for v in (axis.get("xyz") if axis is not None else "1 0 0").split()]),
                    lower=float(limit.get("lower", 0.0)) if limit is not None else 0.0,
                    upper=float(limit.get("upper", 0.0)) if limit is not None else 0.0,
                    mimic=j.find("mimic") is not None,
                )
            )
        self.links = {}
        for link in root.findall("link"):
            inertial = link.find("inertial")
            mass, com, inertia = 0.0, np.zeros(3), np.zeros((3, 3))
            if inertial is not None:
                H = origin_of(inertial)
                mass = float(inertial.find("mass").get("value"))
                i = {k: float(v) for k, v in inertial.find("inertia").attrib.items()}
                I = np.array(
                    [[i["ixx"], i["ixy"], i["ixz"]], [i["ixy"], i["iyy"], i["iyz"]], [i["ixz"], i["iyz"], i["izz"]]]
                )
                com, inertia = H[:3, 3], H[:3, :3] @ I @ H[:3, :3].T
            self.links[link.get("name")] = (mass, com, inertia)
        self.parent_joint = {j["child"]: j for j in self.joints}
        self.root = next(name for name in self.links if name not in self.parent_joint)

    def movable(self) -> list[str]:
        return [j["name"] for j in self.joints if j["type"] in ("revolute", "continuous", "prismatic")]

    def poses(self, q: dict | None = None) -> dict:
        """W_H_link of every link with the joints at `q` (0 where absent), the root at the identity."""
        q = q or {}
        out = {self.root: np.eye(4)}
        queue = [self.root]
        while queue:
            link = queue.pop(0)
            for j in self.joints:
                if j["parent"] != link:
                    continue
                M = np.eye(4)
                value = q.get(j["name"], 0.0)
                if j["type"] in ("revolute", "continuous"):
                    M[:3, :3] = rodrigues(j["axis"], value)
                elif j["type"] == "prismatic":
                    M[:3, 3] = np.asarray(j["axis"]) / np.linalg.norm(j["axis"]) * value
                out[j["child"]] = out[link] @ j["origin"] @ M
                queue.append(j["child"])
        return out

    def bfs_links(self) -> list[str]:
        order, queue = [], [self.root]
        while queue:
            link = queue.pop(0)
            order.append(link)
            queue += sorted(j["child"] for j in self.joints if j["parent"] == link)  # siblings by name, as JaxSim
        return order


def placed_inertia(mass, com, inertia, W_H_L) -> np.ndarray:
    """spatial_inertia of a body with CoM `com` and inertia `inertia` (about the CoM) in the frame L at W_H_L."""
    R, p = W_H_L[:3, :3], W_H_L[:3, 3]
    return spatial_inertia(mass, R @ com + p, R @ inertia @ R.T)


def spatial_inertia(mass, com_W, inertia_W) -> np.ndarray:
    """(6, 6) spatial inertia about the world origin, [linear; angular], of a body with CoM com_W and
    rotational inertia inertia_W (about the CoM, world axes)."""
    C = skew(com_W)
    M = np.zeros((6, 6))
    M[:3, :3] = mass * np.eye(3)
    M[:3, 3:] = -mass * C
    M[3:, :3] = mass * C
    M[3:, 3:] = inertia_W - mass * C @ C
    return M


# ------------------------------------------------------------------------------------ robots


MODELS = [
    ("random-0", None),
    ("random-3", None),
    ("random-15", None),
    ("randomfixed-100", None),
    ("randomfixed-101", None),
    ("pendulum-4", None),
    ("icub", None),
    ("icub", "legs"),
    ("ergocub", None),
    ("ergocub", "seed"),
]
MODEL_IDS = [c if w is None else f"{c}-{w}" for c, w in MODELS]


# ------------------------------------------------------------------------------------ the seed


@pytest.mark.parametrize("as_path", [str, pathlib.Path], ids=["str", "Path"])
def test_seed_ergocub_reduced(as_path):
    """The seed notebook's output, exactly: ergoCub from its URDF path reduced to the joints whose names
    contain none of the excluded words. Reference: the seed's printed name, counts and name tuples (exact
    strings, no tolerance)."""
    full = Model.build_from_model_description(as_path(robots.ERGOCUB))
    model = wd.model.reduce(full, robots.seed_joints(full.joint_names()))
    assert model.name() == "ergoCub"
    assert model.number_of_links() == 13
    assert model.number_of_joints() == 12
    assert model.dofs() == 12
    assert model.link_names() == SEED_LINKS
    assert model.joint_names() == SEED_JOINTS
    assert model.floating_base()
    assert model.base_link() == "root_link"
    assert model.dtype == np.float32  # the default scalar


@pytest.mark.parametrize("case,which", [("ergocub", "seed"), ("icub", "legs"), ("random-4", "half")])
def test_considered_joints_equals_reduce(case, which):
    """Model.build_from_model_description(considered_joints=...) is the same model as reduce(full, ...):
    names, tree constants and forward kinematics. Reference: the other construction; both lump on the host
    in float64 from the same description, so they must agree exactly."""
    full = full_model(case)
    if which == "half":
        rng = rng_for(case, "considered")
        names = full.joint_names()
        considered = [names[k] for k in sorted(rng.choice(len(names), len(names) // 2, replace=False))]
    else:
        considered = considered_of(case, which)
    a = Model.build_from_model_description(text_of(case), considered_joints=considered, dtype=np.float64)
    b = wd.model.reduce(full, considered)
    assert a.link_names() == b.link_names()
    assert a.joint_names() == b.joint_names()
    assert a.frame_names() == b.frame_names()
    assert set(a.joint_names()) == set(considered)
    for field in ("parent", "joint_type", "parent_H_joint", "joint_axis", "joint_pivot", "link_mass", "link_com",
                  "link_inertia", "frame_parent", "link_H_frame", "position_limits"):  # fmt: skip
        np.testing.assert_array_equal(getattr(a.tree, field), getattr(b.tree, field), err_msg=field)
    data, _ = random_data(a, rng_for(case, which, "fk"))
    data_b = wd.data.Data.build(
        b, base_position=data.base_position.numpy(), base_quaternion=data.base_quaternion.numpy(),
        joint_positions=data.joint_positions.numpy(),
    )  # fmt: skip
    np.testing.assert_array_equal(
        wd.model.forward_kinematics(a, data).numpy(), wd.model.forward_kinematics(b, data_b).numpy()
    )


@pytest.mark.parametrize("case,which", MODELS, ids=MODEL_IDS)
def test_tree_order(case, which):
    """Links are ordered parents first (parent index < child index, the base first with parent -1), joint i
    moves link i + 1 (its URDF child is link i + 1, its URDF parent lumps into link parent[i + 1]), and links
    are breadth-first (siblings by name, JaxSim's order). Reference: the URDF read with ElementTree (exact, no tolerance)."""
    model = built(case, which)
    urdf = Urdf(text_of(case))
    parent = model.tree.parent
    assert parent[0] == -1
    assert np.all(parent[1:] < np.arange(1, model.number_of_links())), parent
    assert np.all(parent[1:] >= 0)
    np.testing.assert_array_equal(model.parent.numpy(), parent)
    links = set(model.link_names())
    bfs = urdf.bfs_links()
    assert model.base_link() == (bfs[1] if urdf.root == "world" else bfs[0])
    for i, joint_name in enumerate(model.joint_names()):
        joint = next(j for j in urdf.joints if j["name"] == joint_name)
        assert joint["type"] in ("revolute", "continuous", "prismatic")
        assert joint["child"] == model.link_names()[i + 1]
        ancestor = joint["parent"]
        while ancestor not in links:
            ancestor = urdf.parent_joint[ancestor]["parent"]
        assert model.link_names()[parent[i + 1]] == ancestor, joint_name
    nL, n = model.number_of_links(), model.dofs()
    np.testing.assert_array_equal(wd.link.names_to_idxs(model, link_names=model.link_names()), np.arange(nL))
    assert wd.link.idxs_to_names(model, link_indices=np.arange(nL)) == model.link_names()
    np.testing.assert_array_equal(wd.joint.names_to_idxs(model, joint_names=model.joint_names()), np.arange(n))
    assert wd.joint.idxs_to_names(model, joint_indices=np.arange(n)) == model.joint_names()
    with pytest.raises(ValueError, match="no link named"):
        wd.link.name_to_idx(model, link_name="no_such_link")
    with pytest.raises(IndexError):
        wd.link.idx_to_name(model, link_index=nL)
    # Breadth-first over the lumped tree means depth never decreases along the link order.
    depth = np.zeros(model.number_of_links(), dtype=int)
    for i in range(1, model.number_of_links()):
        depth[i] = depth[parent[i]] + 1
    assert np.all(np.diff(depth) >= 0), depth


@pytest.mark.parametrize("case,which", MODELS, ids=MODEL_IDS)
def test_frames_names_parents_indices(case, which):
    """Frames are the lumped links: every URDF link (but 'world') that is not a model link, each attached
    to its nearest kept ancestor; frame indices start at number_of_links() and name/index look-ups round
    trip. Reference: the URDF read with ElementTree (exact)."""
    model = built(case, which)
    urdf = Urdf(text_of(case))
    nL, nF = model.number_of_links(), model.number_of_frames()
    links = set(model.link_names())
    expected = [name for name in urdf.bfs_links() if name not in links and name != "world"]
    assert sorted(model.frame_names()) == sorted(expected)
    assert model.frame_names() == tuple(sorted(expected))  # sorted by name, as JaxSim (tree.py)
    assert nF == len(expected)
    for k, name in enumerate(model.frame_names()):
        index = wd.frame.name_to_idx(model, frame_name=name)
        assert index == nL + k
        assert wd.frame.idx_to_name(model, frame_index=index) == name
        ancestor = urdf.parent_joint[name]["parent"]
        while ancestor not in links:
            ancestor = urdf.parent_joint[ancestor]["parent"]
        assert model.link_names()[wd.frame.idx_of_parent_link(model, frame_index=index)] == ancestor, name
    if nF:
        np.testing.assert_array_equal(wd.frame.names_to_idxs(model, frame_names=model.frame_names()), nL + np.arange(nF))
        assert wd.frame.idxs_to_names(model, frame_indices=nL + np.arange(nF)) == model.frame_names()
    for bad in (nL - 1, nL + nF):
        with pytest.raises(IndexError):
            wd.frame.idx_to_name(model, frame_index=bad)
    with pytest.raises(ValueError, match="no frame named"):
        wd.frame.name_to_idx(model, frame_name="no_such_frame")


@pytest.mark.parametrize("case,which", MODELS, ids=MODEL_IDS)
def test_lumping_conserves_inertia(case, which):
    """Lumping conserves the whole robot's mass, CoM and inertia: the total spatial inertia about the world
    origin at the zero configuration (base at the identity, or where a fixed base is welded) summed over the
    URDF's raw links (ElementTree, poses composed in NumPy) equals the one summed over the lumped model's
    links (model.tree masses/CoMs/inertias placed by warpdyn's float64 forward kinematics). Also
    wd.model.total_mass and link.mass. Tolerance 1e-12 relative: both are float64 sums of O(100) terms."""
    model = built(case, which)
    urdf = Urdf(text_of(case))
    for link in model.description.links:  # the description's raw links are the URDF's
        if link.name != "world":
            mass, com, inertia = urdf.links[link.name]
            assert abs(link.mass - mass) <= 1e-12 * max(1.0, mass), link.name
            assert_close(link.com, com, 1e-12, f"CoM of raw link '{link.name}'")
            assert_close(link.inertia, inertia, 1e-12, f"inertia of raw link '{link.name}'")
    poses = urdf.poses()
    raw = np.zeros((6, 6))
    for name, (mass, com, inertia) in urdf.links.items():
        raw += placed_inertia(mass, com, inertia, poses[name])
    data = wd.data.Data.zero(model)
    H_links = wd.model.forward_kinematics(model, data).numpy()
    if urdf.root == "world":  # the raw poses have the world at the identity: so does the welded base
        assert_close(H_links[0], poses[model.base_link()], 1e-12, "welded base pose")
    lumped = np.zeros((6, 6))
    tree = model.tree
    for i in range(model.number_of_links()):
        lumped += placed_inertia(tree.link_mass[i], tree.link_com[i], tree.link_inertia[i], H_links[i])
        assert wd.link.mass(model, link_index=i) == tree.link_mass[i]
    total = sum(m for m, _, _ in urdf.links.values())
    assert abs(wd.model.total_mass(model) - total) <= 1e-12 * total
    assert_close(lumped, raw, 1e-12, "total spatial inertia about the world origin")
    assert np.all(tree.link_mass >= 0.0)
    for i in range(model.number_of_links()):
        assert np.all(np.linalg.eigvalsh(tree.link_inertia[i]) >= -1e-12), f"link {i} inertia not PSD"


@pytest.mark.parametrize("case,which", [("ergocub", "seed"), ("icub", None), ("random-15", None), ("randomfixed-101", None)])
def test_frame_transform_vs_unfused_mujoco(case, which, dtype):
    """frame.transform of every lumped link equals MuJoCo's pose of that body in a MuJoCo model built without
    fusing (fusestatic off: every URDF link is a body), at a random state. Tolerance: float64 1e-10 (rounding
    over ~10 composed transforms, observed ~1e-15), float32 1e-4 (epsilon 1.2e-7 times the same)."""
    model = built(case, which, dtype)
    tol = {np.dtype(np.float64): 1e-10, np.dtype(np.float32): 1e-4}[np.dtype(dtype)]
    considered = None if which is None else model.joint_names()
    mj = robots.mujoco_model(text_of(case), considered, floating=model.floating_base(), fuse_static=False)
    st = robots.MujocoState(mj, model.joint_names(), model.floating_base())
    data, state = random_data(model, rng_for(case, which, "frames", np.dtype(dtype).name))
    st.set(*state)
    nL = model.number_of_links()
    assert model.number_of_frames() > 0
    for k, name in enumerate(model.frame_names()):
        p, R = st.body_pose(name)
        H = wd.frame.transform(model, data, frame_index=nL + k).numpy()
        assert_close(H, H_of(R, p), tol, f"frame '{name}'")


def _locked_choice(full, considered, rng, count):
    others = [name for name in full.joint_names() if name not in considered]
    names = [others[k] for k in rng.choice(len(others), count, replace=False)]
    values = {}
    for name in names:
        lower, upper = wd.joint.position_limit(full, joint_index=wd.joint.name_to_idx(full, joint_name=name))
        lower, upper = max(lower, -2.0), min(upper, 2.0)
        value = 0.0
        while abs(value) < 0.1:  # != 0, so that locking at 0 would fail
            value = rng.uniform(lower, upper)
        values[name] = value
    return values


@pytest.mark.parametrize("case,which", [("ergocub", "seed"), ("icub", "legs"), ("random-15", "half")])
def test_reduce_with_locked_positions_matches_mujoco(case, which, dtype):
    """reduce() with locked_joint_positions != 0 equals MuJoCo's model with ALL joints, the locked ones held at
    those positions (qpos set, qvel 0): link poses, Mixed Jacobians (base and kept-joint columns), link
    velocities, and lumped frames (vs the unfused MuJoCo body). Also the whole robot's spatial inertia at
    the locked configuration is conserved, and the locks survive a second reduce. Tolerance: float64 1e-10,
    float32 1e-4 (see test_kinematics_mujoco)."""
    tol = {np.dtype(np.float64): 1e-10, np.dtype(np.float32): 1e-4}[np.dtype(dtype)]
    full = full_model(case, dtype)
    rng = rng_for(case, which, "locked", np.dtype(dtype).name)
    if which == "half":
        names = full.joint_names()
        considered = [names[k] for k in sorted(rng.choice(len(names), len(names) // 2, replace=False))]
    else:
        considered = considered_of(case, which)
    locked = _locked_choice(full, considered, rng, min(6, full.dofs() - len(considered)))
    model = wd.model.reduce(full, considered, locked_joint_positions=locked)
    for name, value in locked.items():
        assert model.tree.locked_joints[name] == value
    assert set(model.joint_names()) == set(considered)

    text = text_of(case)
    floating = model.floating_base()
    mj = robots.mujoco_model(text, None, floating=floating)
    mj_unfused = robots.mujoco_model(text, None, floating=floating, fuse_static=False)
    names = list(model.joint_names()) + list(locked)
    data, (p, q, s, v, sd) = random_data(model, rng)
    s_all = np.concatenate([s, list(locked.values())])
    sd_all = np.concatenate([sd, np.zeros(len(locked))])
    st, su = robots.MujocoState(mj, names, floating), robots.MujocoState(mj_unfused, names, floating)
    st.set(p, q, s_all, v, sd_all)
    su.set(p, q, s_all, v, sd_all)

    n = model.dofs()
    H = wd.model.forward_kinematics(model, data).numpy()
    J = wd.model.generalized_free_floating_jacobian(model, data).numpy()  # Mixed in and out
    for i, name in enumerate(model.link_names()):
        ref = st if st.has_body(name) else su
        p_mj, R_mj = ref.body_pose(name)
        assert_close(H[i], H_of(R_mj, p_mj), tol, f"pose of link '{name}'")
        J_mj = ref.body_jacobian_mixed(name)[:, : 6 + n]
        first = 0 if floating else 6
        assert_close(J[i][:, first:], J_mj[:, first:], tol, f"Jacobian of link '{name}'")
        v_link = wd.link.velocity(model, data, link_index=i).numpy()
        assert_close(v_link, ref.body_velocity_mixed(name), tol, f"velocity of link '{name}'")
    nL = model.number_of_links()
    for k, name in enumerate(model.frame_names()):
        p_mj, R_mj = su.body_pose(name)
        assert_close(wd.frame.transform(model, data, frame_index=nL + k).numpy(), H_of(R_mj, p_mj), tol, f"frame '{name}'")

    # Spatial inertia of the whole robot at the locked configuration (float64 host constants).
    urdf = Urdf(text)
    poses = urdf.poses(locked)
    raw = np.zeros((6, 6))
    for name, (mass, com, inertia) in urdf.links.items():
        raw += placed_inertia(mass, com, inertia, poses[name])
    zero = wd.model.reduce(full_model(case), considered, locked_joint_positions=locked)
    H0 = wd.model.forward_kinematics(zero, wd.data.Data.zero(zero)).numpy()
    if urdf.root == "world":
        H0 = np.linalg.inv(H0[0]) @ poses[zero.base_link()] @ H0  # the raw poses have the world at the identity
    lumped = np.zeros((6, 6))
    for i in range(zero.number_of_links()):
        Hi, t = H0[i], zero.tree
        lumped += placed_inertia(t.link_mass[i], t.link_com[i], t.link_inertia[i], Hi)
    assert_close(lumped, raw, 1e-12, "spatial inertia at the locked configuration")

    # A second reduction keeps the first one's locks, and adds its own.
    kept, dropped = list(model.joint_names())[1:], model.joint_names()[0]
    again = wd.model.reduce(model, kept, locked_joint_positions={dropped: 0.25})
    assert again.tree.locked_joints == {**model.tree.locked_joints, dropped: 0.25}
    with pytest.raises(ValueError):
        wd.model.reduce(model, kept, locked_joint_positions={next(iter(locked)): 0.1})  # already locked
    # A kept joint's position locks nothing (JaxSim's: a posture of every joint may be passed).
    posture = wd.model.reduce(model, kept, locked_joint_positions={kept[0]: 0.1})
    assert posture.tree.locked_joints == {**model.tree.locked_joints, dropped: 0.0} and set(posture.joint_names()) == set(kept)
    with pytest.raises(ValueError):
        wd.model.reduce(model, kept + ["no_such_joint"])


@pytest.mark.parametrize("case", ["random-0", "icub", "ergocub"])
def test_position_limits(case):
    """joint.position_limit / position_limits vs the URDF's <limit> (ElementTree): revolute and prismatic
    limits as written, continuous joints unlimited (-inf, inf); position_limits follows the order of the
    names asked for. Exact (the same float parsed from the same text)."""
    model = full_model(case)
    urdf = Urdf(text_of(case))
    by_name = {j["name"]: j for j in urdf.joints}
    lower_all, upper_all = wd.joint.position_limits(model)
    assert lower_all.shape == upper_all.shape == (model.dofs(),)
    seen_types = set()
    for i, name in enumerate(model.joint_names()):
        j = by_name[name]
        seen_types.add(j["type"])
        expected = (-np.inf, np.inf) if j["type"] == "continuous" else (j["lower"], j["upper"])
        assert wd.joint.position_limit(model, joint_index=i) == expected, name
        assert (lower_all[i], upper_all[i]) == expected, name
    if case == "random-0":
        assert {"revolute", "prismatic", "continuous"} <= seen_types  # the case covers all three
    rng = rng_for(case, "limits")
    subset = [model.joint_names()[k] for k in rng.permutation(model.dofs())[: max(1, model.dofs() // 2)]]
    lower, upper = wd.joint.position_limits(model, joint_names=subset)
    np.testing.assert_array_equal(lower, [lower_all[model.joint_names().index(n)] for n in subset])
    np.testing.assert_array_equal(upper, [upper_all[model.joint_names().index(n)] for n in subset])
    with pytest.raises(IndexError):
        wd.joint.position_limit(model, joint_index=model.dofs())


_INERTIAL = (
    '<inertial><origin xyz="0.01 0.02 -0.05"/><mass value="{m}"/>'
    '<inertia ixx="0.03" iyy="0.04" izz="0.02" ixy="0.001" ixz="0" iyz="0.002"/></inertial>'
)


def small_urdf(world_joint: str = "", mimic: bool = False) -> str:
    """base -> arm (revolute) -> hand (revolute, optionally mimicking the first) -> tool (fixed)."""
    world = ""
    if world_joint:
        world = (
            '<link name="world"/>'
            f'<joint name="world_joint" type="{world_joint}"><parent link="world"/><child link="base"/>'
            '<origin xyz="0.1 -0.2 0.7" rpy="0.3 -0.4 1.1"/></joint>'
        )
    mimic_tag = '<mimic joint="shoulder" multiplier="2.0" offset="0.1"/>' if mimic else ""
    return (
        f'<robot name="small">{world}'
        f'<link name="base">{_INERTIAL.format(m=2.0)}</link>'
        f'<link name="arm">{_INERTIAL.format(m=1.0)}</link>'
        f'<link name="hand">{_INERTIAL.format(m=0.5)}</link>'
        f'<link name="tool">{_INERTIAL.format(m=0.2)}</link>'
        '<joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/>'
        '<origin xyz="0 0.1 0.3" rpy="0 0.2 0"/><axis xyz="0 1 0"/>'
        '<limit lower="-1.5" upper="1.5" effort="10" velocity="5"/></joint>'
        '<joint name="elbow" type="revolute"><parent link="arm"/><child link="hand"/>'
        '<origin xyz="0.4 0 0" rpy="0.1 0 0"/><axis xyz="1 0 1"/>'
        f'<limit lower="-2" upper="2" effort="10" velocity="5"/>{mimic_tag}</joint>'
        '<joint name="tool_joint" type="fixed"><parent link="hand"/><child link="tool"/>'
        '<origin xyz="0 0 0.1" rpy="0 0 0.5"/></joint>'
        "</robot>"
    )


def _fk_vs_numpy(model, urdf_text, s, tol):
    """FK of every link and frame (base at the identity) vs the URDF composed in NumPy."""
    poses = Urdf(urdf_text).poses(dict(zip(model.joint_names(), s)))
    data = wd.data.Data.build(model, joint_positions=s)
    H = wd.model.forward_kinematics(model, data).numpy()
    for i, name in enumerate(model.link_names()):
        assert_close(H[i], poses[name], tol, f"link '{name}'")
    nL = model.number_of_links()
    for k, name in enumerate(model.frame_names()):
        assert_close(wd.frame.transform(model, data, frame_index=nL + k).numpy(), poses[name], tol, f"frame '{name}'")


def test_mimic_joint_warns_once_and_is_kept():
    """A URDF mimic joint is kept as an independent joint with one warning that names it (and not the joint
    it mimics); the kinematics treat it as independent: FK vs the URDF composed in NumPy, float64 1e-12."""
    text = small_urdf(mimic=True)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = Model.build_from_model_description(text, dtype=np.float64)
    messages = [str(w.message) for w in caught]
    naming = [m for m in messages if "elbow" in m]
    assert len(naming) == 1, messages
    assert "mimic" in naming[0]
    assert "shoulder" not in naming[0]
    assert model.joint_names() == ("shoulder", "elbow")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Model.build_from_model_description(small_urdf(), dtype=np.float64, fixed_base=True)  # no mimic: no warning
    _fk_vs_numpy(model, text, np.array([0.7, -1.3]), 1e-12)


def test_world_floating_joint_is_floating_base():
    """A URDF whose root 'world' connects to the robot by a floating joint gives a floating-base model
    rooted at the child (no 'world' link, no joint for the floating one); FK vs MuJoCo, whose URDF importer
    makes that joint a free joint. Tolerance 1e-12 (float64, 3 links)."""
    text = small_urdf("floating")
    model = Model.build_from_model_description(text, dtype=np.float64)
    assert model.floating_base()
    assert model.base_link() == "base"
    assert model.link_names() == ("base", "arm", "hand")
    assert model.joint_names() == ("shoulder", "elbow")
    assert model.frame_names() == ("tool",)
    mj = robots.mujoco_model(text, None, floating=False)  # MuJoCo's importer adds the free joint itself
    assert mj.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
    st = robots.MujocoState(mj, model.joint_names(), True)
    data, state = random_data(model, rng_for("floating-urdf"))
    st.set(*state)
    H = wd.model.forward_kinematics(model, data).numpy()
    for i, name in enumerate(model.link_names()):
        p, R = st.body_pose(name)
        assert_close(H[i], H_of(R, p), 1e-12, f"link '{name}'")
    J = wd.model.generalized_free_floating_jacobian(model, data).numpy()
    for i, name in enumerate(model.link_names()):
        assert_close(J[i], st.body_jacobian_mixed(name), 1e-12, f"Jacobian of '{name}'")


def test_world_fixed_joint_is_fixed_base():
    """A URDF whose root 'world' connects to the robot by a fixed joint gives a fixed-base model welded
    where the joint's origin says: the default data's base pose is that origin (rpy composed in NumPy), FK
    of links and frames vs the URDF composed in NumPy, and a base velocity is refused. Tolerance 1e-12."""
    text = small_urdf("fixed")
    model = Model.build_from_model_description(text, dtype=np.float64)
    assert not model.floating_base()
    assert model.base_link() == "base"
    assert model.link_names() == ("base", "arm", "hand")
    assert model.joint_names() == ("shoulder", "elbow")
    world_H_base = Urdf(text).poses()["base"]
    assert_close(world_H_base[:3, 3], [0.1, -0.2, 0.7], 1e-15, "origin xyz")
    data = wd.data.Data.zero(model)
    assert_close(data.base_transform.numpy(), world_H_base, 1e-12, "default base pose of a fixed base")
    urdf = Urdf(text)
    s = np.array([-0.4, 1.2])
    poses = urdf.poses(dict(zip(model.joint_names(), s)))
    data = wd.data.Data.build(model, joint_positions=s)
    H = wd.model.forward_kinematics(model, data).numpy()
    for i, name in enumerate(model.link_names()):
        assert_close(H[i], poses[name], 1e-12, f"link '{name}'")
    assert_close(wd.frame.transform(model, data, frame_index=3).numpy(), poses["tool"], 1e-12, "frame 'tool'")
    with pytest.raises(ValueError):
        wd.data.Data.build(model, base_linear_velocity=[0.1, 0.0, 0.0])


@pytest.mark.parametrize("kind", ["reduced", "single-link"])
def test_model_without_joints(kind, dtype):
    """A model with no joints (every joint locked by reduce(model, []), or a URDF of one link) is one rigid
    floating body: one link, the rest frames, the whole mass; its single-environment data has JaxSim's
    shapes, joint positions/velocities of shape (0,) (batched: (N, 0)), and its FK and generalized velocity
    are the base's. Reference: the state given (exact up to the dtype: 1e-12 float64, 1e-6 float32)."""
    tol = {np.dtype(np.float64): 1e-12, np.dtype(np.float32): 1e-6}[np.dtype(dtype)]
    if kind == "reduced":
        full = full_model("random-0", dtype)
        model = wd.model.reduce(full, [])
        assert model.number_of_frames() == full.number_of_links() - 1 + full.number_of_frames()
        assert abs(wd.model.total_mass(model) - wd.model.total_mass(full)) <= tol * wd.model.total_mass(full)  # sums in other orders
    else:
        model = Model.build_from_model_description(robots.random_tree_urdf(1, num_links=1), dtype=dtype)
        assert model.frame_names() == ()
    assert model.dofs() == model.number_of_joints() == 0
    assert model.number_of_links() == 1
    assert model.floating_base()
    rng = rng_for("no joints", kind)
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    p, v = rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 6)
    data = wd.data.Data.build(
        model, base_position=p, base_quaternion=q, base_linear_velocity=v[:3], base_angular_velocity=v[3:]
    )
    assert data.joint_positions.numpy().shape == (0,)
    assert data.joint_velocities.numpy().shape == (0,)
    assert_close(data.generalized_velocity.numpy(), v, tol, "generalized velocity")
    H = wd.model.forward_kinematics(model, data).numpy()
    assert_close(H[0], H_of(robots.rotation_wxyz(q), p), tol, "base pose")
    J = wd.model.generalized_free_floating_jacobian(model, data).numpy()
    assert_close(J[0], np.eye(6), tol, "Jacobian of the base (Mixed in and out)")
    batched = wd.data.Data.build(model, base_position=p, base_quaternion=q, num_envs=3)
    assert batched.joint_positions.numpy().shape == (3, 0)
