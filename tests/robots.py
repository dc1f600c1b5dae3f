"""Robots the tests run on, and the same robots in MuJoCo (the reference).

- `random_tree_urdf(seed)`: a random kinematic tree (revolute and prismatic joints with random axes,
  offsets and inertias, some fixed joints to lump, depth up to 30).
- `pendulum_chain_urdf(n)`: a chain of n revolute links, fixed to the world; `rod_chain_urdf(masses)`: the
  same with a mass per rod.
- `icub_urdf()`: iCubGazeboV2_5 from the icub-models package; `ergocub_urdf()`: the seed's ergoCubSN001.
- `ERGOCUB_LEG_JOINTS(model)`, `ICUB_LEG_JOINTS(model)`: the joints the seed keeps.
- `icub_legs_source()`, `ergocub_seed_source()`: (URDF text, considered joints) of the iCub's legs and the
  seed's ergoCub.
- `mujoco_model(urdf_text, considered_joints, floating)`: the same robot in MuJoCo, the joints that are not
  considered made fixed (locked at 0), meshes stripped, with a free joint when floating (`mujoco_spec`: its
  spec; fuse_static=False keeps every URDF link a body).
- `MujocoState`: sets MuJoCo's qpos/qvel from warpdyn's state, mapping joints by name and converting
  the base velocity (MuJoCo's free joint: world linear velocity of the body origin, body-frame angular).
- The simulation tests' set-up (tests/test_simulation*.py, tests/test_actuation.py): the integrators `SIE`,
  `RK4`, gravity `G`; a free body (`BODY_URDF`, `BODY_INERTIA`), a box (`BOX_URDF`, `BOX_MASS`, `BOX_HALF`),
  `wheels_urdf`; `build`, `contact_free`, `rollout`, `host`; quaternions (`qmul`, `quat_distance`);
  MuJoCo's RK4 on the same robot (`mujoco_rk4`, `mujoco_state`); JaxSim's actuation in NumPy
  (`jaxsim_resultant_torques`).
- The seed's ergoCub with collidable points (tests/test_contact_geometry.py, test_contact_derivatives.py):
  `ergocub_full_model`, `ergocub_seed_model`, `ergocub_seed_with_points` (`NO_MESH`), and random states
  for them (`random_state_kwargs`).
- The model tests' robots by case name (tests/test_model.py, test_model_mjcf.py): `text_of`, `full_model`,
  `considered_of`, `built`, `case_source`; their random states (`rng_for`, `random_data`,
  `uniform_state_kwargs`); `H_of`, `assert_close`.
"""

from __future__ import annotations

import functools
import os
import pathlib
import xml.etree.ElementTree as ET
import zlib

import numpy as np

import warpdyn as wd
from warpdyn.assets import ergocub_urdf as _ergocub_path

ERGOCUB = _ergocub_path()
_EXCLUDED = ("camera", "neck", "wrist", "thumb", "index", "middle", "ring", "pinkie", "torso", "elbow", "shoulder")


def assert_same_compilation_results(a, b) -> None:
    """Two runs of the same operations in two launch layouts: bitwise on the CPU (the same operations per item), to
    rounding on a GPU (another compilation of them)."""
    if TEST_DEVICE == "cpu":
        np.testing.assert_array_equal(a, b)
    else:
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(a).max()))


def seed_joints(joint_names) -> list[str]:
    """The joints the seed notebook keeps: every joint whose name contains none of _EXCLUDED."""
    return [j for j in joint_names if not any(word in j for word in _EXCLUDED)]


def ergocub_urdf() -> str:
    return ERGOCUB.read_text()


def icub_path() -> str:
    import icub_models

    return str(icub_models.get_model_file("iCubGazeboV2_5"))


def icub_urdf() -> str:
    return pathlib.Path(icub_path()).read_text()


def icub_leg_joints(joint_names) -> list[str]:
    return [j for j in joint_names if any(part in j for part in ("hip", "knee", "ankle"))]


def movable_joint_names(text: str) -> list[str]:
    """The names of a description's joints that are not fixed, in its order."""
    return [j.name for j in wd.description.load(text).joints if j.type != "fixed"]


