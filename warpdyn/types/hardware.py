"""JaxSim's hardware parametrisation, host side: each link's parametrisable shape, its nominal geometry and
density, and the frames the scaling moves (JaxSim 0.9.0's `HwLinkMetadata`, `ScalingFactors`,
`LinkParametrizableShape`; the device side is kernels/hardware.py, the function warpdyn.model.update_hw_parameters).

A link is parametrised by its first visual that is a box, a cylinder or a sphere (JaxSim's rule; warpdyn also takes
a capsule, an SDF visual, which JaxSim does not parametrise; meshes, which JaxSim scales from their volumetric
moments, are not parametrised here: such links keep their parameters, though JaxSim's mesh helpers,
`HwLinkMetadata.compute_mesh_inertia` and its moments, are), when the
link's frame is its joint's frame (always for warpdyn's trees). Its density is the link's (lumped) mass over the
visual's volume; L_H_G is its inertial frame (the centre of mass and the inertial axes the description gave).
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np

__all__ = ["LinkParametrizableShape", "HwLinkMetadata", "ScalingFactors", "hw_link_metadata", "shape_volume", "scale_vector", "scaled_collisions"]


@dataclasses.dataclass(frozen=True)
class LinkParametrizableShape:
    """JaxSim's shape codes, and a capsule."""

    Unsupported: ClassVar[int] = -1
    Box: ClassVar[int] = 0
    Cylinder: ClassVar[int] = 1
    Sphere: ClassVar[int] = 2
    Capsule: ClassVar[int] = 3  # warpdyn's (JaxSim 0.9.0 has none): an SDF capsule visual


@dataclasses.dataclass(frozen=True, eq=False)
class HwLinkMetadata:
    """Per link (nL): link_shape (nL,) int (LinkParametrizableShape), geometry (nL, 3) (box: the full extents
    [lx, ly, lz]; cylinder and capsule: [r, l, 0], l the cylinder's (part's) length; sphere: [r, 0, 0]) [m], density (nL,) [kg/m^3], L_H_G (nL, 4, 4) the
    inertial frame in the link; per joint (nj): L_H_pre (nj, 4, 4), the joint's frame in its parent link (JaxSim's
    λ_H_pre), and joint_parent (nj,) int, that parent link. float64, host."""

    link_shape: np.ndarray
    geometry: np.ndarray
    density: np.ndarray
    L_H_G: np.ndarray
    L_H_pre: np.ndarray
    joint_parent: np.ndarray

    @classmethod
    def empty(cls) -> HwLinkMetadata:
        """Metadata of no links (JaxSim's `HwLinkMetadata.empty`)."""
        return cls(np.zeros(0, dtype=np.int32), np.zeros((0, 3)), np.zeros(0), np.zeros((0, 4, 4)), np.zeros((0, 4, 4)), np.zeros(0, dtype=np.int32))

    @staticmethod
    def precompute_mesh_moments(vertices, faces) -> np.ndarray:
        """(13,) the volumetric moments of a closed triangle mesh (JaxSim's): its volume V [m^3], centroid c (3,) [m]
        and second moment about the origin S (3 x 3, flattened) [m^5], each the sum over the tetrahedra that the
        faces (M, 3) int form with the origin (vertices (V, 3) [m]; the faces' winding either way); zeros for a
        mesh of no volume."""
        triangles = np.asarray(vertices, dtype=np.float64)[np.asarray(faces, dtype=int)]
        A, B, C = triangles[:, 0], triangles[:, 1], triangles[:, 2]
        volumes = np.einsum("ij,ij->i", A, np.cross(B, C)) / 6.0
        total = volumes.sum()
        if abs(total) <= 1e-12:
            return np.zeros(13)
        volumes = volumes * np.sign(total)
        V = volumes.sum()
        centroid = (volumes[:, None] * (A + B + C)).sum(axis=0) / (4.0 * V)
        S = A + B + C
        second = np.einsum("t,tij->ij", volumes / 20.0, np.einsum("ti,tj->tij", A, A) + np.einsum("ti,tj->tij", B, B)
                           + np.einsum("ti,tj->tij", C, C) + np.einsum("ti,tj->tij", S, S))  # fmt: skip
        return np.concatenate([[V], centroid, second.reshape(-1)])

    @staticmethod
    def compute_mesh_inertia_from_moments(moments, dims, density) -> tuple[float, np.ndarray]:
        """(mass [kg], inertia (3, 3) about the centre of mass [kg m^2]) of the mesh whose `precompute_mesh_moments`
        are `moments`, scaled by dims (3,) along its axes (V' = det(S) V, c' = S c, S' = det(S) S_d S S_d), of
        `density` [kg/m^3] (JaxSim's); zeros for a mesh of no volume."""
        moments, d = np.asarray(moments, dtype=np.float64), np.asarray(dims, dtype=np.float64)
        if moments[0] <= 1e-12:
            return 0.0, np.zeros((3, 3))
        det = float(np.prod(d))
        mass = float(density) * moments[0] * det
        centroid = d * moments[1:4]
        second = float(density) * det * (d[:, None] * moments[4:13].reshape(3, 3) * d[None, :]) - mass * np.outer(centroid, centroid)
        return mass, np.trace(second) * np.eye(3) - second

    @staticmethod
    def compute_mesh_inertia(vertices, faces, density) -> tuple[float, np.ndarray, np.ndarray]:
        """(mass [kg], centre of mass (3,) [m], inertia (3, 3) about it [kg m^2]) of a closed triangle mesh of
        `density` [kg/m^3] (JaxSim's `compute_mesh_inertia`: vertices (V, 3), faces (M, 3) int)."""
        moments = HwLinkMetadata.precompute_mesh_moments(vertices, faces)
        mass, inertia = HwLinkMetadata.compute_mesh_inertia_from_moments(moments, np.ones(3), density)
        return mass, moments[1:4].copy(), inertia


