"""MJCF, compiled by MuJoCo and read from its MjModel into a `ModelDescription` (see
warpdyn.description.model for the conventions; docs/mujoco_semantics.md for MuJoCo's).

What is read, and how MuJoCo's structure maps onto warpdyn's one-joint-per-link tree:

- Every body is a link (mass, CoM, inertia, colliding geoms, `gravcomp`); a body without joints is welded
  to its parent by a fixed joint named "{parent}_to_{body}" (lumped by `build_tree`).
- A body with several hinge/slide joints j1..jk becomes a chain: massless links named "{body}/{j1}", ...,
  "{body}/{j(k-1)}" followed by the body itself. j1 carries the body's pos/quat as its origin; j2..jk have
  an identity origin and their own anchor (pivot) and axis, written in the body frame as moved by the
  joints before them, which is how MuJoCo applies a body's joints (mj_kinematics1).
- Hinge/slide: q = MuJoCo's qpos (`ref` is folded into the origin); ball: q = MuJoCo's quaternion, about the
  joint's `pos`. Each joint starts at MuJoCo's qpos0 (`initial_position`).
- The world body: one free-jointed child, beside bodies welded to the world with no joints below them (static
  scenery: the bodies dropped and listed in the warning, their geoms the world's), is a floating base (starting at the body's pose, MuJoCo's
  qpos0); one welded child is a fixed base welded at its pose; otherwise (a scene: several trees) the base is
  the fixed link "world", into which the bodies welded to the world are lumped, and each free body hangs from
  it by a "free" joint starting at the body's pose. A free joint's armature, damping, frictionloss and
  stiffness are read; a floating base's frictionloss is not (listed in the warning).
- Collisions: the geoms of moving bodies are their links' collision shapes; those that do not move (the world
  body's, welded bodies') are `world_geoms`, posed in the world (planes and heightfields: the terrain); MuJoCo's
  pair filter (contype/conaffinity, welds, `<exclude>`, `<pair>`) gives `geom_pairs`
  (warpdyn.description.collision_pairs).
- Keyframes (`<key>`): by name, in MuJoCo's qpos/qvel layout (`ModelDescription.keyframes`,
  `mujoco_joints`).
- Actuators with a joint transmission on a hinge/slide joint and no activation dynamics become
  `ActuatorDescription`s; the others are dropped and listed in the warning.
- `<option>`: gravity (any direction), timestep, integrator, disable flags.
"""

from __future__ import annotations

import pathlib
import warnings
import xml.etree.ElementTree as ET

import numpy as np

from ..kernels.collision_polygons import MAX_FACE
from .collision_pairs import MULTICCD_TYPES, mujoco_geom_pairs, multiccd
from .model import (
    ActuatorDescription,
    CollisionShape,
    EqualityDescription,
    FrictionConstraint,
    JointDescription,
    Keyframe,
    LimitConstraint,
    LinkDescription,
    ModelDescription,
    caller_stacklevel,
    finish_tree,
    homogeneous,
    joint_motion,
    quaternion_product,
    quaternion_wxyz_to_matrix,
)

__all__ = ["load_mjcf"]

_INTEGRATORS = {
    "mjINT_EULER": "Euler",
    "mjINT_RK4": "RK4",
    "mjINT_IMPLICIT": "implicit",
    "mjINT_IMPLICITFAST": "implicitfast",
    "mjINT_DISCRETE": "discrete",
}

# The kinds of the NotModelledWarning, in the order the message lists them.
FLUID = "fluid forces (opt density/viscosity > 0, or geoms with fluidshape)"
JOINT_LIMITS = "joint limits (MuJoCo's limit constraints: solved as MuJoCo does where model.limit_constraints is set, off by default)"
FRICTIONLOSS = ("frictionloss (MuJoCo: a friction constraint; warpdyn applies it as JaxSim's static friction, or a hinge's or "
                "slide's as MuJoCo's friction constraint where model.frictionloss_constraints is set)")
POLYNOMIAL = "polynomial joint stiffness/damping (only the linear coefficient is kept)"
SPRING_YIELD = "joint spring yield (plasticity)"
FREE_JOINT_PARAMETERS = "frictionloss of a floating base's free joint (a floating base has no static friction)"
EQUALITY = "equality constraints other than connect, weld, joint and fixed-tendon couplings, and those inactive at the start (spatial tendons, flex)"
TENDONS = "tendons (their springs, dampers, armature, limits and actuators)"
MUSCLES = "muscles (dropped)"
ACTIVATION = "actuators with activation dynamics (integrator, filter, position timeconst...; dropped)"
TRANSMISSION = "actuators with a non-joint transmission or on the free joint (dropped)"
GAIN_BIAS = "actuators with gain/bias types other than fixed/affine/none (dropped)"
DELAY = "actuators with a delay (dropped)"
PLUGIN = "plugins (dropped)"
DISABLED_GROUP = "actuators in groups disabled by actuatorgroupdisable (dropped)"
ACTUATOR_POLYNOMIAL = "polynomial actuator damping (only the linear coefficient is kept)"
ACTUATOR_GRAVCOMP = (
    "actuatorgravcomp (warpdyn applies the joint's gravity compensation as a passive force: its actuatorfrcrange "
    "does not clamp it, and it is kept in a model without actuators)"
)
GEOMS = "collision geoms of unsupported types (plane/hfield on bodies, sdf)"
GROUND = ("ground geoms other than one upward plane (several planes, heightfields, a plane facing down: the terrain stays "
          "the plane z = 0; set model.terrain, e.g. to a HeightfieldTerrain)")