def icub_legs_source() -> tuple[str, tuple[str, ...]]:
    """(URDF text, considered joints) of the iCub's legs."""
    text = icub_urdf()
    return text, tuple(icub_leg_joints(movable_joint_names(text)))


def ergocub_seed_source() -> tuple[str, tuple[str, ...]]:
    """(URDF text, considered joints) of the seed's ergoCub."""
    text = ergocub_urdf()
    return text, tuple(seed_joints(movable_joint_names(text)))


def _origin(xyz, rpy) -> str:
    return f'<origin xyz="{xyz[0]:.17g} {xyz[1]:.17g} {xyz[2]:.17g}" rpy="{rpy[0]:.17g} {rpy[1]:.17g} {rpy[2]:.17g}"/>'


def _inertial(rng, mass_range=(0.1, 5.0)) -> str:
    """A physically valid inertia: a random box's, rotated randomly, with a random CoM offset."""
    mass = rng.uniform(*mass_range)
    a, b, c = rng.uniform(0.05, 0.5, size=3)
    I = mass / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    I = Q @ I @ Q.T
    com = rng.uniform(-0.2, 0.2, size=3)
    return (
        f'<inertial>{_origin(com, (0, 0, 0))}<mass value="{mass:.17g}"/>'
        f'<inertia ixx="{I[0, 0]:.17g}" ixy="{I[0, 1]:.17g}" ixz="{I[0, 2]:.17g}" '
        f'iyy="{I[1, 1]:.17g}" iyz="{I[1, 2]:.17g}" izz="{I[2, 2]:.17g}"/></inertial>'
    )


def random_tree_urdf(seed: int, num_links: int | None = None, max_depth: int = 30, fixed_base: bool = False) -> str:
    """A random tree of `num_links` links: revolute (60%), prismatic (25%) and fixed (15%) joints."""
    rng = np.random.default_rng(seed)
    num_links = int(rng.integers(2, 25)) if num_links is None else num_links
    depth = [0]
    parts = [f'<robot name="random_{seed}">']
    if fixed_base:
        parts.append('<link name="world"/>')
        parts.append(
            f'<joint name="world_to_link0" type="fixed"><parent link="world"/><child link="link0"/>'
            f"{_origin(rng.uniform(-1, 1, 3), rng.uniform(-np.pi, np.pi, 3))}</joint>"
        )
    parts.append(f'<link name="link0">{_inertial(rng)}</link>')
    for i in range(1, num_links):
        candidates = [k for k in range(i) if depth[k] < max_depth]
        parent = int(rng.choice(candidates)) if rng.uniform() < 0.5 else candidates[-1]
        depth.append(depth[parent] + 1)
        kind = rng.choice(["revolute", "prismatic", "fixed", "continuous"], p=[0.5, 0.25, 0.15, 0.1])
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        limit = '<limit lower="-2" upper="2" effort="100" velocity="10"/>' if kind in ("revolute", "prismatic") else ""
        parts.append(f'<link name="link{i}">{_inertial(rng)}</link>')
        parts.append(
            f'<joint name="joint{i}" type="{kind}"><parent link="link{parent}"/><child link="link{i}"/>'
            f"{_origin(rng.uniform(-0.5, 0.5, 3), rng.uniform(-np.pi, np.pi, 3))}"
            f'<axis xyz="{axis[0]:.17g} {axis[1]:.17g} {axis[2]:.17g}"/>{limit}</joint>'
        )
    parts.append("</robot>")
    return "\n".join(parts)


def pendulum_chain_urdf(n: int = 5, length: float = 0.5, mass: float = 1.0) -> str:
    """n identical rods hanging from a world-fixed base, revolute about y, each with its CoM at mid-length."""
    return rod_chain_urdf([mass] * n, length, izz=lambda m: 1e-6, name="pendulum_chain")