@dataclasses.dataclass(frozen=True, eq=False)
class ScalingFactors:
    """JaxSim's scaling factors: dims (nL, 3) or (N, nL, 3), the factors of each link's geometry (box: [lx, ly, lz];
    cylinder and capsule: [r, l, -]; sphere: [r, -, -]), and density (nL,) or (N, nL), the factors of each link's
    density; NumPy arrays or Warp arrays of the model's scalar (which carry gradients when they require them)."""

    dims: object
    density: object


def shape_volume(shape: int, geometry: np.ndarray) -> float:
    """The volume [m^3] of a box (full extents), cylinder (r, l), sphere (r) or capsule (r, l: its cylinder's)."""
    if shape == LinkParametrizableShape.Box:
        return float(np.prod(geometry))
    if shape == LinkParametrizableShape.Cylinder:
        return float(np.pi * geometry[0] ** 2 * geometry[1])
    if shape == LinkParametrizableShape.Sphere:
        return float(4.0 / 3.0 * np.pi * geometry[0] ** 3)
    if shape == LinkParametrizableShape.Capsule:
        return float(np.pi * geometry[0] ** 2 * geometry[1] + 4.0 / 3.0 * np.pi * geometry[0] ** 3)
    raise ValueError(f"shape code {shape} has no volume")


def hw_link_metadata(model) -> HwLinkMetadata:
    """The model's HwLinkMetadata (see the module docstring), from its description and its tree; links outside the
    model's `parametrized_links` (when given) Unsupported, as JaxSim's."""
    tree, description, chosen = model.tree, model.description, model.parametrized_links
    by_name = {link.name: link for link in description.links}
    nL, nj = tree.number_of_links, tree.number_of_joints
    shape = np.full(nL, LinkParametrizableShape.Unsupported, dtype=np.int32)
    geometry, density = np.zeros((nL, 3)), np.zeros(nL)
    L_H_G = np.tile(np.eye(4), (nL, 1, 1))
    for i, name in enumerate(tree.link_names):
        link = by_name.get(name)
        if link is None or (chosen is not None and name not in chosen):
            continue
        visual = next((v for v in link.visuals if v.kind in ("box", "cylinder", "sphere", "capsule")), None)
        L_H_G[i, :3, :3] = link.inertial_rotation
        L_H_G[i, :3, 3] = link.com
        if visual is None:
            continue
        if visual.kind == "box":
            shape[i], geometry[i] = LinkParametrizableShape.Box, np.asarray(visual.size, dtype=np.float64)
        elif visual.kind in ("cylinder", "capsule"):
            code = LinkParametrizableShape.Cylinder if visual.kind == "cylinder" else LinkParametrizableShape.Capsule
            shape[i], geometry[i] = code, (visual.radius, visual.length, 0.0)
        else:
            shape[i], geometry[i] = LinkParametrizableShape.Sphere, (visual.radius, 0.0, 0.0)
        volume = shape_volume(int(shape[i]), geometry[i])
        density[i] = float(tree.link_mass[i]) / volume if volume > 0.0 else 0.0
    return HwLinkMetadata(
        link_shape=shape,
        geometry=geometry,
        density=density,
        L_H_G=L_H_G,
        L_H_pre=np.asarray(tree.parent_H_joint, dtype=np.float64)[1:].reshape(nj, 4, 4),
        joint_parent=np.asarray(tree.parent, dtype=np.int32)[1:],
    )


def scale_vector(shape: int, dims: np.ndarray) -> np.ndarray:
    """The factors of a parametrised link's frame coordinates (kernels/hardware.py's `scale_vector`): a box's
    (d0, d1, d2), a cylinder's and a capsule's (d0, d0, d1), a sphere's (d0, d0, d0)."""
    if shape in (LinkParametrizableShape.Cylinder, LinkParametrizableShape.Capsule):
        return np.array([dims[0], dims[0], dims[1]])
    if shape == LinkParametrizableShape.Sphere:
        return np.full(3, dims[0])
    return np.asarray(dims, dtype=np.float64)[:3].copy()


def scaled_collisions(description, link_names, metadata: HwLinkMetadata, dims: np.ndarray):
    """The description with the collision shapes of each parametrised link (a description link named as the lumped
    link it is) scaled as JaxSim's export scales them by the link's scale vector s: a box's extents (an ellipsoid's
    radii) by s, a sphere's radius by s0, a cylinder's radius by s0 and length by s2, each pose's translation by s. The collidable points of
    the shapes written so are the ones update_hw_parameters moves (but a cylinder's, which JaxSim's points keep;
    shapes of links lumped into a parametrised one keep theirs)."""
    factors = {name: scale_vector(int(shape), dims[i]) for i, (name, shape) in enumerate(zip(link_names, metadata.link_shape)) if shape >= 0}
    links = []
    for link in description.links:
        s = factors.get(link.name)
        if s is not None:
            shapes = []
            for shape in link.collisions:
                H = np.array(shape.link_H_shape, dtype=np.float64)
                H[:3, 3] *= s
                changes = {"link_H_shape": H}
                if shape.kind in ("box", "ellipsoid"):
                    changes["size"] = np.asarray(shape.size, dtype=np.float64) * s
                elif shape.kind in ("sphere", "cylinder", "capsule"):
                    changes["radius"] = shape.radius * s[0]
                    if shape.kind != "sphere":
                        changes["length"] = shape.length * s[2]
                shapes.append(dataclasses.replace(shape, **changes))
            link = dataclasses.replace(link, collisions=shapes)
        links.append(link)
    return dataclasses.replace(description, links=links)