STATIC_BODIES = "bodies welded to the world beside the free body (static scenery: not links; their geoms are the world's)"
UNCOLLIDED_PAIRS = (
    "pairs of geoms that warpdyn's narrow phase does not collide (with a geom of an unsupported type; <pair>s of a geom "
    "without a shape, or with the ground, whose contacts are the terrain's law's)"
)
BODY_CONTACTS = (
    "contacts between bodies, off by default (model.geom_contacts = True makes the soft law act on them; "
    "wd.contact.geom_contacts finds them)"
)
TORSION = "torsional and rolling friction of geom pairs with condim 4 or 6 (their sliding friction acts)"
MULTICCD = (
    f"MuJoCo's multiCCD contacts on a mesh's hull faces of more than {MAX_FACE} vertices (a pair meeting on such a face keeps "
    "GJK and EPA's one contact)"
)
MOCAP = "mocap bodies (kept welded at their initial pose)"
FLEX = "flexes"
SKINS = "skins"


def load_mjcf(root: ET.Element, path: str | None, where: str) -> ModelDescription:
    import mujoco

    try:
        if path is not None:  # MuJoCo resolves <include> and asset files against the path
            m = mujoco.MjModel.from_xml_path(path)
        else:
            m = mujoco.MjModel.from_xml_string(ET.tostring(root, encoding="unicode"))
    except Exception as error:
        raise ValueError(f"{where} is not a valid MJCF: {error}") from None

    notes: dict[str, list[str]] = {}

    def note(kind: str, name: str) -> None:
        names = notes.setdefault(kind, [])
        if name not in names:
            names.append(name)

    def name_of(obj, i, prefix):
        return mujoco.mj_id2name(m, obj, i) or f"{prefix}{i}"

    def body_name(i):
        return mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, i) or f"body{i}"

    def joint_name(j):
        return name_of(mujoco.mjtObj.mjOBJ_JOINT, j, "joint")

    gravity, time_step, integrator, disabled = _options(m, where, mujoco)
    if m.opt.density > 0.0 or m.opt.viscosity > 0.0:
        note(FLUID, f"<option density={float(m.opt.density):g} viscosity={float(m.opt.viscosity):g}>")

    links, joints = [], []
    for b in range(1, m.nbody):
        name = body_name(b)
        link = LinkDescription(name=name, mass=float(m.body_mass[b]), com=np.array(m.body_ipos[b], dtype=np.float64))
        R_i = quaternion_wxyz_to_matrix(m.body_iquat[b])
        link.inertia = R_i @ np.diag(m.body_inertia[b]) @ R_i.T
        link.gravcomp = float(m.body_gravcomp[b])
        _mjcf_collisions(m, b, link, mujoco, note, name_of)
        if int(m.body_mocapid[b]) >= 0:
            note(MOCAP, name)

        parent = "world" if m.body_parentid[b] == 0 else body_name(m.body_parentid[b])
        origin = homogeneous(quaternion_wxyz_to_matrix(m.body_quat[b]), m.body_pos[b])
        njnt, adr = int(m.body_jntnum[b]), int(m.body_jntadr[b])
        if njnt == 0:
            links.append(link)
            joints.append(JointDescription(name=f"{parent}_to_{name}", type="fixed", parent=parent, child=name, origin=origin))
            continue
        if int(m.jnt_type[adr]) == mujoco.mjtJoint.mjJNT_FREE:  # the compiler makes it the body's only joint, on a world child
            jname = joint_name(adr)
            if parent != "world":
                raise ValueError(f"{where}: joint '{jname}' has type 'free' inside the tree (body '{name}')")
            links.append(link)
            joints.append(_joint(m, adr, jname, "world", name, np.eye(4), note, mujoco))
            continue
        chain_parent, chain_origin = parent, origin
        for k in range(njnt):
            jname = joint_name(adr + k)
            child = name if k == njnt - 1 else f"{name}/{jname}"
            if k < njnt - 1:
                links.append(LinkDescription(name=child))  # massless: the body as moved by joints j1..jk
            joints.append(_joint(m, adr + k, jname, chain_parent, child, chain_origin, note, mujoco))
            chain_parent, chain_origin = child, np.eye(4)
        links.append(link)

    names = [link.name for link in links]
    if len(set(names)) != len(names):
        duplicated = sorted({n for n in names if names.count(n) > 1})
        raise ValueError(
            f"{where}: link names {duplicated} are used twice (the links of a multi-joint body are named "
            "'{body}/{joint}': rename the body or joint that clashes)"
        )

    links, joints = _world_children(m, links, joints, where, note, mujoco)

    actuators = _actuators(m, joint_name, note, mujoco)
    poses = mujoco.MjData(m)
    mujoco.mj_kinematics(m, poses)  # at qpos0: where bodies welded to the world and their geoms are
    equalities = _equalities(m, body_name, joint_name, name_of, note, disabled, mujoco, poses)
    _constraints_and_others(m, note, name_of, mujoco)

    world_link = LinkDescription(name="world")
    model_name = root.get("model") or (pathlib.Path(path).stem if path else "model")
    floating = [j for j in joints if j.type == "floating"]
    description = finish_tree(model_name, [world_link, *links], joints, "mjcf", where)
    if floating:  # a lone free body: the floating base starts at the body's pose (MuJoCo's qpos0)
        q0 = floating[0].initial_position
        description.initial_world_H_base = homogeneous(quaternion_wxyz_to_matrix(q0[3:]), q0[:3])
        description.base_joint = floating[0]
    description.actuators = actuators
    description.equalities = equalities
    description.world_geoms = _world_geoms(m, mujoco, note, name_of, poses)
    description.ground = _ground(m, mujoco, note, name_of, poses)
    description.excludes = [(name_of(mujoco.mjtObj.mjOBJ_BODY, int(s) >> 16, "body"), name_of(mujoco.mjtObj.mjOBJ_BODY, int(s) & 0xFFFF, "body"))
                            for s in m.exclude_signature]
    description.geom_pairs, uncollided = mujoco_geom_pairs(m, mujoco, lambda g: name_of(mujoco.mjtObj.mjOBJ_GEOM, g, "geom"))
    if description.geom_pairs:
        note(BODY_CONTACTS, f"{len(description.geom_pairs)} geom pairs")
    rolling = [p for p in description.geom_pairs if p.condim > 3]
    if rolling:
        example = f"{name_of(mujoco.mjtObj.mjOBJ_GEOM, rolling[0].geom1, 'geom')}/{name_of(mujoco.mjtObj.mjOBJ_GEOM, rolling[0].geom2, 'geom')}"
        note(TORSION, f"{len(rolling)} geom pairs (e.g. {example}, condim {rolling[0].condim})")
    for kinds, names in sorted(uncollided.items()):
        note(UNCOLLIDED_PAIRS, f"{len(names)} {kinds} (e.g. {names[0]})")
    description.multiccd = multiccd(m, mujoco)
    if description.multiccd:
        large = sorted({name_of(mujoco.mjtObj.mjOBJ_GEOM, g, "geom") for p in description.geom_pairs for g in (p.geom1, p.geom2)
                        if (int(m.geom_type[p.geom1]), int(m.geom_type[p.geom2])) in MULTICCD_TYPES and _large_faces(m, g, mujoco)})  # fmt: skip
        if large:
            note(MULTICCD, f"{len(large)} mesh geoms (e.g. {large[0]})")
    description.gravity = gravity
    description.time_step = time_step
    description.integrator = integrator
    description.disabled = disabled
    description.not_modelled = {kind: notes[kind] for kind in _KIND_ORDER if kind in notes}
    description.mujoco_joints = [(joint_name(j), _JOINT_TYPES[int(m.jnt_type[j])], int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j])) for j in range(m.njnt)]
    description.keyframes = [
        Keyframe(
            name=mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_KEY, k) or f"key{k}",
            qpos=np.array(m.key_qpos[k], dtype=np.float64),
            qvel=np.array(m.key_qvel[k], dtype=np.float64),
            ctrl=np.array(m.key_ctrl[k], dtype=np.float64),
            time=float(m.key_time[k]),
        )
        for k in range(m.nkey)
    ]
    return description