def rod_chain_urdf(masses, length=0.5, offsets=None, izz=lambda m: m * 1e-4, name="chain") -> str:
    """A chain of rods hanging from a world-fixed base, hinges about y; rod i has mass masses[i] (CoM at
    mid-length, rod inertia about x and y, izz(mass) about z: 1e-4 m^2 times its mass by default); joint i
    sits at offsets[i] along z of its parent (default 0 for the first, -length for the others)."""
    parts = [f'<robot name="{name}">', '<link name="world"/>', '<link name="base"/>',
             '<joint name="world_to_base" type="fixed"><parent link="world"/><child link="base"/></joint>']
    parent = "base"
    for i, mass in enumerate(masses):
        I = mass * length**2 / 12.0
        z = (0.0 if i == 0 else -length) if offsets is None else offsets[i]
        parts.append(
            f'<link name="rod{i}"><inertial><origin xyz="0 0 {-length / 2}"/><mass value="{mass:.17g}"/>'
            f'<inertia ixx="{I:.17g}" iyy="{I:.17g}" izz="{izz(mass):.17g}" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        )
        parts.append(
            f'<joint name="hinge{i}" type="continuous"><parent link="{parent}"/><child link="rod{i}"/>'
            f'<origin xyz="0 0 {z}"/><axis xyz="0 1 0"/></joint>'
        )
        parent = f"rod{i}"
    parts.append("</robot>")
    return "\n".join(parts)


def _strip_geometry(urdf_text: str, considered_joints, keep_collision=None) -> str:
    """The URDF without visual elements, nor collision elements (but those for which keep_collision(element)
    is true, when given), non-considered movable joints made fixed (at 0)."""
    root = ET.fromstring(urdf_text)
    for link in root.findall("link"):
        for visual in link.findall("visual"):
            link.remove(visual)
        for collision in link.findall("collision"):
            if keep_collision is None or not keep_collision(collision):
                link.remove(collision)
    if considered_joints is not None:
        keep = set(considered_joints)
        for joint in root.findall("joint"):
            if joint.get("type") not in ("fixed", "floating") and joint.get("name") not in keep:
                joint.set("type", "fixed")
    for element in root.findall("gazebo") + root.findall("transmission"):
        root.remove(element)
    return ET.tostring(root, encoding="unicode")


def mujoco_spec(urdf_text: str, considered_joints=None, floating: bool = True, fuse_static: bool = True, keep_collision=None):
    """MuJoCo's spec of the robot as _strip_geometry leaves it: fixed links fused (as warpdyn lumps them)
    unless fuse_static is False (then every URDF link is a body), with a free joint when floating."""
    import mujoco

    spec = mujoco.MjSpec.from_string(_strip_geometry(urdf_text, considered_joints, keep_collision))
    spec.compiler.fusestatic = fuse_static
    if floating:
        spec.worldbody.first_body().add_freejoint()
    return spec


def mujoco_model(urdf_text: str, considered_joints=None, floating: bool = True, fuse_static: bool = True, keep_collision=None):
    """MuJoCo's model of the robot: mujoco_spec's, compiled."""
    return mujoco_spec(urdf_text, considered_joints, floating, fuse_static, keep_collision).compile()


class MujocoState:
    """MuJoCo's data for a warpdyn state of one environment (float64 NumPy)."""

    def __init__(self, mj_model, joint_names, floating: bool):
        import mujoco

        self.mujoco = mujoco
        self.m = mj_model
        self.d = mujoco.MjData(mj_model)
        self.floating = floating
        self.qpos_adr = np.array([mj_model.joint(name).qposadr[0] for name in joint_names], dtype=int)
        self.dof_adr = np.array([mj_model.joint(name).dofadr[0] for name in joint_names], dtype=int)

    def set(self, base_position, base_quaternion_wxyz, joint_positions, mixed_base_velocity, joint_velocities):
        """Set qpos/qvel; the base velocity is warpdyn's Mixed [W_pdot_B; W_omega_WB]."""
        d = self.d
        d.qpos[:] = 0.0
        d.qvel[:] = 0.0
        if self.floating:
            q = np.asarray(base_quaternion_wxyz, dtype=np.float64)
            d.qpos[0:3] = base_position
            d.qpos[3:7] = q
            R = rotation_wxyz(q)
            d.qvel[0:3] = mixed_base_velocity[:3]
            d.qvel[3:6] = R.T @ np.asarray(mixed_base_velocity[3:])
        d.qpos[self.qpos_adr] = joint_positions
        d.qvel[self.dof_adr] = joint_velocities
        self.mujoco.mj_forward(self.m, d)

    def has_body(self, name) -> bool:
        """False for a fixed base, which MuJoCo fuses into the world."""
        try:
            self.m.body(name)
        except KeyError:
            return False
        return True

    def body_pose(self, name):
        b = self.m.body(name).id
        return self.d.xpos[b].copy(), self.d.xmat[b].reshape(3, 3).copy()

    def body_jacobian_mixed(self, name) -> np.ndarray:
        """(6, 6 + n) Jacobian of the body frame: Mixed output, warpdyn's Mixed generalized velocity as input."""
        mujoco = self.mujoco
        b = self.m.body(name).id
        jacp, jacr = np.zeros((3, self.m.nv)), np.zeros((3, self.m.nv))
        mujoco.mj_jacBody(self.m, self.d, jacp, jacr, b)
        J_mj = np.vstack([jacp, jacr])
        n = len(self.dof_adr)
        J = np.zeros((6, 6 + n))
        if self.floating:
            R = rotation_wxyz(self.d.qpos[3:7])
            J[:, 0:3] = J_mj[:, 0:3]
            J[:, 3:6] = J_mj[:, 3:6] @ R.T
        J[:, 6:] = J_mj[:, self.dof_adr]
        return J

    def body_velocity_mixed(self, name) -> np.ndarray:
        """[W_pdot_L; W_omega_WL] of the body frame (mjOBJ_XBODY; mjOBJ_BODY is the inertial frame), reordered
        from MuJoCo's [angular; linear]."""
        res = np.zeros(6)
        self.mujoco.mj_objectVelocity(self.m, self.d, self.mujoco.mjtObj.mjOBJ_XBODY, self.m.body(name).id, res, 0)
        return np.concatenate([res[3:], res[:3]])


def rotation_wxyz(q) -> np.ndarray:
    w, x, y, z = np.asarray(q, dtype=np.float64) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def skew(v) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def motion_transform(R: np.ndarray, p) -> np.ndarray:
    """A_X_B (6, 6) for A_H_B = (R, p), [linear; angular]."""
    X = np.zeros((6, 6))
    X[:3, :3] = R
    X[:3, 3:] = skew(p) @ R
    X[3:, 3:] = R
    return X


def to_mixed(repr_name: str, R: np.ndarray, p) -> np.ndarray:
    """(6, 6) map from a frame's velocity in `repr_name` to its Mixed velocity (frame at (R, p) in W)."""
    if repr_name == "Mixed":
        return np.eye(6)
    if repr_name == "Body":
        return motion_transform(R, np.zeros(3))
    return motion_transform(np.eye(3), -np.asarray(p))


def from_mixed(repr_name: str, R: np.ndarray, p) -> np.ndarray:
    return np.linalg.inv(to_mixed(repr_name, R, p))


# ------------------------------------------------------------------------------------------------
# Simulation (tests/test_simulation.py, test_simulation_energy.py, test_simulation_extremes.py,
# test_actuation.py)

TEST_DEVICE = os.environ.get("WARPDYN_TEST_DEVICE", "cpu")
"""The device the suite runs on (tests/conftest.py makes it Warp's default)."""

SIE = wd.model.IntegratorType.SemiImplicitEuler
RK4 = wd.model.IntegratorType.RungeKutta4
G = 9.81

# A free body: principal axes along the link's axes, CoM at the link origin, no collision shape. Its moments
# violate the triangle inequality (0.02 + 0.05 < 0.08), so it loads with an UnphysicalInertiaWarning (ignored
# in pyproject.toml): kept because tests/test_simulation_extremes.py's documented drift figures are measured
# on it (a physical (0.03, 0.05, 0.08) drifts 0.9 % instead of 17.6 %).
BODY_INERTIA = np.diag([0.02, 0.05, 0.08])
BODY_URDF = """<robot name="body"><link name="body"><inertial><mass value="2"/>
<inertia ixx="0.02" iyy="0.05" izz="0.08" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>"""

# A 2 kg cube of side 0.2 m: 8 collidable points at its corners (JaxSim's box points).
BOX_MASS, BOX_HALF = 2.0, 0.1
BOX_URDF = """<robot name="box"><link name="box"><inertial><mass value="2"/>
<inertia ixx="0.013333333333333334" iyy="0.013333333333333334" izz="0.013333333333333334" ixy="0" ixz="0" iyz="0"/>
</inertial><collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision></link></robot>"""


def wheels_urdf(inertias, limits=None) -> str:
    """Wheels on a world-fixed base, each a joint about the world z axis through its CoM: gravity and
    Coriolis forces vanish and the mass matrix is diag(inertias), so sddot_i = tau_i / inertias[i]. The
    moments about x and y (max(0.1, I / 2), which no joint-space quantity reads) make each a physical inertia."""
    parts = ['<robot name="wheels">', '<link name="world"/>', '<link name="base"/>',
             '<joint name="world_to_base" type="fixed"><parent link="world"/><child link="base"/></joint>']
    for i, I in enumerate(inertias):
        kind, limit = "continuous", ""
        if limits is not None:
            kind, limit = "revolute", f'<limit lower="{limits[i][0]:.17g}" upper="{limits[i][1]:.17g}" effort="1" velocity="1"/>'
        parts.append(
            f'<link name="wheel{i}"><inertial><mass value="1"/>'
            f'<inertia ixx="{max(0.1, I / 2):.17g}" iyy="{max(0.1, I / 2):.17g}" izz="{I:.17g}" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        )
        parts.append(
            f'<joint name="axle{i}" type="{kind}"><parent link="base"/><child link="wheel{i}"/>'
            f'<origin xyz="{0.5 * i} 0 0"/><axis xyz="0 0 1"/>{limit}</joint>'
        )
    parts.append("</robot>")
    return "\n".join(parts)


def build(text, dtype, *, integrator=SIE, time_step=1e-3, **kwargs) -> wd.model.Model:
    """The model of `text` (a description, as Model.build_from_model_description takes it) with the given
    integrator and time step."""
    model = wd.model.Model.build_from_model_description(text, dtype=dtype, **kwargs)
    model.integrator = integrator
    model.time_step = time_step
    return model


def contact_free(model) -> wd.model.Model:
    """The model with joint friction off and every collidable point disabled (limit springs are off by
    default): a passive, conservative system."""
    n = model.dofs()
    model.set_joint_parameters(friction_static=np.zeros(n), friction_viscous=np.zeros(n))
    nc = len(model.kin_dyn_parameters.contact_parameters.body)
    return wd.contact.with_collidable_points(model, enabled=[False] * nc) if nc else model


def assert_transitions_equal_central(model, data, steps=(1,), h: float = 3e-7, rtol: float = 2e-6) -> None:
    """A and B of `steps` steps from `data` (wd.autodiff.transition_matrices, reverse mode) equal central differences
    of step h to rtol of their largest entry."""
    for count in steps:
        exact = wd.autodiff.transition_matrices(model, data, steps=count)
        central = wd.autodiff.transition_matrices(model, data, steps=count, method="central", h=h)
        for key in ("A", "B"):
            A, fd = exact[key].numpy(), central[key].numpy()
            assert np.abs(A - fd).max() <= rtol * np.abs(A).max(), (key, count)


def rollout(model, data, steps, record=None, **step_kwargs):
    """`steps` steps; returns (data, [record(data) after each step])."""
    out = []
    for _ in range(steps):
        data = wd.model.step(model, data, **step_kwargs)
        if record is not None:
            out.append(record(data))
    return data, out


def qmul(a, b) -> np.ndarray:
    """Hamilton product of (w, x, y, z) quaternions."""
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ])


