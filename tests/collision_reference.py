"""MuJoCo's contacts of one pair of geoms at many poses, the reference of tests/test_collision_primitives.py and
test_collision_box.py: geom1 on a mocap body, geom2 on a free body, posed through mocap_pos, mocap_quat and qpos."""

import mujoco
import numpy as np


def posed_contacts(m: mujoco.MjModel, rng: np.random.Generator, poses) -> tuple:
    """(xpos (n, 2, 3), xmat (n, 2, 3, 3), contacts): for each (p_local, q_local) of `poses` (geom2's pose relative to
    geom1's), geom1 at a random pose (a random unit quaternion, a position uniform in [-1, 1]^3), MuJoCo's world poses
    of the two geoms and its contacts (positions (k, 3), frames (k, 3, 3), distances (k,)) after mj_collision."""
    d = mujoco.MjData(m)
    xpos, xmat, contacts = [], [], []
    for p_local, q_local in poses:
        q1 = rng.normal(size=4)
        q1 /= np.linalg.norm(q1)
        p1 = rng.uniform(-1, 1, size=3)
        R1 = np.empty(9)
        mujoco.mju_quat2Mat(R1, q1)
        d.mocap_pos[0] = p1
        d.mocap_quat[0] = q1
        d.qpos[:3] = p1 + R1.reshape(3, 3) @ np.asarray(p_local, dtype=float)
        mujoco.mju_mulQuat(d.qpos[3:7], q1, np.asarray(q_local, dtype=float))
        mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
        con = d.contact[: d.ncon]
        assert all(tuple(c.geom) == (0, 1) for c in con)  # geom1 = the mocap body's, in MuJoCo's order
        xpos.append(d.geom_xpos.copy())
        xmat.append(d.geom_xmat.reshape(2, 3, 3).copy())
        contacts.append((np.array([c.pos for c in con]).reshape(-1, 3), np.array([c.frame for c in con]).reshape(-1, 3, 3), np.array([c.dist for c in con])))
    return np.array(xpos), np.array(xmat), contacts
