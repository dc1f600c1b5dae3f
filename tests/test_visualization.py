"""warpdyn.visualization: recording rollouts with rerun, and its NumPy geometry helpers.

The recordings are read back with rerun's own reader (`rerun.chunk.RrdReader`, rerun-sdk >= 0.41, the
test extra's bound) and compared with what warpdyn computes: link poses, collidable points, contact
forces, frame times, the terrain.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest
import rerun  # noqa: F401  (the test extra; a missing install fails here, it does not skip)

import warpdyn as wd
import warpdyn.visualization as viz
from warpdyn.description import CollisionShape

BOX_MASS, BOX_HALF, G = 2.0, 0.1, 9.81
BOX_URDF = """<robot name="box"><link name="box"><inertial><mass value="2"/>
<inertia ixx="0.013333333333333334" iyy="0.013333333333333334" izz="0.013333333333333334" ixy="0" ixz="0" iyz="0"/>
</inertial><collision><origin xyz="0 0 0.01" rpy="0 0 0.3"/><geometry><box size="0.2 0.2 0.2"/></geometry></collision>
<collision><origin xyz="0 0 0.2"/><geometry><sphere radius="0.05"/></geometry></collision>
<collision><origin xyz="0.2 0 0" rpy="1.5707963267948966 0 0"/><geometry><cylinder radius="0.03" length="0.1"/></geometry></collision>
</link></robot>"""

TERRAINS = {
    "flat": wd.terrain.FlatTerrain(height=0.05),
    "plane": wd.terrain.PlaneTerrain(normal=(0.2, -0.1, 1.0), point=(0.3, 0.1, -0.2)),
    "heightfield": wd.terrain.HeightfieldTerrain(
        np.random.default_rng(0).uniform(-0.05, 0.05, size=(7, 5)), origin=(-0.4, -0.3), spacing=(0.15, 0.12)
    ),
}


def _box(dtype=np.float64, terrain=None):
    model = wd.model.Model.build_from_model_description(BOX_URDF, dtype=dtype)
    if terrain is not None:
        model.terrain = terrain
    return model


def _read(path) -> tuple[dict, dict]:
    """(temporal, static) of an .rrd file: each {entity path: {column: [per-row values]}}, the temporal
    rows in frame order."""
    import pyarrow as pa
    from rerun.chunk import RrdReader

    temporal: dict = {}
    static: dict = {}
    for chunk in RrdReader(str(path)).store().stream():
        batch = chunk.to_record_batch()
        entry = (static if chunk.is_static else temporal).setdefault(chunk.entity_path, {})
        for name in batch.schema.names:
            if name.startswith("rerun.") or name == "log_time":  # row ids; the wall clock
                continue
            column = batch.column(name)
            if pa.types.is_duration(column.type):  # sim_time: integer nanoseconds
                column = column.cast(pa.int64())
            entry.setdefault(name, []).extend(column.to_pylist())
    for entry in temporal.values():
        order = np.argsort(entry["frame"], kind="stable")
        for name, values in entry.items():
            entry[name] = [values[i] for i in order]
    return temporal, static


# ---------------------------------------------------------------------------------- recordings


def test_record_rollout_of_a_box_writes_what_the_simulation_computes(tmp_path):
    """A box (with a box, a sphere and a cylinder) thrown onto the ground: the .rrd file holds every
    `every`-th state and the last one, the link pose of each equal to FK of the recorded state, the points
    and their forces equal to warpdyn's, and the static shapes and terrain."""
    model = _box()
    data = wd.data.Data.build(model, base_position=[0.0, 0.0, 0.2], base_linear_velocity=[0.6, 0.0, -0.5])
    steps, every = 150, 7  # frames 0, 7, ..., 147 and 150
    path = tmp_path / "sub" / "box.rrd"
    final, rec = viz.record_rollout(model, data, steps=steps, every=every, path=path, force_scale=1e-2)
    assert path.is_file() and path.stat().st_size > 10_000
    assert path.read_bytes()[:3] == b"RRF"

    # the records are the rollout's
    ref_final, ref = wd.simulation.rollout(model, data, steps=steps, record=tuple(rec))
    for name in rec:
        np.testing.assert_array_equal(rec[name].numpy(), ref[name].numpy())
    np.testing.assert_array_equal(final.base_position.numpy(), ref_final.base_position.numpy())

    frames = [*range(0, steps, every), steps]
    logged, static = _read(path)
    link = logged["/world/robot/links/box"]
    assert link["frame"] == list(range(len(frames)))
    np.testing.assert_allclose(link["sim_time"], np.array(frames) * model.time_step * 1e9)  # nanoseconds
    bp, bq = rec["base_position"].numpy(), rec["base_quaternion"].numpy()
    points_logged = logged["/world/contact/points"]["Points3D:positions"]
    forces = logged["/world/contact/forces"]
    cpf = rec["collidable_point_forces"].numpy()
    last_forces = wd.contact.collidable_point_forces(model, final).numpy()
    touched = 0
    for k, t in enumerate(frames):
        state = wd.data.Data.build(model, base_position=bp[t], base_quaternion=bq[t])
        H = wd.model.forward_kinematics(model, state).numpy()[0]
        np.testing.assert_allclose(link["Transform3D:translation"][k], [H[:3, 3]], atol=1e-6)
        np.testing.assert_allclose(np.reshape(link["Transform3D:mat3x3"][k], (3, 3)).T, H[:3, :3], atol=1e-6)  # column-major
        p = wd.contact.collidable_point_positions(model, state).numpy()
        np.testing.assert_allclose(points_logged[k], p, atol=1e-6)
        f = (cpf[t] if t < steps else last_forces)[:, :3]
        active = np.linalg.norm(f, axis=1) > 0
        touched += active.sum()
        np.testing.assert_allclose(np.reshape(forces["Arrows3D:vectors"][k], (-1, 3)), 1e-2 * f[active], rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(np.reshape(forces["Arrows3D:origins"][k], (-1, 3)), p[active], atol=1e-6)
    assert touched > 0  # the box landed during the recording

    assert not any("/collision/" in path or "/terrain/" in path for path in logged)
    shapes = {path: entry for path, entry in static.items() if "/collision/" in path}
    assert sorted(shapes) == [
        "/world/robot/links/box/collision/0_box",
        "/world/robot/links/box/collision/1_sphere",
        "/world/robot/links/box/collision/2_cylinder",
    ]
    np.testing.assert_allclose(shapes["/world/robot/links/box/collision/0_box"]["Boxes3D:half_sizes"][0], [[0.1, 0.1, 0.1]])
    np.testing.assert_allclose(shapes["/world/robot/links/box/collision/0_box"]["Transform3D:translation"][0], [[0, 0, 0.01]], atol=1e-7)
    np.testing.assert_allclose(shapes["/world/robot/links/box/collision/1_sphere"]["Ellipsoids3D:half_sizes"][0], [[0.05] * 3])
    np.testing.assert_allclose(np.reshape(static["/world/terrain/mesh"]["Mesh3D:vertex_positions"][0], (-1, 3))[:, 2], -5e-4, atol=1e-7)


def test_log_from_data_single_and_batched(tmp_path):
    """RerunRecorder.log from Data: the environment `env` of a batch, the box resting on flat ground at
    the predicted load (the logged vertical contact force is m g)."""
    model = _box()
    z0 = -wd.contact.collidable_point_positions(model, wd.data.Data.build(model)).numpy()[..., 2].min()
    single = wd.data.Data.build(model, base_position=[0.0, 0.0, z0])  # the box's bottom corners on the ground
    final, _ = wd.simulation.rollout(model, single, steps=600, record=())  # settles on the ground
    batch = wd.data.Data.build(
        model,
        base_position=np.r_[final.base_position.numpy().reshape(1, 3), [[0.0, 0.0, 2.0]]],
        base_quaternion=np.r_[final.base_quaternion.numpy().reshape(1, 4), [[1.0, 0.0, 0.0, 0.0]]],
        num_envs=2,
    )
    path = tmp_path / "log.rrd"
    with viz.RerunRecorder(model, path=path, env=1, force_scale=1e-2) as recorder:
        recorder.log(final, time=0.5)
        recorder.log(batch, time=0.6)  # env 1: 2 m up, no contact
    logged, _ = _read(path)
    np.testing.assert_allclose(logged["/world/robot/links/box"]["Transform3D:translation"][1], [[0.0, 0.0, 2.0]], atol=1e-9)
    force_z = logged["/world/plots/contact_force_z"]["Scalars:scalars"]
    np.testing.assert_allclose(force_z[0], [BOX_MASS * G], rtol=1e-3)  # resting (the settling's tail: 1e-5)
    np.testing.assert_allclose(force_z[1], [0.0])
    in_contact = logged["/world/plots/points_in_contact"]["Scalars:scalars"]
    assert in_contact[0] == [4.0] and in_contact[1] == [0.0]
    colors = logged["/world/contact/points"]["Points3D:colors"]
    assert colors[1] == [int.from_bytes(bytes(viz.POINT_FREE_COLOR), "big")] * len(colors[1])
    with pytest.raises(RuntimeError, match="closed"):
        recorder.log(final)
    with pytest.raises(ValueError, match="env = 5"):
        with viz.RerunRecorder(model, path=tmp_path / "bad.rrd", env=5) as bad:
            bad.log(batch)


def test_recorder_arguments_and_missing_rerun(tmp_path, monkeypatch):
    model = _box()
    with pytest.raises(ValueError, match="exactly one sink"):
        viz.RerunRecorder(model)
    with pytest.raises(ValueError, match="exactly one sink"):
        viz.RerunRecorder(model, path=tmp_path / "a.rrd", spawn=True)
    with pytest.raises(ValueError, match="every"):
        viz.record_rollout(model, wd.data.Data.build(model), steps=2, every=0, path=tmp_path / "b.rrd")
    monkeypatch.setitem(sys.modules, "rerun", None)  # as if rerun-sdk were not installed
    with pytest.raises(ImportError, match=r"pip install \"warpdyn\[viz\]\""):
        viz.RerunRecorder(model, path=tmp_path / "c.rrd")
    assert viz.terrain_mesh(wd.terrain.FlatTerrain())[0].shape == (4, 3)  # the helpers need no rerun


def test_a_heightfield_terrain_and_mjcf_shapes_are_logged(tmp_path):
    """An MJCF body with a capsule, a mesh (vertices only: drawn as their convex hull) and an ellipsoid over a
    heightfield: shapes static under the link, the terrain mesh is the grid."""
    mjcf = """<mujoco><asset><mesh name="tet" vertex="0 0 0  0.1 0 0  0 0.1 0  0 0 0.1"/></asset>
    <worldbody><body name="b" pos="0 0 0.5"><freejoint/><inertial pos="0 0 0" mass="1" diaginertia="0.01 0.01 0.01"/>
    <geom type="capsule" size="0.05 0.1"/><geom type="mesh" mesh="tet" pos="0.2 0 0"/><geom type="ellipsoid" size="0.1 0.05 0.02"/>
    </body></worldbody></mujoco>"""
    model = wd.model.Model.build_from_model_description(mjcf, dtype=np.float64)
    model.terrain = TERRAINS["heightfield"]
    path = tmp_path / "mjcf.rrd"
    viz.record_rollout(model, wd.data.Data.build(model, base_position=[0.0, 0.0, 0.3]), steps=5, path=path)
    _, static = _read(path)
    kinds = sorted(p.rsplit("/", 1)[1] for p in static if "/collision/" in p)
    assert kinds == ["0_capsule", "1_mesh", "2_ellipsoid"]
    ellipsoid = next(v for p, v in static.items() if p.endswith("2_ellipsoid"))
    np.testing.assert_allclose(ellipsoid["Ellipsoids3D:half_sizes"][0], [[0.1, 0.05, 0.02]])
    capsule = next(v for p, v in static.items() if p.endswith("0_capsule"))
    np.testing.assert_allclose(capsule["Capsules3D:translations"][0], [[0.0, 0.0, -0.1]])
    np.testing.assert_allclose(capsule["Capsules3D:lengths"][0], [0.2])
    mesh = next(v for p, v in static.items() if p.endswith("1_mesh"))
    assert len(mesh["Mesh3D:triangle_indices"][0]) == 4  # the tetrahedron's hull
    vertices = np.reshape(static["/world/terrain/mesh"]["Mesh3D:vertex_positions"][0], (-1, 3))
    assert vertices.shape == (7 * 5, 3)


def test_the_example_writes_a_recording(tmp_path):
    """examples/visualize_drop.py: the seed's ergoCub legs dropped onto an inclined plane for 0.2 s."""
    import pathlib

    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "examples"))
    try:
        import visualize_drop
    finally:
        sys.path.pop(0)
    out = tmp_path / "drop.rrd"
    with pytest.warns(wd.contact.UnresolvedMeshWarning, match="62 collision mesh"):  # the seed has no mesh files
        result = visualize_drop.main(["ergocub", str(out), "--duration", "0.2", "--every", "10", "--terrain", "plane"])
    assert out.is_file() and out.stat().st_size > 10_000
    assert bool(result["final"].healthy.numpy().reshape(-1)[0])
    logged, _ = _read(out)
    assert len(logged["/world/robot/links/root_link"]["frame"]) == 21