def quat_distance(a, b) -> float:
    """max |a - b| up to the sign of the quaternion."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return min(np.abs(a - b).max(), np.abs(a + b).max())


def host(array) -> np.ndarray:
    """A Warp array as float64 NumPy."""
    return np.asarray(array.numpy(), dtype=np.float64)


def mujoco_rk4(text, floating, dt, considered_joints=None):
    """MuJoCo's model of `text` with RK4 at dt, constraints, damping and springs off."""
    import mujoco

    mj = mujoco_model(text, considered_joints, floating=floating)
    off = mujoco.mjtDisableBit
    mj.opt.disableflags |= off.mjDSBL_CONSTRAINT | off.mjDSBL_DAMPER | off.mjDSBL_SPRING
    mj.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    mj.opt.timestep = dt
    return mj


def mujoco_state(model, mj, data) -> MujocoState:
    state = MujocoState(mj, model.joint_names(), model.floating_base())
    state.set(host(data.base_position), host(data.base_quaternion), host(data.joint_positions),
              host(data.base_velocity), host(data.joint_velocities))
    return state


def jaxsim_resultant_torques(tau_ref, s, sdot, limits, k, d, kc, kv, a, friction=True):
    """JaxSim's compute_resultant_torques (/tmp/jaxsim_sim.md 3.2) in NumPy, elementwise."""
    tau_pl = -k * (np.minimum(s - limits[:, 0], 0.0) + np.maximum(s - limits[:, 1], 0.0))
    tau_pl = tau_pl - tau_pl * d * sdot  # jnp.positive is the identity: damping times the spring torque
    tau_fr = -(kc * np.sign(sdot) + kv * sdot) if friction else 0.0
    total = tau_ref + tau_fr + tau_pl
    speed = np.abs(sdot)
    limit = np.where(speed <= a.omega_th, a.torque_max,
                     np.where(speed <= a.omega_max, a.torque_max * (1 - (speed - a.omega_th) / (a.omega_max - a.omega_th)), 0.0))
    return np.clip(total, -limit, limit)