_JOINT_TYPES = {0: "free", 1: "ball", 2: "slide", 3: "hinge"}
"""MuJoCo's mjtJoint values by their XML names."""


_KIND_ORDER = (
    FLUID,
    JOINT_LIMITS,
    FRICTIONLOSS,
    POLYNOMIAL,
    SPRING_YIELD,
    FREE_JOINT_PARAMETERS,
    EQUALITY,
    TENDONS,
    MUSCLES,
    ACTIVATION,
    TRANSMISSION,
    GAIN_BIAS,
    DELAY,
    PLUGIN,
    DISABLED_GROUP,
    ACTUATOR_POLYNOMIAL,
    ACTUATOR_GRAVCOMP,
    BODY_CONTACTS,
    UNCOLLIDED_PAIRS,
    MULTICCD,
    TORSION,
    GEOMS,
    GROUND,
    STATIC_BODIES,
    MOCAP,
    FLEX,
    SKINS,
)


def _options(m, where, mujoco):
    """(gravity vector (3,) [m/s^2, world frame], timestep, integrator name, disabled flag names) of <option>."""
    g = np.array(m.opt.gravity, dtype=np.float64) + 0.0  # no -0.0
    integrator = None
    for enum_name, value in mujoco.mjtIntegrator.__members__.items():
        if int(value) == int(m.opt.integrator):
            integrator = _INTEGRATORS.get(enum_name, enum_name.removeprefix("mjINT_").lower())
    flags = int(m.opt.disableflags)
    disabled = frozenset(
        enum_name.removeprefix("mjDSBL_").lower()
        for enum_name, value in mujoco.mjtDisableBit.__members__.items()
        if enum_name != "mjNDISABLE" and flags & int(value)
    )
    return g, float(m.opt.timestep), integrator, disabled


