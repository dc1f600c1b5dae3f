"""The physical ranges of a model's parameters, checked per environment on the device after each step.

A parameter's Warp array edited in place (`model.link_mass.assign(...)`, a domain randomisation written by a
torch view, a Warp K or mu of the contacts) is read by the next step as it is, with no host check: a check on
the host would synchronise at every step. So every step ends with `keep_unphysical`, one thread per
environment: an environment whose parameters (its row of each (P, count) parameter, P = 1 shared or N) are out
of range is flagged (valid = 0) and keeps its state, as the integrators flag a non-finite state.

Checked (`CHECKED`: every model array whose range is more than finiteness, warpdyn.types.parameters):
- non-negative and finite: link_mass (but a fixed base's, which no dynamics reads), the joints' limit spring and
  damper, frictions, armature, damping, stiffness, the floating base's free-joint armature, damping and
  stiffness (NaN fails every comparison);
- (lower, upper) with lower <= upper, no NaN: position_limits, joint_actuator_force_range, actuator_ctrl_range,
  actuator_force_range;
- link_inertia: a finite diagonal >= -INERTIA_ATOL x the largest diagonal entry of the environment's
  inertias (a necessary condition of positive semi-definiteness, the host's tolerance; the host's full check,
  the principal moments, is warpdyn.types.parameters.validate_parameters, when a step's plan is built);
- with contacts: K and D positive and finite, mu non-negative and finite, and the deformation's stability
  dt K / D < the integrator's limit wherever the environment's collidable points can reach the terrain:
  a floating base, a chain of unbounded reach (`reach` < 0), a heightfield, or a fixed base whose origin is
  within `reach` of the flat or inclined plane (the base where the data puts it).
Parameters whose only fault can be a NaN or an infinity (centres of mass, gravity compensations, which MuJoCo
allows negative, spring references, gears, gains, biases) are not read: such a value makes the state non-finite, which the integrator flags.

Cost, per step and no host work: each environment's thread reads its own rows of the parameters given per
environment (domain randomisation), its K, D, mu and, for a fixed base, its base position; a parameter shared
by the environments is read once, by thread 0, which flags every environment when it finds one out of range
(a rare event, written serially). Measured on a 2-core CPU (Warp's CPU graph), the ergoCub legs with servos,
Stepper.step: N = 1 5.0 -> 5.8 us (of which 0.35 us the launch itself), N = 256 582 -> 590 us; reading every
parameter in every thread had cost 702 us at N = 256. Not measured on a GPU. Gradients of a flagged
environment are not meaningful (its state is copied over the integrator's).
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .integrators import kernels as integrator_kernels
from .soft_contacts import HEIGHTFIELD

CHECKED = (
    "link_mass",
    "link_inertia",
    "position_limits",
    "joint_limit_spring",
    "joint_limit_damper",
    "friction_static",
    "friction_viscous",
    "armature",
    "damping",
    "stiffness",
    "joint_actuator_force_range",
    "actuator_ctrl_range",
    "actuator_force_range",
    "base_armature",
    "base_damping",
    "base_stiffness",
)
"""The model arrays the device check reads (those whose registry check is more than finiteness)."""

INERTIA_ATOL = 1e-9
"""Tolerance of a negative diagonal entry of an inertia, relative to the largest entry of the environment's
inertias: warpdyn.description.physical.INERTIA_ATOL (tests/test_faults_inputs.py checks they agree)."""


@factory
def kernels(scalar) -> types.SimpleNamespace:
    B = bundles(scalar)
    I = integrator_kernels(scalar, False)  # its keep_state (no joint structure)
    vec2 = wp.types.vector(2, scalar)
    mat33 = wp.types.matrix((3, 3), scalar)

    @wp.func
    def checks_row(rows: int, env: int):
        """Whether thread `env` checks its row of a (rows, count) parameter: its own row when the parameter is
        given per environment, the one shared row in thread 0 alone (once per launch, not once per environment)."""
        return rows > 1 or env == 0

    @wp.func
    def split(rows: int, bad: int):
        """(own, shared) faults: those of a per-environment row flag its environment, those of a shared row all."""
        if rows > 1:
            return wp.vec2i(bad, 0)
        return wp.vec2i(0, bad)

    @wp.func
    def negative_faults(values: wp.array2d(dtype=scalar), env: int, first: int):
        """(own, shared) counts of the entries from `first` on of the row this thread checks (`checks_row`) that
        are not finite and non-negative."""
        bad = int(0)
        if checks_row(values.shape[0], env):
            row = wp.min(env, values.shape[0] - 1)
            for k in range(first, values.shape[1]):
                v = values[row, k]
                if not (wp.isfinite(v) and v >= scalar(0.0)):
                    bad = bad + 1
        return split(values.shape[0], bad)

    @wp.func
    def unordered_faults(values: wp.array2d(dtype=vec2), env: int):
        """(own, shared) counts of the (lower, upper) pairs with NaN or lower > upper (inf allowed)."""
        bad = int(0)
        if checks_row(values.shape[0], env):
            row = wp.min(env, values.shape[0] - 1)
            for k in range(values.shape[1]):
                pair = values[row, k]
                if not (pair[0] <= pair[1]):
                    bad = bad + 1
        return split(values.shape[0], bad)

    @wp.func
    def inertia_faults(values: wp.array2d(dtype=mat33), env: int, first: int):
        """(own, shared): 1 if an inertia from `first` on of the row has a diagonal entry that is not finite or
        is below -INERTIA_ATOL x the row's largest diagonal entry (which bounds every entry of a positive
        semi-definite matrix). Off-diagonal entries are not read: a NaN there makes the state non-finite."""
        bad = int(0)
        if checks_row(values.shape[0], env):
            row = wp.min(env, values.shape[0] - 1)
            nonfinite = scalar(0.0)
            largest = scalar(0.0)
            lowest = scalar(0.0)
            for k in range(first, values.shape[1]):
                for a in range(3):
                    v = values[row, k][a, a]
                    nonfinite = I.poison(nonfinite, v)
                    largest = wp.max(largest, v)
                    lowest = wp.min(lowest, v)
            if not wp.isfinite(nonfinite) or lowest < -scalar(wp.static(INERTIA_ATOL)) * largest:
                bad = 1
        return split(values.shape[0], bad)

    @wp.func
    def unphysical_model(model: B.Model, env: int):
        """(own, shared) counts of the faults (see the module docstring) of the model parameters this thread
        checks. A fixed base's own mass and inertia are not read: no dynamics reads them."""
        base = 1 - model.floating_base  # the first link whose inertial values matter
        bad = negative_faults(model.link_mass, env, base) + inertia_faults(model.link_inertia, env, base)
        bad = bad + unordered_faults(model.position_limits, env) + unordered_faults(model.joint_actuator_force_range, env)
        bad = bad + negative_faults(model.joint_limit_spring, env, 0) + negative_faults(model.joint_limit_damper, env, 0)
        bad = bad + negative_faults(model.friction_static, env, 0) + negative_faults(model.friction_viscous, env, 0)
        bad = bad + negative_faults(model.armature, env, 0) + negative_faults(model.damping, env, 0)
        bad = bad + negative_faults(model.stiffness, env, 0)
        bad = bad + negative_faults(model.base_armature, env, 0) + negative_faults(model.base_damping, env, 0)
        bad = bad + negative_faults(model.base_stiffness, env, 0)
        bad = bad + unordered_faults(model.actuator_ctrl_range, env) + unordered_faults(model.actuator_force_range, env)
        return bad

    @wp.func
    def unphysical_contacts(contacts: B.Contacts, terrain: B.Terrain, rate_limit: scalar, reach: scalar, x: B.State, env: int):
        """1 if the environment's K, D or mu is out of range, or if its dt K / D reaches the integrator's limit
        (K / D >= rate_limit) while its points can reach the terrain (reach < 0: always), else 0."""
        K = B.env_parameter(contacts.K, env)
        D = B.env_parameter(contacts.D, env)
        mu = B.env_parameter(contacts.mu, env)
        bad = int(0)
        if not (wp.isfinite(K) and K > scalar(0.0) and wp.isfinite(D) and D > scalar(0.0) and wp.isfinite(mu) and mu >= scalar(0.0)):
            bad = 1
        elif K >= rate_limit * D:
            reachable = reach < scalar(0.0) or terrain.kind == HEIGHTFIELD
            if not reachable:
                h = terrain.height[wp.min(env, terrain.height.shape[0] - 1)]
                n = terrain.normal
                distance = n[0] * x.base_position[env, 0] + n[1] * x.base_position[env, 1] + n[2] * (x.base_position[env, 2] - h)
                reachable = not (distance > reach)
            if reachable:
                bad = 1
        return bad

    @wp.kernel(module="unique")
    def keep_unphysical(
        # model
        model: B.Model,
        contacts: B.Contacts,
        terrain: B.Terrain,
        with_contacts: int,
        rate_limit: scalar,
        reach: scalar,
        # state: the step's start x and its result y
        x: B.State,
        # outputs
        y: B.State,
    ):
        """y = x and y.valid = 0 for an environment whose parameters are out of range (module docstring);
        nothing written for the others. with_contacts: whether the step has enabled collidable points;
        rate_limit: the integrator's dt K / D limit over dt [1/s]; reach: the farthest an enabled point can
        be from the base origin [m], < 0 for unbounded (a floating base, a prismatic joint on its chain)."""
        env = wp.tid()
        faults = unphysical_model(model, env)
        own = faults[0]
        if with_contacts != 0:
            own = own + unphysical_contacts(contacts, terrain, rate_limit, reach, x, env)
        if own > 0:
            I.keep_state(env, x, y)
        if faults[1] > 0:  # thread 0 found a shared parameter out of range: it flags every environment
            for other in range(x.valid.shape[0]):
                I.keep_state(other, x, y)

    return types.SimpleNamespace(
        checks_row=checks_row,
        split=split,
        negative_faults=negative_faults,
        unordered_faults=unordered_faults,
        inertia_faults=inertia_faults,
        unphysical_model=unphysical_model,
        unphysical_contacts=unphysical_contacts,
        keep_unphysical=keep_unphysical,
    )
