"""An MJCF's ground plane is the model's terrain (ModelDescription.ground, warpdyn.types.terrain.terrain_of_ground):
a floor lowered, raised or tilted is where MuJoCo puts it, not the plane z = 0; what warpdyn cannot take as its
terrain (several planes, a heightfield, a plane facing down) is named in the loader's warning and the terrain stays
z = 0. Reference: MuJoCo's geom_xpos and geom_xmat at qpos0, and a box dropped on the floor resting on it."""

import warnings

import mujoco
import numpy as np
import pytest

import warpdyn as wd
from warpdyn.terrain import FlatTerrain, PlaneTerrain


def _scene(ground: str) -> str:
    return f"""<mujoco><option timestep="0.001"/><worldbody>{ground}
      <body name="box" pos="0.3 0.2 0.5"><freejoint/><geom name="box" type="box" size="0.05 0.05 0.05" mass="1"/></body>
    </worldbody></mujoco>"""


def _model(xml: str):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        return wd.model.Model.build_from_model_description(xml, dtype=np.float64)


def _mujoco_plane(xml: str, name: str = "floor") -> tuple[np.ndarray, np.ndarray]:
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    return np.array(d.geom(name).xmat).reshape(3, 3)[:, 2], np.array(d.geom(name).xpos)


@pytest.mark.parametrize("height", [-0.25, 0.0, 0.4])
def test_a_level_floor_is_a_flat_terrain_at_its_height(height):
    """A floor at z = height is FlatTerrain(height); a box dropped on the lowered floor comes to rest on it, its
    centre half its side above (within the soft law's sink, 2 mm)."""
    xml = _scene(f'<geom name="floor" type="plane" size="0 0 1" pos="0 0 {height}"/>')
    terrain = _model(xml).terrain
    assert isinstance(terrain, FlatTerrain) and float(terrain.elevation) == pytest.approx(height, abs=1e-15)
    if height != -0.25:
        return
    model = _model(xml)
    model.contact_params = wd.model.SoftContactsParams(K=1e5, D=2e3, mu=0.5)
    data = wd.data.Data.build(model, base_position=np.array([0.3, 0.2, height + 0.3]), num_envs=1)
    stepper = wd.simulation.Stepper(model, data, substeps=1500)
    stepper.step()
    z = float(stepper.data.base_position.numpy().reshape(3)[2])
    assert bool(stepper.data.healthy.numpy()[0]) and abs(z - (height + 0.05)) < 2e-3, z


def test_a_tilted_floor_is_a_plane_terrain_through_mujocos_pose():
    """A floor turned 10 degrees about x and moved is the PlaneTerrain through MuJoCo's geom_xpos with its z axis."""
    xml = _scene('<geom name="floor" type="plane" size="0 0 1" pos="0.1 -0.2 -0.3" euler="10 0 0"/>')
    normal, point = _mujoco_plane(xml)
    terrain = _model(xml).terrain
    assert isinstance(terrain, PlaneTerrain)
    np.testing.assert_allclose(terrain.unit_normal, normal, rtol=0, atol=1e-15)
    np.testing.assert_allclose(terrain.point, point, rtol=0, atol=1e-15)


@pytest.mark.parametrize(
    "ground, named",
    [
        ('<geom name="floor" type="plane" size="0 0 1" pos="0 0 -1"/><geom name="shelf" type="plane" size="1 1 1" pos="0 0 1"/>', ["floor (plane)", "shelf (plane)"]),
        ('<geom name="floor" type="plane" size="0 0 1" euler="180 0 0"/>', ["floor (plane)"]),
    ],
    ids=["two_planes", "facing_down"],
)
def test_grounds_it_cannot_take_are_named_and_the_terrain_stays_level(ground, named):
    """Two planes, or one facing down: the warning names each ground geom and the terrain is the plane z = 0."""
    with pytest.warns(wd.model.NotModelledWarning, match="ground geoms other than one upward plane") as caught:
        model = wd.model.Model.build_from_model_description(_scene(ground), dtype=np.float64)
    message = " ".join(str(w.message) for w in caught)
    assert all(name in message for name in named), message
    assert isinstance(model.terrain, FlatTerrain) and float(model.terrain.elevation) == 0.0


def test_without_a_floor_the_terrain_is_level_at_zero():
    """No plane in the world: FlatTerrain(0), as for URDF and SDF."""
    model = _model(_scene(""))
    assert model.description.ground is None and float(model.terrain.elevation) == 0.0