def _actuator_share(m, field: str, j: int, mujoco) -> float:
    """gear^2 * value summed over the actuators with a joint transmission on joint j, as MuJoCo's
    mj_actuatorArmature / mj_actuatorDamping compute it (MuJoCo >= 3.7; 0 before)."""
    if not hasattr(m, field):
        return 0.0
    values = getattr(m, field)
    outadr = getattr(m, "actuator_outadr", None)

    def gear2(k):
        g = float(m.actuator_gear[int(outadr[k]) if outadr is not None else k][0])
        return g * g

    actuator = int(m.jnt_actuatorid[j]) if hasattr(m, "jnt_actuatorid") else -2
    if actuator == -1:
        return 0.0
    if actuator >= 0:
        return float(values[actuator]) * gear2(actuator)
    total = 0.0
    for k in range(m.nu):
        if int(m.actuator_trnid[k][0]) == j and int(m.actuator_trntype[k]) in (
            mujoco.mjtTrn.mjTRN_JOINT,
            mujoco.mjtTrn.mjTRN_JOINTINPARENT,
        ):
            total += float(values[k]) * gear2(k)
    return total


def _joint(m, j, jname, parent, child, origin, note, mujoco) -> JointDescription:
    """MuJoCo's joint j as a JointDescription: hinge (revolute), slide (prismatic), ball, or free (a free body of a
    scene: its origin the identity, its initial position the body's pose). A ball or free joint's per-DoF
    parameters are its first DoF's (MJCF gives one value per joint)."""
    Joint = mujoco.mjtJoint
    kind = {int(Joint.mjJNT_HINGE): "revolute", int(Joint.mjJNT_SLIDE): "prismatic", int(Joint.mjJNT_BALL): "ball",
            int(Joint.mjJNT_FREE): "free"}[int(m.jnt_type[j])]
    axis = np.array(m.jnt_axis[j], dtype=np.float64)
    pivot = np.zeros(3) if kind == "free" else np.array(m.jnt_pos[j], dtype=np.float64)
    qposadr, dof = int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j])
    joint = JointDescription(name=jname, type=kind, parent=parent, child=child, origin=origin, axis=axis, pivot=pivot)
    nq = joint.coordinates
    joint.initial_position = np.array(m.qpos0[qposadr : qposadr + nq], dtype=np.float64)
    if kind in ("revolute", "prismatic"):
        qpos0 = float(m.qpos0[qposadr])
        if qpos0 != 0.0:  # MuJoCo moves the joint by qpos - qpos0: fold -qpos0 into the origin, so that q = qpos
            joint.origin = origin @ joint_motion(kind, axis, pivot, -qpos0)
        if m.jnt_limited[j]:
            joint.lower, joint.upper = (float(v) for v in m.jnt_range[j])
            joint.limit_constraint = LimitConstraint(solref=np.array(m.jnt_solref[j], dtype=np.float64), solimp=np.array(m.jnt_solimp[j], dtype=np.float64),
                                                     margin=float(m.jnt_margin[j]), invweight=float(m.dof_invweight0[dof]))  # fmt: skip
            note(JOINT_LIMITS, jname)
        joint.springref = float(m.qpos_spring[qposadr])
    elif kind == "ball" and m.jnt_limited[j]:  # a limit on the rotation angle: MuJoCo's bound is the range's larger end
        joint.limit_constraint = LimitConstraint(solref=np.array(m.jnt_solref[j], dtype=np.float64), solimp=np.array(m.jnt_solimp[j], dtype=np.float64),
                                                 margin=float(m.jnt_margin[j]), invweight=float(m.dof_invweight0[dof]), angle=float(max(m.jnt_range[j])))  # fmt: skip
        note(JOINT_LIMITS, jname)
    joint.damping = 0.0  # JaxSim's viscous friction: MuJoCo's damping is passive_damping
    joint.friction = float(m.dof_frictionloss[dof])
    if joint.friction != 0.0:
        if kind in ("revolute", "prismatic"):
            joint.friction_constraint = FrictionConstraint(solref=np.array(m.dof_solref[dof], dtype=np.float64),
                                                           solimp=np.array(m.dof_solimp[dof], dtype=np.float64), invweight=float(m.dof_invweight0[dof]))  # fmt: skip
        note(FRICTIONLOSS, jname)
    joint.armature = float(m.dof_armature[dof]) + _actuator_share(m, "actuator_armature", j, mujoco)
    joint.passive_damping = float(m.dof_damping[dof]) + _actuator_share(m, "actuator_damping", j, mujoco)
    joint.stiffness = float(m.jnt_stiffness[j])
    if hasattr(m, "jnt_actfrclimited") and m.jnt_actfrclimited[j]:
        joint.actuator_force_range = np.array(m.jnt_actfrcrange[j], dtype=np.float64)
    if hasattr(m, "jnt_actgravcomp"):
        joint.actuator_gravcomp = bool(m.jnt_actgravcomp[j])
        if joint.actuator_gravcomp and np.any(m.body_gravcomp != 0.0):
            note(ACTUATOR_GRAVCOMP, jname)
    if (hasattr(m, "jnt_stiffnesspoly") and np.any(m.jnt_stiffnesspoly[j] != 0.0)) or (
        hasattr(m, "dof_dampingpoly") and np.any(m.dof_dampingpoly[dof] != 0.0)
    ):
        note(POLYNOMIAL, jname)
    if hasattr(m, "jnt_springyield") and np.any(np.asarray(m.jnt_springyield[j]) != 0.0):
        note(SPRING_YIELD, jname)
    return joint


