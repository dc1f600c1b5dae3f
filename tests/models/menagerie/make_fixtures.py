"""Write the mesh-free fixtures of this folder from MuJoCo Menagerie, and check them against the originals.

    python tests/models/menagerie/make_fixtures.py --menagerie PATH

Run by hand (the tests read the fixtures it wrote, never the Menagerie). Each original is compiled with MuJoCo
and written back from the compiled MjModel, so that the fixture has its kinematics and dynamics exactly:
- every body with its compiled pos/quat and an explicit <inertial> (body_mass, body_ipos, body_iquat,
  body_inertia), `mocap` and `gravcomp`; <compiler inertiafromgeom="false">, so no geom adds mass;
- every joint with its compiled type, pos, axis, range and limited, ref (qpos0), springref (qpos_spring),
  armature, damping, stiffness, frictionloss, actuatorfrcrange, actuatorgravcomp and its constraint
  parameters (margin, solref/solimp of limit and friction), a ball or free joint's per-dof values included;
- the collision geoms (contype or conaffinity set) with their contact parameters: primitives as compiled,
  meshes as their bounding box (MuJoCo's geom_aabb, in the geom's frame); visual-only geoms, sites,
  cameras, lights, sensors, materials and textures dropped;
- actuators with a joint transmission as <general> with the compiled dynamics, gain and bias types and
  parameters, gear and ranges; equality constraints (connect between bodies, joint couplings), contact
  excludes, keyframes (qpos, qvel, ctrl, act, mocap poses) and <option> (gravity, timestep, integrator,
  density, viscosity, the disable and enable flags).
Anything else these originals would need raises, rather than being dropped silently.

Then each fixture is compared with its original at qpos0 and at random states (tests/mjcf_compare.py's
MuJoCo side: M, qfrc_bias, qfrc_passive + qfrc_actuator at ctrl = 0, qacc with constraints disabled; and
qfrc_actuator at random controls), and qpos0 and the keyframes with the original's; the largest relative
error is printed and must be below 1e-10.
"""

from __future__ import annotations

import argparse
import pathlib
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET

import mujoco
import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))  # tests/

import mjcf_compare  # noqa: E402
import mjcf_models  # noqa: E402

FIXTURES = {
    "cassie.xml": ("agility_cassie/cassie.xml", "LICENSE.agility_cassie"),
    "mjx_single_cube.xml": ("franka_emika_panda/mjx_single_cube.xml", "LICENSE.franka_emika_panda"),
    "rby1a_1.2.xml": ("rainbow_robotics_rby1/rby1a_1.2.xml", "LICENSE.rainbow_robotics_rby1"),
}
"""fixture file: (its original in the Menagerie, the robot directory's LICENSE copied beside it)."""

TOL = 1e-10
RANDOM_STATES = 3

_JOINT = {mujoco.mjtJoint.mjJNT_FREE.value: "free", mujoco.mjtJoint.mjJNT_BALL.value: "ball", mujoco.mjtJoint.mjJNT_SLIDE.value: "slide", mujoco.mjtJoint.mjJNT_HINGE.value: "hinge"}
_GEOM = {mujoco.mjtGeom.mjGEOM_PLANE.value: "plane", mujoco.mjtGeom.mjGEOM_SPHERE.value: "sphere", mujoco.mjtGeom.mjGEOM_CAPSULE.value: "capsule",
         mujoco.mjtGeom.mjGEOM_ELLIPSOID.value: "ellipsoid", mujoco.mjtGeom.mjGEOM_CYLINDER.value: "cylinder", mujoco.mjtGeom.mjGEOM_BOX.value: "box"}  # fmt: skip
_INTEGRATOR = {mujoco.mjtIntegrator.mjINT_EULER.value: "Euler", mujoco.mjtIntegrator.mjINT_RK4.value: "RK4",
               mujoco.mjtIntegrator.mjINT_IMPLICIT.value: "implicit", mujoco.mjtIntegrator.mjINT_IMPLICITFAST.value: "implicitfast"}  # fmt: skip
