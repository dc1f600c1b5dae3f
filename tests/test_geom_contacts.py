"""wd.contact.geom_pairs and geom_contacts against MuJoCo's mj_collision: the pairs of geoms on bodies that MuJoCo may
collide (its filters by body, weld, parent weld, bit masks, <exclude>, and its explicit <pair>s) and, at random
states, their contacts (count, positions, contact frames, distances) as MuJoCo's d.contact holds them.

The pair list is compared with the pairs MuJoCo reports contacts for when every geom is made a sphere and every margin
100 m: each pair its filters let through then reaches its narrow phase, which reports every pair of spheres nearer
than its margin. The
models: SCENE (written to exercise each filter), and the shipped Menagerie fixtures Cassie (self-collision among its
legs' capsules and spheres) and RB-Y1 (2255 pairs of its meshes' bounding boxes, four <exclude>s).

Contacts are compared pair by pair, in MuJoCo's order within a pair: to 1e-10 in float64 (the narrow phase is
MuJoCo's arithmetic; tests/test_collision_primitives.py and test_collision_box.py hold each pair function to MuJoCo
over many more poses, float32 included); what this adds is the geoms' world poses from warpdyn's link poses, the
dispatch by type, the pair slots and the bounding-sphere filter.
"""

import copy
import pathlib
import warnings

import mujoco
import numpy as np
import pytest
import scipy.spatial

import warpdyn as wd
from mjcf_compare import mujoco_to_warpdyn_state
from mjcf_models import random_state
from warpdyn.description import mjcf
from warpdyn.description.collision_pairs import COLLIDED_TYPES, CONVEX_TYPES, MULTICCD_TYPES

MENAGERIE = pathlib.Path(__file__).parent / "models" / "menagerie"

SCENE = """<mujoco model="filters">
  <default><geom friction="0.8 0.01 0.001"/></default>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="shelf" pos="1 0 0.2"><geom name="shelf_box" type="box" size="0.2 0.2 0.02"/></body>
    <body name="arm" pos="0 0 0.5"><freejoint/>
      <geom name="arm_sphere" type="sphere" size="0.08"/>
      <geom name="arm_box" type="box" size="0.05 0.05 0.1" pos="0 0 0.1" contype="2" conaffinity="0"/>
      <body name="forearm" pos="0 0 0.2"><joint name="elbow" axis="0 1 0"/>
        <geom name="forearm_capsule" type="capsule" size="0.04 0.1" pos="0 0 0.1"/>
        <body name="wrist_plate" pos="0 0 0.2"><geom name="plate" type="box" size="0.06 0.06 0.01" priority="1" friction="0.3 0.02 0.002"/></body>
        <body name="hand" pos="0 0 0.2"><joint name="wrist" axis="1 0 0"/>
          <geom name="hand_sphere" type="sphere" size="0.05" pos="0 0 0.05" margin="0.01" gap="0.005"/>
        </body>
      </body>
    </body>
    <body name="crate" pos="0.1 0 0.6"><freejoint/>
      <geom name="crate_box" type="box" size="0.1 0.1 0.1" condim="4"/>
      <geom name="crate_cylinder" type="cylinder" size="0.05 0.1" pos="0 0 0.15"/>
      <geom name="crate_ghost" type="sphere" size="0.05" contype="0" conaffinity="0"/>
    </body>
    <body name="ball" pos="0 0.1 0.7"><freejoint/>
      <geom name="ball_sphere" type="sphere" size="0.07" conaffinity="3"/>
      <geom name="ball_cylinder" type="cylinder" size="0.03 0.05"/>
    </body>
    <body name="pin" pos="0.05 -0.1 0.6"><freejoint/><geom name="pin_capsule" type="capsule" size="0.03 0.12"/></body>
  </worldbody>
  <contact>
    <exclude body1="crate" body2="pin"/>
    <pair geom1="arm_sphere" geom2="forearm_capsule" margin="0.02" gap="0.01" friction="0.5 0.4 0.03 0.002 0.001" condim="6"/>
  </contact>
</mujoco>"""
"""Each filter once: arm_box collides only with geoms whose conaffinity has bit 2 (ball_sphere); forearm is arm's child
(parent weld: no pairs) but for the explicit <pair>; wrist_plate is welded to forearm (one link); hand is forearm's
child (none) but collides with arm (its grandparent); crate_ghost collides with nothing; crate and pin are excluded;
shelf is welded to the world (its box does not move, and collides with every moving body, the floor aside: the floor
is the terrain); the cylinders' pairs but with spheres are MuJoCo's convex solver's (kernels/collision_convex.py's: one
contact, MuJoCo's multiCCD polygons named in the loader's warning); plate's priority gives its friction."""