def _world_children(m, links, joints, where, note, mujoco):
    """The world's children (see the module docstring). One free body beside bodies welded to the world (with no
    joints below them) is a robot in static scenery: the floating base (its joint "floating", with its armature,
    damping and stiffness; its frictionloss noted), the scenery's bodies dropped and noted (their geoms are the
    world's: `_world_geoms`). Otherwise a scene: the world is the base, bodies welded to it are lumped into it, free
    bodies hang from it by their free joints."""
    world_joints = [j for j in joints if j.parent == "world"]
    if not world_joints:
        raise ValueError(f"{where}: the world body has no child body: there is nothing to simulate")
    children: dict[str, list] = {}
    for joint in joints:
        children.setdefault(joint.parent, []).append(joint)

    def subtree(link):
        out = [link]
        for joint in children.get(link, []):
            out += subtree(joint.child)
        return out

    free = [j for j in world_joints if j.type == "free"]
    static = [
        j for j in world_joints
        if j.type == "fixed" and all(k.type == "fixed" for l in subtree(j.child) for k in children.get(l, []))
    ]
    if len(free) == 1 and len(free) + len(static) == len(world_joints):
        joint = free[0]
        if joint.friction != 0.0:
            note(FREE_JOINT_PARAMETERS, joint.name)
        dropped = {l for j in static for l in subtree(j.child)}
        for name in sorted(dropped, key=[link.name for link in links].index):
            note(STATIC_BODIES, name)
        floating = JointDescription(name=joint.name, type="floating", parent="world", child=joint.child, origin=np.eye(4),
                                    initial_position=joint.initial_position, armature=joint.armature,
                                    passive_damping=joint.passive_damping, stiffness=joint.stiffness)
        kept = [floating if k is joint else k for k in joints if k.child not in dropped]
        return [l for l in links if l.name not in dropped], kept
    return links, joints


def _actuators(m, joint_name, note, mujoco) -> list[ActuatorDescription]:
    Trn, Dyn, Gain, Bias = mujoco.mjtTrn, mujoco.mjtDyn, mujoco.mjtGain, mujoco.mjtBias
    outadr = getattr(m, "actuator_outadr", None)
    actuators = []
    for k in range(m.nu):
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, k) or f"actuator{k}"
        trn, dyn = int(m.actuator_trntype[k]), int(m.actuator_dyntype[k])
        gain, bias = int(m.actuator_gaintype[k]), int(m.actuator_biastype[k])
        j = int(m.actuator_trnid[k][0])
        joint_transmission = trn in (Trn.mjTRN_JOINT, Trn.mjTRN_JOINTINPARENT)
        if hasattr(m, "actuator_dampingpoly") and np.any(m.actuator_dampingpoly[k] != 0.0):
            note(ACTUATOR_POLYNOMIAL, name)
        if dyn == Dyn.mjDYN_MUSCLE or gain == Gain.mjGAIN_MUSCLE or bias == Bias.mjBIAS_MUSCLE:
            reason = MUSCLES
        elif not joint_transmission or int(m.jnt_type[j]) not in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
            reason = TRANSMISSION
        elif dyn != Dyn.mjDYN_NONE:
            reason = ACTIVATION
        elif gain not in (Gain.mjGAIN_FIXED, Gain.mjGAIN_AFFINE) or bias not in (Bias.mjBIAS_NONE, Bias.mjBIAS_AFFINE):
            reason = GAIN_BIAS
        elif hasattr(m, "actuator_delay") and float(m.actuator_delay[k]) != 0.0:
            reason = DELAY
        elif int(m.actuator_plugin[k]) >= 0:
            reason = PLUGIN
        elif (
            (hasattr(m, "actuator_outnum") and int(m.actuator_outnum[k]) != 1)
            or (hasattr(m, "actuator_ctrlnum") and int(m.actuator_ctrlnum[k]) != 1)
        ):
            reason = TRANSMISSION
        elif 0 <= int(m.actuator_group[k]) < 31 and int(m.opt.disableactuator) & (1 << int(m.actuator_group[k])):
            reason = DISABLED_GROUP
        else:
            reason = None
        if reason is not None:
            note(reason, name)
            continue
        actuators.append(
            ActuatorDescription(
                name=name,
                joint=joint_name(j),
                gear=float(m.actuator_gear[int(outadr[k]) if outadr is not None else k][0]),
                ctrl_range=np.array(m.actuator_ctrlrange[k], dtype=np.float64),
                ctrl_limited=bool(m.actuator_ctrllimited[k]),
                force_range=np.array(m.actuator_forcerange[k], dtype=np.float64),
                force_limited=bool(m.actuator_forcelimited[k]),
                gain=np.array(m.actuator_gainprm[k][:3], dtype=np.float64),
                gain_type="fixed" if gain == Gain.mjGAIN_FIXED else "affine",
                bias=np.array(m.actuator_biasprm[k][:3], dtype=np.float64),
                bias_type="none" if bias == Bias.mjBIAS_NONE else "affine",
            )
        )
    return actuators