# ----------------------------------------------------------------------------- geometry helpers


@pytest.mark.parametrize("kind", sorted(TERRAINS))
def test_terrain_mesh_lies_on_the_terrain(kind):
    terrain = TERRAINS[kind]
    vertices, triangles, normals = viz.terrain_mesh(terrain, center=(0.4, -0.2), half_extent=1.5)
    np.testing.assert_allclose(vertices[:, 2], terrain.height(vertices[:, 0], vertices[:, 1]), atol=1e-12)
    np.testing.assert_allclose(normals, terrain.normal(vertices[:, 0], vertices[:, 1]), atol=1e-12)
    assert triangles.dtype == np.int32 and triangles.min() == 0 and triangles.max() == len(vertices) - 1
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    up = np.cross(b - a, c - a)[:, 2]
    assert np.all(up > 0)  # counter-clockwise seen from above
    if kind == "heightfield":
        nx, ny = terrain.heights.shape
        assert len(vertices) == nx * ny and len(triangles) == 2 * (nx - 1) * (ny - 1)
        np.testing.assert_allclose(vertices[:, 2], terrain.heights.reshape(-1), atol=1e-15)
        centres = (a + b + c) / 3  # the bilinear surface is not planar: the triangles are within its bumps
        assert np.abs(centres[:, 2] - terrain.height(centres[:, 0], centres[:, 1])).max() < 0.05
    else:
        np.testing.assert_allclose(np.sort(vertices[:, 0]), [-1.1, -1.1, 1.9, 1.9])
        np.testing.assert_allclose(np.sort(vertices[:, 1]), [-1.7, -1.7, 1.3, 1.3])
        assert len(triangles) == 2
        # a plane's triangles are the plane: every point of them is on the terrain
        w = np.random.default_rng(1).dirichlet(np.ones(3), size=50)
        p = w @ np.stack([a[0], b[0], c[0]])
        np.testing.assert_allclose(p[:, 2], terrain.height(p[:, 0], p[:, 1]), atol=1e-12)
    with pytest.raises(ValueError, match="half_extent"):
        viz.terrain_mesh(wd.terrain.FlatTerrain(), half_extent=0.0)