def _model(xml_or_path, dtype=np.float64):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        return wd.model.Model.build_from_model_description(xml_or_path, dtype=dtype)


def _mujoco(xml_or_path) -> mujoco.MjModel:
    if isinstance(xml_or_path, pathlib.Path):
        return mujoco.MjModel.from_xml_path(str(xml_or_path))
    return mujoco.MjModel.from_xml_string(xml_or_path)


CASES = {"scene": SCENE, "cassie": MENAGERIE / "cassie.xml", "rby1": MENAGERIE / "rby1a_1.2.xml", "leap": wd.assets.leap_hand_cube_mjcf()}


def _geom_name(m, g: int) -> str:
    return mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}"  # the loader's name of an unnamed geom


def _body_contacts(m, d, types=None) -> dict:
    """{(geom1, geom2): [(pos, frame, dist), ...]} of MuJoCo's contacts between geoms whose types (`types`, default
    m.geom_type) warpdyn's narrow phase collides, but the ground's (planes on the world: warpdyn's terrain), in
    MuJoCo's order; the names in that order of types."""
    types = m.geom_type if types is None else types
    ground = (int(mujoco.mjtGeom.mjGEOM_PLANE), int(mujoco.mjtGeom.mjGEOM_HFIELD))
    out = {}
    for c in d.contact[: d.ncon]:
        g1, g2 = int(c.geom[0]), int(c.geom[1])
        if any(int(types[g]) in ground and int(m.body_weldid[m.geom_bodyid[g]]) == 0 for g in (g1, g2)):
            continue
        if int(types[g1]) > int(types[g2]):
            g1, g2 = g2, g1
        if (int(types[g1]), int(types[g2])) not in COLLIDED_TYPES:
            continue
        key = (_geom_name(m, g1), _geom_name(m, g2))
        out.setdefault(key, []).append((np.array(c.pos), np.array(c.frame).reshape(3, 3), float(c.dist)))
    return out


@pytest.mark.parametrize("case", CASES)
def test_pairs_are_those_mujoco_collides(case):
    """The pairs (names, in MuJoCo's geom order) are exactly those MuJoCo collides when every margin is 100 m, at
    qpos0 and two random states."""
    model, m = _model(CASES[case]), _mujoco(CASES[case])
    ours = set(wd.contact.geom_pairs(model).names)
    _assert_mujoco_collides(m, ours)
    assert len(ours) == {"scene": len(SCENE_PAIRS), "cassie": 49, "rby1": 2255, "leap": 325}[case]


EGGS = """<mujoco><worldbody><geom name="floor" type="plane" size="5 5 .1"/>
  <geom name="table" type="box" size=".3 .3 .02" pos="0 0 .4"/>
  <body name="egg" pos="0.02 0.01 0.4495" euler="0 0 20"><freejoint/><geom name="egg" type="ellipsoid" size=".06 .04 .03"/></body>
  <body name="ball" pos=".15 0 .5"><freejoint/><geom name="ball" type="sphere" size=".04"/></body>
  <body name="rod" pos="0 .15 .5"><freejoint/><geom name="rod" type="capsule" size=".02 .06"/></body>
  <body name="pebble" pos="0 -.15 .5"><freejoint/><geom name="pebble" type="ellipsoid" size=".03 .05 .02"/></body>
</worldbody></mujoco>"""
"""Two ellipsoids among free bodies above a table (a box of the world), the egg 0.5 mm into it."""


def test_ellipsoids_are_collided_as_mujoco_collides_them():
    """An MJCF's ellipsoids load as shapes (their radii), named in no note (the one note: contacts between bodies are
    off by default), pair with every moving geom and the table as MuJoCo's do, and the egg's contact with the table is
    the exact one (to 1e-12 m) and MuJoCo's (depth and normal to 2e-6, about its EPA's tolerance; its point 0.13 mm aside)."""
    with pytest.warns(wd.model.NotModelledWarning) as caught:
        model = wd.model.Model.build_from_model_description(EGGS, dtype=np.float64)
    assert len(caught) == 1 and list(model.description.not_modelled) == [mjcf.BODY_CONTACTS]
    shapes = {shape.name: shape for link in model.description.links for shape in link.collisions}
    assert shapes["egg"].kind == "ellipsoid" and np.allclose(shapes["egg"].size, [0.06, 0.04, 0.03])
    m = _mujoco(EGGS)
    pairs = wd.contact.geom_pairs(model)
    _assert_mujoco_collides(m, set(pairs.names))
    assert len(pairs) == 10 and ("egg", "table") in pairs.names
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    (pos, frame, dist), = _body_contacts(m, d)[("egg", "table")]
    count, position, normal_frame, distance = (a.numpy() for a in wd.contact.geom_contacts(model, wd.data.Data.build(model)))
    k = pairs.names.index(("egg", "table"))
    s = pairs.first[k]
    assert count[k] == 1  # the exact contact: 0.5 mm deep, straight down, midway between the egg's bottom and the table
    np.testing.assert_allclose([distance[s], *normal_frame[s][0], *position[s]], [-0.0005, 0, 0, -1, 0.02, 0.01, 0.41975], atol=1e-12)
    np.testing.assert_allclose([distance[s], *normal_frame[s][0]], [dist, *frame[0]], atol=2e-6)  # MuJoCo's: to its EPA's tolerance
    np.testing.assert_allclose(position[s], pos, atol=2e-4)  # (its EPA's point: 0.13 mm beside the exact one)