def _equalities(m, body_name, joint_name, name_of, note, disabled, mujoco, poses) -> list[EqualityDescription]:
    """The connect, weld, joint and fixed-tendon equality constraints active at the start (MuJoCo's eq_active0), as MuJoCo compiled
    them; the others are noted as not modelled. None when MuJoCo's constraints or equalities are disabled. poses: an
    MjData after mj_kinematics at qpos0."""
    if "constraint" in disabled or "equality" in disabled:
        return []
    Eq, Obj = mujoco.mjtEq, mujoco.mjtObj
    equalities = []
    for i in range(m.neq):
        name = name_of(Obj.mjOBJ_EQUALITY, i, "equality")
        kind, active = int(m.eq_type[i]), bool(m.eq_active0[i])
        data, o1, o2 = np.array(m.eq_data[i], dtype=np.float64), int(m.eq_obj1id[i]), int(m.eq_obj2id[i])
        solref = np.array(m.eq_solref[i], dtype=np.float64)
        if (solref[0] > 0) != (solref[1] > 0):  # MuJoCo's getsolparam: a mixed format is replaced by the default
            warnings.warn(f"{name}: solref {solref.tolist()} mixes MuJoCo's standard and direct formats; MuJoCo replaces it with its default [0.02, 1], as warpdyn does", stacklevel=caller_stacklevel())
            solref = np.array([0.02, 1.0])
        common = dict(name=name, solref=solref, solimp=np.array(m.eq_solimp[i], dtype=np.float64))
        if active and kind in (Eq.mjEQ_CONNECT, Eq.mjEQ_WELD):
            weld, identity = kind == Eq.mjEQ_WELD, np.array([1.0, 0.0, 0.0, 0.0])
            if int(m.eq_objtype[i]) == Obj.mjOBJ_SITE:  # site semantics: the sites' frames on their bodies
                b1, b2 = int(m.site_bodyid[o1]), int(m.site_bodyid[o2])
                anchor1, anchor2 = np.array(m.site_pos[o1], dtype=np.float64), np.array(m.site_pos[o2], dtype=np.float64)
                rot1, rot2 = np.array(m.site_quat[o1], dtype=np.float64), np.array(m.site_quat[o2], dtype=np.float64)
            elif weld:  # MuJoCo's weld: body1's anchor at data[3:6], body2's at data[0:3], relpose at data[6:10]
                b1, b2, anchor1, anchor2, rot1, rot2 = o1, o2, data[3:6], data[0:3], data[6:10], identity
            else:
                b1, b2, anchor1, anchor2, rot1, rot2 = o1, o2, data[0:3], data[3:6], identity, identity
            # a body welded to the world (the world, static scenery) is the world: its anchor and frame in world axes
            (name1, anchor1, rot1), (name2, anchor2, rot2) = (_on_world(m, b, anchor, rot, body_name, poses) for b, anchor, rot in ((b1, anchor1, rot1), (b2, anchor2, rot2)))
            equalities.append(EqualityDescription(
                kind="weld" if weld else "connect", body1=name1, body2=name2,
                anchor1=anchor1, anchor2=anchor2, rot1=rot1, rot2=rot2, torquescale=float(data[10]) if weld else 1.0,
                invweight=float(m.body_invweight0[b1, 0] + m.body_invweight0[b2, 0]),
                invweight_rotation=float(m.body_invweight0[b1, 1] + m.body_invweight0[b2, 1]), **common,
            ))  # fmt: skip
        elif active and kind == Eq.mjEQ_JOINT:
            invweight = float(m.dof_invweight0[m.jnt_dofadr[o1]] + (m.dof_invweight0[m.jnt_dofadr[o2]] if o2 >= 0 else 0.0))
            equalities.append(EqualityDescription(
                kind="joint", joint1=joint_name(o1), joint2=joint_name(o2) if o2 >= 0 else None, polycoef=data[0:5].copy(),
                invweight=invweight, **common,
            ))  # fmt: skip
        elif active and kind == Eq.mjEQ_TENDON and all(_fixed_tendon(m, t, mujoco) for t in (o1, o2) if t >= 0):
            invweight = float(m.tendon_invweight0[o1] + (m.tendon_invweight0[o2] if o2 >= 0 else 0.0))
            terms = [[(joint_name(int(m.wrap_objid[w])), float(m.wrap_prm[w])) for w in range(m.tendon_adr[t], m.tendon_adr[t] + m.tendon_num[t])] if t >= 0 else None
                     for t in (o1, o2)]  # fmt: skip
            equalities.append(EqualityDescription(kind="tendon", tendon1=terms[0], tendon2=terms[1], polycoef=data[0:5].copy(), invweight=invweight, **common))
        else:
            note(EQUALITY, name)
    return equalities