@pytest.mark.parametrize("kind", sorted(TERRAINS))
def test_grid_lines_and_penetration(kind):
    terrain = TERRAINS[kind]
    lines = viz.terrain_grid_lines(terrain, center=(0.1, 0.0), half_extent=1.0, spacing=0.25, samples=9)
    assert len(lines) == 8 + 9  # x = -0.75, ..., 1.0 (the square spans [-0.9, 1.1]) and y = -1.0, ..., 1.0
    for line in lines:
        np.testing.assert_allclose(line[:, 2], terrain.height(line[:, 0], line[:, 1]), atol=1e-12)
    x = np.linspace(-1, 1, 11)
    h = terrain.height(x, 0.3 * x)
    n = terrain.normal(x, 0.3 * x)
    for offset in (-0.01, 0.0, 0.02):
        points = np.stack([x, 0.3 * x, h - offset], axis=1)
        np.testing.assert_allclose(viz.point_penetration(terrain, points), offset * n[:, 2], atol=1e-15)
    colors = viz.point_colors([-1e-3, 0.0, 1e-3, 5e-3], depth_scale=2e-3)
    assert colors.dtype == np.uint8 and colors.shape == (4, 4)
    np.testing.assert_array_equal(colors[0], viz.POINT_FREE_COLOR)
    np.testing.assert_array_equal(colors[1], viz.POINT_TOUCH_COLOR)
    np.testing.assert_array_equal(colors[3], viz.POINT_DEEP_COLOR)
    np.testing.assert_array_equal(colors[2], np.rint(0.5 * viz.POINT_TOUCH_COLOR + 0.5 * viz.POINT_DEEP_COLOR))