def _assert_mujoco_collides(m, ours: set) -> None:
    """`ours` (names) are exactly the pairs MuJoCo collides when every margin is 100 m, at qpos0 and two random states."""
    wide = copy.deepcopy(m)
    wide.geom_type[:] = mujoco.mjtGeom.mjGEOM_SPHERE  # sphere-sphere reports every pair within its margin
    wide.geom_margin[:] = 100.0
    wide.pair_margin[:] = 100.0
    wide.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_MIDPHASE)  # its trees' boxes are the geoms' own, without margins
    d = mujoco.MjData(wide)
    rng = np.random.default_rng(0)
    for qpos in (wide.qpos0, random_state(wide, rng)[0], random_state(wide, rng)[0]):
        d.qpos[:] = qpos
        mujoco.mj_forward(wide, d)
        assert set(_body_contacts(wide, d, types=m.geom_type)) == ours


SCENE_PAIRS = (
    ("arm_sphere", "forearm_capsule"),  # the <pair>
    ("arm_sphere", "shelf_box"), ("forearm_capsule", "shelf_box"), ("shelf_box", "plate"), ("hand_sphere", "shelf_box"),
    ("shelf_box", "crate_box"), ("crate_cylinder", "shelf_box"), ("ball_sphere", "shelf_box"), ("ball_cylinder", "shelf_box"),
    ("pin_capsule", "shelf_box"),  # the shelf, welded to the world
    ("arm_sphere", "hand_sphere"), ("arm_sphere", "crate_box"), ("arm_sphere", "crate_cylinder"), ("arm_sphere", "ball_sphere"),
    ("arm_sphere", "ball_cylinder"), ("ball_sphere", "arm_box"), ("arm_sphere", "pin_capsule"),
    ("forearm_capsule", "crate_box"), ("forearm_capsule", "crate_cylinder"), ("ball_sphere", "forearm_capsule"),
    ("forearm_capsule", "ball_cylinder"), ("forearm_capsule", "pin_capsule"),
    ("plate", "crate_box"), ("crate_cylinder", "plate"), ("ball_sphere", "plate"), ("ball_cylinder", "plate"), ("pin_capsule", "plate"),
    ("hand_sphere", "crate_box"), ("hand_sphere", "crate_cylinder"), ("hand_sphere", "ball_sphere"), ("hand_sphere", "ball_cylinder"),
    ("hand_sphere", "pin_capsule"),
    ("ball_sphere", "crate_box"), ("ball_cylinder", "crate_box"), ("ball_sphere", "crate_cylinder"), ("crate_cylinder", "ball_cylinder"),
    ("ball_sphere", "pin_capsule"), ("pin_capsule", "ball_cylinder"),
)  # fmt: skip
"""SCENE's pairs by its docstring's rules, in warpdyn's order (explicit pairs, then by body pair), each (geom1, geom2)
in MuJoCo's order: geom1's type <= geom2's, else geom1 on the body of lower id."""