# ------------------------------------------------------------------------------------------------
# The seed's ergoCub with collidable points (tests/test_contact_geometry.py, test_contact_derivatives.py)

NO_MESH = wd.contact.CollidablePointsOptions(shapes=("box", "sphere", "cylinder", "capsule"))


@functools.cache
def ergocub_full_model(dtype):
    return wd.model.Model.build_from_model_description(ergocub_urdf(), dtype=dtype)


@functools.cache
def ergocub_seed_model(dtype):
    full = ergocub_full_model(dtype)
    return wd.model.reduce(full, seed_joints(full.joint_names()))


def ergocub_seed_with_points(dtype, options=NO_MESH):
    """The seed's reduced ergoCub with points made with `options` (no mesh by default: no warning)."""
    return wd.contact.with_collidable_points(ergocub_seed_model(dtype), options=options)


def random_state_kwargs(model, rng, num_envs=None, z_range=(-1.0, 1.0)):
    """Data.build's keyword arguments for a random state: a floating base anywhere in [-1, 1]^3 (z in
    z_range) with a random orientation and velocity (Mixed, in [-1, 1]), a fixed base where the model
    welds it, at rest; joints uniform within their limits (+-pi where unlimited), speeds in [-1, 1].
    (N, ...) arrays when num_envs is given."""
    N = 1 if num_envs is None else num_envs
    n = model.dofs()
    if model.floating_base():
        p = rng.uniform(-1.0, 1.0, size=(N, 3))
        p[:, 2] = rng.uniform(*z_range, size=N)
        q = rng.normal(size=(N, 4))
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        lin, ang = rng.uniform(-1.0, 1.0, size=(N, 3)), rng.uniform(-1.0, 1.0, size=(N, 3))
    else:
        H = model.description.world_H_base
        p, q = np.tile(H[:3, 3], (N, 1)), np.tile(wd.data._quaternion_wxyz(H[:3, :3]), (N, 1))
        lin, ang = np.zeros((N, 3)), np.zeros((N, 3))
    low, high = model.tree.position_limits.T
    s = rng.uniform(np.where(np.isfinite(low), low, -np.pi), np.where(np.isfinite(high), high, np.pi), size=(N, n))
    state = dict(base_position=p, base_quaternion=q, joint_positions=s, base_linear_velocity=lin,
                 base_angular_velocity=ang, joint_velocities=rng.uniform(-1.0, 1.0, size=(N, n)))
    return state if num_envs is not None else {k: v[0] for k, v in state.items()}