def test_shape_primitives_and_skeleton():
    H = np.eye(4)
    H[:3, 3] = [0.1, 0.2, 0.3]
    box = viz.shape_primitive(CollisionShape("box", H, size=np.array([0.2, 0.4, 0.06])))
    assert box.kind == "box"
    np.testing.assert_allclose(box.half_sizes, [0.1, 0.2, 0.03])
    np.testing.assert_array_equal(box.link_H_shape, H)
    sphere = viz.shape_primitive(CollisionShape("sphere", H, radius=0.05))
    assert (sphere.kind, sphere.radius) == ("sphere", 0.05)
    capsule = viz.shape_primitive(CollisionShape("capsule", H, radius=0.05, length=0.3))
    assert (capsule.kind, capsule.radius, capsule.length) == ("capsule", 0.05, 0.3)
    mesh = viz.shape_primitive(CollisionShape("mesh", H, filename="package://x/y.stl", scale=np.array([1e-3] * 3)))
    assert mesh.filename == "package://x/y.stl" and mesh.vertices is None
    np.testing.assert_allclose(mesh.scale, 1e-3)
    with pytest.raises(ValueError, match="unknown"):
        viz.shape_primitive(CollisionShape("cone", H))
    # the box's half sizes are the distance of its collidable points (corners) to its centre, per axis
    model = _box()
    points = np.asarray(model.kin_dyn_parameters.contact_parameters.point)[:8]
    shape = model.tree.collisions[0][0]
    local = (points - shape.link_H_shape[:3, 3]) @ shape.link_H_shape[:3, :3]
    np.testing.assert_allclose(np.abs(local), np.broadcast_to(viz.shape_primitive(shape).half_sizes, (8, 3)), atol=1e-12)

    parent = np.array([-1, 0, 1, 0])
    W_H_L = np.tile(np.eye(4), (4, 1, 1))
    W_H_L[:, :3, 3] = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 0, 2]]
    np.testing.assert_array_equal(
        viz.skeleton_segments(parent, W_H_L), [[[0, 0, 0], [1, 0, 0]], [[1, 0, 0], [1, 1, 0]], [[0, 0, 0], [0, 0, 2]]]
    )