def test_the_scenes_filters_and_parameters():
    """SCENE's pairs one by one (its docstring), with MuJoCo's parameters: margin and gap the sums (the <pair>'s own),
    friction by priority or maximum, condim the maximum; the convex solver's pairs with faces (a cylinder's, a box's)
    have multiCCD's four slots (kernels/collision_polygons.py), the others one."""
    with pytest.warns(wd.model.NotModelledWarning, match=r"\['38 geom pairs'\]") as caught:
        model = wd.model.Model.build_from_model_description(SCENE, dtype=np.float64)
    message = " ".join(str(w.message) for w in caught)
    assert "multiCCD" not in message
    assert "'7 geom pairs (e.g. arm_sphere/forearm_capsule, condim 6)'" in message  # torsion and rolling: named (not the plate's: priority)
    pairs = wd.contact.geom_pairs(model)
    assert pairs.names == SCENE_PAIRS
    row = {names: k for k, names in enumerate(pairs.names)}
    explicit = row[("arm_sphere", "forearm_capsule")]
    assert pairs.margin[explicit] == 0.02 and pairs.gap[explicit] == 0.01 and pairs.condim[explicit] == 6
    np.testing.assert_array_equal(pairs.friction[explicit], [0.5, 0.4, 0.03, 0.002, 0.001])
    hand = row[("arm_sphere", "hand_sphere")]
    assert pairs.margin[hand] == 0.01 and pairs.gap[hand] == 0.005 and pairs.slots[hand] == 1
    box = row[("arm_sphere", "crate_box")]
    assert pairs.condim[box] == 4 and pairs.margin[box] == 0.0
    np.testing.assert_array_equal(pairs.friction[box], [0.8, 0.8, 0.01, 0.001, 0.001])
    np.testing.assert_array_equal(pairs.friction[row[("plate", "crate_box")]], [0.3, 0.3, 0.02, 0.002, 0.002])  # priority 1
    assert pairs.slots[row[("plate", "crate_box")]] == 8 and pairs.slots[row[("pin_capsule", "plate")]] == 2
    links = model.link_names()
    assert links[pairs.link1[row[("plate", "crate_box")]]] == "forearm"  # the welded plate is lumped into forearm
    shelf = row[("arm_sphere", "shelf_box")]
    assert pairs.link2[shelf] == -1 and pairs.link_H_geom2[shelf][2, 3] == pytest.approx(0.2)  # the world's, in the world
    moving = {links[k] for k in np.concatenate([pairs.link1, pairs.link2]) if k >= 0}
    assert moving == {"arm", "forearm", "hand", "crate", "ball", "pin"}
    assert list(pairs.first) == list(np.concatenate([[0], np.cumsum(pairs.slots)[:-1]])) and pairs.contacts == int(pairs.slots.sum())
    faces = [(int(a), int(b)) in MULTICCD_TYPES for a, b in zip(pairs.type1, pairs.type2)]
    assert sum(faces) == 9 and pairs.slots[row[("crate_cylinder", "shelf_box")]] == 4
    assert all(pairs.slots[k] == 4 for k in np.nonzero(faces)[0]) and all(pairs.slots[k] == 1 for k in range(len(pairs)) if (int(pairs.type1[k]), int(pairs.type2[k])) in CONVEX_TYPES and not faces[k])


def _compare(model, m, qpos, tol: float) -> int:
    """Our contacts at MuJoCo's qpos against d.contact (multiCCD on: several contacts for the pairs of its convex
    solver that meet face to face, whose count alone is compared here: their geometry, to MuJoCo's EPA's precision, is
    tests/test_collision_convex.py's and test_collision_polygons.py's); the number of contacts compared."""
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_forward(m, d)
    expected = _body_contacts(m, d)
    state = mujoco_to_warpdyn_state(model, m, qpos, np.zeros(m.nv))
    contacts = wd.contact.geom_contacts(model, wd.data.Data.build(model, **state.data_kwargs))
    pairs = wd.contact.geom_pairs(model)
    count, position, frame, dist = (a.numpy() for a in contacts)
    compared = 0
    for k, names in enumerate(pairs.names):
        theirs = expected.get(names, [])
        assert count[k] == len(theirs), (names, count[k], len(theirs))
        convex = (int(pairs.type1[k]), int(pairs.type2[k])) in CONVEX_TYPES
        for j, (pos, F, dd) in enumerate([] if convex else theirs):
            s = pairs.first[k] + j
            np.testing.assert_allclose(position[s], pos, atol=tol, err_msg=str(names))
            np.testing.assert_allclose(frame[s], F, atol=tol, err_msg=str(names))
            np.testing.assert_allclose(dist[s], dd, atol=tol, err_msg=str(names))
            compared += 1
        unused = slice(pairs.first[k] + count[k], pairs.first[k] + pairs.slots[k])
        assert np.all(np.isinf(dist[unused])) and not np.any(position[unused]) and not np.any(frame[unused])
    return compared


def _crowded(m, rng):
    """A random state of SCENE with its free bodies crowded about one point, their orientations random."""
    qpos, _ = random_state(m, rng)
    for name in ("arm", "crate", "ball", "pin"):
        adr = int(m.jnt_qposadr[m.body_jntadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)]])
        qpos[adr : adr + 3] = [0.0, 0.0, 0.6] + rng.uniform(-0.12, 0.12, 3)
    return qpos


def _touching(m, rng, count: int):
    """`count` random states (mjcf_models.random_state) at which MuJoCo finds contacts between moving bodies (Cassie's
    legs touch at about 1 in 40)."""
    d = mujoco.MjData(m)
    for _ in range(2000):
        qpos = random_state(m, rng)[0]
        d.qpos[:] = qpos
        mujoco.mj_forward(m, d)
        if _body_contacts(m, d):
            yield qpos
            count -= 1
            if count == 0:
                return
    raise AssertionError("too few random states with contacts")


