"""JaxSim 0.9.0 parity: JaxSim code, renamed, gives JaxSim's numbers.

Every call of tests/jaxsim/cases.py is JaxSim code (`api.model.free_floating_mass_matrix(model=model,
data=data)`, ...) run here with `api = warpdyn`, on four models (the ergoCub's legs from the shipped SDF, a
welded arm, a floating hopper and a box whose feet and corners touch the ground), in the three velocity
representations. The reference is JaxSim 0.9.0 itself on the same SDF files and states: its results, stored
by tests/jaxsim/generate_reference.py (float64) in tests/jaxsim/reference.npz, since JaxSim compiles each
call for seconds and needs JAX, which the suite does not install.

Tolerance: 1e-9 of the quantity's magnitude (at least 1): both compute in float64 with other algorithms
and orders of operations (measured ~1e-12; the contact forces, K = 1e6 N/m^1.5 times millimetre
penetrations, carry ~1e-11 of their magnitude). The differences that are warpdyn's on purpose
(docs/porting.md, "different") are checked as the relation the docs state instead of equality
(`DIFFERENT`), each with its reason.
"""

from __future__ import annotations

import functools
import pathlib
import sys
import warnings

import numpy as np
import pytest

import warpdyn as wd

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "jaxsim"))

import cases  # noqa: E402

REFERENCE = dict(np.load(ROOT / "tests" / "jaxsim" / "reference.npz"))


