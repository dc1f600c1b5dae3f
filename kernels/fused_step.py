"""A semi-implicit Euler step in one kernel, for launches that no tape records.

One thread per environment runs what warpdyn.engine.step otherwise launches as seven to nine kernels (the
joint forces, FK, link velocities, the contact forces of the points and their sums per link, ABA, the
integrator), from the state x. It walks the tree in depth-first order (`walk`), so that most links follow
their parent:
1. from the base: the link poses W_H_i and velocities v_i (link coordinates); the joint forces tau_i
   (written to the controls' joint forces); the external force f_i on each link (the contact forces of its
   enabled points, plus the given Inertial link force and its passive force), the tangential deformation
   integrated, m+ = m + dt m_dot; c_i and the bias force v_i x* I_i v_i - f_i;
2. from the leaves: ABA's articulated inertias and bias forces, a link's terms summed into its parent's;
3. from the base: ABA's accelerations, the joints integrated; then the base (kernels/integrators.py's
   functions) and the health check: a flagged environment keeps its state (rewritten over what 1 and 3
   wrote) and gets valid = 0.
What a link hands to the next link of the walk (its pose and velocity, its articulated terms for its parent, its
acceleration) stays in registers when that link is its child, the first one; a link with more children keeps it in
a slot for the others (`walk`). The base's slot, when it has one, also holds its pose, velocity and own bias force
for its children, and pass 3 computes its pose and velocity from x again: live in registers through passes 1 and 2,
they made float64 spill (benchmarks/results/performance_rounds.md, round 14). The walk comes in groups of the base's subtrees
(warpdyn.engine.fused_layout): one thread walks them all, or `lanes` threads of one block walk a group each, side
by side (for few environments: a step's chain of dependent operations is shorter), each computing the base alike;
they sum their terms of the base's articulated inertia and bias force, then their health checks, through a tile.
What one pass hands to the next per link (the bias force then U_i / d_i, u_i / d_i, c_i: RECORD numbers, its
record) stays on the chip instead of in arrays in global memory, and is read and written once per step: in the
thread's local memory, or in the block's shared memory (`shared_block`; warpdyn.engine.fused_layout's
`shared_records`), where the loads of the state, which share the L1 cache with local memory, do not evict it
(benchmarks/results/performance_rounds.md, round 12). The joint positions, velocities and force references are not kept there: passes
1 and 3 load link k + 1's while link k is computed (pass 2 reads the positions again), so that the local arrays
fill less of the L1 cache (benchmarks/results/performance_rounds.md, round 10). Likewise what pass 3 needs of a link is loaded while
the link before it is computed, and so are, in float32, the joint terms in pass 1 (in float64 that spills
registers: round 13); pass 2 loads a link's joint terms first and computes its joint transform last, so that its
articulated terms' arithmetic covers the loads and the transform is not live across it (round 14); and the contact
points' states ahead of their use: in float32 two points per iteration, their chains side by side, while the next
two are loaded; in float64 one at a time, two points ahead (pairs make float64 spill registers). Pass 2 sums the
articulated inertias as their 21 numbers (symmetric: fewer registers than 6x6 sums). The kernel has no grid-stride
loop (a thread per environment or lane: fewer registers; float64 spills less). The joint transforms lambda(i)_H_i
are either kept from pass 1 (7 numbers more per link; `keep_joint_transforms`) or rebuilt in passes 2 and 3 from
the joint positions (their sines and cosines again: cheaper on a GPU once the environments' local arrays outgrow
its caches than keeping either the transforms or their joints' 4 coefficients; benchmarks/results/performance_rounds.md, rounds 8 and
9). The records are kernels/scratch.py's, as vectors. The local arrays' sizes are the model's numbers of links and
slots, so one kernel serves the models of those sizes (`kernel`); the passes' loops over links are not unrolled
(unrolled, a model took tens of seconds to compile on an H100: benchmarks/results/performance_rounds.md, round 3).

Each formula is a building block the staged kernels use too: the joint forces (kernels/actuation.py's
`joint_force`), the joint transforms, link velocities and velocity products (kernels/joints.py), the passive
link forces (kernels/forces.py's `passive_link_wrench`), the per-point contact law (`law_parameters` and
`contact_at` of warpdyn.engine.contact_stage's `point_law`), ABA's terms (kernels/aba.py's `inertia_funcs`: bias
forces, the base's articulated inertia and bias force with its free-joint rotor, `articulated`, the
accelerations) and the integration (kernels/integrators.py's `euler_coordinate`, `euler_rate`,
`euler_base_from`). What is its own is the order of the work (the walk, the records on the chip, the loads
ahead), and the sum of a link's contact forces about its origin, in world axes (short lever arms) rather than
Inertial wrenches about the world's origin.

Forward only: the module has no backward pass. Its models' joints have one DoF each, or are free joints below a
fixed base (`free_roots`: a scene's free bodies and floating robots below its world; kernels/joints.py's
multi-DoF variant, for the joints' addresses). A free joint's parent is then still, so pass 2 solves its six
DoFs at once when it reaches it (kernels/aba.py's `free_joint_acceleration`: its accelerations go to its
record's U_i / d_i and c_i for pass 3) and hands nothing to the base. warpdyn.engine.step's Plan chooses it for
those models alone. Under a tape, with gradients, for RK4 and for ball joints or free joints below a moving link,
a step is warpdyn.engine.step's launch list, whose numbers these equal to rounding (tests/test_fused_step.py).
"""