@pytest.mark.parametrize("case", CASES)
def test_contacts_equal_mujocos(case):
    """At random states with contacts (SCENE's bodies crowded so that most pairs touch) each pair's contacts are
    MuJoCo's, and its unused slots hold (0, 0, +inf)."""
    model, m = _model(CASES[case]), _mujoco(CASES[case])
    rng = np.random.default_rng(1)
    states = [_crowded(m, rng) for _ in range(12)] if case == "scene" else list(_touching(m, rng, 4))
    compared = sum(_compare(model, m, qpos, 1e-10) for qpos in states)
    assert compared >= {"scene": 60, "cassie": 8, "rby1": 20, "leap": 60}[case]


def test_batched_and_both_layouts(layout):
    """Three environments at different states equal each state alone, in both array layouts; float32 within 2e-5 m of
    float64 where the counts agree (the narrow phase's float32 is tested against MuJoCo in its own files)."""
    model, model32, m = _model(SCENE), _model(SCENE, np.float32), _mujoco(SCENE)
    rng = np.random.default_rng(2)
    states = [mujoco_to_warpdyn_state(model, m, _crowded(m, rng), np.zeros(m.nv)).data_kwargs for _ in range(3)]
    batched = {name: np.stack([s[name] for s in states]) for name in states[0]}
    together = [a.numpy() for a in wd.contact.geom_contacts(model, wd.data.Data.build(model, num_envs=3, **batched))]
    alone = [[a.numpy() for a in wd.contact.geom_contacts(model, wd.data.Data.build(model, **s))] for s in states]
    for n in range(3):
        for a, b in zip(together, alone[n]):
            np.testing.assert_array_equal(a[n], b)
    single = [a.numpy() for a in wd.contact.geom_contacts(model32, wd.data.Data.build(model32, num_envs=3, **batched))]
    assert np.mean(single[0] == together[0]) > 0.9
    pairs = wd.contact.geom_pairs(model)
    for n in range(3):
        for k in np.flatnonzero(single[0][n] == together[0][n]):
            s = slice(pairs.first[k], pairs.first[k] + together[0][n, k])
            np.testing.assert_allclose(single[1][n, s], together[1][n, s], atol=2e-5)
            np.testing.assert_allclose(single[3][n, s], together[3][n, s], atol=2e-5)


def test_urdf_has_no_geom_pairs():
    """URDF and SDF carry no collision filter: no pairs (an opt-in self-collision is not built yet), and the query
    returns empty arrays."""
    model = wd.model.Model.build_from_model_description(wd.assets.ergocub_urdf())
    assert len(wd.contact.geom_pairs(model)) == 0
    contacts = wd.contact.geom_contacts(model, wd.data.Data.build(model))
    assert contacts.count.shape == (0,) and contacts.distance.shape == (0,)


ARM_URDF = pathlib.Path(__file__).parent / "models" / "self_collision_arm.urdf"
"""A fixed-base URDF arm: boxes and spheres on its base, upper arm, lower arm (with a tip welded to it by a fixed
joint) and a finger; MuJoCo compiles it as it is (fixed joints fused: the base into the world, the tip into the lower
arm)."""


def _urdf_names(m) -> dict:
    """MuJoCo's geom g -> "{link}/{k}" (k its place among its body's geoms; the world body is the URDF's base)."""
    out = {}
    for g in range(m.ngeom):
        b = int(m.geom_bodyid[g])
        out[g] = f"{'base' if b == 0 else mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b)}/{g - int(m.body_geomadr[b])}"
    return out


def _mujoco_urdf_pairs(m) -> set:
    """The pairs {frozenset(("link/k", "link/k"))} MuJoCo collides on a URDF's model m (every geom made a sphere,
    margins 100 m, at qpos0)."""
    names = _urdf_names(m)
    wide = copy.deepcopy(m)
    wide.geom_type[:] = mujoco.mjtGeom.mjGEOM_SPHERE
    wide.geom_margin[:] = 100.0
    wide.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_MIDPHASE)
    d = mujoco.MjData(wide)
    mujoco.mj_forward(wide, d)
    return {frozenset((names[int(c.geom[0])], names[int(c.geom[1])])) for c in d.contact[: d.ncon]}


def _urdf_contacts(m, model, rng, states: int):
    """At `states` random states where MuJoCo's model m of a URDF folds onto itself: each of the model's pairs' count
    asserted MuJoCo's, then for each contact (the pair's index, MuJoCo's contact, warpdyn's nearest contact's position,
    normal (in MuJoCo's order of the geoms) and distance)."""
    for qpos in _touching(m, rng, states):
        yield from _urdf_contacts_at(m, model, qpos)