def test_record_rollout_of_a_batch_in_body_representation(tmp_path):
    """Environment `env` of a batch whose data is in the Body representation: the logged poses are that
    environment's, the arrows its forces in world axes (the same as a Mixed run's: the representation does
    not change the motion)."""
    model = _box()
    positions = [[0.0, 0.0, 0.3], [0.5, 0.2, 0.1]]
    velocities = [[0.0, 0.0, 0.0], [0.4, 0.0, -0.3]]
    spin = [[0.0, 0.0, 0.0], [0.0, 0.0, 3.0]]  # the box yaws: its axes leave the world's
    # at the identity orientation, Body and Mixed velocities of the base are the same numbers
    body = wd.data.Data.build(
        model, base_position=positions, base_linear_velocity=velocities, base_angular_velocity=spin, num_envs=2,
        velocity_representation=wd.VelRepr.Body,
    )
    mixed = wd.data.Data.build(model, base_position=positions[1], base_linear_velocity=velocities[1], base_angular_velocity=spin[1])
    paths = tmp_path / "body.rrd", tmp_path / "mixed.rrd"
    _, rec = viz.record_rollout(model, body, steps=120, every=3, env=1, path=paths[0], force_scale=1e-2)
    viz.record_rollout(model, mixed, steps=120, every=3, path=paths[1], force_scale=1e-2)
    (body_log, _), (mixed_log, _) = _read(paths[0]), _read(paths[1])
    translation = np.reshape(body_log["/world/robot/links/box"]["Transform3D:translation"], (-1, 3))
    np.testing.assert_allclose(translation, rec["base_position"].numpy()[::3, 1], atol=1e-7)
    arrows = [np.reshape(v, (-1, 3)) for v in body_log["/world/contact/forces"]["Arrows3D:vectors"]]
    reference = [np.reshape(v, (-1, 3)) for v in mixed_log["/world/contact/forces"]["Arrows3D:vectors"]]
    assert sum(len(a) for a in arrows) > 0
    for a, b in zip(arrows, reference, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6)