import warp as wp

from ..engine import warp_private
from .aba import inertia_funcs
from .actuation import joint_force
from .bundles import bundles
from .factory import factory
from .forces import kernels as force_funcs
from .integrators import kernels as integrator_funcs
from .joints import joints
from .scratch import SYM66, TRANSFORM, scratch
from .spatial import FREE, INERTIAL, MIXED, spatial

BASE = wp.constant(-2)
"""In a walk, a link's parent slot when its parent is the base (the first link of a group)."""

RECORD = wp.constant(13)
"""The numbers a link's passes hand to each other, its record: the bias force then U_i / d_i (6), at 0; u_i / d_i
(1), at UD_AT; c_i (6), at C_AT."""

UD_AT = wp.constant(6)
C_AT = wp.constant(7)
"""Where u_i / d_i and c_i are in a link's record (`RECORD`); a record without c_i has C_AT numbers."""


def shared_numbers(links: int, block: int, shared_c: bool = True) -> int:
    """The numbers a block of `block` threads keeps in shared memory for a model of `links` links: each link's
    record, without c_i unless shared_c (`kernel`)."""
    return (RECORD if shared_c else C_AT) * links * block


def unfilled(scalar, *shape: int) -> str:
    """A native snippet that returns a local Warp vector (shape (n,)) or matrix (rows, cols) of `scalar` whose
    numbers nothing has written. Warp's constructors write zeros first, which a record that each pass writes before
    a pass reads it does not need: in float64 on a GPU, the 78 zeros of c (local memory) stalled the start of a step
    (benchmarks/results/performance_rounds.md, round 15). The union's other member is the one its constructor sets."""
    cpp = warp_private.native_name(wp.types.vector(shape[0], scalar) if len(shape) == 1 else wp.types.matrix(shape, scalar))
    return f"""
    union Unfilled {{ {cpp} value; unsigned char none; CUDA_CALLABLE Unfilled() : none(0) {{}} }} unfilled;
    return unfilled.value;"""