def _urdf_contacts_at(m, model, qpos):
    """`_urdf_contacts` at the state qpos."""
    names, pairs = _urdf_names(m), wd.contact.geom_pairs(model)
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_forward(m, d)
    expected = {}
    for c in d.contact[: d.ncon]:
        expected.setdefault(frozenset((names[int(c.geom[0])], names[int(c.geom[1])])), []).append(c)
    count, position, frame, dist = (a.numpy() for a in wd.contact.geom_contacts(model, wd.data.Data.build(model, joint_positions=qpos)))
    for k, pair in enumerate(pairs.names):
        cs = expected.get(frozenset(pair), [])
        assert count[k] == len(cs), pair
        for c in cs:  # warpdyn's nearest of the pair's contacts (multiCCD's polygons may start elsewhere)
            s = pairs.first[k] + int(np.linalg.norm(position[pairs.first[k] : pairs.first[k] + count[k]] - c.pos, axis=1).argmin())
            sign = 1.0 if names[int(c.geom[0])] == pair[0] else -1.0  # MuJoCo's order of the pair's geoms
            yield k, c, position[s], sign * frame[s][0], dist[s]


def _rock_obj(path: pathlib.Path, seed: int, radii) -> None:
    """An OBJ of 20 points on an ellipsoid of `radii` about (0.01, 0, 0.02) and their convex hull's faces, facing out
    (MuJoCo's inertia reads the faces; both take the hull for collisions)."""
    u = np.random.default_rng(seed).normal(size=(20, 3))
    v = u / np.linalg.norm(u, axis=1, keepdims=True) * radii + [0.01, 0.0, 0.02]
    faces = []
    for a, b, c in scipy.spatial.ConvexHull(v).simplices:
        outward = np.dot(np.cross(v[b] - v[a], v[c] - v[a]), v[a] - v.mean(axis=0)) > 0
        faces.append((a, b, c) if outward else (a, c, b))
    path.write_text("".join(f"v {x:.12f} {y:.12f} {z:.12f}\n" for x, y, z in v) + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces))


def test_urdf_meshes_self_collide_as_in_mujoco(tmp_path):
    """The arm with its upper arm's box and its finger's sphere replaced by convex meshes (OBJ files beside the URDF,
    one scaled, one at a turned origin): with_self_collision reads their files, and its pairs are MuJoCo's on the same
    URDF; at states where the arm folds onto itself each pair's count is MuJoCo's (multiCCD on: the hulls' polygons
    compiled by MuJoCo from the same vertices), each contact's distance within 1e-5 m of MuJoCo's (its EPA's tolerance)
    and its normal within 2e-3. A mesh whose file is missing is named in a NotModelledWarning and collides with
    nothing."""
    _rock_obj(tmp_path / "arm_rock.obj", 1, (0.03, 0.03, 0.15))
    _rock_obj(tmp_path / "finger_rock.obj", 2, (0.04, 0.05, 0.03))
    text = ARM_URDF.read_text()
    text = text.replace('<collision><origin xyz="0 0 0.15"/><geometry><box size="0.05 0.05 0.3"/></geometry></collision>',
                        '<collision><origin xyz="0 0 0.13"/><geometry><mesh filename="arm_rock.obj" scale="1 1 1.1"/></geometry></collision>')
    text = text.replace('<collision><origin xyz="0 0.08 0"/><geometry><sphere radius="0.03"/></geometry></collision>',
                        '<collision><origin xyz="0 0.08 0" rpy="0.3 0.2 0.1"/><geometry><mesh filename="finger_rock.obj"/></geometry></collision>')
    assert text.count("_rock.obj") == 2
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(text)
    model = wd.contact.with_self_collision(_model(urdf))
    pairs = wd.contact.geom_pairs(model)
    m = mujoco.MjModel.from_xml_path(str(urdf))
    assert {frozenset(p) for p in pairs.names} == _mujoco_urdf_pairs(m) and len(pairs) == 7
    assert sum(7 in (a, b) for a, b in zip(pairs.type1, pairs.type2)) == 4  # base-upper, base-finger, upper-finger, upper's sphere-finger
    compared = 0
    for k, c, _, normal, dist in _urdf_contacts(m, model, np.random.default_rng(4), 6):
        assert abs(dist - c.dist) < 1e-5, pairs.names[k]
        np.testing.assert_allclose(normal, c.frame[:3], atol=2e-3, err_msg=str(pairs.names[k]))
        compared += 1 if 7 in (pairs.type1[k], pairs.type2[k]) else 0
    assert compared >= 3
    (tmp_path / "finger_rock.obj").unlink()
    with pytest.warns(wd.model.NotModelledWarning, match=r"meshes whose files were not found or read.*: 1 box-mesh, 1 mesh-mesh, 1 sphere-mesh"):
        fewer = wd.contact.with_self_collision(_model(urdf))
    assert len(wd.contact.geom_pairs(fewer)) == 4  # the finger's three pairs dropped