_DYN = {e.value: name.removeprefix("mjDYN_").lower() for name, e in mujoco.mjtDyn.__members__.items()}
_GAIN = {e.value: name.removeprefix("mjGAIN_").lower() for name, e in mujoco.mjtGain.__members__.items()}
_BIAS = {e.value: name.removeprefix("mjBIAS_").lower() for name, e in mujoco.mjtBias.__members__.items()}


_DEFAULT = mujoco.MjModel.from_xml_string(
    '<mujoco><worldbody><body><joint name="j"/><geom size="1"/></body></worldbody><actuator><general joint="j"/></actuator></mujoco>'
)
"""MuJoCo's default values of the attributes written below: an attribute equal to its default is left out."""


def _unless(value, default):
    """value, or None (left out) where it equals MuJoCo's default."""
    return None if np.array_equal(np.asarray(value), np.asarray(default)) else value


def _trimmed(values) -> np.ndarray:
    """A parameter vector without its trailing zeros (MJCF reads the values left out as 0)."""
    values = np.asarray(values)
    nonzero = np.flatnonzero(values)
    return values[: nonzero[-1] + 1 if nonzero.size else 1]


def _num(values) -> str:
    """Numbers as the shortest text that reads back to the same float64."""
    return " ".join(repr(float(v)) for v in np.atleast_1d(values))


def _name(m, obj, i) -> str | None:
    return mujoco.mj_id2name(m, obj, i)


def _element(parent, tag, name=None, **attributes) -> ET.Element:
    """A child element; numeric attributes written with _num, None ones left out."""
    e = ET.SubElement(parent, tag)
    if name:
        e.set("name", name)
    for key, value in attributes.items():
        if value is not None:
            e.set(key, value if isinstance(value, str) else _num(value))
    return e


def _same(values, what):
    """The one value a joint's dofs share (MJCF writes one per joint)."""
    values = np.asarray(values)
    if not np.all(values == values[0]):
        raise NotImplementedError(f"{what} differs between the dofs of one joint: {values}")
    return values[0]


def _joint(m, body_element, j) -> None:
    kind = _JOINT[int(m.jnt_type[j])]
    dofs = range(m.jnt_dofadr[j], m.jnt_dofadr[j] + {"free": 6, "ball": 3}.get(kind, 1))
    if np.any(m.jnt_stiffnesspoly[j]) or np.any(m.dof_dampingpoly[list(dofs)]):
        raise NotImplementedError(f"joint {j}: polynomial stiffness or damping")
    a = int(m.jnt_qposadr[j])
    one_dof = kind in ("hinge", "slide")
    d = _DEFAULT
    _element(
        body_element,
        "joint",
        _name(m, mujoco.mjtObj.mjOBJ_JOINT, j),
        type=kind,
        pos=_unless(m.jnt_pos[j], d.jnt_pos[0]) if kind != "free" else None,
        axis=m.jnt_axis[j] if one_dof else None,
        ref=_unless(m.qpos0[a], 0.0) if one_dof else None,
        springref=_unless(m.qpos_spring[a], 0.0) if one_dof else None,
        limited="true" if m.jnt_limited[j] else None,
        range=m.jnt_range[j] if m.jnt_limited[j] else None,
        margin=_unless(m.jnt_margin[j], d.jnt_margin[0]),
        solreflimit=_unless(m.jnt_solref[j], d.jnt_solref[0]),
        solimplimit=_unless(m.jnt_solimp[j], d.jnt_solimp[0]),
        stiffness=_unless(m.jnt_stiffness[j], 0.0),
        armature=_unless(_same(m.dof_armature[dofs], f"joint {j} armature"), 0.0),
        damping=_unless(_same(m.dof_damping[dofs], f"joint {j} damping"), 0.0),
        frictionloss=_unless(_same(m.dof_frictionloss[dofs], f"joint {j} frictionloss"), 0.0),
        solreffriction=_unless(_same(m.dof_solref[dofs], f"joint {j} solreffriction"), d.dof_solref[0]),
        solimpfriction=_unless(_same(m.dof_solimp[dofs], f"joint {j} solimpfriction"), d.dof_solimp[0]),
        actuatorfrclimited="true" if m.jnt_actfrclimited[j] else None,
        actuatorfrcrange=m.jnt_actfrcrange[j] if m.jnt_actfrclimited[j] else None,
        actuatorgravcomp="true" if m.jnt_actgravcomp[j] else None,
    )