def _on_world(m, b: int, anchor, rot, body_name, poses) -> tuple:
    """(the body's name, the anchor, the frame (w, x, y, z)), in world axes and named "world" for a body welded to
    the world (MuJoCo's body_weldid 0: the world, static scenery, which a floating base's description drops), at
    its pose `poses` (an MjData after mj_kinematics at qpos0)."""
    anchor, rot = np.asarray(anchor, dtype=np.float64).copy(), np.asarray(rot, dtype=np.float64).copy()
    if int(m.body_weldid[b]) != 0:
        return body_name(b), anchor, rot
    R = np.asarray(poses.xmat[b], dtype=np.float64).reshape(3, 3)
    return "world", R @ anchor + np.asarray(poses.xpos[b], dtype=np.float64), quaternion_product(np.asarray(poses.xquat[b], dtype=np.float64), rot)


def _fixed_tendon(m, t: int, mujoco) -> bool:
    """Whether MuJoCo's tendon t is fixed: a linear combination of joint positions (every wrap a joint)."""
    return all(int(m.wrap_type[w]) == mujoco.mjtWrap.mjWRAP_JOINT for w in range(m.tendon_adr[t], m.tendon_adr[t] + m.tendon_num[t]))


def _constraints_and_others(m, note, name_of, mujoco) -> None:
    Obj = mujoco.mjtObj
    for i in range(m.ntendon):
        note(TENDONS, name_of(Obj.mjOBJ_TENDON, i, "tendon"))
    for i in range(m.nflex):
        note(FLEX, name_of(Obj.mjOBJ_FLEX, i, "flex"))
    for i in range(m.nskin):
        note(SKINS, name_of(Obj.mjOBJ_SKIN, i, "skin"))
    for i in range(m.nplugin):
        note(PLUGIN, name_of(Obj.mjOBJ_PLUGIN, i, "plugin"))


def _geom_type_name(kind: int, mujoco) -> str:
    for enum_name, value in mujoco.mjtGeom.__members__.items():
        if int(value) == kind:
            return enum_name.removeprefix("mjGEOM_").lower()
    return str(kind)


def _mjcf_collisions(m, b: int, link: LinkDescription, mujoco, note, name_of) -> None:
    for g in range(int(m.body_geomadr[b]), int(m.body_geomadr[b]) + int(m.body_geomnum[b])):
        if m.geom_fluid[g][0] > 0.0:
            note(FLUID, f"{link.name} (fluidshape)")
        if m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0:
            continue
        H = homogeneous(quaternion_wxyz_to_matrix(m.geom_quat[g]), m.geom_pos[g])
        shape = _shape(m, g, H, mujoco, name_of)
        if shape is not None:
            link.collisions.append(shape)
        else:
            geom = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g} of '{link.name}'"
            note(GEOMS, f"{geom} ({_geom_type_name(int(m.geom_type[g]), mujoco)})")


def _world_geoms(m, mujoco, note, name_of, d) -> list[CollisionShape]:
    """The colliding geoms that do not move (body_weldid 0: the world body's and those of bodies welded to it), posed
    in the world as MuJoCo places them (d: an MjData after mj_kinematics at qpos0); planes and heightfields are the terrain's."""
    out = []
    for g in range(m.ngeom):
        kind = int(m.geom_type[g])
        if int(m.body_weldid[m.geom_bodyid[g]]) != 0 or (m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0):
            continue
        if kind in (mujoco.mjtGeom.mjGEOM_PLANE, mujoco.mjtGeom.mjGEOM_HFIELD):
            continue
        shape = _shape(m, g, homogeneous(np.array(d.geom_xmat[g], dtype=np.float64).reshape(3, 3), d.geom_xpos[g]), mujoco, name_of)
        if shape is not None:
            out.append(shape)
        elif int(m.geom_bodyid[g]) == 0:  # a welded body's are noted with its link's
            note(GEOMS, f"{name_of(mujoco.mjtObj.mjOBJ_GEOM, g, 'geom')} of the world ({_geom_type_name(kind, mujoco)})")
    return out


def _ground(m, mujoco, note, name_of, d) -> tuple[np.ndarray, np.ndarray] | None:
    """The world body's one colliding plane, (unit normal, point) [world, m] as MuJoCo places it: the model's terrain
    (planes on other bodies, welded or not, are noted with GEOMS). None without one; with several, or with a
    heightfield, or a plane facing down, None and a note naming them (the terrain then stays the plane z = 0 until
    model.terrain is set). d: an MjData after mj_kinematics at qpos0."""
    ground = [g for g in range(m.ngeom) if int(m.geom_bodyid[g]) == 0 and (m.geom_contype[g] or m.geom_conaffinity[g])
              and int(m.geom_type[g]) in (mujoco.mjtGeom.mjGEOM_PLANE, mujoco.mjtGeom.mjGEOM_HFIELD)]  # fmt: skip
    if not ground:
        return None
    normal = np.array(d.geom_xmat[ground[0]], dtype=np.float64).reshape(3, 3)[:, 2]
    if len(ground) == 1 and int(m.geom_type[ground[0]]) == mujoco.mjtGeom.mjGEOM_PLANE and normal[2] > 1e-6:
        return normal, np.array(d.geom_xpos[ground[0]], dtype=np.float64)
    for g in ground:
        note(GROUND, f"{name_of(mujoco.mjtObj.mjOBJ_GEOM, g, 'geom')} ({_geom_type_name(int(m.geom_type[g]), mujoco)})")
    return None