def _box_obj(path: pathlib.Path, low, high) -> None:
    """An OBJ of the box from corner `low` to `high`: its 8 corners and 12 triangles, facing out."""
    corners = np.array([[(low, high)[(k >> i) & 1][i] for i in range(3)] for k in range(8)], dtype=float)
    quads = ((0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5))  # outward: right-handed
    faces = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    path.write_text("".join(f"v {x:.17g} {y:.17g} {z:.17g}\n" for x, y, z in corners) + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces))


_INERTIAL = '<inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>'
STACK_URDF = f"""<robot name="stack">
  <link name="base">{_INERTIAL}<collision><geometry><mesh filename="slab.obj"/></geometry></collision></link>
  <link name="lift">{_INERTIAL}</link><link name="turn">{_INERTIAL}</link>
  <link name="tip">{_INERTIAL}<collision><geometry><mesh filename="cube.obj"/></geometry></collision>
    <collision><origin xyz="0.25 0 {0.0625 * (2**0.5 - 1)!r}" rpy="{np.pi / 4!r} 0 0"/><geometry><mesh filename="cube.obj"/></geometry></collision></link>
  <joint name="lift" type="prismatic"><parent link="base"/><child link="lift"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="turn" type="revolute"><parent link="lift"/><child link="turn"/><axis xyz="0 0 1"/><limit lower="-4" upper="4" effort="1" velocity="1"/></joint>
  <joint name="tilt" type="revolute"><parent link="turn"/><child link="tip"/><axis xyz="0.6 0.8 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>"""
"""A mesh slab (the fixed base) under two mesh cubes on one link: one on its face, one turned 45 degrees about x onto
its edge (its lowest edge level with the other's bottom face); the link lifts, turns about z and tilts. Their sizes
are binary fractions: MuJoCo keeps a mesh's vertices in float32, warpdyn a file's as read (float64)."""


def _stack_urdf(folder: pathlib.Path) -> pathlib.Path:
    """STACK_URDF written into `folder` with its slab's and cube's OBJ files; its path."""
    _box_obj(folder / "slab.obj", (-0.5, -0.5, -0.0625), (0.5, 0.5, 0.0))
    _box_obj(folder / "cube.obj", (-0.0625, -0.0625, -0.0625), (0.0625, 0.0625, 0.0625))
    (folder / "stack.urdf").write_text(STACK_URDF)
    return folder / "stack.urdf"