@functools.cache
def model_of(name: str) -> wd.model.Model:
    spec = cases.MODELS[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        text = (ROOT / spec["path"]).read_text()
        return wd.model.JaxSimModel.build_from_model_description(text, considered_joints=spec["considered_joints"], dtype=np.float64)


def reference(key: str) -> dict:
    """The stored arrays of one case: {"": array} or {"/0": ..., "/1/0": ...} for tuples, {"/error": msg}."""
    return {k[len(key) :]: v for k, v in REFERENCE.items() if k == key or k.startswith(key + "/")}


def close(got: np.ndarray, expected: np.ndarray, what: str) -> str | None:
    """None when got equals expected to 1e-9 of its magnitude, else the mismatch."""
    got, expected = np.asarray(got, dtype=np.float64), np.asarray(expected, dtype=np.float64)
    expected = np.where(np.abs(expected) >= np.finfo(np.float64).max, np.copysign(np.inf, expected), expected)  # JaxSim's "no limit"
    same_infinity = np.isinf(expected) & (got == expected)  # an unlimited joint's limits: warpdyn's +-inf
    got, expected = np.where(same_infinity, 0.0, got), np.where(same_infinity, 0.0, expected)
    if got.shape != expected.shape:
        if expected.shape == () and got.shape == (1,):  # a scalar: a (1,) Warp array (no 0-d arrays), documented
            got = got.reshape(())
        else:
            return f"{what}: shape {got.shape}, JaxSim's {expected.shape}"
    scale = max(1.0, float(np.abs(expected).max(initial=0.0)))
    error = float(np.abs(got - expected).max(initial=0.0))
    return None if error <= 1e-9 * scale else f"{what}: {error:.3g} from JaxSim's (scale {scale:.3g})"


def fixed_base_relations(name: str, call: str, got: dict, expected: dict, M: np.ndarray):
    """The fixed-base conventions that differ on purpose (docs/porting.md): warpdyn's rows and columns of the
    base are the welded mechanism's (the weld's reaction wrench, the joints' own inverse inertia), JaxSim's are
    zeros or the floating robot's. The joints' parts are equal; each relation is checked."""
    if call == "model.inverse_dynamics":
        return [close(got["/1"], expected["/1"], "joint forces"), close(expected["/0"], 0.0 * expected["/0"], "JaxSim's base wrench is 0")]
    if "" not in got:
        return None
    g, e = got[""], expected[""]
    if call == "model.free_floating_mass_matrix_inverse":
        return [close(g[6:, 6:], np.linalg.inv(M[6:, 6:]), "joint block = inv(M_jj)"), close(g[:6], 0.0 * g[:6], "base rows 0")]
    if call in ("model.free_floating_bias_forces", "model.free_floating_gravity_forces"):
        return [close(g[6:], e[6:], "joint rows"), close(e[:6], 0.0 * e[:6], "JaxSim's base rows are 0")]
    if call == "model.free_floating_coriolis_matrix":
        return [close(g[6:, 6:], e[6:, 6:], "joint block"), close(g[:6, :6], e[:6, :6], "base block")]
    return None


DIFFERENT = {
    "model.potential_energy": "U = m g z_CoM (physics, MuJoCo); JaxSim's m z_CoM model.gravity is -U",
    "model.mechanical_energy": "K + U with warpdyn's U (JaxSim's K - U is not conserved)",
    "com.bias_acceleration[Body]": "JaxSim 0.9.0 raises in the Body representation (a broadcasting error in jaxsim/api/com.py)",
    "data.replace[fixed]": "a welded base has no velocity: warpdyn refuses one (JaxSim stores it and uses it in some functions only)",
    "kin_dyn_parameters.tree_transforms": "JaxSim 0.9.0 raises (it calls .inverse() on an array)",
    "joint index out of range": "an IndexError naming the index; JAX clamps an index out of range and reads another joint's value",
    "ode.system_position_dynamics": "JaxSim's reads the data's velocity as if it were Inertial (its callers switch to Inertial first): "
    "equal for Inertial data; warpdyn's are the derivatives whatever the representation",
    "ode.system_acceleration[contacts]": "JaxSim's adds the Inertial contact forces to link forces in the data's representation: equal "
    "for Inertial data (system_dynamics and the integrators, which JaxSim calls so, are compared in every representation)",
}


def _different_average_jacobian(call: str, representation: str) -> bool:
    """JaxSim's average_velocity_jacobian is another frame's when the output representation is Body and the
    data's is not, or the other way round (warpdyn.model.average_velocity_jacobian's docstring)."""
    if not call.startswith("model.average_velocity_jacobian["):
        return False
    output = call[len("model.average_velocity_jacobian[") : -1]
    return output != representation and "Body" in (output, representation)


@pytest.mark.parametrize("representation", cases.REPRESENTATIONS)
@pytest.mark.parametrize("name", list(cases.MODELS))
def test_jaxsim_calls_renamed_give_jaxsim_numbers(name, representation):
    """Each call of cases.calls with api = warpdyn against JaxSim's stored result (see the module docstring)."""
    model = model_of(name)
    spec = cases.MODELS[name]
    for kind, names in (("links", model.link_names()), ("joints", model.joint_names()), ("frames", model.frame_names())):
        assert tuple(names) == tuple(REFERENCE[f"{name}/{kind}"].tolist()), f"{name}: the {kind}' order is JaxSim's"
    np.testing.assert_allclose(model.kin_dyn_parameters.contact_parameters.point, REFERENCE[f"{name}/points"], atol=1e-14)
    kwargs = cases.state(name, model.joint_names(), model.floating_base())
    x = cases.inputs(name, model.dofs(), model.number_of_links()) | {"link": spec["link"], "frame": spec["frame"]}
    data = wd.data.JaxSimModelData.build(model=model, velocity_representation=getattr(wd.common.VelRepr, representation), **kwargs)
    M = wd.model.free_floating_mass_matrix(model, data).numpy()
    failures, compared = [], 0
    for call, run in cases.calls(wd, model, data, x).items():
        key = f"{name}/{representation}/{call}"
        expected = reference(key)
        assert expected, f"{key}: no reference (regenerate tests/jaxsim/reference.npz)"
        if call == "data.replace" and not model.floating_base():
            with pytest.raises(ValueError, match="fixed base: base velocities must be zero"):
                run()
            continue
        if "/error" in expected:
            assert (call == "com.bias_acceleration" and representation == "Body") or call == "kin_dyn_parameters.tree_transforms", f"{key}: JaxSim raised {expected['/error']}"
            continue  # DIFFERENT: JaxSim 0.9.0 raises; warpdyn's are checked in tests/test_centroidal.py, tests/test_jaxsim_api.py
        if call == "joint.position_limit" and model.dofs() == 0:
            with pytest.raises(IndexError, match="joint_index 0 is out of range"):  # DIFFERENT["joint index out of range"]
                run()
            continue
        got = cases.flatten(cases.host(run()), "")
        if _different_average_jacobian(call, representation):
            continue
        if not model.floating_base() and (relations := fixed_base_relations(name, call, got, expected, M)) is not None:
            failures += [f"{call}: {r}" for r in relations if r]
            compared += 1
            continue
        if call == "ode.system_position_dynamics" and representation != "Inertial":
            continue  # DIFFERENT["ode.system_position_dynamics"]
        if call == "ode.system_acceleration" and representation != "Inertial" and np.abs(reference(f"{name}/Inertial/contact.link_contact_forces").get("/0", np.zeros(1))).max() > 0:
            continue  # DIFFERENT["ode.system_acceleration[contacts]"]
        if call in ("model.potential_energy", "model.mechanical_energy"):
            K = reference(f"{name}/{representation}/model.kinetic_energy")[""]
            U = reference(f"{name}/{representation}/model.potential_energy")[""]
            expected = {"": -U if call == "model.potential_energy" else K - U}
        if sorted(got) != sorted(expected):
            failures.append(f"{call}: parts {sorted(got)}, JaxSim's {sorted(expected)}")
            continue
        failures += [f"{call}{part}: {r}" for part in got if (r := close(got[part], expected[part], "value"))]
        compared += 1
    assert compared > 40, f"only {compared} calls compared"
    assert not failures, "\n".join(failures)


def test_the_reference_is_jaxsim_090_and_names_every_case():
    """The stored reference was made by JaxSim 0.9.0, and holds every case of cases.py (model, representation,
    call): a case added without regenerating the reference fails here, not silently."""
    assert str(REFERENCE["jaxsim_version"]) == "0.9.0"
    for name in cases.MODELS:
        model = model_of(name)
        data = wd.data.Data.build(model)
        x = cases.inputs(name, model.dofs(), model.number_of_links()) | {"link": cases.MODELS[name]["link"], "frame": cases.MODELS[name]["frame"]}
        for call in cases.calls(wd, model, data, x):
            for representation in cases.REPRESENTATIONS:
                assert reference(f"{name}/{representation}/{call}"), f"{name}/{representation}/{call}"