# ------------------------------------------------------------------------------------------------
# Robots by case name (tests/test_model.py, test_model_mjcf.py)


@functools.cache
def text_of(case: str) -> str:
    """A description by case name: 'random-<seed>', 'randomfixed-<seed>' (random_tree_urdf, fixed
    base), 'pendulum-<n>', 'icub', 'ergocub'."""
    kind, _, arg = case.partition("-")
    return {
        "random": lambda: random_tree_urdf(int(arg)),
        "randomfixed": lambda: random_tree_urdf(int(arg), fixed_base=True),
        "pendulum": lambda: pendulum_chain_urdf(int(arg)),
        "icub": icub_urdf,
        "ergocub": ergocub_urdf,
    }[kind]()


def case_source(case: str) -> tuple[str, tuple[str, ...] | None]:
    """(URDF text, considered joints or None) by case name: text_of's, but 'icublegs' (the iCub's legs) and
    'ergocub' reduced to the seed's joints."""
    if case == "icublegs":
        return icub_legs_source()
    if case == "ergocub":
        return ergocub_seed_source()
    return text_of(case), None


@functools.cache
def full_model(case: str, dtype=np.float64) -> wd.model.Model:
    return wd.model.Model.build_from_model_description(text_of(case), dtype=dtype)


def considered_of(case: str, which: str | None):
    names = full_model(case).joint_names()
    return {None: None, "legs": icub_leg_joints(names), "seed": seed_joints(names)}[which]