@pytest.mark.parametrize("tilt", [0.0, 3e-3], ids=["flat", "tilted"])
def test_urdf_mesh_faces_give_mujocos_multiccd_contacts(tmp_path, tilt):
    """with_self_collision on a URDF of mesh files: MuJoCo compiles the hulls' polygons from the same vertices
    (description.mjcf.hull_polygons), so that a mesh cube on a mesh slab gets multiCCD's four contacts and one on its
    edge two, MuJoCo's on the same URDF: the counts equal at every state; the contacts MuJoCo's to 1e-9 m flat and
    within 5e-6 m tilted by up to `tilt` (tests/test_collision_polygons.py: MuJoCo 4.0 places tilted contacts
    slightly otherwise)."""
    urdf = _stack_urdf(tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("error", wd.model.NotModelledWarning)  # no pair left with one contact for want of faces
        model = wd.contact.with_self_collision(_model(urdf))
    pairs = wd.contact.geom_pairs(model)
    assert list(pairs.slots) == [4, 4]
    m = mujoco.MjModel.from_xml_path(str(urdf))
    rng = np.random.default_rng(5)
    tol = 1e-9 if tilt == 0.0 else 5e-6
    counts = []
    for _ in range(12):
        qpos = np.array([0.0625 - rng.uniform(5e-5, 1e-3), rng.uniform(-np.pi, np.pi), rng.uniform(-tilt, tilt)])
        for _, c, position, normal, dist in _urdf_contacts_at(m, model, qpos):
            np.testing.assert_allclose(position, c.pos, atol=tol)
            np.testing.assert_allclose(normal, c.frame[:3], atol=1e-9)
            assert abs(dist - c.dist) <= tol
        counts.append(wd.contact.geom_contacts(model, wd.data.Data.build(model, joint_positions=qpos)).count.numpy())
    counts = np.array(counts)
    assert (counts[:, 0] == 4).sum() >= 6 and (counts[:, 1] == 2).sum() >= 6, counts


def test_hull_polygons_are_those_mujoco_compiles_from_the_file(tmp_path):
    """description.mjcf.hull_polygons on a rock's vertices as warpdyn reads its OBJ file (an uneven hull, which MuJoCo
    turns to its inertial frame) gives the polygons MuJoCo compiles loading that file: each the same vertices, in the
    file's frame, about the same outward normal, counterclockwise."""
    from warpdyn.description.mjcf import hull_polygons

    _rock_obj(tmp_path / "rock.obj", 3, (0.05, 0.02, 0.08))
    vertices = np.array([[float(x) for x in line.split()[1:]] for line in (tmp_path / "rock.obj").read_text().splitlines() if line.startswith("v ")])
    normals, indices = hull_polygons(vertices)
    m = mujoco.MjModel.from_xml_string(f'<mujoco><compiler meshdir="{tmp_path}"/><asset><mesh file="rock.obj"/></asset><worldbody><geom type="mesh" mesh="rock"/></worldbody></mujoco>')
    R = np.empty(9)
    mujoco.mju_quat2Mat(R, m.mesh_quat[0])
    R = R.reshape(3, 3)
    assert abs(np.trace(R) - 3.0) > 0.1  # the inertial frame is turned: the mapping back is exercised
    theirs_vertices = np.asarray(m.mesh_vert, dtype=np.float64) @ R.T + m.mesh_pos[0]
    theirs = [(R @ m.mesh_polynormal[q], theirs_vertices[m.mesh_polyvert[m.mesh_polyvertadr[q] : m.mesh_polyvertadr[q] + m.mesh_polyvertnum[q]]]) for q in range(m.mesh_polynum[0])]
    assert len(indices) == len(theirs) >= 8
    for normal, rows in zip(normals, indices):
        match = [k for k, (n, _) in enumerate(theirs) if n @ normal > 1.0 - 1e-9]
        assert len(match) == 1, normal
        mine, other = vertices[rows], theirs[match[0]][1]
        assert len(mine) == len(other)
        assert all(np.linalg.norm(other - v, axis=1).min() < 1e-6 for v in mine)  # float32 vertices in MuJoCo
        assert np.cross(mine[1] - mine[0], mine[2] - mine[1]) @ normal > 0.0  # (MuJoCo merges triangles whose
        # normals fall within 0.01 rad of each other: its polygons may be slightly off one plane)


def test_urdf_meshes_without_mujocos_polygons_are_named(tmp_path, monkeypatch):
    """Without MuJoCo to compile a mesh file's hull polygons (hull_polygons None), with_self_collision names the pairs
    with a mesh that keep one contact, and gives them one slot."""
    urdf = _stack_urdf(tmp_path)
    monkeypatch.setattr(wd.types.geoms, "hull_polygons", lambda vertices: None)
    with pytest.warns(wd.model.NotModelledWarning, match=r"2 shape pairs with a mesh get one contact.*pip install mujoco"):
        model = wd.contact.with_self_collision(_model(urdf))
    assert list(wd.contact.geom_pairs(model).slots) == [1, 1]


def test_urdf_self_collision_is_mujocos():
    """wd.contact.with_self_collision on a URDF: its pairs are those MuJoCo collides on the same URDF (every geom made a
    sphere, margins 100 m: the base collides with its child, a fixed base being welded to the world; a link never with
    its parent otherwise), and at random states where the arm folds onto itself its contacts are MuJoCo's to 1e-10;
    `exclude` drops a link pair; an MJCF is refused."""
    model = wd.contact.with_self_collision(_model(ARM_URDF))
    pairs = wd.contact.geom_pairs(model)
    m = mujoco.MjModel.from_xml_path(str(ARM_URDF))
    theirs = _mujoco_urdf_pairs(m)
    assert {frozenset(p) for p in pairs.names} == theirs and len(theirs) == 7
    compared = 0
    for _, c, position, normal, dist in _urdf_contacts(m, model, np.random.default_rng(3), 4):
        np.testing.assert_allclose(position, c.pos, atol=1e-10)
        np.testing.assert_allclose(normal, c.frame[:3], atol=1e-10)
        np.testing.assert_allclose(dist, c.dist, atol=1e-10)
        compared += 1
    assert compared >= 4
    fewer = wd.contact.with_self_collision(_model(ARM_URDF), exclude=[("base", "upper")])
    assert len(wd.contact.geom_pairs(fewer)) == 5 and all("upper" not in a + b or "base" not in a + b for a, b in wd.contact.geom_pairs(fewer).names)
    with pytest.raises(ValueError, match="is MJCF"):
        wd.contact.with_self_collision(_model(SCENE))
    with pytest.raises(ValueError, match="exclude names links"):
        wd.contact.with_self_collision(_model(ARM_URDF), exclude=[("base", "hand")])