def _geom(m, body_element, g) -> None:
    if m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0:
        return  # visual only
    kind = int(m.geom_type[g])
    pos, quat, size = m.geom_pos[g], m.geom_quat[g], m.geom_size[g]
    if kind == mujoco.mjtGeom.mjGEOM_MESH.value:  # its bounding box, in the geom's frame
        R = np.zeros(9)
        mujoco.mju_quat2Mat(R, quat)
        pos, size, name = pos + R.reshape(3, 3) @ m.geom_aabb[g, :3], m.geom_aabb[g, 3:], "box"
    elif kind in _GEOM:
        name = _GEOM[kind]
    else:
        raise NotImplementedError(f"geom {g} has type {kind}")
    d = _DEFAULT
    _element(
        body_element,
        "geom",
        _name(m, mujoco.mjtObj.mjOBJ_GEOM, g),
        type=name,
        size=size,
        pos=_unless(pos, 0.0 * pos),
        quat=_unless(quat, d.geom_quat[0]),
        group=_unless(str(int(m.geom_group[g])), "0"),
        contype=_unless(str(int(m.geom_contype[g])), "1"),
        conaffinity=_unless(str(int(m.geom_conaffinity[g])), "1"),
        condim=_unless(str(int(m.geom_condim[g])), "3"),
        priority=_unless(str(int(m.geom_priority[g])), "0"),
        friction=_unless(m.geom_friction[g], d.geom_friction[0]),
        solmix=_unless(m.geom_solmix[g], d.geom_solmix[0]),
        solref=_unless(m.geom_solref[g], d.geom_solref[0]),
        solimp=_unless(m.geom_solimp[g], d.geom_solimp[0]),
        margin=_unless(m.geom_margin[g], 0.0),
        gap=_unless(m.geom_gap[g], 0.0),
    )


def _body(m, parent_element, b, children) -> None:
    e = _element(
        parent_element,
        "body",
        _name(m, mujoco.mjtObj.mjOBJ_BODY, b),
        pos=_unless(m.body_pos[b], np.zeros(3)),
        quat=_unless(m.body_quat[b], _DEFAULT.body_quat[1]),
        mocap="true" if m.body_mocapid[b] >= 0 else None,
        gravcomp=m.body_gravcomp[b] if m.body_gravcomp[b] else None,
    )
    _element(e, "inertial", pos=m.body_ipos[b], quat=m.body_iquat[b], mass=m.body_mass[b], diaginertia=m.body_inertia[b])
    for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b]):
        _joint(m, e, j)
    for g in range(m.body_geomadr[b], m.body_geomadr[b] + m.body_geomnum[b]):
        _geom(m, e, g)
    for child in children[b]:
        _body(m, e, child, children)


def _flags(m, option) -> None:
    flags = {}
    for prefix, members, value, setting in (("mjDSBL_", mujoco.mjtDisableBit, m.opt.disableflags, "disable"), ("mjENBL_", mujoco.mjtEnableBit, m.opt.enableflags, "enable")):
        for name, bit in members.__members__.items():
            if not name.startswith(("mjNDISABLE", "mjNENABLE")) and int(value) & int(bit):
                flags[name.removeprefix(prefix).lower()] = setting
    if flags:
        _element(option, "flag", **flags)


