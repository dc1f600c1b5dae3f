"""The contact-model seam (warpdyn.engine.contact_stage): a step reads a contact model through its stage alone.

A stage that gives the fused step no per-point law takes the launch list (the plan's one choice) with the same
numbers; a contact model's class finds its stage through its base classes; a class without one is refused by
name."""

import numpy as np
import pytest

import robots
import warpdyn as wd
from warpdyn.engine import contact_stage
from warpdyn.engine import step as engine_step


class _StagedSoft(contact_stage.SoftContactStage):
    """The soft stage without its per-point law: the fused step does not apply."""

    point_law = None


class _MarkedSoft(wd.rbda.contacts.SoftContacts):
    """A soft contact model of its own class, whose stage is _StagedSoft."""


class _DerivedSoft(wd.rbda.contacts.SoftContacts):
    """A soft contact model with no stage of its own."""


def _legs(contact_model):
    model = robots.ergocub_seed_with_points(np.float64)
    model = wd.model.reduce(model, model.joint_names())
    model.contact_model = contact_model
    return model


def _standing(model, N=8):
    rng = np.random.default_rng(4)
    lowest = float(wd.contact.collidable_point_positions(model, wd.data.Data.build(model)).numpy()[:, 2].min())
    return wd.data.Data.build(
        model,
        num_envs=N,
        base_position=np.stack([np.zeros(N), np.zeros(N), -lowest - 0.002 + rng.uniform(-0.001, 0.001, N)], axis=1),
        joint_velocities=rng.uniform(-1.0, 1.0, (N, model.dofs())),
        base_linear_velocity=rng.normal(0.0, 0.3, (N, 3)),
    )


def test_a_stage_without_a_point_law_takes_the_launch_list_with_the_same_numbers(monkeypatch):
    monkeypatch.setitem(contact_stage.STAGES, _MarkedSoft, _StagedSoft)
    fused_model, staged_model = _legs(wd.rbda.contacts.SoftContacts()), _legs(_MarkedSoft())
    assert isinstance(engine_step.plan(staged_model).contact_stage, _StagedSoft) and engine_step.plan(staged_model).fused is None
    assert type(engine_step.plan(fused_model).contact_stage) is contact_stage.SoftContactStage and engine_step.plan(fused_model).fused is not None
    data = _standing(fused_model)
    tau = np.random.default_rng(5).uniform(-5.0, 5.0, (8, fused_model.dofs()))
    a, b = data, data
    for _ in range(20):
        a = wd.model.step(fused_model, a, joint_force_references=tau)
        b = wd.model.step(staged_model, b, joint_force_references=tau)
    assert np.abs(a.tangential_deformation_state.numpy()).max() > 0.0, "the points touch"
    for name in ("base_position", "base_velocity", "joint_positions", "joint_velocities", "tangential_deformation_state"):
        np.testing.assert_allclose(getattr(a, name).numpy(), getattr(b, name).numpy(), rtol=0.0, atol=1e-11, err_msg=name)


def test_a_contact_model_class_finds_its_stage_through_its_base_classes():
    assert type(engine_step.plan(_legs(_DerivedSoft())).contact_stage) is contact_stage.SoftContactStage


def test_a_contact_model_without_a_stage_is_refused_by_name(monkeypatch):
    monkeypatch.delitem(contact_stage.STAGES, wd.rbda.contacts.SoftContacts)
    with pytest.raises(ValueError, match="model.contact_model is a SoftContacts, which warpdyn's step does not simulate"):
        engine_step.plan(_legs(wd.rbda.contacts.SoftContacts()))