@factory
def kernel(scalar, links: int, slots: int, so3: bool, actuation: tuple | None, point_law, terrain_kind: int | None, passive: bool, free_roots: bool, keep_joint_transforms: bool, lanes: int = 1, shared_block: int = 0, shared_c: bool = True):
    """The fused step in `scalar` for models of `links` links whose walk has `slots` slots (local arrays of those
    sizes; at least 1), with MuJoCo's base step (so3) or JaxSim's, the joint forces of kernels/actuation.py's
    `joint_force(scalar, *actuation)` (None: a model without joints), the contacts of the per-point law
    `point_law(scalar, terrain_kind)` (a kind of terrain, or None: any; warpdyn.engine.contact_stage's
    `point_law`: kernels/soft_contacts.py's `kernels`, whose `law_parameters`, `contact_at` and
    `height_parameter` it calls), the links' passive forces (gravity
    compensation, a floating base's free-joint damper and spring: kernels/forces.py's `passive_link_wrench`) when
    `passive`, for models whose joints have one DoF each or (free_roots) are free joints below a fixed base
    (a scene's free bodies and floating robots: kernels/aba.py's `free_joint_acceleration`), keeping the joint transforms of pass 1 for
    passes 2 and 3 or recomputing them; one thread per environment (lanes 1, launched over N), or `lanes`
    threads per environment, one per group of the walk (launched over (N, lanes) in blocks of `lanes`); the
    links' records in each thread's local memory (shared_block 0), or, for launches in blocks of `shared_block`
    threads, one thread per environment, in the block's shared memory (CUDA only; within CUDA's 48 KiB of static
    shared memory: `shared_numbers(links, shared_block, shared_c)` numbers): the whole record, or without c_i
    (not shared_c: the bias force then U_i / d_i, and u_i / d_i, C_AT numbers per link; c_i in local memory)."""
    sp = spatial(scalar)
    B = bundles(scalar)
    FREE_ROOTS = free_roots
    jm = joints(scalar, FREE_ROOTS)
    I = integrator_funcs(scalar, FREE_ROOTS)
    C = point_law(scalar, terrain_kind)
    F = inertia_funcs(scalar)
    inertia_to, articulated = F.inertia_to, F.articulated
    passive_link_wrench = force_funcs(scalar).passive_link_wrench
    PASSIVE = passive
    SO3 = wp.constant(int(so3))
    KEEP = keep_joint_transforms
    PAIRS = scalar == wp.float32  # contact points two at a time (in float64 that spills: performance_rounds.md, round 10)
    TERMS_AHEAD = scalar == wp.float32  # pass 1 loads link k + 1's joint terms ahead (in float64 that spills: performance_rounds.md, round 13)
    ACTUATED = actuation is not None
    resultant_torque = joint_force(scalar, *(actuation or (False, False)), multi_dof=FREE_ROOTS)
    LANES = lanes
    base_terms = wp.types.vector(SYM66 + 6, scalar)
    links6 = wp.types.matrix((links, 6), scalar)
    links7 = wp.types.matrix((links, TRANSFORM), scalar)
    per_link = wp.types.vector(links, scalar)
    slots6 = wp.types.matrix((slots, 6), scalar)
    slots7 = wp.types.matrix((slots, TRANSFORM), scalar)
    slots21 = wp.types.matrix((slots, SYM66), scalar)
    sym21 = wp.types.vector(SYM66, scalar)
    sc = scratch(scalar)

    @wp.func_native(unfilled(scalar, links, TRANSFORM))
    def links7_unfilled() -> links7:
        """A links7 whose numbers nothing has written (`unfilled`)."""

    @wp.func_native(unfilled(scalar, links, 6))
    def links6_unfilled() -> links6:
        """A links6 whose numbers nothing has written (`unfilled`)."""

    @wp.func_native(unfilled(scalar, links))
    def per_link_unfilled() -> per_link:
        """A per_link whose numbers nothing has written (`unfilled`)."""

    pack7, unpack7, pack21, unpack21 = sc.pack_transform, sc.unpack_transform, sc.pack_sym66, sc.unpack_sym66
    if shared_block and lanes != 1:
        raise ValueError(f"the fused step keeps its records in shared memory on one thread per environment, not {lanes} lanes")
    SHARED = shared_block
    C_SHARED = bool(SHARED) and shared_c
    PER_LINK = RECORD if C_SHARED else C_AT  # a link's shared numbers
    if SHARED:
        code = f"""
        __shared__ {"float" if scalar == wp.float32 else "double"} records[{shared_numbers(links, SHARED, shared_c)}];
        const int at = k * {SHARED} + threadIdx.x;
        if (store) records[at] = value;
        return records[at];"""

        @wp.func_native(code)
        def shared_record(k: int, value: scalar, store: int) -> scalar:
            """This thread's record number k in its block's shared memory: `value` stored there first when
            `store`. Record k of the block's thread t is element k * SHARED + t (consecutive threads, consecutive
            banks)."""

        @wp.func
        def put6(k: int, v: sp.vec6):
            """v as this thread's shared records k to k + 5."""
            for a in range(6):
                shared_record(k + a, v[a], 1)

        @wp.func
        def get6(k: int):
            """This thread's shared records k to k + 5."""
            z = scalar(0.0)
            return sp.vec6(shared_record(k, z, 0), shared_record(k + 1, z, 0), shared_record(k + 2, z, 0), shared_record(k + 3, z, 0), shared_record(k + 4, z, 0), shared_record(k + 5, z, 0))

    @wp.func
    def point_state(contacts: B.Contacts, x: B.State, env: int, c: int):
        """(enabled point c's position on its link L_p_C, its contact-state row, its tangential deformation m at x)."""
        row = contacts.point_row[c]
        m = x.tangential_deformation
        return B.vec3_parameter(contacts.L_p_C, env, c), row, sp.vec3(m[env, row, 0], m[env, row, 1], m[env, row, 2])

    @wp.func
    def point_force(contacts: B.Contacts, terrain: B.Terrain, h0: scalar, law: sp.vec3, dt: scalar, env: int, c: int, row: int,
                    L_p_C: sp.vec3, m: sp.vec3, W_R_L: sp.mat33, W_o_L: sp.vec3, W_v_o: sp.vec3, W_omega: sp.vec3, write: bool,
                    y: B.State, W_f_C: wp.array3d(dtype=scalar)):
        """(f, r, 0 x m+): enabled point c's contact force f [N, world axes], the point from its link's origin r
        [m, world axes], and the health check's term of its m+ = m + dt m_dot (NaN when not finite), for a link
        at W_o_L with the rotation W_R_L, its origin's velocity W_v_o and angular velocity W_omega (world axes).
        When `write`: m+ goes to y's contact-state row `row`, the Inertial wrench to W_f_C unless that is empty."""
        r = W_R_L * L_p_C
        p = W_o_L + r
        f, m_dot = C.contact_at(contacts, terrain, h0, law, p, W_v_o + wp.cross(W_omega, r), m)
        bad = scalar(0.0)
        if write:
            if W_f_C.shape[0] > 0:
                w = sp.stack(f, wp.cross(p, f))
                for a in range(6):
                    W_f_C[env, c, a] = w[a]
            for a in range(3):
                m_next = I.euler_rate(m[a], m_dot[a], dt)
                bad = I.poison(bad, m_next)
                y.tangential_deformation[env, row, a] = m_next
        return f, r, bad

    @wp.func
    def external_force(model: B.Model, contacts: B.Contacts, terrain: B.Terrain, controls: B.Controls, env: int, L: int, W_H_L: sp.transform,
                       v_L: sp.vec6, h0: scalar, law: sp.vec3, dt: scalar, x: B.State, y: B.State, W_f_C: wp.array3d(dtype=scalar)):
        """(the external force on link L in its own coordinates, 0 or NaN): the contact forces of its enabled
        points (at the pose W_H_L, velocity v_L in link coordinates) plus the given Inertial link force if any,
        plus its passive force (kernels/forces.py's `passive_link_wrench`) in a kernel made `passive`.
        Writes each point's m+ = m + dt m_dot into y, and its Inertial wrench into W_f_C unless that is empty;
        the second value is 0 x the sum of the m+, NaN when one is not finite (the health check's). A link
        without points or a given force costs two loads. The points are placed with the link's rotation matrix
        W_R_L, their velocities from the link origin's, their moments summed about the link's origin (not the
        world's: short lever arms, whatever the robot's distance from the origin)."""
        L_f = sp.vec6(scalar(0.0))
        if wp.static(PASSIVE):
            L_f = sp.force_from(W_H_L, passive_link_wrench(model, env, L, W_H_L, v_L))
        nonfinite = scalar(0.0)
        count = contacts.link_point_count[L]
        if controls.link_forces.shape[0] == 0 and count == 0:
            return L_f, nonfinite
        if controls.link_forces.shape[0] > 0:
            L_f = L_f + sp.force_from(W_H_L, B.link_force(controls, env, L))
        if count > 0:
            first = contacts.link_first_point[L]
            last = first + count - 1
            W_R_L = wp.quat_to_matrix(wp.transform_get_rotation(W_H_L))
            W_o_L = wp.transform_get_translation(W_H_L)
            W_v_o = W_R_L * sp.lin(v_L)  # the link origin's velocity, world axes
            W_omega = W_R_L * sp.ang(v_L)
            W_f = sp.vec3(scalar(0.0))  # the points' forces, and their moments about the link's origin, world axes
            W_tau = sp.vec3(scalar(0.0))
            if wp.static(PAIRS):
                # two points per iteration, their chains side by side; the next two loaded meanwhile
                a_p, a_row, a_m = point_state(contacts, x, env, first)
                b_p, b_row, b_m = point_state(contacts, x, env, wp.min(first + 1, last))
                for pair in range((count + 1) // 2):
                    c = first + 2 * pair
                    p0 = a_p
                    row0 = a_row
                    m0 = a_m
                    p1 = b_p
                    row1 = b_row
                    m1 = b_m
                    a_p, a_row, a_m = point_state(contacts, x, env, wp.min(c + 2, last))
                    b_p, b_row, b_m = point_state(contacts, x, env, wp.min(c + 3, last))
                    two = c + 1 <= last  # else the second is the first again: not summed, not written (bad1 is 0)
                    f0, r0, bad0 = point_force(contacts, terrain, h0, law, dt, env, c, row0, p0, m0, W_R_L, W_o_L, W_v_o, W_omega, True, y, W_f_C)
                    f1, r1, bad1 = point_force(contacts, terrain, h0, law, dt, env, c + 1, row1, p1, m1, W_R_L, W_o_L, W_v_o, W_omega, two, y, W_f_C)
                    if not two:
                        f1 = sp.vec3(scalar(0.0))
                    W_f = W_f + f0 + f1
                    W_tau = W_tau + wp.cross(r0, f0) + wp.cross(r1, f1)
                    nonfinite = nonfinite + bad0 + bad1
            else:
                # two points ahead: the state of point c + 2 (the last's again near the end) is loaded while point
                # c is computed, so that a load from memory has two points' work to arrive
                next_p, next_row, next_m = point_state(contacts, x, env, first)
                then_p, then_row, then_m = point_state(contacts, x, env, wp.min(first + 1, last))
                for c in range(first, last + 1):
                    L_p_C = next_p
                    row = next_row
                    m = next_m
                    next_p = then_p
                    next_row = then_row
                    next_m = then_m
                    then_p, then_row, then_m = point_state(contacts, x, env, wp.min(c + 2, last))
                    f, r, bad = point_force(contacts, terrain, h0, law, dt, env, c, row, L_p_C, m, W_R_L, W_o_L, W_v_o, W_omega, True, y, W_f_C)
                    W_f = W_f + f
                    W_tau = W_tau + wp.cross(r, f)
                    nonfinite = nonfinite + bad
            L_f = L_f + sp.stack(W_f * W_R_L, W_tau * W_R_L)  # (W_R_L^T W_f, W_R_L^T W_tau)
        return L_f, nonfinite

    @wp.func
    def join_terms(IA: sym21, pA: sp.vec6):
        """(IA's 21 numbers then pA's 6): a base's terms as one vector, for a tile."""
        out = base_terms()
        for a in range(SYM66):
            out[a] = IA[a]
        for a in range(6):
            out[SYM66 + a] = pA[a]
        return out

    @wp.func
    def sym21_of(terms: base_terms):
        out = sym21()
        for a in range(SYM66):
            out[a] = terms[a]
        return out

    @wp.func
    def vec6_of(terms: base_terms):
        return sp.vec6(terms[SYM66], terms[SYM66 + 1], terms[SYM66 + 2], terms[SYM66 + 3], terms[SYM66 + 4], terms[SYM66 + 5])

    @wp.kernel(module="unique", module_options={"enable_backward": False}, grid_stride=False)
    def fused_euler_step(
        model: B.Model,
        contacts: B.Contacts,
        terrain: B.Terrain,
        x: B.State,
        controls: B.Controls,
        torque_max: scalar,
        omega_th: scalar,
        omega_max: scalar,
        tau_ref: wp.array2d(dtype=scalar),
        ctrl: wp.array2d(dtype=scalar),
        walk: wp.array(dtype=wp.vec3i),
        starts: wp.array(dtype=wp.int32),
        dt: scalar,
        quaternion_tolerance: scalar,
        divergence_speed: scalar,
        implicit_dt: scalar,
        # outputs: the state at t + dt; the link poses and the points' contact wrenches at x (or empty: none)
        y: B.State,
        W_H_L: wp.array2d(dtype=sp.transform),
        W_f_C: wp.array3d(dtype=scalar),
    ):
        """One semi-implicit Euler step from x to y with soft contacts and ABA.

        walk (nL,): the links in depth-first order, the base first, each as (i, its slot or -1, its parent's
        slot, or -1 when the parent is the link before it in the walk, BASE for a group's first link); starts
        (G + 1,): where each group begins in the walk, then nL (warpdyn.engine.fused_layout's `fused_walk`; G
        is `lanes` when lanes > 1; a single thread walks the groups one after the other).
        W_H_L (N, nL): the link poses at x, as kernels/kinematics.py's forward_kinematics writes them, and
        W_f_C (N, P, 6): the Inertial wrench of each enabled point's contact force at x, as
        kernels/soft_contacts.py's point_contact_forces writes it; each when not empty.
        controls: the joint forces tau (N, n), an output (none without joints), and the Inertial link forces
        (N, nL, 6) (or none); tau from the joint force references tau_ref (N, n), the actuators' controls ctrl
        (N, na) and the torque-speed curve (torque_max, omega_th, omega_max), as the actuation kernel's.
        implicit_dt: dt for MuJoCo's implicit joint damping in ABA's joint inertia, else 0.
        """
        if wp.static(LANES == 1):
            env = wp.tid()
            lane = 0
        else:
            env, lane = wp.tid()
        nl = model.parent.shape[0]
        law = C.law_parameters(contacts, env)
        h0 = C.height_parameter(terrain, env)
        W_H_B = B.base_pose(x, env)
        B_v = sp.motion_from(W_H_B, sp.repr_to_inertial(MIXED, W_H_B, B.base_velocity_mixed(x, env)))
        # a link's records, each written by a pass before a pass reads it
        X = links7_unfilled()  # lambda(i)_H_i, when kept
        c = links6_unfilled()  # c_i = v_i x S_i qd_i
        pU = links6_unfilled()  # pass 1: v_i x* I_i v_i - f_i; pass 2: U_i / d_i
        ud = per_link_unfilled()  # u_i / d_i
        slot_H = slots7()  # W_H_i of the links with slots
        slot_v = slots6()  # pass 1: their v_i; pass 3: their a'_i
        slot_IA = slots21()  # the sums of the articulated inertias and bias forces of their children but the first
        slot_pA = slots6()
        # 1. poses, velocities, external and bias forces, from the base (its own forces in lane 0)
        f_0 = sp.vec6(scalar(0.0))
        nonfinite = scalar(0.0)
        if lane == 0:
            f_0, nonfinite = external_force(model, contacts, terrain, controls, env, 0, W_H_B, B_v, h0, law, dt, x, y, W_f_C)
            if W_H_L.shape[0] > 0:
                W_H_L[env, 0] = W_H_B
        p_0 = F.base_bias_force(model, env, implicit_dt, B_v, B.gravity_in(model, env, W_H_B)) - f_0
        base_own = walk[0][1]
        if base_own >= 0:
            slot_H[base_own] = pack7(W_H_B)
            slot_v[base_own] = B_v
            if lane == 0:  # p_0 summed with the base's children's terms in pass 2, rather than live through it
                slot_pA[base_own] = p_0
        W_H_prev = W_H_B
        v_prev = B_v
        first = int(1)
        last = nl
        if wp.static(LANES > 1):
            first = starts[lane]
            last = starts[lane + 1]
        k_first = wp.max(wp.min(first, last - 1), 0)  # where the prefetches of passes 1 and 3 begin (valid if no link)
        # link k + 1's joint position, velocity and force reference are loaded while link k is computed
        has_joints = x.joint_positions.shape[1] > 0
        s_n = scalar(0.0)
        sd_n = scalar(0.0)
        ref_n = scalar(0.0)
        if has_joints:
            i_n = walk[k_first][0]
            j_n = wp.max(jm.dof_address(model, i_n), 0)
            s_n = x.joint_positions[env, wp.max(jm.position_address(model, i_n), 0)]
            sd_n = x.joint_velocities[env, j_n]
            ref_n = tau_ref[env, j_n]
        if wp.static(TERMS_AHEAD):
            jt_n, Q0_n, Q1_n, t0_n, t1_n, t2_n = jm.joint_terms_of(model, env, walk[k_first][0])
        for k in range(first, last):
            i = walk[k][0]
            own = walk[k][1]
            up = walk[k][2]
            s_i = s_n
            qd_i = sd_n
            ref_i = ref_n
            i_n = walk[wp.min(k + 1, last - 1)][0]
            j_n = jm.dof_address(model, i_n)
            s_n = x.joint_positions[env, jm.position_address(model, i_n)]
            sd_n = x.joint_velocities[env, j_n]
            ref_n = tau_ref[env, j_n]
            W_H_P = W_H_prev
            v_P = v_prev
            if up == BASE:
                up = base_own
            if up >= 0:
                W_H_P = unpack7(slot_H[up])
                v_P = slot_v[up]
            if wp.static(TERMS_AHEAD):
                X_i = jm.joint_transform_from(jt_n, Q0_n, Q1_n, t0_n, t1_n, t2_n, s_i)
                jt_n, Q0_n, Q1_n, t0_n, t1_n, t2_n = jm.joint_terms_of(model, env, walk[wp.min(k + 1, last - 1)][0])
            else:
                jt, Q0, Q1, t0, t1, t2 = jm.joint_terms_of(model, env, i)  # loaded first, as round 9 measured
                X_i = jm.joint_transform_from(jt, Q0, Q1, t0, t1, t2, s_i)
            if wp.static(FREE_ROOTS):
                free = model.joint_type[i] == FREE
                if free:
                    X_i = jm.joint_transform(model, i, x.joint_positions, env)
            if wp.static(KEEP):
                X[i] = pack7(X_i)
            W_H_i = W_H_P * X_i
            if W_H_L.shape[0] > 0:
                W_H_L[env, i] = W_H_i
            if wp.static(ACTUATED):
                j = jm.dof_address(model, i)
                controls.joint_forces[env, j] = resultant_torque(model, torque_max, omega_th, omega_max, env, i - 1, j, s_i, qd_i, ref_i, ctrl, x.joint_positions)
                if wp.static(FREE_ROOTS):
                    if free:  # its other 5 DoFs
                        for k in range(1, 6):
                            controls.joint_forces[env, j + k] = resultant_torque(
                                model, torque_max, omega_th, omega_max, env, i - 1, j + k, s_i, x.joint_velocities[env, j + k], tau_ref[env, j + k], ctrl,
                                x.joint_positions,
                            )  # fmt: skip
            S_qd = model.dof_S[jm.dof_address(model, i)] * qd_i
            if wp.static(FREE_ROOTS):
                if free:
                    S_qd = jm.joint_motion_of(model, i, X_i, x.joint_velocities, env)
            v_i = jm.link_velocity(X_i, v_P, S_qd)
            if own >= 0:
                slot_H[own] = pack7(W_H_i)
                slot_v[own] = v_i
            f_i, bad = external_force(model, contacts, terrain, controls, env, i, W_H_i, v_i, h0, law, dt, x, y, W_f_C)
            nonfinite = nonfinite + bad
            if wp.static(C_SHARED):
                put6(PER_LINK * i + C_AT, jm.velocity_product(model, i, v_i, S_qd))
            else:
                c[i] = jm.velocity_product(model, i, v_i, S_qd)
            if wp.static(SHARED):
                put6(PER_LINK * i, F.bias_force(v_i, B.spatial_inertia_times(model, env, i, v_i)) - f_i)
            else:
                pU[i] = F.bias_force(v_i, B.spatial_inertia_times(model, env, i, v_i)) - f_i
            W_H_prev = W_H_i
            v_prev = v_i
        # 2. articulated inertias and bias forces, from the leaves; a link's terms summed into its parent's: the
        # first child's in registers (the next link of the walk back), the others' in the parent's slot
        IA_next = sym21()
        pA_next = sp.vec6(scalar(0.0))
        for k in range(last - first):
            kk = last - 1 - k
            i = walk[kk][0]
            own = walk[kk][1]
            up = walk[kk][2]
            if wp.static(KEEP):
                X_i = unpack7(X[i])
            else:  # the joint's terms and position loaded now, its transform computed after `articulated`
                jt, Q0, Q1, t0, t1, t2 = jm.joint_terms_of(model, env, i)
                q_i = x.joint_positions[env, jm.position_address(model, i)]
            S = model.dof_S[jm.dof_address(model, i)]
            IA = pack21(B.spatial_inertia_of(model, env, i)) + IA_next  # summed as 21 numbers: symmetric, fewer registers
            if wp.static(SHARED):
                pA = get6(PER_LINK * i) + pA_next
            else:
                pA = pU[i] + pA_next
            if own >= 0:
                IA = IA + slot_IA[own]
                pA = pA + slot_pA[own]
            if wp.static(C_SHARED):
                c_i = get6(PER_LINK * i + C_AT)
            else:
                c_i = c[i]
            if wp.static(FREE_ROOTS):
                if model.joint_type[i] == FREE:  # below the fixed base: its accelerations now, for pass 3 (in U_i / d_i and c_i)
                    if wp.static(KEEP):
                        X_f = X_i
                    else:
                        X_f = jm.joint_transform(model, i, x.joint_positions, env)
                    a_f = F.link_acceleration(X_f, -B.gravity_in(model, env, B.base_pose(x, env)), c_i)
                    Ud_i, a_f = F.free_joint_acceleration(
                        model, controls, env, jm.dof_address(model, i), implicit_dt, jm.free_joint_rotation(model, i, X_f), unpack21(IA), pA, a_f
                    )
                    ud_i = scalar(0.0)
                    Ia = sp.mat66(scalar(0.0))  # nothing for the fixed base
                    pa = sp.vec6(scalar(0.0))
                    if wp.static(C_SHARED):
                        put6(PER_LINK * i + C_AT, a_f)
                    else:
                        c[i] = a_f
                else:
                    Ud_i, ud_i, Ia, pa = articulated(model, controls, env, jm.dof_address(model, i), implicit_dt, S, unpack21(IA), pA, c_i)
            else:
                Ud_i, ud_i, Ia, pa = articulated(model, controls, env, jm.dof_address(model, i), implicit_dt, S, unpack21(IA), pA, c_i)
            if wp.static(SHARED):
                put6(PER_LINK * i, Ud_i)
                shared_record(PER_LINK * i + UD_AT, ud_i, 1)
            else:
                pU[i] = Ud_i
                ud[i] = ud_i
            if wp.static(not KEEP):
                X_i = jm.joint_transform_from(jt, Q0, Q1, t0, t1, t2, q_i)
            IA_next = pack21(inertia_to(X_i, Ia))
            pA_next = sp.force_to(X_i, pa)
            if up == BASE:
                up = base_own
            if up >= 0:
                slot_IA[up] = slot_IA[up] + IA_next
                slot_pA[up] = slot_pA[up] + pA_next
                IA_next = sym21()
                pA_next = sp.vec6(scalar(0.0))
        # the base's articulated terms: its own in lane 0, its children's in the lanes that walk them, summed
        IA0 = unpack21(IA_next)
        pA0 = pA_next
        if base_own >= 0:
            IA0 = IA0 + unpack21(slot_IA[base_own])
            pA0 = pA0 + slot_pA[base_own]
        if lane == 0:
            IA0 = IA0 + F.base_inertia(model, env, implicit_dt)
            if base_own < 0:
                pA0 = pA0 + p_0
        if wp.static(LANES > 1):
            summed = wp.tile_extract(wp.tile_sum(wp.tile(join_terms(pack21(IA0), pA0), preserve_type=True)), 0)
            IA0 = unpack21(sym21_of(summed))
            pA0 = vec6_of(summed)
        # 3. accelerations, from the base; the joints integrated (written now: a flagged environment's state is
        # rewritten below)
        W_H_B = B.base_pose(x, env)  # again, rather than live in registers through passes 1 and 2
        B_v = sp.motion_from(W_H_B, sp.repr_to_inertial(MIXED, W_H_B, B.base_velocity_mixed(x, env)))
        B_a_g = B.gravity_in(model, env, W_H_B)
        a0 = F.base_acceleration(model, IA0, pA0, B_a_g)
        base = sp.vec6(scalar(0.0))
        if model.floating_base != 0:
            base = sp.base_acceleration_from_body(INERTIAL, W_H_B, B_v, a0 + B_a_g)
        if base_own >= 0:
            slot_v[base_own] = a0
        p_B, Q_B, pdot_B, omega_B, healthy = I.base_state(x, env)  # for 4., read now: its wait overlaps pass 3
        a_prev = a0
        # what link k + 1 needs (its walk entry, joint terms, motion subspace, and what passes 1 and 2 kept) is
        # loaded while link k is computed, so that its waits for memory overlap that work
        w_n = walk[k_first]
        i_n = w_n[0]
        if wp.static(KEEP):
            X_n = X[i_n]
        else:
            jt_n, Q0_n, Q1_n, t0_n, t1_n, t2_n = jm.joint_terms_of(model, env, i_n)
        S_n = sp.vec6(scalar(0.0))
        if has_joints:  # (a model without joints has no motion subspace to read)
            S_n = model.dof_S[wp.max(jm.dof_address(model, i_n), 0)]
        if wp.static(C_SHARED):
            c_n = get6(PER_LINK * i_n + C_AT)
        else:
            c_n = c[i_n]
        if wp.static(SHARED):
            pU_n = get6(PER_LINK * i_n)
            ud_n = shared_record(PER_LINK * i_n + UD_AT, scalar(0.0), 0)
        else:
            pU_n = pU[i_n]
            ud_n = ud[i_n]
        q_n = scalar(0.0)
        qd_n = scalar(0.0)
        if has_joints:
            q_n = x.joint_positions[env, wp.max(jm.position_address(model, i_n), 0)]
            qd_n = x.joint_velocities[env, wp.max(jm.dof_address(model, i_n), 0)]
        for k in range(first, last):
            i = i_n
            own = w_n[1]
            up = w_n[2]
            if wp.static(KEEP):
                X_i = unpack7(X_n)
            else:
                X_i = jm.joint_transform_from(jt_n, Q0_n, Q1_n, t0_n, t1_n, t2_n, q_n)
            S = S_n
            c_i = c_n
            Ud_i = pU_n
            ud_i = ud_n
            s_i = q_n
            sd_i = qd_n
            w_n = walk[wp.min(k + 1, last - 1)]
            i_n = w_n[0]
            if wp.static(KEEP):
                X_n = X[i_n]
            else:
                jt_n, Q0_n, Q1_n, t0_n, t1_n, t2_n = jm.joint_terms_of(model, env, i_n)
            S_n = model.dof_S[wp.max(jm.dof_address(model, i_n), 0)]
            if wp.static(C_SHARED):
                c_n = get6(PER_LINK * i_n + C_AT)
            else:
                c_n = c[i_n]
            if wp.static(SHARED):
                pU_n = get6(PER_LINK * i_n)
                ud_n = shared_record(PER_LINK * i_n + UD_AT, scalar(0.0), 0)
            else:
                pU_n = pU[i_n]
                ud_n = ud[i_n]
            q_n = x.joint_positions[env, jm.position_address(model, i_n)]
            qd_n = x.joint_velocities[env, jm.dof_address(model, i_n)]
            a_P = a_prev
            if up == BASE:
                up = base_own
            if up >= 0:
                a_P = slot_v[up]
            a_i = F.link_acceleration(X_i, a_P, c_i)
            qdd = F.dof_acceleration(Ud_i, ud_i, a_i)
            a_i = a_i + S * qdd
            one_dof = True
            if wp.static(FREE_ROOTS):
                if model.joint_type[i] == FREE:  # its accelerations from pass 2: qdd in U_i / d_i, a_i in c_i
                    one_dof = False
                    a_i = c_i
                    nonfinite = nonfinite + I.rotating_joint_step(
                        FREE, jm.position_address(model, i), jm.dof_address(model, i), env, dt, x, Ud_i, True, y, divergence_speed
                    )
            if own >= 0:
                slot_v[own] = a_i
            a_prev = a_i
            if one_dof:
                s_next, sd_next = I.euler_coordinate(s_i, sd_i, qdd, dt)
                nonfinite = I.poison(I.poison(I.poison_speed(nonfinite, sd_i, divergence_speed), sd_next), s_next)
                y.joint_velocities[env, jm.dof_address(model, i)] = sd_next
                y.joint_positions[env, jm.position_address(model, i)] = s_next
        if lane == 0:
            for row in range(x.tangential_deformation.shape[1]):
                if contacts.row_point[row] < 0:  # a disabled point's deformation does not change
                    for r in range(3):
                        m_row = x.tangential_deformation[env, row, r]
                        nonfinite = I.poison(nonfinite, m_row)
                        y.tangential_deformation[env, row, r] = m_row
        if wp.static(LANES > 1):  # (after every lane's writes)
            nonfinite = wp.tile_extract(wp.tile_sum(wp.tile(nonfinite)), 0)
        # 4. the base integrated, in lane 0
        if lane == 0:
            p_next, pdot_next, omega_next, Q_next, ok = I.euler_base_from(
                SO3, dt, quaternion_tolerance, divergence_speed, p_B, Q_B, pdot_B, omega_B, healthy, sp.lin(base), sp.ang(base)
            )
            ok = ok and wp.isfinite(nonfinite)
            if ok:
                I.write_base(env, y, p_next, pdot_next, omega_next, Q_next)
                y.valid[env] = 1
            else:
                I.keep_state(env, x, y)

    return fused_euler_step