def fixture_xml(m: mujoco.MjModel, header: str) -> str:
    """The MJCF of the compiled model `m`, as the module docstring says, with `header` as its first comment."""
    root = ET.Element("mujoco", model=bytes(m.names).split(b"\0", 1)[0].decode())
    root.append(ET.Comment(header))
    _element(root, "compiler", angle="radian", autolimits="true", inertiafromgeom="false")
    o = m.opt
    option = _element(root, "option", timestep=o.timestep, gravity=o.gravity, density=_unless(o.density, 0.0),
                      viscosity=_unless(o.viscosity, 0.0), wind=_unless(o.wind, np.zeros(3)), integrator=_INTEGRATOR[int(o.integrator)])  # fmt: skip
    _flags(m, option)
    children = {b: [] for b in range(m.nbody)}
    for b in range(1, m.nbody):
        children[int(m.body_parentid[b])].append(b)
    world = _element(root, "worldbody")
    for g in range(m.body_geomadr[0], m.body_geomadr[0] + m.body_geomnum[0]):
        _geom(m, world, g)
    for b in children[0]:
        _body(m, world, b, children)
    if m.nexclude:
        contact = _element(root, "contact")
        for signature in m.exclude_signature:
            _element(contact, "exclude", body1=_name(m, mujoco.mjtObj.mjOBJ_BODY, int(signature) >> 16), body2=_name(m, mujoco.mjtObj.mjOBJ_BODY, int(signature) & 0xFFFF))
    if m.neq:
        equality = _element(root, "equality")
        for i in range(m.neq):
            common = dict(active="true" if m.eq_active0[i] else "false", solref=m.eq_solref[i], solimp=m.eq_solimp[i])
            name = _name(m, mujoco.mjtObj.mjOBJ_EQUALITY, i)
            if m.eq_type[i] == mujoco.mjtEq.mjEQ_CONNECT.value and m.eq_objtype[i] == mujoco.mjtObj.mjOBJ_BODY.value:
                bodies = [_name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.eq_obj1id[i])), _name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.eq_obj2id[i]))]
                _element(equality, "connect", name, body1=bodies[0], body2=bodies[1], anchor=m.eq_data[i, :3], **common)
            elif m.eq_type[i] == mujoco.mjtEq.mjEQ_JOINT.value:
                joint2 = _name(m, mujoco.mjtObj.mjOBJ_JOINT, int(m.eq_obj2id[i])) if m.eq_obj2id[i] >= 0 else None
                _element(equality, "joint", name, joint1=_name(m, mujoco.mjtObj.mjOBJ_JOINT, int(m.eq_obj1id[i])), joint2=joint2, polycoef=m.eq_data[i, :5], **common)
            else:
                raise NotImplementedError(f"equality {i} of type {int(m.eq_type[i])}")
    if m.nu:
        actuator = _element(root, "actuator")
        for i in range(m.nu):
            if m.actuator_trntype[i] != mujoco.mjtTrn.mjTRN_JOINT.value or np.any(m.actuator_armature[i]) or np.any(m.actuator_damping[i]):
                raise NotImplementedError(f"actuator {i}: not a plain joint transmission")
            d = _DEFAULT
            _element(
                actuator,
                "general",
                _name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, i),
                joint=_name(m, mujoco.mjtObj.mjOBJ_JOINT, int(m.actuator_trnid[i, 0])),
                gear=_unless(_trimmed(m.actuator_gear[i]), _trimmed(d.actuator_gear[0])),
                dyntype=_unless(_DYN[int(m.actuator_dyntype[i])], "none"),
                gaintype=_unless(_GAIN[int(m.actuator_gaintype[i])], "fixed"),
                biastype=_unless(_BIAS[int(m.actuator_biastype[i])], "none"),
                dynprm=_unless(_trimmed(m.actuator_dynprm[i]), _trimmed(d.actuator_dynprm[0])),
                gainprm=_unless(_trimmed(m.actuator_gainprm[i]), _trimmed(d.actuator_gainprm[0])),
                biasprm=_unless(_trimmed(m.actuator_biasprm[i]), _trimmed(d.actuator_biasprm[0])),
                actearly="true" if m.actuator_actearly[i] else None,
                ctrllimited="true" if m.actuator_ctrllimited[i] else None,
                ctrlrange=m.actuator_ctrlrange[i] if m.actuator_ctrllimited[i] else None,
                forcelimited="true" if m.actuator_forcelimited[i] else None,
                forcerange=m.actuator_forcerange[i] if m.actuator_forcelimited[i] else None,
                actlimited="true" if m.actuator_actlimited[i] else None,
                actrange=m.actuator_actrange[i] if m.actuator_actlimited[i] else None,
            )
    if m.nkey:
        keyframe = _element(root, "keyframe")
        for k in range(m.nkey):
            _element(
                keyframe,
                "key",
                _name(m, mujoco.mjtObj.mjOBJ_KEY, k),
                time=_unless(m.key_time[k], 0.0),
                qpos=m.key_qpos[k],
                qvel=_unless(m.key_qvel[k], 0.0 * m.key_qvel[k]),
                act=m.key_act[k] if m.na else None,
                ctrl=m.key_ctrl[k] if m.nu else None,
                mpos=m.key_mpos[k] if m.nmocap else None,
                mquat=m.key_mquat[k] if m.nmocap else None,
            )
    ET.indent(root, "  ")
    return ET.tostring(root, encoding="unicode") + "\n"