def _large_faces(m, g: int, mujoco) -> bool:
    """Whether geom g is a mesh with a hull polygon of more than MAX_FACE vertices."""
    polygons = _mesh_polygons(m, int(m.geom_dataid[g])) if int(m.geom_type[g]) == int(mujoco.mjtGeom.mjGEOM_MESH) else None
    return polygons is not None and max(len(indices) for indices in polygons[1]) > MAX_FACE


def _mesh_polygons(m, mesh: int) -> tuple | None:
    """Mesh `mesh`'s hull polygons as MuJoCo compiled them (`CollisionShape.polygons`); None where it has none (an
    older MuJoCo without mesh_polynum)."""
    if not hasattr(m, "mesh_polynum") or int(m.mesh_polynum[mesh]) == 0:
        return None
    first, count = int(m.mesh_polyadr[mesh]), int(m.mesh_polynum[mesh])
    normals = np.array(m.mesh_polynormal[first : first + count], dtype=np.float64).reshape(count, 3)
    indices = tuple(np.array(m.mesh_polyvert[m.mesh_polyvertadr[q] : m.mesh_polyvertadr[q] + m.mesh_polyvertnum[q]], dtype=np.int64) for q in range(first, first + count))
    return normals, indices


def hull_polygons(vertices: np.ndarray) -> tuple | None:
    """The hull polygons MuJoCo compiles for a mesh of `vertices` (k, 3) [m] (a URDF's or SDF's mesh file, scaled), as
    `CollisionShape.polygons` in the frame of `vertices` (normals (q, 3); indices: rows of `vertices`); None where
    MuJoCo is not installed or does not compile the mesh (fewer than four points off one plane). MuJoCo keeps the
    vertices' order, but in the mesh's inertial frame (mesh_pos, mesh_quat): the normals are turned back, and the
    vertices checked to come back to `vertices` (to their float32 rounding)."""
    try:
        import mujoco
    except ImportError:
        return None
    vertices = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    text = " ".join(repr(float(x)) for x in vertices.ravel())
    try:
        m = mujoco.MjModel.from_xml_string(f'<mujoco><asset><mesh name="hull" vertex="{text}"/></asset><worldbody><geom type="mesh" mesh="hull"/></worldbody></mujoco>')
    except ValueError:
        return None
    polygons = _mesh_polygons(m, 0)
    R = np.empty(9)
    mujoco.mju_quat2Mat(R, m.mesh_quat[0])
    R = R.reshape(3, 3)
    theirs = np.asarray(m.mesh_vert, dtype=np.float64) @ R.T + m.mesh_pos[0]
    size = max(float(np.ptp(vertices, axis=0).max()), 1e-12)
    if polygons is None or theirs.shape != vertices.shape or np.abs(theirs - vertices).max() > 1e-6 * size:
        return None
    return polygons[0] @ R.T, polygons[1]


def _shape(m, g: int, H: np.ndarray, mujoco, name_of) -> CollisionShape | None:
    """Geom g as a CollisionShape at the pose H (its body's frame, or the world's), with MuJoCo's collision
    attributes; None for a kind warpdyn does not represent (plane, heightfield, sdf)."""
    size = np.array(m.geom_size[g], dtype=np.float64)
    kind = int(m.geom_type[g])
    geom = dict(
        geom=g, name=name_of(mujoco.mjtObj.mjOBJ_GEOM, g, "geom"), contype=int(m.geom_contype[g]),
        conaffinity=int(m.geom_conaffinity[g]), margin=float(m.geom_margin[g]), gap=float(m.geom_gap[g]),
        friction=tuple(float(f) for f in m.geom_friction[g]), condim=int(m.geom_condim[g]), priority=int(m.geom_priority[g]),
    )  # fmt: skip
    Geom = mujoco.mjtGeom
    if kind == Geom.mjGEOM_BOX:
        return CollisionShape("box", H, size=2.0 * size, **geom)
    if kind == Geom.mjGEOM_SPHERE:
        return CollisionShape("sphere", H, radius=float(size[0]), **geom)
    if kind == Geom.mjGEOM_ELLIPSOID:
        return CollisionShape("ellipsoid", H, size=size.copy(), **geom)
    if kind in (Geom.mjGEOM_CYLINDER, Geom.mjGEOM_CAPSULE):
        return CollisionShape("cylinder" if kind == Geom.mjGEOM_CYLINDER else "capsule", H, radius=float(size[0]), length=2.0 * float(size[1]), **geom)
    if kind == Geom.mjGEOM_MESH:
        mesh = int(m.geom_dataid[g])
        start, count = int(m.mesh_vertadr[mesh]), int(m.mesh_vertnum[mesh])
        vertices = np.array(m.mesh_vert[start : start + count], dtype=np.float64)
        return CollisionShape("mesh", H, vertices=vertices, scale=np.ones(3), polygons=_mesh_polygons(m, mesh), **geom)
    return None