def built(case, which, dtype=np.float64) -> wd.model.Model:
    considered = considered_of(case, which)
    full = full_model(case, dtype)
    return full if considered is None else wd.model.reduce(full, considered)

def rng_for(*key) -> np.random.Generator:
    return np.random.default_rng(zlib.crc32(repr(key).encode()))


def uniform_state_kwargs(model, rng, num_envs=None) -> dict:
    """Data.build's keyword arguments for a random state: joints in [-2, 2], speeds in [-1, 1]; a floating
    base in [-1, 1]^3 raised 0.5 in z, any orientation, velocities in [-1, 1]. (N, ...) arrays when num_envs
    is given."""
    N = 1 if num_envs is None else num_envs
    n = model.dofs()
    kwargs = dict(joint_positions=rng.uniform(-2.0, 2.0, (N, n)), joint_velocities=rng.uniform(-1.0, 1.0, (N, n)))
    if model.floating_base():
        q = rng.normal(size=(N, 4))
        kwargs.update(
            base_position=rng.uniform(-1.0, 1.0, (N, 3)) + [0.0, 0.0, 0.5],
            base_quaternion=q / np.linalg.norm(q, axis=1, keepdims=True),
            base_linear_velocity=rng.uniform(-1.0, 1.0, (N, 3)),
            base_angular_velocity=rng.uniform(-1.0, 1.0, (N, 3)),
        )
    if num_envs is None:
        kwargs = {k: v[0] for k, v in kwargs.items()}
    return kwargs


def random_data(model, rng):
    """Data with a random state, and the stored state (float64) to hand to MuJoCo."""
    n = model.dofs()
    kwargs = dict(joint_positions=rng.uniform(-2.0, 2.0, n), joint_velocities=rng.uniform(-1.0, 1.0, n))
    if model.floating_base():
        q = rng.normal(size=4)
        kwargs.update(
            base_position=rng.uniform(-1.0, 1.0, 3),
            base_quaternion=q / np.linalg.norm(q),
            base_linear_velocity=rng.uniform(-1.0, 1.0, 3),
            base_angular_velocity=rng.uniform(-1.0, 1.0, 3),
        )
    data = wd.data.Data.build(model, **kwargs)
    f64 = lambda a: np.asarray(a.numpy(), dtype=np.float64)  # noqa: E731
    state = (
        f64(data.base_position),
        f64(data.base_quaternion),
        f64(data.joint_positions),
        f64(data.base_velocity_state)[0],  # Mixed
        f64(data.joint_velocities),
    )
    return data, state


def H_of(R, p) -> np.ndarray:
    H = np.eye(4)
    H[:3, :3], H[:3, 3] = R, p
    return H


def assert_close(actual, expected, tol, what):
    actual, expected = np.asarray(actual, dtype=np.float64), np.asarray(expected, dtype=np.float64)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    scale = max(1.0, np.abs(expected).max(initial=0.0))
    err = np.abs(actual - expected).max(initial=0.0)
    assert np.isfinite(err) and err <= tol * scale, f"{what}: max error {err:.3e} > {tol:.0e} * {scale:.3g}"