def differences(original: mujoco.MjModel, fixture: mujoco.MjModel, seed: int = 0) -> dict:
    """The largest relative difference of the fixture from its original: M, h, forces, qacc over qpos0 and
    RANDOM_STATES random states (mjcf_compare's MuJoCo side), qfrc_actuator at random controls (a third
    outside their ranges) in those states, qpos0 and the keyframes."""
    if (original.nq, original.nv, original.nu, original.nkey) != (fixture.nq, fixture.nv, fixture.nu, fixture.nkey):
        raise AssertionError("the fixture's sizes differ from the original's")
    errors = dict.fromkeys((*mjcf_compare.QUANTITIES, "actuators"), 0.0)
    references = mjcf_compare.reference(original), mjcf_compare.reference(fixture)
    rng = np.random.default_rng(seed)
    for qpos, qvel in mjcf_compare.states(original, RANDOM_STATES, seed):
        theirs, ours = (mjcf_compare.mujoco_quantities(ref, qpos, qvel) for ref in references)
        floor = mjcf_compare.floors(theirs, original.opt.gravity)
        for name in mjcf_compare.QUANTITIES:
            errors[name] = max(errors[name], mjcf_compare.relative_error(ours[name], theirs[name], floor[name]))
        ctrl = mjcf_models.random_ctrl(original, rng)
        theirs, ours = (mjcf_models.actuator_forces(model, qpos, qvel, ctrl).qfrc_actuator for model in (original, fixture))
        errors["actuators"] = max(errors["actuators"], mjcf_compare.relative_error(ours, theirs))
    errors["qpos0"] = mjcf_compare.relative_error(fixture.qpos0, original.qpos0)
    keys = ("key_qpos", "key_qvel", "key_ctrl", "key_act", "key_mpos", "key_mquat")
    errors["keyframes"] = max((mjcf_compare.relative_error(getattr(fixture, k), getattr(original, k)) for k in keys if getattr(original, k).size), default=0.0)
    return errors


def _revision(menagerie: pathlib.Path, given: str | None) -> str:
    if given:
        return given
    out = subprocess.run(["git", "rev-parse", "HEAD"], cwd=menagerie, capture_output=True, text=True)
    if out.returncode:
        raise SystemExit(f"{menagerie} is not a git checkout: name its commit with --revision")
    return out.stdout.strip()


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--menagerie", required=True, type=pathlib.Path, help="a checkout of mujoco_menagerie")
    parser.add_argument("--revision", help="the Menagerie's commit, when PATH is not a git checkout")
    args = parser.parse_args(argv)
    revision = _revision(args.menagerie, args.revision)
    worst = 0.0
    for fixture, (source, licence) in FIXTURES.items():
        original_path = args.menagerie / source
        original = mujoco.MjModel.from_xml_path(str(original_path))
        header = (f" Derived from MuJoCo Menagerie {source} (commit {revision}) by make_fixtures.py: the compiled model's "
                  f"kinematics and dynamics, meshes replaced by their bounding boxes. Licence: {licence}. ")  # fmt: skip
        (HERE / fixture).write_text(fixture_xml(original, header))
        shutil.copyfile(original_path.parent / "LICENSE", HERE / licence)
        errors = differences(original, mujoco.MjModel.from_xml_path(str(HERE / fixture)))
        worst = max(worst, *errors.values())
        size = (HERE / fixture).stat().st_size
        print(f"{fixture} ({size / 1024:.1f} KB) from {source}: " + ", ".join(f"{k} {v:.1e}" for k, v in errors.items()))
    if worst > TOL:
        raise SystemExit(f"a fixture differs from its original by {worst:.1e} > {TOL:g}")
    print(f"all within {TOL:g} of their originals (largest {worst:.1e})")


if __name__ == "__main__":
    main()
